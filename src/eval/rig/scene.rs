//! The metrics of eval-rig (module doc of [`super`]), measured against what a character's
//! accessories hide, hold and share at rest.

use std::collections::BTreeMap;

use super::edits::body_layers;
use super::report::Scores;
use crate::geom::triangle_grid::TriangleGrid;
use crate::geom::{component_labels, triangle_edges};
use crate::puppet::rig_data::{Constraint, RigEdge};
use crate::puppet::{LayerKind, Puppet};
use crate::rig::deform::bind_point;
use crate::rig::mask::Mask;

/// A point bound to a layer's rest mesh: its triangle's corners (global numbering), barycentric
/// weights.
pub(super) type Bound = ([usize; 3], [f32; 3]);

/// An accessory's attachment to its parent at rest.
struct Attachment {
    child: usize,
    parent: usize,
    /// Pixels the two share at rest.
    overlap: usize,
    /// Up to 16 points of the shared region, bound to the child and to the parent.
    anchors: Vec<(Bound, Bound)>,
}

/// A body layer's outline samples hidden at rest by a set of accessories.
struct Hidden {
    /// The accessories that hide them.
    cover: Vec<usize>,
    /// Runs of hidden samples (in outline order), each bound to the layer's rest mesh as
    /// (triangle corners, global numbering; weights).
    rings: Vec<Vec<Bound>>,
    /// Samples over all runs.
    count: usize,
}

/// Layer `l`'s triangles (corner positions) in `pose`, its vertices from global index `offset`.
fn placed_triangles(puppet: &Puppet, l: usize, pose: &[[f32; 2]], offset: usize) -> Vec<[[f32; 2]; 3]> {
    puppet.layers[l]
        .mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| pose[offset + i as usize]))
        .collect()
}

/// Where a bound point is in `pose`.
pub(super) fn position((tri, w): &Bound, pose: &[[f32; 2]]) -> [f32; 2] {
    [0, 1].map(|c| w[0] * pose[tri[0]][c] + w[1] * pose[tri[1]][c] + w[2] * pose[tri[2]][c])
}

/// How much of some hidden outline a pose keeps covered.
struct Covered {
    /// Share of the samples covered (1 without samples).
    share: f64,
    /// Deepest exposure, pixels.
    deepest: f64,
    /// Runs of more than 4 uncovered samples.
    blobs: usize,
    /// Where the uncovered samples are, pixels.
    exposed: Vec<[f32; 2]>,
}

/// Carries each sample of `groups` by the pose (`at`) and checks it against the union of its
/// group's accessory triangles in that pose (`placed`): exactly, not on pixels, so a motion
/// smaller than a pixel does not flip a sample that lies near a pixel's edge.
fn covered(groups: &[Hidden], placed: &dyn Fn(usize) -> Vec<[[f32; 2]; 3]>, at: &dyn Fn(&Bound) -> [f32; 2]) -> Covered {
    let (mut kept, mut total, mut deepest, mut blobs) = (0usize, 0usize, 0.0f64, 0usize);
    let mut exposed = Vec::new();
    for group in groups {
        total += group.count;
        let cover = TriangleGrid::new(group.cover.iter().flat_map(|&a| placed(a)).collect(), COVER_CELL);
        for ring in &group.rings {
            let mut run = 0usize;
            for bound in ring {
                let q = at(bound);
                if cover.covers(q) {
                    kept += 1;
                    blobs += usize::from(run > 4);
                    run = 0;
                } else {
                    run += 1;
                    deepest = deepest.max(f64::from(cover.distance(q)));
                    exposed.push(q);
                }
            }
            blobs += usize::from(run > 4);
        }
    }
    Covered {
        share: if total == 0 { 1.0 } else { kept as f64 / total as f64 },
        deepest,
        blobs,
        exposed,
    }
}

/// Grid cell (pixels) of the accessory triangles the occlusion samples are checked against.
const COVER_CELL: f32 = 4.0;

/// How deep under its accessories an outline sample must lie at rest to count as hidden
/// (pixels). A sample within half a pixel of the cover's rim shares its pixel with the rim: the
/// artwork does not hide it, it draws the accessory's edge along it (a cap drawn to the head's
/// curve), and any motion at all, even a rigid one rounded differently, would "expose" it.
const HIDDEN_MARGIN: f32 = 0.5;

