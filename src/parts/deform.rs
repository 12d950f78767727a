//! Parts deformed into every pose as rigidly as possible (apes-part-extraction.md appendix B):
//! each part of the reference pose gets a control mesh, a regular grid over its oriented
//! bounding box cut into triangles, which is placed in every other pose by the part's
//! similarity and then bent by [`ArapFit`] towards where the part's pixels correspond to there.
//! The paper pulls the meshes towards the target image through a differentiable render; these
//! pull them towards the correspondences the parts were found from (the same ones, after the
//! checks), with correspondences far from the similarity's placement left out as mistakes.

use rayon::prelude::*;

use super::flow::{Correspondences, Flow};
use super::pose::SheetPose;
use super::segment::Segmentation;
use super::superpixels::NONE;
use crate::error::{Error, Result};
use crate::geom::similarity::Similarity;
use crate::geom::{ArapFit, MeshPoint};

/// How parts are bent into the poses.
#[derive(Clone, Debug, PartialEq)]
pub struct BendOptions {
    /// Control-mesh vertex spacing as a share of the pose's larger side.
    pub spacing: f32,
    /// Weight of the ARAP energy against the pull of the correspondences (per correspondence).
    pub stiffness: f64,
    /// Local/global iterations.
    pub iterations: usize,
    /// Correspondences farther than this share of the pose's larger side from where the part's
    /// similarity puts their pixel do not pull.
    pub outlier: f32,
}

impl Default for BendOptions {
    fn default() -> Self {
        BendOptions {
            spacing: 1.0 / 24.0,
            stiffness: 1.0,
            iterations: 10,
            outlier: 1.0 / 16.0,
        }
    }
}

/// How the poses are rebuilt from the parts.
#[derive(Clone, Debug, PartialEq)]
pub enum Rebuild {
    /// Each part moved by its similarity.
    Rigid,
    /// Each part's control mesh bent by ARAP towards its correspondences (the paper's).
    Arap(BendOptions),
}

impl Rebuild {
    /// The parts' meshes bent into every pose ([`deform_parts`]), or `None` for a rigid rebuild.
    ///
    /// # Errors
    /// As [`deform_parts`].
    pub fn meshes(&self, poses: &[SheetPose], seg: &Segmentation, flows: &Correspondences) -> Result<Option<Vec<PartMesh>>> {
        match self {
            Rebuild::Rigid => Ok(None),
            Rebuild::Arap(options) => deform_parts(poses, seg, flows, options).map(Some),
        }
    }
}

/// One part's control mesh on the reference pose and where it lies in every pose.
#[derive(Clone, Debug, PartialEq)]
pub struct PartMesh {
    /// Rest positions on the reference pose, pixels.
    pub rest: Vec<[f32; 2]>,
    /// Triangles of the grid.
    pub triangles: Vec<[u32; 3]>,
    /// Per pose, the deformed positions; `None` where the part has no motion (not in that pose).
    pub posed: Vec<Option<Vec<[f32; 2]>>>,
}

/// A regular grid over the oriented bounding box of a set of points.
struct Grid {
    origin: [f32; 2],
    /// Unit axes of the box (the points' principal directions).
    axes: [[f32; 2]; 2],
    cell: f32,
    cells: [usize; 2],
}

