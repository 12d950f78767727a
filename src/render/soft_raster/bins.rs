//! Tiles of 4×4 pixels, each listing the faces (or outline edges) whose bounding box — grown by
//! a given reach: 0 for faces, which matter only where they contain the pixel, and the cut
//! distance for outline edges — reaches one of its pixel centres. Keeps the cost ∝ pixels ×
//! nearby faces (issue 3, "what to build" 3). Items stay in global order, so a tile's list runs
//! back to front by layer. 4×4 measured a little faster than 8×8 on the benchmark character
//! (faces of 5–10 px²; benches/README.md).

use super::{real, Real};

/// Tile edge in pixels.
pub(crate) const TILE: usize = 4;

/// Faces binned into tiles for one pose.
pub(crate) struct Bins<T> {
    pub tiles_x: usize,
    /// `faces[start[t]..start[t + 1]]` are tile t's faces (t = ty · tiles_x + tx).
    pub start: Vec<u32>,
    pub faces: Vec<u32>,
    /// Grown bounding box of every face, `[x0, y0, x1, y1]` in pixels (empty if off-image).
    pub boxes: Vec<[T; 4]>,
}

impl<T: Real> Bins<T> {
    /// Bins the faces of one pose. `corners(f)` gives face f's three positions; `reach` is the
    /// growth in pixels (√ of the cut distance², 0 when crisp).
    pub fn new(face_count: usize, corners: impl Fn(usize) -> [[T; 2]; 3], reach: T, width: usize, height: usize) -> Self {
        let tiles_x = width.div_ceil(TILE);
        let tiles_y = height.div_ceil(TILE);
        let margin = real::<T>(1e-3);
        let half = real::<T>(0.5);
        let mut boxes = Vec::with_capacity(face_count);
        // Pixel-index ranges [x0, x1] × [y0, y1] of each face, or None when off-image.
        let mut ranges: Vec<Option<[usize; 4]>> = Vec::with_capacity(face_count);
        let mut count = vec![0u32; tiles_x * tiles_y + 1];
        for f in 0..face_count {
            let v = corners(f);
            let r = reach + margin;
            let bx = [
                v[0][0].min(v[1][0]).min(v[2][0]) - r,
                v[0][1].min(v[1][1]).min(v[2][1]) - r,
                v[0][0].max(v[1][0]).max(v[2][0]) + r,
                v[0][1].max(v[1][1]).max(v[2][1]) + r,
            ];
            boxes.push(bx);
            // Pixel i has its centre at i + 0.5: i ∈ [ceil(x0 − 0.5), floor(x1 − 0.5)].
            let lo_x = (bx[0] - half).ceil().max(T::zero());
            let lo_y = (bx[1] - half).ceil().max(T::zero());
            let hi_x = (bx[2] - half).floor().min(real((width - 1) as f64));
            let hi_y = (bx[3] - half).floor().min(real((height - 1) as f64));
            if lo_x > hi_x || lo_y > hi_y {
                ranges.push(None);
                continue;
            }
            let idx = |v: T| v.to_usize().expect("clamped to the image");
            let rg = [idx(lo_x) / TILE, idx(lo_y) / TILE, idx(hi_x) / TILE, idx(hi_y) / TILE];
            for ty in rg[1]..=rg[3] {
                for tx in rg[0]..=rg[2] {
                    count[ty * tiles_x + tx + 1] += 1;
                }
            }
            ranges.push(Some(rg));
        }
        for t in 1..count.len() {
            count[t] += count[t - 1];
        }
        let start = count;
        let mut fill = start.clone();
        let mut faces = vec![0u32; *start.last().expect("at least one entry") as usize];
        for (f, rg) in ranges.iter().enumerate() {
            let Some(rg) = rg else { continue };
            for ty in rg[1]..=rg[3] {
                for tx in rg[0]..=rg[2] {
                    let t = ty * tiles_x + tx;
                    faces[fill[t] as usize] = f as u32;
                    fill[t] += 1;
                }
            }
        }
        Bins {
            tiles_x,
            start,
            faces,
            boxes,
        }
    }

    /// The faces of tile (tx, ty).
    #[inline]
    pub fn tile(&self, tx: usize, ty: usize) -> &[u32] {
        let t = ty * self.tiles_x + tx;
        &self.faces[self.start[t] as usize..self.start[t + 1] as usize]
    }
}