/// What the metrics measure against, prepared once per character at rest.
pub(super) struct Scene<'a> {
    puppet: &'a Puppet,
    offsets: Vec<usize>,
    /// The accessory layers.
    pub(super) accessories: Vec<usize>,
    /// Per body layer, its outline hidden by the accessories in front of it.
    hidden: Vec<Hidden>,
    /// Per body layer, its outline hidden by the accessories that follow it.
    own: Vec<Hidden>,
    /// Per accessory, its attachment to its first parent.
    attachments: Vec<Attachment>,
    /// Coincident seams: a child point, the parent point nearest it, their rest distance.
    seams: Vec<(Bound, Bound, f32)>,
}

impl<'a> Scene<'a> {
    /// What `puppet`'s metrics measure against, its accessories following it by `edges`.
    pub(super) fn new(puppet: &'a Puppet, edges: &[RigEdge]) -> Self {
        let offsets = puppet.vertex_offsets();
        let masks: Vec<Mask> = puppet.layers.iter().map(|l| Mask::of_layer(l, 0.5)).collect();
        let accessories: Vec<usize> = (0..puppet.layers.len())
            .filter(|&l| puppet.layers[l].kind == LayerKind::Accessory)
            .collect();
        let bind = |l: usize, p: [f32; 2]| {
            let (t, w) = bind_point(&puppet.layers[l].mesh, p);
            (puppet.layers[l].mesh.triangles[t as usize].map(|i| offsets[l] + i as usize), w)
        };
        let rest = puppet.rest_vertices();
        let at_rest = |bound: &Bound| position(bound, &rest);
        // What covers at rest is what the meshes cover (within the mesher's tolerance of the
        // artwork), so an unedited pose keeps every sample and every overlap.
        let mesh_mask = |l: usize| {
            let m = &puppet.layers[l].mesh;
            Mask::of_triangles(&m.vertices, &m.triangles, puppet.width, puppet.height)
        };
        // The body layer each accessory follows, through its first parents.
        let follows = |a: usize| {
            let mut at = a;
            for _ in 0..puppet.layers.len() {
                if puppet.layers[at].kind == LayerKind::Body {
                    return Some(at);
                }
                at = edges.iter().find(|e| e.child == at)?.parent;
            }
            None
        };
        let hidden_by = |b: usize, cover: Vec<usize>| {
            let front = TriangleGrid::new(
                cover.iter().flat_map(|&a| placed_triangles(puppet, a, &rest, offsets[a])).collect(),
                COVER_CELL,
            );
            let (mut ring, mut rings, mut count) = (Vec::new(), Vec::new(), 0);
            for s in masks[b].outline(1.0) {
                // Judged where the score will look for it: an outline pixel just outside the
                // layer's mesh is bound to the mesh's nearest point, and that point is the sample.
                let bound = bind(b, s);
                if front.covers_disc(at_rest(&bound), HIDDEN_MARGIN) {
                    ring.push(bound);
                    count += 1;
                } else if !ring.is_empty() {
                    rings.push(std::mem::take(&mut ring));
                }
            }
            if !ring.is_empty() {
                rings.push(ring);
            }
            (count > 0).then_some(Hidden { cover, rings, count })
        };
        let (mut hidden, mut own) = (Vec::new(), Vec::new());
        for b in body_layers(puppet) {
            let front: Vec<usize> = accessories.iter().copied().filter(|&a| a > b).collect();
            let following: Vec<usize> = front.iter().copied().filter(|&a| follows(a) == Some(b)).collect();
            hidden.extend(hidden_by(b, front));
            own.extend(hidden_by(b, following));
        }
        let mut attachments = Vec::new();
        let mut seams = Vec::new();
        for e in edges {
            let (c, p) = (e.child, e.parent);
            if !attachments.iter().any(|a: &Attachment| a.child == c) {
                let shared = masks[c].and(&masks[p]);
                let pixels: Vec<usize> = (0..shared.inside.len()).filter(|&i| shared.inside[i]).collect();
                let anchors = (0..16.min(pixels.len()))
                    .map(|k| {
                        let q = shared.centre(pixels[k * pixels.len() / 16.min(pixels.len())]);
                        (bind(c, q), bind(p, q))
                    })
                    .collect();
                attachments.push(Attachment {
                    child: c,
                    parent: p,
                    // Counted as the score counts it, on the meshes, so a pose that moves
                    // nothing retains exactly 1.
                    overlap: mesh_mask(c).and(&mesh_mask(p)).count(),
                    anchors,
                });
            }
            if e.constraints.contains(&Constraint::Coincident) {
                let parent_edge = masks[p].outline(1.0);
                for q in masks[c].outline(2.0) {
                    if let Some(r) = parent_edge
                        .iter()
                        .copied()
                        .min_by(|a, b| dist(*a, q).total_cmp(&dist(*b, q)))
                        .filter(|r| dist(*r, q) <= 1.0)
                    {
                        seams.push((bind(c, q), bind(p, r), dist(q, r)));
                    }
                }
            }
        }
        Scene {
            puppet,
            offsets,
            accessories,
            hidden,
            own,
            attachments,
            seams,
        }
    }