impl Grid {
    /// The box around `points` (pixel centres, so each counts half a pixel either way), cut into
    /// cells of about `spacing` pixels.
    fn around(points: &[[f32; 2]], spacing: f32) -> Grid {
        let n = points.len().max(1) as f32;
        let mean = points.iter().fold([0.0f32; 2], |m, p| [m[0] + p[0] / n, m[1] + p[1] / n]);
        let (mut xx, mut xy, mut yy) = (0.0f32, 0.0f32, 0.0f32);
        for p in points {
            let d = [p[0] - mean[0], p[1] - mean[1]];
            xx += d[0] * d[0];
            xy += d[0] * d[1];
            yy += d[1] * d[1];
        }
        let angle = 0.5 * (2.0 * xy).atan2(xx - yy);
        let axes = [[angle.cos(), angle.sin()], [-angle.sin(), angle.cos()]];
        let along = |p: &[f32; 2], a: usize| (p[0] - mean[0]) * axes[a][0] + (p[1] - mean[1]) * axes[a][1];
        let range = |a: usize| {
            points
                .iter()
                .map(|p| along(p, a))
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
        };
        let ((u0, u1), (v0, v1)) = (range(0), range(1));
        let cells = |lo: f32, hi: f32| (((hi - lo + 1.0) / spacing).ceil() as usize).max(1);
        let cells = [cells(u0, u1), cells(v0, v1)];
        // Centre the grid on the box, each cell exactly `spacing` across.
        let start = |lo: f32, hi: f32, count: usize| 0.5 * (lo + hi) - 0.5 * count as f32 * spacing;
        let (su, sv) = (start(u0, u1, cells[0]), start(v0, v1, cells[1]));
        let origin = [
            mean[0] + su * axes[0][0] + sv * axes[1][0],
            mean[1] + su * axes[0][1] + sv * axes[1][1],
        ];
        Grid {
            origin,
            axes,
            cell: spacing,
            cells,
        }
    }

    fn vertex(&self, i: usize, j: usize) -> [f32; 2] {
        let (u, v) = (i as f32 * self.cell, j as f32 * self.cell);
        [
            self.origin[0] + u * self.axes[0][0] + v * self.axes[1][0],
            self.origin[1] + u * self.axes[0][1] + v * self.axes[1][1],
        ]
    }

    fn index(&self, i: usize, j: usize) -> u32 {
        (j * (self.cells[0] + 1) + i) as u32
    }

    fn vertices(&self) -> Vec<[f32; 2]> {
        (0..=self.cells[1])
            .flat_map(|j| (0..=self.cells[0]).map(move |i| (i, j)))
            .map(|(i, j)| self.vertex(i, j))
            .collect()
    }

    /// Two triangles per cell, positive area on screen (the axes are a rotation).
    fn triangles(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(2 * self.cells[0] * self.cells[1]);
        for j in 0..self.cells[1] {
            for i in 0..self.cells[0] {
                out.push([self.index(i, j), self.index(i + 1, j), self.index(i, j + 1)]);
                out.push([self.index(i + 1, j), self.index(i + 1, j + 1), self.index(i, j + 1)]);
            }
        }
        out
    }

    /// The point `p` as barycentric weights on the triangle of the grid that holds it (clamped
    /// into the grid).
    fn locate(&self, p: [f32; 2]) -> MeshPoint {
        let d = [p[0] - self.origin[0], p[1] - self.origin[1]];
        let u = (d[0] * self.axes[0][0] + d[1] * self.axes[0][1]) / self.cell;
        let v = (d[0] * self.axes[1][0] + d[1] * self.axes[1][1]) / self.cell;
        let u = u.clamp(0.0, self.cells[0] as f32);
        let v = v.clamp(0.0, self.cells[1] as f32);
        let (i, j) = ((u as usize).min(self.cells[0] - 1), (v as usize).min(self.cells[1] - 1));
        let (fu, fv) = (f64::from(u - i as f32), f64::from(v - j as f32));
        if fu + fv <= 1.0 {
            MeshPoint {
                corners: [self.index(i, j), self.index(i + 1, j), self.index(i, j + 1)],
                weights: [1.0 - fu - fv, fu, fv],
            }
        } else {
            MeshPoint {
                corners: [self.index(i + 1, j), self.index(i + 1, j + 1), self.index(i, j + 1)],
                weights: [1.0 - fv, fu + fv - 1.0, 1.0 - fu],
            }
        }
    }
}

