//! The build preview: every layer's wireframe in its own colour over the (faded) artwork, joints
//! marked as rings — what a person checks after `puppet build`; and the same meshes as faint
//! hairlines over a pose's render, for an artist to trace over (`puppet suggest`).

use crate::picture::Picture;
use crate::puppet::Puppet;

/// Distinct wireframe colours (Sasha Trubetskoy's 20-colour list, first 12), cycled per layer.
const PALETTE: [[f32; 3]; 12] = [
    [0.902, 0.098, 0.294],
    [0.235, 0.706, 0.294],
    [0.263, 0.388, 0.847],
    [0.961, 0.510, 0.192],
    [0.569, 0.118, 0.706],
    [0.259, 0.831, 0.957],
    [0.941, 0.196, 0.902],
    [0.502, 0.502, 0.0],
    [0.0, 0.502, 0.502],
    [0.604, 0.388, 0.141],
    [0.502, 0.0, 0.0],
    [0.0, 0.0, 0.502],
];

/// The wireframe colour of layer `i`.
pub fn layer_colour(i: usize) -> [f32; 3] {
    PALETTE[i % PALETTE.len()]
}

/// Draws `puppet`'s rest meshes over `artwork` (same size as the puppet's frame), upscaled by
/// `scale` so that edges of small sprites stay visible. Returns an opaque picture.
pub fn wireframe_preview(puppet: &Puppet, vertices: &[[f32; 2]], artwork: &Picture, scale: u32) -> Picture {
    let mut out = faded(artwork, scale, 0.55);
    draw_meshes(&mut out, puppet, vertices, scale, 1.0);
    let sf = scale.max(1) as f32;
    for joint in &puppet.joints {
        let p = vertices[puppet.global_index(joint.a)];
        let c = [p[0] * sf, p[1] * sf];
        draw_ring(&mut out, c, 2.2 * sf.min(4.0), 1.4, [0.0, 0.0, 0.0]);
        draw_ring(&mut out, c, 1.0 * sf.min(4.0), 1.2, [1.0, 1.0, 0.0]);
    }
    out
}

/// A picture to trace over: `artwork` (a render of the pose `vertices`) nearly at full
/// strength, upscaled by `scale`, under faint hairlines of the pose's meshes that show how
/// each layer is bent, without hiding the art.
pub fn trace_over(puppet: &Puppet, vertices: &[[f32; 2]], artwork: &Picture, scale: u32) -> Picture {
    let mut out = faded(artwork, scale, 0.9);
    draw_meshes(&mut out, puppet, vertices, scale, 0.3);
    out
}

/// `artwork` at `opacity` over white, nearest-neighbour upscaled by `scale`: lines drawn on it
/// stay readable on any colour.
fn faded(artwork: &Picture, scale: u32, opacity: f32) -> Picture {
    let s = scale.max(1);
    let (w, h) = (artwork.width * s, artwork.height * s);
    let mut out = Picture::filled(w, h, [1.0; 4]);
    for y in 0..h {
        for x in 0..w {
            let p = artwork.get(x / s, y / s);
            let a = p[3] * opacity;
            let px = &mut out.pixels[(y * w + x) as usize];
            for k in 0..3 {
                px[k] = p[k] * a + (1.0 - a);
            }
        }
    }
    out
}

/// Every layer's mesh edges in its own colour, at `coverage` (1: solid lines), on `out`
/// (the puppet's frame upscaled by `scale`).
fn draw_meshes(out: &mut Picture, puppet: &Puppet, vertices: &[[f32; 2]], scale: u32, coverage: f32) {
    let offsets = puppet.vertex_offsets();
    let sf = scale.max(1) as f32;
    for (li, layer) in puppet.layers.iter().enumerate() {
        let colour = layer_colour(li);
        let v = |i: u32| {
            let p = vertices[offsets[li] + i as usize];
            [p[0] * sf, p[1] * sf]
        };
        let mut edges: Vec<(u32, u32)> = layer
            .mesh
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
            .collect();
        // Each edge once: a shared edge drawn twice would look darker than a boundary edge.
        edges.sort_unstable();
        edges.dedup();
        for (a, b) in edges {
            draw_segment(out, v(a), v(b), 0.6, colour, coverage);
        }
    }
}

/// Blends `colour` into `pic` at pixel (x, y) with coverage `a`.
fn blend(pic: &mut Picture, x: i64, y: i64, a: f32, colour: [f32; 3]) {
    if a <= 0.0 || x < 0 || y < 0 || x >= pic.width as i64 || y >= pic.height as i64 {
        return;
    }
    let px = &mut pic.pixels[(y * pic.width as i64 + x) as usize];
    let a = a.min(1.0);
    for k in 0..3 {
        px[k] = colour[k] * a + px[k] * (1.0 - a);
    }
}

/// An anti-aliased segment of half-width `half` at `coverage`: it falls off linearly over one
/// pixel at the edges.
fn draw_segment(pic: &mut Picture, a: [f32; 2], b: [f32; 2], half: f32, colour: [f32; 3], coverage: f32) {
    let (x0, x1) = (
        (a[0].min(b[0]) - half - 1.0).floor() as i64,
        (a[0].max(b[0]) + half + 1.0).ceil() as i64,
    );
    let (y0, y1) = (
        (a[1].min(b[1]) - half - 1.0).floor() as i64,
        (a[1].max(b[1]) + half + 1.0).ceil() as i64,
    );
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = (d[0] * d[0] + d[1] * d[1]).max(1e-12);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let p = [x as f32 + 0.5 - a[0], y as f32 + 0.5 - a[1]];
            let t = ((p[0] * d[0] + p[1] * d[1]) / len2).clamp(0.0, 1.0);
            let dist = ((p[0] - t * d[0]).powi(2) + (p[1] - t * d[1]).powi(2)).sqrt();
            blend(pic, x, y, coverage * (half + 0.5 - dist).min(1.0), colour);
        }
    }
}

/// An anti-aliased ring (circle outline) of radius `r` and width `width`.
fn draw_ring(pic: &mut Picture, c: [f32; 2], r: f32, width: f32, colour: [f32; 3]) {
    let reach = (r + width + 1.0).ceil() as i64;
    for y in (c[1] as i64 - reach)..=(c[1] as i64 + reach) {
        for x in (c[0] as i64 - reach)..=(c[0] as i64 + reach) {
            let dist = ((x as f32 + 0.5 - c[0]).powi(2) + (y as f32 + 0.5 - c[1]).powi(2)).sqrt();
            blend(pic, x, y, width * 0.5 + 0.5 - (dist - r).abs(), colour);
        }
    }
}