    /// The global indices of the accessories' vertices.
    pub(super) fn accessory_vertices(&self) -> impl Iterator<Item = usize> + '_ {
        self.accessories.iter().flat_map(|&l| self.offsets[l]..self.offsets[l + 1])
    }

    /// Layer `l`'s coverage in `pose`.
    pub(super) fn layer_mask(&self, l: usize, pose: &[[f32; 2]]) -> Mask {
        let p = self.puppet;
        Mask::of_triangles(
            &pose[self.offsets[l]..self.offsets[l + 1]],
            &p.layers[l].mesh.triangles,
            p.width,
            p.height,
        )
    }

    /// Where `pose` uncovers outline its accessories hid at rest, pixels.
    pub(super) fn exposed(&self, pose: &[[f32; 2]]) -> Vec<[f32; 2]> {
        let placed = |a: usize| placed_triangles(self.puppet, a, pose, self.offsets[a]);
        covered(&self.hidden, &placed, &|bound: &Bound| position(bound, pose)).exposed
    }

    /// Every metric of `pose` (global numbering).
    pub(super) fn score(&self, pose: &[[f32; 2]]) -> Scores {
        let at = |bound: &Bound| position(bound, pose);
        let masks: BTreeMap<usize, Mask> = self.accessories.iter().map(|&a| (a, self.layer_mask(a, pose))).collect();
        let placed = |a: usize| placed_triangles(self.puppet, a, pose, self.offsets[a]);
        let occlusion = covered(&self.hidden, &placed, &at);
        let own = covered(&self.own, &placed, &at);
        let mut retention = Vec::new();
        let mut drift = Vec::new();
        for a in &self.attachments {
            if a.overlap > 0 {
                let parent = masks.get(&a.parent).cloned().unwrap_or_else(|| self.layer_mask(a.parent, pose));
                retention.push(masks[&a.child].and(&parent).count() as f64 / a.overlap as f64);
            }
            drift.extend(a.anchors.iter().map(|(x, y)| f64::from(dist(at(x), at(y)))));
        }
        let (mut inverted, mut stretch) = (0usize, Vec::new());
        for &l in &self.accessories {
            let mesh = &self.puppet.layers[l].mesh;
            for t in &mesh.triangles {
                let r = t.map(|i| mesh.vertices[i as usize]);
                let d = t.map(|i| pose[self.offsets[l] + i as usize]);
                let area = |c: [[f32; 2]; 3]| (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]);
                if area(d) * area(r).signum() <= 0.0 {
                    inverted += 1;
                }
                stretch.push(largest_stretch(r, d));
            }
        }
        let seam_change: Vec<f64> = self
            .seams
            .iter()
            .map(|(a, b, rest)| f64::from((dist(at(a), at(b)) - rest).abs()))
            .collect();
        Scores {
            occlusion_kept: occlusion.share,
            deepest_exposure: occlusion.deepest,
            leak_blobs: occlusion.blobs,
            own_occlusion_kept: own.share,
            own_deepest_exposure: own.deepest,
            overlap_retention: median(&mut retention),
            anchor_drift: if drift.is_empty() {
                0.0
            } else {
                drift.iter().sum::<f64>() / drift.len() as f64
            },
            inverted,
            new_holes: self
                .accessories
                .iter()
                .map(|&a| {
                    let mesh = &self.puppet.layers[a].mesh;
                    let placed = &pose[self.offsets[a]..self.offsets[a] + mesh.vertices.len()];
                    new_holes(&mesh.triangles, &mesh.vertices, placed, self.puppet.width, self.puppet.height)
                })
                .sum(),
            seam_change_p95: (!seam_change.is_empty()).then(|| percentile(&mut seam_change.clone(), 0.95)),
            stretch_p95: percentile(&mut stretch, 0.95),
        }
    }
}

