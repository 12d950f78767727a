//! As-rigid-as-possible shape interpolation between two poses of one mesh (Alexa, Cohen-Or &
//! Levin 2000, "As-rigid-as-possible shape interpolation"): the classical in-between of two
//! keyframes, which turns limbs instead of sliding their vertices along straight lines.
//!
//! Each triangle's map from the rest mesh to pose a and to pose b is a 2×2 Jacobian J, split by
//! its polar decomposition J = R(θ)·S (θ the closest rotation's angle, S the rest). At time t the
//! triangle wants A(t) = R(θ_a + t·δ)·((1 − t)·S_a + t·S_b), δ = θ_b − θ_a taken the short way
//! round relative to its group's rotation (a layer turns as one, so two triangles of a forearm
//! turned by 170° do not pick opposite ways round). The vertices are the least-squares fit of
//! every triangle's edges to its A(t) times its rest edges, plus links (a puppet's joints) held
//! with a large weight at their offset in the keyframes, interpolated linearly (zero where both
//! keyframes join them; a fit may leave a joint a little apart, and both ends must be reproduced):
//!
//! ```text
//! E(x) = Σ_f Σ_{(i,j) ∈ f} ‖(x_i − x_j) − A_f(t)(r_i − r_j)‖²
//!      + w_link Σ_{(i,j) links} ‖(x_i − x_j) − ((1 − t)(a_i − a_j) + t(b_i − b_j))‖²
//! ```
//!
//! one sparse system factorised once for every t. Alexa et al. interpolate the source-to-target
//! map directly; with the rest mesh as the common reference both ends are reproduced exactly
//! whatever their triangles (a fitted pose may fold one) and the rest mesh is well shaped by
//! construction. The translation of each connected component (triangles plus links) is fixed
//! afterwards by interpolating linearly the centroid of its anchor group (a puppet's root layer,
//! so a limb turning about its joint does not drag the body along the chord), or of the whole
//! component if it has no triangle of that group.

use std::collections::BTreeMap;

use super::components::{component_labels, triangle_edges};
use super::cotan_laplacian::{laplacian_from_edges, positions_f64, CotanEdge};
use super::min_quad_with_fixed::MinQuadWithFixed;
use crate::error::{Error, Result};

/// The weight of a link (joint) against one triangle edge: large enough that joined vertices
/// stay together within a small fraction of a pixel, small enough to keep the system well
/// conditioned.
const LINK_WEIGHT: f64 = 1e3;

/// A triangle's Jacobian from rest, as the polar pair (angle, stretch), at both ends.
#[derive(Clone, Copy, Debug)]
struct TrianglePath {
    /// θ_a, radians.
    angle: f64,
    /// θ_b − θ_a, unwrapped.
    turn: f64,
    /// S_a and S_b as row-major 2×2 matrices.
    stretch: [[f64; 4]; 2],
}

/// The interpolation between two poses of a mesh, factorised once; [`at`](Self::at) gives the
/// pose at any t (0 is pose a, 1 is pose b).
#[derive(Debug)]
pub struct RigidInterpolation {
    rest: Vec<[f64; 2]>,
    triangles: Vec<[u32; 3]>,
    paths: Vec<TrianglePath>,
    /// Each link's vertices and their offset x_i − x_j in a and in b.
    links: Vec<([u32; 2], [[f64; 2]; 2])>,
    system: MinQuadWithFixed,
    /// Component of each vertex, whether it counts towards its component's centroid, and the
    /// components' centroids in a and b.
    component: Vec<usize>,
    counted: Vec<bool>,
    centroids: [Vec<[f64; 2]>; 2],
}

