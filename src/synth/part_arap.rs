//! Small non-rigid deformation of one part (APES appendix B, "non-rigid deformation for
//! augmentation"): control handles on the part's grid are shifted by Gaussian offsets with σ
//! ≈ 2 % of the image size and the grid follows as-rigidly-as-possible
//! ([`crate::geom::ArapSolver`], factorised once per part and reused for every frame).
//!
//! The part's pivot and its children's pivots are handles with zero offset, so the skeleton
//! stays connected and the part bends or bulges between its joints; one or two free handles,
//! away from the pivots, carry the offsets.

use super::deformation::Grid;
use super::shape::Shape;
use crate::error::{Error, Result};
use crate::geom::ArapSolver;
use crate::rng::Rng;

/// ARAP iterations per frame (libigl's usual 10; the offsets are small, so this converges).
const ITERATIONS: usize = 10;

/// The ARAP deformer of one part.
pub struct PartArap {
    solver: ArapSolver,
    rest: Vec<[f64; 2]>,
    /// Number of leading handles that are pinned (zero offset).
    pinned: usize,
    /// Per free handle, three 2D standard-normal vectors: offset = σ (g0 + g1 cos φ + g2 sin φ) / √3.
    gains: Vec<[[f32; 2]; 3]>,
}

impl PartArap {
    /// Sets up the deformer of a part with silhouette `shape` on `grid`; `pins` are local
    /// points kept in place, `free` the number of offset handles, `rng` picks them.
    ///
    /// # Errors
    /// [`Error::Geometry`] if the solver cannot be set up (a degenerate grid).
    pub fn new(grid: &Grid, shape: &Shape, pins: &[[f32; 2]], free: usize, rng: &mut Rng) -> Result<Self> {
        let vertices = grid.vertices();
        let nearest = |p: [f32; 2]| {
            (0..vertices.len())
                .min_by(|&a, &b| dist2(vertices[a], p).total_cmp(&dist2(vertices[b], p)))
                .expect("a grid has vertices") as u32
        };
        let mut handles: Vec<u32> = Vec::new();
        for &p in pins {
            let h = nearest(p);
            if !handles.contains(&h) {
                handles.push(h);
            }
        }
        let pinned = handles.len();
        let [lo, hi] = shape.bounds();
        let reach = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        for _ in 0..free {
            // Inside the part, at least 30 % of its extent from every other handle; else the
            // inside vertex farthest from them.
            let far = |v: usize| {
                handles
                    .iter()
                    .map(|&h| dist2(vertices[v], vertices[h as usize]))
                    .fold(f32::INFINITY, f32::min)
            };
            let inside: Vec<usize> = (0..vertices.len())
                .filter(|&v| shape.sdf(vertices[v]) < 0.0 && !handles.contains(&(v as u32)))
                .collect();
            let good: Vec<usize> = inside.iter().copied().filter(|&v| far(v) >= (0.3 * reach).powi(2)).collect();
            let pick = if !good.is_empty() {
                good[rng.below(good.len())]
            } else {
                match inside.iter().copied().max_by(|&a, &b| far(a).total_cmp(&far(b))) {
                    Some(v) => v,
                    None => break,
                }
            };
            handles.push(pick as u32);
        }
        let gains = (pinned..handles.len())
            .map(|_| {
                [
                    [rng.normal(), rng.normal()],
                    [rng.normal(), rng.normal()],
                    [rng.normal(), rng.normal()],
                ]
            })
            .collect();
        let rest: Vec<[f64; 2]> = vertices.iter().map(|p| [p[0] as f64, p[1] as f64]).collect();
        let solver = ArapSolver::new(&rest, &grid.triangles(), &handles)
            .map_err(|e| Error::geometry("synthetic part deformation", e.to_string()))?;
        Ok(PartArap {
            solver,
            rest,
            pinned,
            gains,
        })
    }

    /// Deformed grid vertices for handle offsets of scale `sigma` (local units): smooth in the
    /// cycle phase `phase` for cyclic motions, fresh Gaussian offsets from `rng` when `None`.
    /// Positions are rounded to 1/1000 unit so that truth.json stores exactly what was drawn.
    pub fn deform(&mut self, sigma: f32, phase: Option<f32>, rng: &mut Rng) -> Vec<[f32; 2]> {
        let handles = self.solver.handles().to_vec();
        let targets: Vec<[f64; 2]> = handles
            .iter()
            .enumerate()
            .map(|(k, &h)| {
                let r = self.rest[h as usize];
                if k < self.pinned {
                    return r;
                }
                let g = self.gains[k - self.pinned];
                let o = match phase {
                    Some(phi) => {
                        let (c, s) = (libm::cosf(phi), libm::sinf(phi));
                        let k3 = 1.0 / 3f32.sqrt();
                        [
                            k3 * (g[0][0] + g[1][0] * c + g[2][0] * s),
                            k3 * (g[0][1] + g[1][1] * c + g[2][1] * s),
                        ]
                    }
                    None => [rng.normal(), rng.normal()],
                };
                [r[0] + (sigma * o[0]) as f64, r[1] + (sigma * o[1]) as f64]
            })
            .collect();
        let out = self.solver.solve(&targets, ITERATIONS, &self.rest);
        out.iter().map(|p| [quantise(p[0]), quantise(p[1])]).collect()
    }
}

fn quantise(x: f64) -> f32 {
    ((x * 1000.0).round() / 1000.0) as f32
}

fn dist2(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}
