//! Drawing a posed character (issue 4 item 3): every pixel of every part is evaluated through
//! the inverse of the part's placement and deformation — pixel → deformed local point → rest
//! local point — where the analytic shape and its look are sampled ([`paint`]). Frames are thus
//! drawn from the posed shapes, never warped from the template. Parts are composited back to
//! front ("over", straight alpha), and the label map records the front-most part covering at
//! least half of each pixel.

use rayon::prelude::*;

use super::character::Character;
use super::deformation::{Grid, InverseMap};
use super::look::{paint, Wobble};
use crate::geom::similarity::Similarity;
use crate::picture::Picture;

/// Label value of pixels no part covers.
pub const BACKGROUND: u8 = u8::MAX;

/// One part placed in a frame.
#[derive(Clone, Debug)]
pub struct Placed<'a> {
    /// Part local frame → frame pixels.
    pub world: Similarity,
    /// The part's deformation grid (local units).
    pub grid: &'a Grid,
    /// Deformed grid vertices (local units), or `None` for a rigid part.
    pub deformed: Option<&'a [[f32; 2]]>,
    /// This frame's line wobble.
    pub wobble: Wobble,
}

/// A drawn frame and its part label map.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawing {
    /// The frame, transparent background.
    pub image: Picture,
    /// Row-major part index per pixel (index into [`Character::parts`]), [`BACKGROUND`] where
    /// no part covers at least half the pixel.
    pub labels: Vec<u8>,
}

/// Draws every part of `character` as placed by `placed` (one entry per part) into a
/// `width × height` frame.
///
/// # Panics
/// If `placed.len()` differs from the number of parts (a caller bug).
pub fn draw(character: &Character, placed: &[Placed], width: u32, height: u32) -> Drawing {
    assert_eq!(placed.len(), character.parts.len(), "one placement per part");
    let mut image = Picture::filled(width, height, [0.0; 4]);
    let mut labels = vec![BACKGROUND; (width * height) as usize];
    for (i, p) in placed.iter().enumerate() {
        paint_part(character, i, p, width, height, &mut image.pixels, Some(&mut labels));
    }
    Drawing { image, labels }
}

/// Draws part `i` alone (a template layer).
pub fn draw_part(character: &Character, i: usize, placed: &Placed, width: u32, height: u32) -> Picture {
    let mut image = Picture::filled(width, height, [0.0; 4]);
    paint_part(character, i, placed, width, height, &mut image.pixels, None);
    image
}

/// Composites part `i` over `pixels`, updating `labels` where it covers at least half a pixel.
fn paint_part(
    character: &Character,
    i: usize,
    placed: &Placed,
    width: u32,
    height: u32,
    pixels: &mut [[f32; 4]],
    labels: Option<&mut [u8]>,
) {
    let part = &character.parts[i];
    let inverse = placed.deformed.map(|d| InverseMap::new(placed.grid, d));
    let to_local = placed.world.inverse();
    let px = placed.world.scale();
    // Pixel rectangle covering the (deformed) grid.
    let corners = match placed.deformed {
        Some(d) => d.to_vec(),
        None => placed.grid.vertices(),
    };
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for c in &corners {
        let q = placed.world.apply(*c);
        lo = [lo[0].min(q[0]), lo[1].min(q[1])];
        hi = [hi[0].max(q[0]), hi[1].max(q[1])];
    }
    let x0 = lo[0].floor().max(0.0) as usize;
    let x1 = (hi[0].ceil().max(0.0) as usize).min(width as usize);
    let y0 = lo[1].floor().max(0.0) as usize;
    let y1 = (hi[1].ceil().max(0.0) as usize).min(height as usize);
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    let w = width as usize;
    let row = |y: usize, out: &mut [[f32; 4]], lab: Option<&mut [u8]>| {
        let mut lab = lab;
        for x in x0..x1 {
            let l = to_local.apply([x as f32 + 0.5, y as f32 + 0.5]);
            let rest = match &inverse {
                Some(inv) => match inv.rest_of(l) {
                    Some(r) => r,
                    None => continue,
                },
                None => l,
            };
            let src = paint(&part.look, &part.shape, rest, px, &placed.wobble);
            if src[3] <= 0.0 {
                continue;
            }
            let dst = out[x];
            let a = src[3] + dst[3] * (1.0 - src[3]);
            let mut o = [0.0, 0.0, 0.0, a];
            for k in 0..3 {
                o[k] = (src[k] * src[3] + dst[k] * dst[3] * (1.0 - src[3])) / a;
            }
            out[x] = o;
            if src[3] >= 0.5 {
                if let Some(lab) = lab.as_deref_mut() {
                    lab[x] = i as u8;
                }
            }
        }
    };
    let rows = pixels[y0 * w..y1 * w].par_chunks_mut(w);
    match labels {
        Some(labels) => rows
            .zip(labels[y0 * w..y1 * w].par_chunks_mut(w))
            .enumerate()
            .for_each(|(k, (out, lab))| row(y0 + k, out, Some(lab))),
        None => rows.enumerate().for_each(|(k, out)| row(y0 + k, out, None)),
    }
}
