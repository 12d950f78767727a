//! One texture page holding every layer's texture, each cut to the rectangle its mesh's UVs
//! cover (plus a margin, so bilinear sampling at the mesh edge reads the layer's own colours),
//! packed on shelves, tallest first.

use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::puppet::Layer;
use crate::render::animation::MAX_SHEET_SIDE;

/// Pixels kept around each region's UV rectangle, and between regions on the page.
const MARGIN: u32 = 2;

/// Where one layer's texture sits on the page.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Region {
    /// The region's left and top on the page.
    pub at: (u32, u32),
    /// The region's width and height.
    pub size: (u32, u32),
    /// The region's left and top in the layer's texture.
    pub source: (u32, u32),
}

impl Region {
    /// A layer UV (in [0, 1]² of the layer's texture, `texture` px large) as a UV of the region.
    pub fn uv(&self, uv: [f32; 2], texture: (u32, u32)) -> [f64; 2] {
        let px = f64::from(uv[0]) * f64::from(texture.0) - f64::from(self.source.0);
        let py = f64::from(uv[1]) * f64::from(texture.1) - f64::from(self.source.1);
        [px / f64::from(self.size.0), py / f64::from(self.size.1)]
    }
}

/// The page and each layer's region on it (in the order given).
pub(super) struct RegionPage {
    pub regions: Vec<Region>,
    pub page: Picture,
}

/// Packs `layers` onto one page.
///
/// # Errors
/// [`Error::Limit`] if the page would pass [`MAX_SHEET_SIDE`] on a side.
pub(super) fn pack(layers: &[&Layer]) -> Result<RegionPage> {
    let cuts: Vec<((u32, u32), (u32, u32))> = layers.iter().map(|l| used_rectangle(&l.uvs, &l.texture)).collect();
    let area: u64 = cuts.iter().map(|(_, (w, h))| u64::from(w + MARGIN) * u64::from(h + MARGIN)).sum();
    let widest = cuts.iter().map(|(_, (w, _))| *w).max().unwrap_or(1);
    let width = widest.max((area as f64).sqrt().ceil() as u32).max(1);
    let mut order: Vec<usize> = (0..cuts.len()).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(cuts[k].1 .1), k));
    let mut at = vec![(0, 0); cuts.len()];
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    for &k in &order {
        let (w, h) = cuts[k].1;
        if x > 0 && x + w > width {
            (x, y, shelf) = (0, y + shelf + MARGIN, 0);
        }
        at[k] = (x, y);
        x += w + MARGIN;
        shelf = shelf.max(h);
    }
    let height = (y + shelf).max(1);
    if width > MAX_SHEET_SIDE || height > MAX_SHEET_SIDE {
        return Err(Error::limit(
            "the texture page of the layers",
            u64::from(width.max(height)),
            u64::from(MAX_SHEET_SIDE),
            "px",
        ));
    }
    let mut page = Picture::filled(width, height, [0.0; 4]);
    for (k, layer) in layers.iter().enumerate() {
        let ((sx, sy), (w, h)) = cuts[k];
        let (px, py) = at[k];
        for y in 0..h {
            for x in 0..w {
                page.pixels[((py + y) * width + px + x) as usize] = layer.texture.get(sx + x, sy + y);
            }
        }
    }
    let regions = cuts
        .iter()
        .zip(at)
        .map(|(&(source, size), at)| Region { at, size, source })
        .collect();
    Ok(RegionPage { regions, page })
}

/// The rectangle of `texture` (left-top, size) covering `uvs` and a margin, inside the texture.
fn used_rectangle(uvs: &[[f32; 2]], texture: &Picture) -> ((u32, u32), (u32, u32)) {
    let (tw, th) = (texture.width, texture.height);
    let bound = |f: fn(f32, f32) -> f32, start: f32, axis: usize| uvs.iter().map(|uv| uv[axis]).fold(start, f);
    let x0 = ((bound(f32::min, 1.0, 0) * tw as f32).floor() as i64 - i64::from(MARGIN)).clamp(0, i64::from(tw) - 1) as u32;
    let y0 = ((bound(f32::min, 1.0, 1) * th as f32).floor() as i64 - i64::from(MARGIN)).clamp(0, i64::from(th) - 1) as u32;
    let x1 = ((bound(f32::max, 0.0, 0) * tw as f32).ceil() as i64 + i64::from(MARGIN)).clamp(i64::from(x0) + 1, i64::from(tw)) as u32;
    let y1 = ((bound(f32::max, 0.0, 1) * th as f32).ceil() as i64 + i64::from(MARGIN)).clamp(i64::from(y0) + 1, i64::from(th)) as u32;
    ((x0, y0), (x1 - x0, y1 - y0))
}
