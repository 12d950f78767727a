//! One triangle against one pixel centre: signed distance, barycentric weights (exact inside,
//! clamped outside) and their vector-Jacobian products w.r.t. the three corners
//! (neural-puppet.md §3.2, the geometry under the soft coverage `D = sigmoid(±d²/σ)`).

use super::{real, Real};

/// A triangle as seen from pixel centre `p`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit<T> {
    /// `p` lies inside the triangle or on its boundary (never for zero area).
    pub inside: bool,
    /// Closest edge: from corner `edge` to corner `(edge + 1) % 3`.
    pub edge: usize,
    /// Position of the closest boundary point along that edge, in [0, 1].
    pub t: T,
    /// `t` was clamped to an end of the edge (its derivative is then 0).
    pub clamped: bool,
    /// Twice the signed area (positive counter-clockwise with y down).
    pub area2: T,
    /// Barycentric weights of the corners: exact inside, those of `q` outside.
    pub w: [T; 3],
}

/// Twice the signed area of (a, b, c): `cross(b − a, c − a)`.
#[inline]
pub(crate) fn area2<T: Real>(a: [T; 2], b: [T; 2], c: [T; 2]) -> T {
    (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
}

/// Gradients of [`area2`] w.r.t. `a` and `b` (the derivative w.r.t. `c` is not needed: `c` is
/// the pixel centre).
#[inline]
fn area2_grad_ab<T: Real>(a: [T; 2], b: [T; 2], c: [T; 2]) -> ([T; 2], [T; 2]) {
    let db = [c[1] - a[1], a[0] - c[0]];
    let dc = [a[1] - b[1], b[0] - a[0]];
    ([-db[0] - dc[0], -db[1] - dc[1]], db)
}

/// Per-pose constants of one triangle, computed once so the per-pixel test is cheap.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tri<T> {
    pub v: [[T; 2]; 3],
    /// Twice the signed area and its sign (0 for zero area).
    pub area2: T,
    pub sign: T,
    /// Edge k runs from corner k to corner k + 1: its vector.
    pub e: [[T; 2]; 3],
}

impl<T: Real> Tri<T> {
    /// The constants of triangle `v`.
    pub fn new(v: [[T; 2]; 3]) -> Self {
        let zero = T::zero();
        let a2 = area2(v[0], v[1], v[2]);
        let sign = if a2 > zero {
            T::one()
        } else if a2 < zero {
            -T::one()
        } else {
            zero
        };
        let e = [0, 1, 2].map(|k| [v[(k + 1) % 3][0] - v[k][0], v[(k + 1) % 3][1] - v[k][1]]);
        Tri { v, area2: a2, sign, e }
    }
}

/// Evaluates the triangle `v` (three corners) at pixel centre `p`: the inside hit, else the
/// hit at the closest point of its boundary (the first of equally close edges).
#[cfg(test)]
pub(crate) fn hit<T: Real>(p: [T; 2], v: [[T; 2]; 3]) -> Hit<T> {
    let tri = Tri::new(v);
    inside_hit(p, &tri).unwrap_or_else(|| {
        let mut best: Option<(usize, Outline<T>)> = None;
        for k in 0..3 {
            let o = closest_on_segment(p, v[k], v[(k + 1) % 3], k as u32);
            if best.is_none_or(|(_, b)| o.dist2 < b.dist2) {
                best = Some((k, o));
            }
        }
        let (k, o) = best.expect("three edges");
        edge_hit(&o, k, tri.area2)
    })
}

/// The hit of triangle `tri` at pixel centre `p` if `p` lies inside it or on its boundary
/// (never for zero area): exact barycentric weights.
#[inline]
pub(crate) fn inside_hit<T: Real>(p: [T; 2], tri: &Tri<T>) -> Option<Hit<T>> {
    let zero = T::zero();
    if tri.sign == zero {
        return None;
    }
    let v = &tri.v;
    // Edge functions: f[k] = cross(e_k, p − v_k), twice the area of (v_k, v_k+1, p), which is
    // the barycentric numerator of corner k + 2.
    let f = [0, 1, 2].map(|k| tri.e[k][0] * (p[1] - v[k][1]) - tri.e[k][1] * (p[0] - v[k][0]));
    if f.iter().all(|&fk| tri.sign * fk >= zero) {
        Some(Hit {
            inside: true,
            edge: 0,
            t: zero,
            clamped: true,
            area2: tri.area2,
            w: [f[1] / tri.area2, f[2] / tri.area2, f[0] / tri.area2],
        })
    } else {
        None
    }
}