impl RigidInterpolation {
    /// Prepares the interpolation from pose `a` to pose `b` of the mesh whose rest positions are
    /// `rest` (pixels, `#V` each). `groups`: one label per triangle for triangles that turn as
    /// one (a puppet's layer); `anchor`: the group whose centroid moves in a straight line (a
    /// puppet's root layer); `links`: vertex pairs kept together (a puppet's joints).
    ///
    /// # Errors
    /// [`Error::Geometry`] if the three position lists differ in length or hold a non-finite
    /// value, a triangle or link indexes past them, a rest triangle is degenerate, or `groups`
    /// does not label every triangle.
    pub fn new(
        rest: &[[f32; 2]],
        triangles: &[[u32; 3]],
        groups: &[u32],
        anchor: u32,
        links: &[[u32; 2]],
        a: &[[f32; 2]],
        b: &[[f32; 2]],
    ) -> Result<Self> {
        let n = rest.len();
        if a.len() != n || b.len() != n {
            return Err(Error::geometry(
                "rigid interpolation",
                format!("the rest mesh has {n} vertices, the poses {} and {}", a.len(), b.len()),
            ));
        }
        if groups.len() != triangles.len() {
            return Err(Error::geometry(
                "rigid interpolation",
                format!("{} group labels for {} triangles", groups.len(), triangles.len()),
            ));
        }
        let (rest, a, b) = (positions_f64(rest)?, positions_f64(a)?, positions_f64(b)?);
        let index_ok = |i: u32| (i as usize) < n;
        if let Some(t) = triangles.iter().position(|t| !t.iter().all(|&i| index_ok(i))) {
            return Err(Error::geometry(
                format!("triangle {t} {:?}", triangles[t]),
                format!("indexes past the {n} vertices"),
            ));
        }
        if let Some(k) = links.iter().position(|l| !l.iter().all(|&i| index_ok(i)) || l[0] == l[1]) {
            return Err(Error::geometry(
                format!("link {k} {:?}", links[k]),
                format!("is not two of the {n} vertices"),
            ));
        }
        let turns = group_turns(triangles, groups, &a, &b);
        let paths = triangles
            .iter()
            .zip(groups)
            .enumerate()
            .map(|(k, (&tri, &g))| {
                let inverse =
                    rest_inverse(&rest, tri).ok_or_else(|| Error::geometry(format!("rest triangle {k} {tri:?}"), "is degenerate"))?;
                let (ja, jb) = (jacobian(&a, tri, &inverse), jacobian(&b, tri, &inverse));
                let ((angle_a, stretch_a), (angle_b, stretch_b)) = (polar(ja), polar(jb));
                let reference = turns.get(&g).copied().unwrap_or(0.0);
                let turn = reference + wrap(angle_b - angle_a - reference);
                Ok(TrianglePath {
                    angle: angle_a,
                    turn,
                    stretch: [stretch_a, stretch_b],
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let mut weights: BTreeMap<(u32, u32), f64> = BTreeMap::new();
        for t in triangles {
            for (i, j) in corner_pairs(*t) {
                *weights.entry((i.min(j), i.max(j))).or_default() += 1.0;
            }
        }
        for l in links {
            *weights.entry((l[0].min(l[1]), l[0].max(l[1]))).or_default() += LINK_WEIGHT;
        }
        let edges: Vec<CotanEdge> = weights.into_iter().map(|((i, j), w)| CotanEdge { i, j, w }).collect();
        let mut q = laplacian_from_edges(n, &edges)?;
        q.val_mut().iter_mut().for_each(|v| *v = -*v);
        let joined = triangle_edges(triangles).chain(links.iter().map(|l| (l[0] as usize, l[1] as usize)));
        let (component, count) = component_labels(n, joined);
        let mut first = vec![None; count];
        for (v, &c) in component.iter().enumerate() {
            first[c].get_or_insert(v as u32);
        }
        let fixed: Vec<u32> = first.into_iter().flatten().collect();
        let system = MinQuadWithFixed::new(q.as_ref(), &fixed)?;
        let mut anchored = vec![false; n];
        for (t, _) in triangles.iter().zip(groups).filter(|(_, &g)| g == anchor) {
            t.iter().for_each(|&i| anchored[i as usize] = true);
        }
        let mut has_anchor = vec![false; count];
        for (v, &c) in component.iter().enumerate() {
            has_anchor[c] |= anchored[v];
        }
        let counted: Vec<bool> = (0..n).map(|v| anchored[v] || !has_anchor[component[v]]).collect();
        let centroids = [&a, &b].map(|p| centroids(p, &component, &counted, count));
        let links = links
            .iter()
            .map(|&[i, j]| ([i, j], [sub(a[i as usize], a[j as usize]), sub(b[i as usize], b[j as usize])]))
            .collect();
        Ok(Self {
            rest,
            triangles: triangles.to_vec(),
            paths,
            links,
            system,
            component,
            counted,
            centroids,
        })
    }

    /// The pose at `t` (0: a, 1: b; values outside extrapolate), pixels.
    pub fn at(&mut self, t: f64) -> Vec<[f32; 2]> {
        let n = self.rest.len();
        let mut rhs = vec![[0.0; 2]; n];
        for (tri, path) in self.triangles.iter().zip(&self.paths) {
            let m = path_matrix(path, t);
            for (i, j) in corner_pairs(*tri) {
                let r = sub(self.rest[i as usize], self.rest[j as usize]);
                let g = [m[0] * r[0] + m[1] * r[1], m[2] * r[0] + m[3] * r[1]];
                let (i, j) = (i as usize, j as usize);
                rhs[i] = [rhs[i][0] + g[0], rhs[i][1] + g[1]];
                rhs[j] = [rhs[j][0] - g[0], rhs[j][1] - g[1]];
            }
        }
        for &([i, j], [da, db]) in &self.links {
            let g = [
                LINK_WEIGHT * (da[0] + t * (db[0] - da[0])),
                LINK_WEIGHT * (da[1] + t * (db[1] - da[1])),
            ];
            let (i, j) = (i as usize, j as usize);
            rhs[i] = [rhs[i][0] + g[0], rhs[i][1] + g[1]];
            rhs[j] = [rhs[j][0] - g[0], rhs[j][1] - g[1]];
        }
        let fixed = vec![[0.0; 2]; self.system.fixed().len()];
        let mut x = vec![[0.0; 2]; n];
        self.system.solve(&rhs, &fixed, &mut x);
        let now = centroids(&x, &self.component, &self.counted, self.centroids[0].len());
        let shifts: Vec<[f64; 2]> = now
            .iter()
            .zip(self.centroids[0].iter().zip(&self.centroids[1]))
            .map(|(now, (a, b))| sub([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])], *now))
            .collect();
        x.iter()
            .zip(&self.component)
            .map(|(p, &c)| [(p[0] + shifts[c][0]) as f32, (p[1] + shifts[c][1]) as f32])
            .collect()
    }
}

/// A(t) = R(θ_a + t·δ)·((1 − t)·S_a + t·S_b), row-major.
fn path_matrix(path: &TrianglePath, t: f64) -> [f64; 4] {
    let (s, c) = (path.angle + t * path.turn).sin_cos();
    let [sa, sb] = path.stretch;
    let m: [f64; 4] = std::array::from_fn(|k| (1.0 - t) * sa[k] + t * sb[k]);
    [c * m[0] - s * m[2], c * m[1] - s * m[3], s * m[0] + c * m[2], s * m[1] + c * m[3]]
}

/// Each group's turn from a to b (the angle of the best rotation between its centred vertices):
/// the reference that unwraps its triangles' turns.
fn group_turns(triangles: &[[u32; 3]], groups: &[u32], a: &[[f64; 2]], b: &[[f64; 2]]) -> BTreeMap<u32, f64> {
    let mut members: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (t, &g) in triangles.iter().zip(groups) {
        members.entry(g).or_default().extend(t.iter().map(|&i| i as usize));
    }
    members
        .into_iter()
        .map(|(g, mut vs)| {
            vs.sort_unstable();
            vs.dedup();
            let mean = |p: &[[f64; 2]]| {
                let s = vs.iter().fold([0.0, 0.0], |s, &i| [s[0] + p[i][0], s[1] + p[i][1]]);
                [s[0] / vs.len() as f64, s[1] / vs.len() as f64]
            };
            let (ca, cb) = (mean(a), mean(b));
            let (mut dot, mut cross) = (0.0, 0.0);
            for &i in &vs {
                let (u, v) = (sub(a[i], ca), sub(b[i], cb));
                dot += u[0] * v[0] + u[1] * v[1];
                cross += u[0] * v[1] - u[1] * v[0];
            }
            (g, cross.atan2(dot))
        })
        .collect()
}

/// The inverse of the rest triangle's edge matrix [r1 − r0, r2 − r0] (columns), row-major, or
/// `None` if it is degenerate.
fn rest_inverse(rest: &[[f64; 2]], t: [u32; 3]) -> Option<[f64; 4]> {
    let r = t.map(|i| rest[i as usize]);
    let (e1, e2) = (sub(r[1], r[0]), sub(r[2], r[0]));
    let det = e1[0] * e2[1] - e2[0] * e1[1];
    let scale = (e1[0] * e1[0] + e1[1] * e1[1]).max(e2[0] * e2[0] + e2[1] * e2[1]);
    if det.abs() <= 1e-12 * scale {
        return None;
    }
    Some([e2[1] / det, -e2[0] / det, -e1[1] / det, e1[0] / det])
}

/// The Jacobian of the rest-to-`p` map on triangle `t`, row-major.
fn jacobian(p: &[[f64; 2]], t: [u32; 3], rest_inverse: &[f64; 4]) -> [f64; 4] {
    let q = t.map(|i| p[i as usize]);
    let (e1, e2) = (sub(q[1], q[0]), sub(q[2], q[0]));
    let m = rest_inverse;
    [
        e1[0] * m[0] + e2[0] * m[2],
        e1[0] * m[1] + e2[0] * m[3],
        e1[1] * m[0] + e2[1] * m[2],
        e1[1] * m[1] + e2[1] * m[3],
    ]
}

/// J = R(θ)·S with R(θ) the rotation closest to J (it maximises tr(RᵀJ)); returns (θ, S).
fn polar(j: [f64; 4]) -> (f64, [f64; 4]) {
    let theta = (j[2] - j[1]).atan2(j[0] + j[3]);
    let (s, c) = theta.sin_cos();
    // S = R(−θ)·J.
    (
        theta,
        [c * j[0] + s * j[2], c * j[1] + s * j[3], -s * j[0] + c * j[2], -s * j[1] + c * j[3]],
    )
}

/// `angle` wrapped into (−π, π].
fn wrap(angle: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let w = angle - tau * (angle / tau).round();
    if w <= -std::f64::consts::PI {
        w + tau
    } else {
        w
    }
}

fn corner_pairs(t: [u32; 3]) -> [(u32, u32); 3] {
    [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
}

/// The mean of each of `count` components' counted vertices, in one pass.
fn centroids(p: &[[f64; 2]], component: &[usize], counted: &[bool], count: usize) -> Vec<[f64; 2]> {
    let mut sums = vec![[0.0f64; 3]; count];
    for ((q, &c), _) in p.iter().zip(component).zip(counted).filter(|(_, &yes)| yes) {
        sums[c] = [sums[c][0] + q[0], sums[c][1] + q[1], sums[c][2] + 1.0];
    }
    sums.into_iter().map(|[x, y, k]| [x / k, y / k]).collect()
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3×3 grid of unit squares (16 vertices, 18 triangles) at `origin`.
    fn grid(origin: [f32; 2], first: u32) -> (Vec<[f32; 2]>, Vec<[u32; 3]>) {
        let vertices = (0..16).map(|k| [origin[0] + (k % 4) as f32, origin[1] + (k / 4) as f32]).collect();
        let mut triangles = Vec::new();
        for y in 0..3u32 {
            for x in 0..3u32 {
                let v = first + y * 4 + x;
                triangles.push([v, v + 4, v + 1]);
                triangles.push([v + 1, v + 4, v + 5]);
            }
        }
        (vertices, triangles)
    }

    type Points = Vec<[f32; 2]>;

    /// Two grids side by side joined where they touch: vertex 3 of the first (3, 0) and vertex
    /// 16 of the second (its corner at the same place); the second grid's own rest positions.
    fn two_grids() -> (Points, Vec<[u32; 3]>, Points) {
        let (mut rest, mut triangles) = grid([0.0, 0.0], 0);
        let (limb, limb_triangles) = grid([3.0, 0.0], 16);
        rest.extend(&limb);
        triangles.extend(limb_triangles);
        (rest, triangles, limb)
    }

    fn rotate(p: &[[f32; 2]], about: [f32; 2], angle: f32) -> Vec<[f32; 2]> {
        let (s, c) = angle.sin_cos();
        p.iter()
            .map(|q| {
                let d = [q[0] - about[0], q[1] - about[1]];
                [about[0] + c * d[0] - s * d[1], about[1] + s * d[0] + c * d[1]]
            })
            .collect()
    }

    fn max_distance(a: &[[f32; 2]], b: &[[f32; 2]]) -> f32 {
        a.iter().zip(b).map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1])).fold(0.0, f32::max)
    }

