//! The analytic shapes a synthetic part is made of (issue 4: ellipses, capsules, rounded boxes,
//! superellipses) and the signed distance each one gives, in the part's local units (negative
//! inside). Drawing turns distances into anti-aliased coverage, outlines and patterns.
//!
//! Distances of rounded boxes, circles and tapered capsules are exact (Quílez's closed forms);
//! the superellipse distance is the first-order estimate `F / |∇F|` of its degree-1 implicit
//! function, exact on the boundary and accurate within the outline band that drawing uses.

use serde::{Deserialize, Serialize};

/// One analytic primitive in a part's local frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Primitive {
    /// `|x'/rx|^n + |y'/ry|^n ≤ 1` around `center`, rotated by `angle` radians (n = 2: ellipse).
    Superellipse {
        /// Centre.
        center: [f32; 2],
        /// Half-axes `[rx, ry]`.
        radii: [f32; 2],
        /// Exponent n > 1 (2 ellipse, larger boxier).
        exponent: f32,
        /// Rotation in radians (y down: positive turns clockwise on screen).
        angle: f32,
    },
    /// A box with rounded corners around `center`, rotated by `angle`.
    RoundedBox {
        /// Centre.
        center: [f32; 2],
        /// Half extents `[hx, hy]`, corners included.
        half: [f32; 2],
        /// Corner radius, at most `min(hx, hy)`.
        radius: f32,
        /// Rotation in radians.
        angle: f32,
    },
    /// The convex hull of a disc of radius `ra` at `a` and one of radius `rb` at `b`.
    Capsule {
        /// First end.
        a: [f32; 2],
        /// Second end.
        b: [f32; 2],
        /// Radius at `a`.
        ra: f32,
        /// Radius at `b`.
        rb: f32,
    },
}

/// A union of primitives: the part's silhouette.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Shape {
    /// The primitives; the shape is their union.
    pub primitives: Vec<Primitive>,
}

impl Primitive {
    /// Signed distance from `p` to the primitive's boundary (negative inside).
    pub fn sdf(&self, p: [f32; 2]) -> f32 {
        match *self {
            Primitive::Superellipse {
                center,
                radii,
                exponent,
                angle,
            } => superellipse_sdf(to_frame(p, center, angle), radii, exponent),
            Primitive::RoundedBox {
                center,
                half,
                radius,
                angle,
            } => {
                let q = to_frame(p, center, angle);
                let r = radius.min(half[0]).min(half[1]).max(0.0);
                let dx = q[0].abs() - half[0] + r;
                let dy = q[1].abs() - half[1] + r;
                let outside = (dx.max(0.0).powi(2) + dy.max(0.0).powi(2)).sqrt();
                outside + dx.max(dy).min(0.0) - r
            }
            Primitive::Capsule { a, b, ra, rb } => capsule_sdf(p, a, b, ra, rb),
        }
    }

    /// An axis-aligned box `[min, max]` that contains the primitive.
    pub fn bounds(&self) -> [[f32; 2]; 2] {
        match *self {
            Primitive::Superellipse { center, radii, angle, .. }
            | Primitive::RoundedBox {
                center,
                half: radii,
                angle,
                ..
            } => {
                // The rotated box of half extents `radii` contains both shapes.
                let (s, c) = (libm::sinf(angle).abs(), libm::cosf(angle).abs());
                let ex = c * radii[0] + s * radii[1];
                let ey = s * radii[0] + c * radii[1];
                [[center[0] - ex, center[1] - ey], [center[0] + ex, center[1] + ey]]
            }
            Primitive::Capsule { a, b, ra, rb } => [
                [(a[0] - ra).min(b[0] - rb), (a[1] - ra).min(b[1] - rb)],
                [(a[0] + ra).max(b[0] + rb), (a[1] + ra).max(b[1] + rb)],
            ],
        }
    }
}