/// Every part of `seg` meshed on the reference pose and bent into every pose by its
/// correspondences from the reference (`flows`); a part with fewer than three usable
/// correspondences into a pose is placed there by its similarity alone.
///
/// # Errors
/// [`Error::Setting`] for options out of range.
pub fn deform_parts(poses: &[SheetPose], seg: &Segmentation, flows: &Correspondences, options: &BendOptions) -> Result<Vec<PartMesh>> {
    if !(options.spacing > 0.0 && options.spacing <= 1.0) {
        return Err(Error::setting("deform spacing", options.spacing, "a share of the pose in (0, 1]"));
    }
    if !(options.stiffness > 0.0 && options.stiffness.is_finite()) {
        return Err(Error::setting("deform stiffness", options.stiffness, "a positive number"));
    }
    if !(options.outlier > 0.0 && options.outlier.is_finite()) {
        return Err(Error::setting("deform outlier", options.outlier, "a positive share of the pose"));
    }
    let reference = &poses[seg.reference];
    let w = reference.width();
    let side = w.max(reference.height()) as f32;
    let mut pixels_of = vec![Vec::new(); seg.parts];
    for (i, &l) in seg.labels[seg.reference].iter().enumerate() {
        if l != NONE && (l as usize) < seg.parts {
            pixels_of[l as usize].push(i);
        }
    }
    Ok(pixels_of
        .into_par_iter()
        .enumerate()
        .map(|(p, pixels)| {
            if pixels.is_empty() {
                return PartMesh {
                    rest: Vec::new(),
                    triangles: Vec::new(),
                    posed: vec![None; poses.len()],
                };
            }
            let points: Vec<[f32; 2]> = pixels.iter().map(|&i| [(i % w) as f32, (i / w) as f32]).collect();
            let grid = Grid::around(&points, (options.spacing * side).max(1.0));
            let part = Part {
                pixels: &pixels,
                points: &points,
                grid: &grid,
                rest: grid.vertices(),
                triangles: grid.triangles(),
            };
            let posed = (0..poses.len())
                .map(|t| {
                    let motion = seg.motions[p][t];
                    if t == seg.reference {
                        Some(part.rest.clone())
                    } else if motion.scale() <= 1e-6 {
                        None
                    } else {
                        Some(part.bend(motion, flows.get(seg.reference, t), options, options.outlier * side))
                    }
                })
                .collect();
            PartMesh {
                rest: part.rest,
                triangles: part.triangles,
                posed,
            }
        })
        .collect())
}

/// One part of the reference pose with its control mesh.
struct Part<'a> {
    /// Its pixels (row-major indices) and their positions.
    pixels: &'a [usize],
    points: &'a [[f32; 2]],
    grid: &'a Grid,
    rest: Vec<[f32; 2]>,
    triangles: Vec<[u32; 3]>,
}