/// The outside hit at the closest point `o` of a triangle's edge from corner `k` to corner
/// `k + 1` (mod 3): weights `1 − t` and `t` on those corners.
#[inline]
pub(crate) fn edge_hit<T: Real>(o: &Outline<T>, k: usize, area2: T) -> Hit<T> {
    let (zero, one) = (T::zero(), T::one());
    let mut w = [zero; 3];
    w[k] = one - o.t;
    w[(k + 1) % 3] = o.t;
    Hit {
        inside: false,
        edge: k,
        t: o.t,
        clamped: o.clamped,
        area2,
        w,
    }
}

/// Adds `Σ_k gw[k] · ∂w_k/∂corners` to `grads`.
///
/// Inside, `w_k = E_k / A` with `E_k` twice the area opposite corner k and `A = Σ E_k`, so
/// `dL = Σ_k (gw_k − ḡ)/A · dE_k` with `ḡ = Σ gw_k w_k`. Outside, `w_i = 1 − t`, `w_j = t` with
/// `t = ((p − v_i)·e)/(e·e)`, `e = v_j − v_i`, differentiated unless clamped.
#[inline]
pub(crate) fn bary_vjp<T: Real>(gw: [T; 3], p: [T; 2], v: [[T; 2]; 3], h: &Hit<T>, grads: &mut [[T; 2]; 3]) {
    if h.inside {
        let gbar = gw[0] * h.w[0] + gw[1] * h.w[1] + gw[2] * h.w[2];
        for k in 0..3 {
            let hk = (gw[k] - gbar) / h.area2;
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let (da, db) = area2_grad_ab(v[a], v[b], p);
            for c in 0..2 {
                grads[a][c] = grads[a][c] + hk * da[c];
                grads[b][c] = grads[b][c] + hk * db[c];
            }
        }
    } else if !h.clamped {
        let (i, j) = (h.edge, (h.edge + 1) % 3);
        let gt = gw[j] - gw[i];
        let e = [v[j][0] - v[i][0], v[j][1] - v[i][1]];
        let ap = [p[0] - v[i][0], p[1] - v[i][1]];
        let m = e[0] * e[0] + e[1] * e[1];
        let two_t = real::<T>(2.0) * h.t;
        for c in 0..2 {
            let dj = (ap[c] - two_t * e[c]) / m;
            let di = (-e[c] - ap[c] + two_t * e[c]) / m;
            grads[j][c] = grads[j][c] + gt * dj;
            grads[i][c] = grads[i][c] + gt * di;
        }
    }
}

/// The nearest boundary edge of a layer within reach of the pixel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Outline<T> {
    /// Index into [`SoftRasterizer::edges`].
    pub edge: u32,
    /// Closest point `q = a + t (b − a)`, t in [0, 1].
    pub t: T,
    /// `p − q`.
    pub pq: [T; 2],
    /// `|p − q|²`.
    pub dist2: T,
    /// `t` was clamped to an end (its derivative is then 0).
    pub clamped: bool,
}

/// The closest point to `p` on segment (a, b) (edge `edge`).
#[inline]
#[cfg(test)]
pub(crate) fn closest_on_segment<T: Real>(p: [T; 2], a: [T; 2], b: [T; 2], edge: u32) -> Outline<T> {
    Seg::new(a, b).closest(p, edge)
}

/// Per-pose constants of one segment (a, b), so the per-pixel closest point needs no division.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Seg<T> {
    pub a: [T; 2],
    /// `b − a` and `1/|b − a|²` (0 for a zero-length segment).
    pub e: [T; 2],
    pub inv_len2: T,
}

impl<T: Real> Seg<T> {
    /// The constants of segment (a, b).
    #[inline]
    pub fn new(a: [T; 2], b: [T; 2]) -> Self {
        let e = [b[0] - a[0], b[1] - a[1]];
        let len2 = e[0] * e[0] + e[1] * e[1];
        let inv_len2 = if len2 > T::zero() { T::one() / len2 } else { T::zero() };
        Seg { a, e, inv_len2 }
    }