impl Shape {
    /// Signed distance to the union's boundary (the minimum over primitives; exact outside
    /// and a lower bound in magnitude inside, which is what coverage and outlines need).
    pub fn sdf(&self, p: [f32; 2]) -> f32 {
        self.primitives.iter().map(|q| q.sdf(p)).fold(f32::INFINITY, f32::min)
    }

    /// An axis-aligned box `[min, max]` containing the shape.
    pub fn bounds(&self) -> [[f32; 2]; 2] {
        let mut b = [[f32::INFINITY; 2], [f32::NEG_INFINITY; 2]];
        for q in &self.primitives {
            let [lo, hi] = q.bounds();
            b = [[b[0][0].min(lo[0]), b[0][1].min(lo[1])], [b[1][0].max(hi[0]), b[1][1].max(hi[1])]];
        }
        b
    }
}

/// `p` in the frame centred at `center` and rotated by `angle`.
fn to_frame(p: [f32; 2], center: [f32; 2], angle: f32) -> [f32; 2] {
    let (s, c) = (libm::sinf(angle), libm::cosf(angle));
    let (x, y) = (p[0] - center[0], p[1] - center[1]);
    [c * x + s * y, -s * x + c * y]
}

/// First-order distance `F / |∇F|` to `|x/rx|^n + |y/ry|^n = 1`, with the degree-1
/// homogeneous `F = (|x/rx|^n + |y/ry|^n)^(1/n) - 1`.
fn superellipse_sdf(q: [f32; 2], radii: [f32; 2], n: f32) -> f32 {
    let (u, v) = ((q[0] / radii[0]).abs(), (q[1] / radii[1]).abs());
    let s = libm::powf(u, n) + libm::powf(v, n);
    if s <= 1e-12 {
        return -radii[0].min(radii[1]);
    }
    let g = libm::powf(s, 1.0 / n);
    // ∂g/∂x = g^(1-n) u^(n-1) / rx (and likewise for y).
    let k = libm::powf(g, 1.0 - n);
    let gx = k * libm::powf(u, n - 1.0) / radii[0];
    let gy = k * libm::powf(v, n - 1.0) / radii[1];
    let grad = (gx * gx + gy * gy).sqrt().max(1e-6);
    // Deep inside the estimate overshoots; the inscribed size bounds it.
    ((g - 1.0) / grad).max(-radii[0].min(radii[1]))
}