impl Part<'_> {
    /// The mesh placed by `motion`, then pulled towards the correspondences of `flow` that lie
    /// within `outlier` pixels of that placement; the placement alone with fewer than three.
    fn bend(&self, motion: Similarity, flow: Option<&Flow>, options: &BendOptions, outlier: f32) -> Vec<[f32; 2]> {
        let placed: Vec<[f32; 2]> = self.rest.iter().map(|&v| motion.apply(v)).collect();
        let Some(flow) = flow else { return placed };
        let (pulled, targets): (Vec<MeshPoint>, Vec<[f64; 2]>) = self
            .pixels
            .iter()
            .zip(self.points)
            .filter_map(|(&i, &x)| {
                let q = flow.at(i)?;
                let m = motion.apply(x);
                ((q[0] - m[0]).hypot(q[1] - m[1]) <= outlier).then(|| (self.grid.locate(x), q.map(f64::from)))
            })
            .unzip();
        if pulled.len() < 3 {
            return placed;
        }
        let rest: Vec<[f64; 2]> = self.rest.iter().map(|v| v.map(f64::from)).collect();
        // A grid with points in it always has a point pulling it; a failure here would be a
        // degenerate grid, and the similarity's placement stands.
        let Ok(mut fit) = ArapFit::new(&rest, &self.triangles, &pulled, options.stiffness) else {
            return placed;
        };
        let initial: Vec<[f64; 2]> = placed.iter().map(|v| v.map(f64::from)).collect();
        let bent = fit.solve(&targets, options.iterations, &initial);
        bent.iter().map(|v| v.map(|c| c as f32)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::picture::Picture;

    /// Two 32 × 32 poses of one 12 × 5 bar at (8, 12); the second's correspondences from the
    /// first given by `to` for every bar pixel, the part's motion by `motion`.
    fn bar(to: impl Fn([f32; 2]) -> [f32; 2], motion: Similarity) -> (Vec<SheetPose>, Segmentation, Correspondences) {
        let (w, h) = (32usize, 32usize);
        let mut image = Picture::filled(w as u32, h as u32, [0.0; 4]);
        let mut labels = vec![NONE; w * h];
        let mut flow = Flow {
            to: vec![[f32::NAN; 2]; w * h],
        };
        for y in 12..17 {
            for x in 8..20 {
                let i = y * w + x;
                image.pixels[i] = [0.2, 0.4, 0.6, 1.0];
                labels[i] = 0;
                flow.to[i] = to([x as f32, y as f32]);
            }
        }
        let pose = SheetPose::new("p", image);
        let mut flows = Correspondences::new(2, w * h);
        flows.set(0, 1, flow).unwrap();
        let seg = Segmentation {
            reference: 0,
            parts: 1,
            labels: vec![labels.clone(), labels],
            motions: vec![vec![Similarity::IDENTITY, motion]],
        };
        (vec![pose.clone(), pose], seg, flows)
    }

    #[test]
    fn a_part_moved_rigidly_is_placed_by_its_motion() {
        let motion = Similarity::new(0.3, 1.0, [2.0, -1.5]);
        let (poses, seg, flows) = bar(|p| motion.apply(p), motion);
        let meshes = deform_parts(&poses, &seg, &flows, &BendOptions::default()).unwrap();
        let mesh = &meshes[0];
        assert!(mesh.triangles.len() >= 2);
        assert_eq!(mesh.posed[0].as_ref(), Some(&mesh.rest));
        let posed = mesh.posed[1].as_ref().unwrap();
        let worst = mesh.rest.iter().zip(posed).fold(0.0f32, |worst, (r, p)| {
            let m = motion.apply(*r);
            worst.max((m[0] - p[0]).hypot(m[1] - p[1]))
        });
        assert!(worst < 0.01, "a vertex {worst} px from the motion's placement");
    }

    #[test]
    fn a_bent_part_follows_its_correspondences_closer_than_its_similarity() {
        // The bar's right half turns down about x = 14: a bend no similarity follows.
        let bend = |p: [f32; 2]| {
            let d = (p[0] - 14.0).max(0.0);
            [p[0] - d * (1.0 - 0.4f32.cos()), p[1] + d * 0.4f32.sin()]
        };
        let (poses, seg, flows) = bar(bend, Similarity::new(0.15, 1.0, [0.0, 1.0]));
        // On this small pose the default outlier limit (2 px) would drop the bend itself.
        let options = BendOptions {
            outlier: 0.25,
            ..BendOptions::default()
        };
        let meshes = deform_parts(&poses, &seg, &flows, &options).unwrap();
        let mesh = &meshes[0];
        let grid = Grid::around(
            &(0..32 * 32)
                .filter(|&i| seg.labels[0][i] == 0)
                .map(|i| [(i % 32) as f32, (i / 32) as f32])
                .collect::<Vec<_>>(),
            BendOptions::default().spacing * 32.0,
        );
        let posed: Vec<[f64; 2]> = mesh.posed[1].as_ref().unwrap().iter().map(|v| v.map(f64::from)).collect();
        let (mut bent, mut rigid) = (0.0f32, 0.0f32);
        for i in (0..32 * 32).filter(|&i| seg.labels[0][i] == 0) {
            let x = [(i % 32) as f32, (i / 32) as f32];
            let q = flows.get(0, 1).unwrap().at(i).unwrap();
            let p = grid.locate(x).locate(&posed);
            bent += (p[0] as f32 - q[0]).hypot(p[1] as f32 - q[1]);
            let m = seg.motions[0][1].apply(x);
            rigid += (m[0] - q[0]).hypot(m[1] - q[1]);
        }
        assert!(bent < 0.5 * rigid, "bent {bent} against rigid {rigid} (summed px)");
    }

    #[test]
    fn settings_out_of_range_are_refused() {
        let (poses, seg, flows) = bar(|p| p, Similarity::IDENTITY);
        for options in [
            BendOptions {
                spacing: 0.0,
                ..BendOptions::default()
            },
            BendOptions {
                stiffness: f64::NAN,
                ..BendOptions::default()
            },
            BendOptions {
                outlier: -1.0,
                ..BendOptions::default()
            },
        ] {
            assert!(deform_parts(&poses, &seg, &flows, &options).is_err(), "{options:?}");
        }
    }
}