    #[test]
    fn a_turned_square_turns_half_way_at_one_half_where_vertex_interpolation_shrinks_it() {
        let (rest, triangles) = grid([10.0, 20.0], 0);
        let centre = [11.5, 21.5];
        let b = rotate(&rest, centre, 2.0);
        let mut interp = RigidInterpolation::new(&rest, &triangles, &[0; 18], 0, &[], &rest, &b).unwrap();
        let half = interp.at(0.5);
        assert!(max_distance(&half, &rotate(&rest, centre, 1.0)) < 1e-4, "{half:?}");
        let linear: Vec<[f32; 2]> = rest
            .iter()
            .zip(&b)
            .map(|(p, q)| [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0])
            .collect();
        let span = |p: &[[f32; 2]]| (p[0][0] - p[15][0]).hypot(p[0][1] - p[15][1]);
        assert!(
            span(&linear) < 0.6 * span(&rest),
            "the straight-line in-between collapses the square"
        );
        assert!((span(&half) - span(&rest)).abs() < 1e-4);
    }

    #[test]
    fn both_ends_are_reproduced_for_non_rigid_poses_with_joints_a_little_apart() {
        let (rest, triangles, _) = two_grids();
        let groups: Vec<u32> = (0..36).map(|t| 7 + t / 18).collect();
        let mut a: Vec<[f32; 2]> = rest.iter().map(|p| [p[0] * 1.3 + 0.1 * p[1] * p[1], p[1] * 0.8 + 2.0]).collect();
        a[16..].iter_mut().for_each(|p| p[1] += 0.4);
        let b = rotate(
            &rest.iter().map(|p| [p[0] + 0.2 * p[1], p[1] * 1.1]).collect::<Vec<_>>(),
            [1.0, 1.0],
            -0.7,
        );
        let mut interp = RigidInterpolation::new(&rest, &triangles, &groups, 7, &[[3, 16]], &a, &b).unwrap();
        assert!(max_distance(&interp.at(0.0), &a) < 1e-4);
        assert!(max_distance(&interp.at(1.0), &b) < 1e-4);
    }

