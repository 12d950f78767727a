//! One triangle against one pixel centre: signed distance, barycentric weights (exact inside,
//! clamped outside) and their vector-Jacobian products w.r.t. the three corners
//! (neural-puppet.md §3.2, the geometry under the soft coverage `D = sigmoid(±d²/σ)`).

use super::{real, Real};

/// A triangle as seen from pixel centre `p`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit<T> {
    /// `p` lies inside the triangle or on its boundary (never for zero area).
    pub inside: bool,
    /// Squared distance from `p` to the triangle's boundary.
    pub dist2: T,
    /// Closest edge: from corner `edge` to corner `(edge + 1) % 3`.
    pub edge: usize,
    /// Position of the closest boundary point along that edge, in [0, 1].
    pub t: T,
    /// `t` was clamped to an end of the edge (its derivative is then 0).
    pub clamped: bool,
    /// `p − q`, `q` the closest boundary point.
    pub pq: [T; 2],
    /// Twice the signed area (positive counter-clockwise with y down).
    pub area2: T,
    /// Barycentric weights of the corners: exact inside, those of `q` outside.
    pub w: [T; 3],
}

impl<T: Real> Hit<T> {
    /// Signed distance squared with its sign (`+d²` inside, `−d²` outside): the SoftRas argument
    /// before division by σ, and the key that picks a layer's colour face (largest wins).
    pub fn signed_dist2(&self) -> T {
        if self.inside {
            self.dist2
        } else {
            -self.dist2
        }
    }
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

/// Evaluates the triangle `v` (three corners) at pixel centre `p`.
#[inline]
pub(crate) fn hit<T: Real>(p: [T; 2], v: [[T; 2]; 3]) -> Hit<T> {
    let zero = T::zero();
    let a2 = area2(v[0], v[1], v[2]);
    // e[k]: twice the area opposite corner k, i.e. its barycentric numerator.
    let e = [area2(v[1], v[2], p), area2(v[2], v[0], p), area2(v[0], v[1], p)];
    let inside = a2 != zero && e.iter().all(|&ek| if a2 > zero { ek >= zero } else { ek <= zero });
    let mut best = (T::infinity(), 0, zero, true, [zero, zero]);
    for k in 0..3 {
        let (a, b) = (v[k], v[(k + 1) % 3]);
        let ed = [b[0] - a[0], b[1] - a[1]];
        let ap = [p[0] - a[0], p[1] - a[1]];
        let m = ed[0] * ed[0] + ed[1] * ed[1];
        let (t, clamped) = if m > zero {
            let t = (ap[0] * ed[0] + ap[1] * ed[1]) / m;
            if t <= zero {
                (zero, true)
            } else if t >= T::one() {
                (T::one(), true)
            } else {
                (t, false)
            }
        } else {
            (zero, true)
        };
        let pq = [ap[0] - t * ed[0], ap[1] - t * ed[1]];
        let d2 = pq[0] * pq[0] + pq[1] * pq[1];
        if d2 < best.0 {
            best = (d2, k, t, clamped, pq);
        }
    }
    let (dist2, edge, t, clamped, pq) = best;
    let w = if inside {
        [e[0] / a2, e[1] / a2, e[2] / a2]
    } else {
        let mut w = [zero; 3];
        w[edge] = T::one() - t;
        w[(edge + 1) % 3] = t;
        w
    };
    Hit { inside, dist2, edge, t, clamped, pq, area2: a2, w }
}

/// Adds `g · ∂(dist²)/∂corners` to `grads`. With `q = v_i + t (v_j − v_i)` the closest point,
/// `∂d²/∂v_i = −2(1 − t)(p − q)` and `∂d²/∂v_j = −2t(p − q)` (the `∂t` term vanishes: either t
/// is clamped or `p − q ⊥ v_j − v_i`).
#[inline]
pub(crate) fn dist2_vjp<T: Real>(g: T, h: &Hit<T>, grads: &mut [[T; 2]; 3]) {
    let two = real::<T>(2.0);
    let (i, j) = (h.edge, (h.edge + 1) % 3);
    let (ci, cj) = (-two * (T::one() - h.t) * g, -two * h.t * g);
    for c in 0..2 {
        grads[i][c] = grads[i][c] + ci * h.pq[c];
        grads[j][c] = grads[j][c] + cj * h.pq[c];
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
        // Flipped winding: still inside, same distance.
        let hf = hit(p, [v[0], v[2], v[1]]);
        assert!(hf.inside && (hf.dist2 - h.dist2).abs() < 1e-12);
    }

    #[test]
    fn outside_point_gets_distance_to_closest_edge_point() {
        let v: [[f64; 2]; 3] = [[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]];
        let h = hit([2.0, -3.0], v);
        assert!(!h.inside);
        assert!((h.dist2 - 9.0).abs() < 1e-12 && (h.t - 0.5).abs() < 1e-12 && h.edge == 0);
        assert_eq!(h.w, [0.5, 0.5, 0.0]);
        let zero_area = hit([1.0f64, 1.0], [[0.0, 0.0], [2.0, 2.0], [4.0, 4.0]]);
        assert!(!zero_area.inside && zero_area.dist2 < 1e-24);
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
                assert!((fd - analytic[k][c]).abs() < 1e-6 * (1.0 + fd.abs()), "corner {k}.{c}: {} vs fd {fd}", analytic[k][c]);
            }
        }
    }

    #[test]
    fn distance_and_barycentric_vjps_match_central_differences() {
        let gw = [0.3, -1.2, 0.7];
        for p in [[3.5, 3.0], [8.0, 1.0], [4.0, 0.2], [-1.0, -2.0], [5.5, 5.0]] {
            let v = tri();
            let h = hit(p, v);
            let mut g = [[0.0; 2]; 3];
            dist2_vjp(1.0, &h, &mut g);
            check(|v| hit(p, v).dist2, v, g);
            let mut g = [[0.0; 2]; 3];
            bary_vjp(gw, p, v, &h, &mut g);
            check(|v| (0..3).map(|k| gw[k] * hit(p, v).w[k]).sum(), v, g);
        }
    }
}