/// Exact distance to a tapered capsule (Quílez, "uneven capsule").
fn capsule_sdf(p: [f32; 2], a: [f32; 2], b: [f32; 2], ra: f32, rb: f32) -> f32 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let h = (dx * dx + dy * dy).sqrt();
    let (px, py) = (p[0] - a[0], p[1] - a[1]);
    if h <= (ra - rb).abs() + 1e-6 {
        // One disc contains the other.
        let da = (px * px + py * py).sqrt() - ra;
        let db = ((p[0] - b[0]).powi(2) + (p[1] - b[1]).powi(2)).sqrt() - rb;
        return da.min(db);
    }
    // Frame with the axis along +y from a.
    let (ax, ay) = (dx / h, dy / h);
    let y = px * ax + py * ay;
    let x = (px * ay - py * ax).abs();
    let sb = (ra - rb) / h;
    let ca = (1.0 - sb * sb).sqrt();
    let k = -x * sb + y * ca;
    if k < 0.0 {
        (x * x + y * y).sqrt() - ra
    } else if k > ca * h {
        (x * x + (y - h) * (y - h)).sqrt() - rb
    } else {
        x * ca + y * sb - ra
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance to the boundary by brute force: the nearest of many boundary samples found by
    /// bisection along rays from an interior point (valid for star-shaped primitives).
    fn brute_distance(prim: &Primitive, p: [f32; 2], inner: [f32; 2]) -> f32 {
        let mut best = f32::INFINITY;
        for k in 0..4000 {
            let t = k as f32 / 4000.0 * std::f32::consts::TAU;
            let dir = [t.cos(), t.sin()];
            let (mut lo, mut hi) = (0.0f32, 100.0f32);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                let q = [inner[0] + dir[0] * mid, inner[1] + dir[1] * mid];
                if prim.sdf(q) < 0.0 {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            let q = [inner[0] + dir[0] * lo, inner[1] + dir[1] * lo];
            best = best.min(((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt());
        }
        best
    }

    #[test]
    fn exact_distances_match_brute_force() {
        let prims = [
            Primitive::RoundedBox {
                center: [1.0, 2.0],
                half: [6.0, 3.0],
                radius: 1.5,
                angle: 0.4,
            },
            Primitive::Capsule {
                a: [0.0, 0.0],
                b: [3.0, 10.0],
                ra: 4.0,
                rb: 2.0,
            },
            Primitive::Superellipse {
                center: [0.0, 0.0],
                radii: [5.0, 5.0],
                exponent: 2.0,
                angle: 0.0,
            },
        ];
        let inner = [[1.0, 2.0], [0.5, 1.0], [0.0, 0.0]];
        for (prim, inner) in prims.iter().zip(inner) {
            for p in [[9.0, 2.0], [-3.0, 7.5], [2.0, -6.0], [12.0, 14.0], [1.5, 1.0]] {
                let d = prim.sdf(p);
                let brute = brute_distance(prim, p, inner);
                assert!((d.abs() - brute).abs() < 0.02, "{prim:?} at {p:?}: sdf {d} vs brute {brute}");
            }
        }
    }

    #[test]
    fn superellipse_distance_is_exact_on_axes_and_accurate_near_the_boundary() {
        let prim = Primitive::Superellipse {
            center: [0.0, 0.0],
            radii: [8.0, 4.0],
            exponent: 3.0,
            angle: 0.0,
        };
        assert!((prim.sdf([10.0, 0.0]) - 2.0).abs() < 1e-4);
        assert!((prim.sdf([0.0, 3.0]) + 1.0).abs() < 1e-4);
        // Within ±1 unit of the boundary (the outline band) the estimate is within 5 %.
        for k in 0..32 {
            let t = k as f32 / 32.0 * std::f32::consts::TAU;
            for scale in [0.9f32, 1.1] {
                // A boundary point of |x/8|^3+|y/4|^3 = 1, pushed in or out along the ray.
                let (c, s) = (t.cos(), t.sin());
                let r = (c.abs().powi(3) / 512.0 + s.abs().powi(3) / 64.0).powf(-1.0 / 3.0);
                let p = [c * r * scale, s * r * scale];
                let brute = brute_distance(&prim, p, [0.0, 0.0]);
                let d = prim.sdf(p);
                assert!((d.abs() - brute).abs() <= 0.05 * brute + 1e-3, "t {t}: sdf {d} vs {brute}");
                assert_eq!(d < 0.0, scale < 1.0);
            }
        }
    }

    #[test]
    fn union_takes_the_nearest_and_bounds_contain_the_shape() {
        let shape = Shape {
            primitives: vec![
                Primitive::Capsule {
                    a: [0.0, 0.0],
                    b: [0.0, 10.0],
                    ra: 2.0,
                    rb: 2.0,
                },
                Primitive::Superellipse {
                    center: [3.0, 12.0],
                    radii: [4.0, 2.0],
                    exponent: 2.0,
                    angle: 0.3,
                },
            ],
        };
        assert!((shape.sdf([-5.0, 5.0]) - 3.0).abs() < 1e-5);
        let [lo, hi] = shape.bounds();
        for i in 0..60 {
            for j in 0..60 {
                let p = [-10.0 + i as f32 * 0.5, -5.0 + j as f32 * 0.5];
                if shape.sdf(p) < 0.0 {
                    assert!(p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1], "{p:?}");
                }
            }
        }
    }
}