    #[test]
    fn a_limb_turning_about_its_joint_stays_on_it_and_keeps_its_length() {
        let (rest, triangles, limb) = two_grids();
        let groups: Vec<u32> = (0..36).map(|t| t / 18).collect();
        let joint = [3.0, 0.0];
        let mut b = rest.clone();
        b[16..].copy_from_slice(&rotate(&limb, joint, 1.5));
        let mut interp = RigidInterpolation::new(&rest, &triangles, &groups, 0, &[[3, 16]], &rest, &b).unwrap();
        let half = interp.at(0.5);
        assert!(max_distance(&half[16..], &rotate(&limb, joint, 0.75)) < 0.05, "{:?}", &half[16..]);
        assert!(max_distance(&half[..16], &rest[..16]) < 0.05);
        assert!((half[3][0] - half[16][0]).hypot(half[3][1] - half[16][1]) < 0.01);
    }

    #[test]
    fn a_group_turned_by_nearly_half_a_turn_takes_one_way_round() {
        let (rest, triangles) = grid([0.0, 0.0], 0);
        let b = rotate(&rest, [1.5, 1.5], 3.1);
        let mut interp = RigidInterpolation::new(&rest, &triangles, &[0; 18], 0, &[], &rest, &b).unwrap();
        assert!(max_distance(&interp.at(0.5), &rotate(&rest, [1.5, 1.5], 1.55)) < 1e-3);
    }

    #[test]
    fn bad_inputs_are_named() {
        let (rest, triangles) = grid([0.0, 0.0], 0);
        let short = &rest[..15];
        let err = |r: Result<RigidInterpolation>| r.unwrap_err().to_string();
        assert!(err(RigidInterpolation::new(&rest, &triangles, &[0; 18], 0, &[], short, &rest)).contains("16 vertices"));
        assert!(err(RigidInterpolation::new(&rest, &triangles, &[0; 17], 0, &[], &rest, &rest)).contains("17 group labels"));
        assert!(err(RigidInterpolation::new(&rest, &triangles, &[0; 18], 0, &[[0, 99]], &rest, &rest)).contains("link 0"));
        let mut flat = rest.clone();
        flat[4] = [0.0, 0.0];
        assert!(err(RigidInterpolation::new(&flat, &triangles, &[0; 18], 0, &[], &rest, &rest)).contains("degenerate"));
        let mut nan = rest.clone();
        nan[2][1] = f32::NAN;
        assert!(err(RigidInterpolation::new(&rest, &triangles, &[0; 18], 0, &[], &rest, &nan)).contains("not finite"));
    }
}