    /// The closest point to `p` (the segment being outline edge `edge`).
    #[inline]
    pub fn closest(&self, p: [T; 2], edge: u32) -> Outline<T> {
        let (zero, one) = (T::zero(), T::one());
        let e = self.e;
        let ap = [p[0] - self.a[0], p[1] - self.a[1]];
        // t = ((p − a)·e)/|e|², clamped to the segment (zero length: t = 0, clamped).
        let t = (ap[0] * e[0] + ap[1] * e[1]) * self.inv_len2;
        let (t, clamped) = if self.inv_len2 == zero || t <= zero {
            (zero, true)
        } else if t >= one {
            (one, true)
        } else {
            (t, false)
        };
        let pq = [ap[0] - t * e[0], ap[1] - t * e[1]];
        Outline {
            edge,
            t,
            pq,
            dist2: pq[0] * pq[0] + pq[1] * pq[1],
            clamped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [[f64; 2]; 3] {
        [[1.0, 1.0], [7.0, 2.0], [3.0, 6.5]]
    }

    #[test]
    fn inside_point_has_exact_barycentrics_that_reconstruct_it() {
        let v = tri();
        let p = [3.5, 3.0];
        let h = hit(p, v);
        assert!(h.inside);
        let q = [0, 1].map(|c| (0..3).map(|k| h.w[k] * v[k][c]).sum::<f64>());
        assert!((q[0] - p[0]).abs() < 1e-12 && (q[1] - p[1]).abs() < 1e-12);
        // Flipped winding: still inside, the same weights (corners 1 and 2 swapped).
        let hf = hit(p, [v[0], v[2], v[1]]);
        let swapped = [hf.w[0], hf.w[2], hf.w[1]];
        assert!(
            hf.inside && (0..3).all(|k| (swapped[k] - h.w[k]).abs() < 1e-12),
            "{:?} vs {:?}",
            hf.w,
            h.w
        );
    }

    #[test]
    fn outside_point_gets_distance_to_closest_edge_point() {
        let v: [[f64; 2]; 3] = [[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]];
        // The closest point, rebuilt from the weights, and its distance² to p.
        let dist2 = |p: [f64; 2], v: [[f64; 2]; 3], h: &Hit<f64>| {
            let q = [0, 1].map(|c| (0..3).map(|k| h.w[k] * v[k][c]).sum::<f64>());
            (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
        };
        let h = hit([2.0, -3.0], v);
        assert!(!h.inside);
        assert!((dist2([2.0, -3.0], v, &h) - 9.0).abs() < 1e-12 && (h.t - 0.5).abs() < 1e-12 && h.edge == 0);
        assert_eq!(h.w, [0.5, 0.5, 0.0]);
        let line = [[0.0, 0.0], [2.0, 2.0], [4.0, 4.0]];
        let zero_area = hit([1.0f64, 1.0], line);
        assert!(!zero_area.inside && dist2([1.0, 1.0], line, &zero_area) < 1e-24);
    }

    /// Central differences of `f(corners)` against `analytic`, coordinate by coordinate.
    fn check(f: impl Fn([[f64; 2]; 3]) -> f64, v: [[f64; 2]; 3], analytic: [[f64; 2]; 3]) {
        let h = 1e-6;
        for k in 0..3 {
            for c in 0..2 {
                let (mut vp, mut vm) = (v, v);
                vp[k][c] += h;
                vm[k][c] -= h;
                let fd = (f(vp) - f(vm)) / (2.0 * h);
                assert!(
                    (fd - analytic[k][c]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "corner {k}.{c}: {} vs fd {fd}",
                    analytic[k][c]
                );
            }
        }
    }

    #[test]
    fn barycentric_vjp_matches_central_differences() {
        let gw = [0.3, -1.2, 0.7];
        for p in [[3.5, 3.0], [8.0, 1.0], [4.0, 0.2], [-1.0, -2.0], [5.5, 5.0]] {
            let v = tri();
            let h = hit(p, v);
            let mut g = [[0.0; 2]; 3];
            bary_vjp(gw, p, v, &h, &mut g);
            check(|v| (0..3).map(|k| gw[k] * hit(p, v).w[k]).sum(), v, g);
        }
    }
}