/// Holes in the coverage of a mesh (`triangles` over `rest`) placed at `placed` that its rest
/// shape, each connected piece moved as a whole by its vertices' mean displacement, does not
/// have: the hole count at [`HOLE_SUPERSAMPLING`] times the canvas resolution less that of the
/// moved rest shape. At the canvas's own resolution a stroke of line art thinner than a pixel
/// in places is rasterised with gaps, which open and close as it moves (a glasses frame whose
/// lens is enclosed in one pose and not the next); at any resolution a stroke thinner than a
/// subsample still does, so the rest shape is counted where the pose has it, and pieces that
/// only translate (eyes on point pins) open none.
fn new_holes(triangles: &[[u32; 3]], rest: &[[f32; 2]], placed: &[[f32; 2]], width: u32, height: u32) -> usize {
    let (piece, count) = component_labels(rest.len(), triangle_edges(triangles));
    let mut shift = vec![[0.0f64; 3]; count];
    for ((r, p), &k) in rest.iter().zip(placed).zip(&piece) {
        shift[k] = [
            shift[k][0] + f64::from(p[0] - r[0]),
            shift[k][1] + f64::from(p[1] - r[1]),
            shift[k][2] + 1.0,
        ];
    }
    let moved: Vec<[f32; 2]> = rest
        .iter()
        .zip(&piece)
        .map(|(r, &k)| {
            let [x, y, n] = shift[k];
            [r[0] + (x / n) as f32, r[1] + (y / n) as f32]
        })
        .collect();
    holes_of_triangles(triangles, placed, width, height).saturating_sub(holes_of_triangles(triangles, &moved, width, height))
}

/// Enclosed holes in the coverage of a mesh placed at `placed` on a `width` × `height` canvas.
fn holes_of_triangles(triangles: &[[u32; 3]], placed: &[[f32; 2]], width: u32, height: u32) -> usize {
    let k = HOLE_SUPERSAMPLING as f32;
    // Rasterised over the layer's bounding box, with a free pixel round it: a piece of the
    // complement that reaches the box's rim is open to the outside, as one reaching the
    // canvas's edge would be.
    let (lo, hi) = placed.iter().fold(([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]), |(lo, hi), p| {
        ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
    });
    let clip = |x: f32, n: u32| (x * k).clamp(0.0, (n as f32) * k);
    let origin = [clip(lo[0], width).floor() - 1.0, clip(lo[1], height).floor() - 1.0];
    let size = |h: f32, n: u32, o: f32| (clip(h, n).ceil() - o + 2.0).max(1.0) as u32;
    let (w, h) = (size(hi[0], width, origin[0]), size(hi[1], height, origin[1]));
    let scaled: Vec<[f32; 2]> = placed.iter().map(|p| [p[0] * k - origin[0], p[1] * k - origin[1]]).collect();
    holes(&Mask::of_triangles(&scaled, triangles, w, h))
}

/// Samples per canvas pixel, per axis, of the coverage that holes are counted in.
const HOLE_SUPERSAMPLING: u32 = 4;

/// Enclosed holes of a coverage mask: pieces of its complement that do not touch the canvas edge.
fn holes(silhouette: &Mask) -> usize {
    let complement = Mask {
        width: silhouette.width,
        height: silhouette.height,
        inside: silhouette.inside.iter().map(|&i| !i).collect(),
    };
    let (w, h) = (silhouette.width as usize, silhouette.height as usize);
    complement
        .pieces()
        .iter()
        .filter(|piece| piece.iter().all(|&i| i % w != 0 && i % w != w - 1 && i / w != 0 && i / w != h - 1))
        .count()
}

/// The larger singular value of the affine map taking triangle `r` to `d`.
fn largest_stretch(r: [[f32; 2]; 3], d: [[f32; 2]; 3]) -> f64 {
    let e = |t: [[f32; 2]; 3]| [[t[1][0] - t[0][0], t[2][0] - t[0][0]], [t[1][1] - t[0][1], t[2][1] - t[0][1]]];
    let (a, b) = (e(r), e(d));
    let det = f64::from(a[0][0] * a[1][1] - a[0][1] * a[1][0]);
    if det.abs() < 1e-12 {
        return 1.0;
    }
    // F = B A⁻¹.
    let inv = [
        [f64::from(a[1][1]) / det, -f64::from(a[0][1]) / det],
        [-f64::from(a[1][0]) / det, f64::from(a[0][0]) / det],
    ];
    let f = [0, 1].map(|i| [0, 1].map(|j| f64::from(b[i][0]) * inv[0][j] + f64::from(b[i][1]) * inv[1][j]));
    let (p, q, r2, s) = (f[0][0], f[0][1], f[1][0], f[1][1]);
    let sum = p * p + q * q + r2 * r2 + s * s;
    let det_f = p * s - q * r2;
    ((sum + (sum * sum - 4.0 * det_f * det_f).max(0.0).sqrt()) / 2.0).sqrt()
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 1.0;
    }
    percentile(values, 0.5)
}

/// The `q` quantile (nearest rank) of `values` (0 for none).
fn percentile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let k = ((q * values.len() as f64).ceil() as usize).clamp(1, values.len()) - 1;
    values[k]
}

pub(super) fn dist(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_thinner_than_a_pixel_encloses_its_hole_wherever_it_lies() {
        // A square frame 0.6 px wide round [x0, x0 + 12]²: four bars, two triangles each.
        let frame = |x0: f32| boxes(&frame_bars(x0, 0.6, 12.0));
        for x0 in [2.0, 2.3, 2.6, 2.9] {
            let (vertices, triangles) = frame(x0);
            assert_eq!(holes_of_triangles(&triangles, &vertices, 20, 20), 1, "frame at {x0}");
        }
        // At the canvas's own resolution the frame at 2.6 covers no pixel centre of its left
        // and top bars, and encloses nothing.
        let (vertices, triangles) = frame(2.6);
        assert_eq!(holes(&Mask::of_triangles(&vertices, &triangles, 20, 20)), 0);
    }

    /// The four bars `[x0, y0, x1, y1]` of a square frame `width` wide round `[at, at + size]²`.
    fn frame_bars(at: f32, width: f32, size: f32) -> [[f32; 4]; 4] {
        let (a, b, c, d) = (at, at + width, at + size - width, at + size);
        [[a, a, d, b], [a, c, d, d], [a, a, b, d], [c, a, d, d]]
    }

    /// Axis-aligned boxes `[x0, y0, x1, y1]` as a mesh, two triangles each.
    fn boxes(bars: &[[f32; 4]]) -> (Vec<[f32; 2]>, Vec<[u32; 3]>) {
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for &[x1, y1, x2, y2] in bars {
            let k = vertices.len() as u32;
            vertices.extend([[x1, y1], [x2, y1], [x2, y2], [x1, y2]]);
            triangles.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
        }
        (vertices, triangles)
    }

    #[test]
    fn pieces_that_only_translate_open_no_hole() {
        // Two square frames 0.15 px wide (under a subsample), one piece each, the first moved by
        // fractions of a pixel and the second not: the hole count at 4× changes as the first
        // moves, and none of it is new.
        let frame = frame_bars(2.0, 0.15, 12.0);
        let bars: Vec<[f32; 4]> = frame
            .into_iter()
            .chain(frame.map(|[x0, y0, x1, y1]| [x0 + 14.0, y0, x1 + 14.0, y1]))
            .collect();
        let (rest, triangles) = boxes(&bars);
        let mut counts = Vec::new();
        for step in 0..12 {
            let shift = |v: usize| {
                let k = if v < 16 { 1.0 } else { 0.0 };
                [0.037 * step as f32 * k, 0.061 * step as f32 * k]
            };
            let placed: Vec<[f32; 2]> = rest
                .iter()
                .enumerate()
                .map(|(v, p)| [p[0] + shift(v)[0], p[1] + shift(v)[1]])
                .collect();
            counts.push(holes_of_triangles(&triangles, &placed, 32, 20));
            assert_eq!(new_holes(&triangles, &rest, &placed, 32, 20), 0, "step {step}");
        }
        assert!(counts.iter().any(|&n| n != counts[0]), "the raw counts should vary: {counts:?}");
    }

    #[test]
    fn a_notch_pinched_shut_is_a_new_hole() {
        // A U with a notch 1 px wide; the pose leans the right arm's top onto the left arm's.
        let (rest, triangles) = boxes(&[[2.0, 2.0, 3.0, 12.0], [4.0, 2.0, 5.0, 12.0], [2.0, 12.0, 5.0, 13.0]]);
        let mut placed = rest.clone();
        for v in [4, 5] {
            placed[v][0] -= 1.5;
        }
        assert_eq!(new_holes(&triangles, &rest, &rest, 20, 20), 0);
        assert_eq!(new_holes(&triangles, &rest, &placed, 20, 20), 1);
    }
}
