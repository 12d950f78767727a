//! A 2D similarity transform (rotation, uniform scale, translation): how a part's local frame
//! sits in the rest frame or in a drawn frame (pixels, y down), and the least-squares similarity
//! between two point sets from their additive moments (how a part moved between two poses, apes-part-extraction.md §3.2).

use serde::{Deserialize, Serialize};

/// `x' = a·x − b·y + tx`, `y' = b·x + a·y + ty`: rotation by `atan2(b, a)` (clockwise on screen
/// for positive angles, since y points down) and scale `√(a² + b²)`, then translation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Similarity {
    /// `scale · cos(angle)`.
    pub a: f32,
    /// `scale · sin(angle)`.
    pub b: f32,
    /// Translation x, pixels.
    pub tx: f32,
    /// Translation y, pixels.
    pub ty: f32,
}

impl Similarity {
    /// The identity.
    pub const IDENTITY: Similarity = Similarity {
        a: 1.0,
        b: 0.0,
        tx: 0.0,
        ty: 0.0,
    };

    /// Rotation by `angle` radians and scale `scale` about the origin, then translation `t`.
    pub fn new(angle: f32, scale: f32, t: [f32; 2]) -> Self {
        Similarity {
            a: scale * libm::cosf(angle),
            b: scale * libm::sinf(angle),
            tx: t[0],
            ty: t[1],
        }
    }

    /// Maps a point.
    pub fn apply(&self, p: [f32; 2]) -> [f32; 2] {
        [self.a * p[0] - self.b * p[1] + self.tx, self.b * p[0] + self.a * p[1] + self.ty]
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Similarity) -> Similarity {
        let [tx, ty] = self.apply([other.tx, other.ty]);
        Similarity {
            a: self.a * other.a - self.b * other.b,
            b: self.b * other.a + self.a * other.b,
            tx,
            ty,
        }
    }

    /// The inverse map.
    ///
    /// # Panics
    /// If the scale is zero (a caller bug: transforms are built with positive scale).
    pub fn inverse(&self) -> Similarity {
        let d = self.a * self.a + self.b * self.b;
        assert!(d > 0.0, "inverse of a zero-scale similarity");
        let (a, b) = (self.a / d, -self.b / d);
        Similarity {
            a,
            b,
            tx: -(a * self.tx - b * self.ty),
            ty: -(b * self.tx + a * self.ty),
        }
    }

    /// The scale factor.
    pub fn scale(&self) -> f32 {
        (self.a * self.a + self.b * self.b).sqrt()
    }

    /// The rotation angle in radians.
    pub fn angle(&self) -> f32 {
        libm::atan2f(self.b, self.a)
    }

    /// The similarity `S` minimising `Σ |S(from[k]) − to[k]|²`, or `None` where
    /// [`Moments::fit`] has none.
    ///
    /// # Panics
    /// If the slices differ in length (a caller bug).
    pub fn fit(from: &[[f32; 2]], to: &[[f32; 2]]) -> Option<Similarity> {
        assert_eq!(from.len(), to.len(), "similarity fit: point sets differ in length");
        let mut m = Moments::default();
        for (&p, &q) in from.iter().zip(to) {
            m.add(p, q);
        }
        m.fit()
    }
}

/// The sums a least-squares similarity between point pairs `p → q` needs (Umeyama's closed
/// form, which in 2D is linear in `(a, b, tx, ty)`): they add, so the fit of a union of point
/// sets, and its residual, cost O(1) from the sets' moments. Kept in f64: a part has thousands
/// of pixels, and centred products cancel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    n: f64,
    p: [f64; 2],
    q: [f64; 2],
    pp: f64,
    qq: f64,
    dot: f64,
    cross: f64,
}

impl Moments {
    /// Adds the pair `p → q`.
    pub fn add(&mut self, p: [f32; 2], q: [f32; 2]) {
        let (p, q) = (p.map(f64::from), q.map(f64::from));
        self.n += 1.0;
        self.p = [self.p[0] + p[0], self.p[1] + p[1]];
        self.q = [self.q[0] + q[0], self.q[1] + q[1]];
        self.pp += p[0] * p[0] + p[1] * p[1];
        self.qq += q[0] * q[0] + q[1] * q[1];
        self.dot += p[0] * q[0] + p[1] * q[1];
        self.cross += p[0] * q[1] - p[1] * q[0];
    }

    /// The moments of both sets of pairs.
    #[must_use]
    pub fn merged(&self, other: &Moments) -> Moments {
        Moments {
            n: self.n + other.n,
            p: [self.p[0] + other.p[0], self.p[1] + other.p[1]],
            q: [self.q[0] + other.q[0], self.q[1] + other.q[1]],
            pp: self.pp + other.pp,
            qq: self.qq + other.qq,
            dot: self.dot + other.dot,
            cross: self.cross + other.cross,
        }
    }

    /// Number of pairs.
    pub fn count(&self) -> usize {
        self.n as usize
    }

    /// Centred sums: `Σ|p̃|²`, `Σ|q̃|²`, `Σ p̃·q̃`, `Σ p̃×q̃`.
    fn centred(&self) -> [f64; 4] {
        let n = self.n;
        let mp = [self.p[0] / n, self.p[1] / n];
        let mq = [self.q[0] / n, self.q[1] / n];
        [
            self.pp - n * (mp[0] * mp[0] + mp[1] * mp[1]),
            self.qq - n * (mq[0] * mq[0] + mq[1] * mq[1]),
            self.dot - n * (mp[0] * mq[0] + mp[1] * mq[1]),
            self.cross - n * (mp[0] * mq[1] - mp[1] * mq[0]),
        ]
    }

    /// The least-squares similarity, or `None` for fewer than two pairs or when every `p` is the
    /// same point (rotation and scale are then undetermined).
    pub fn fit(&self) -> Option<Similarity> {
        let [var, _, dot, cross] = self.centred();
        if self.n < 2.0 || var <= 1e-9 * self.n {
            return None;
        }
        let (a, b) = (dot / var, cross / var);
        let (mp, mq) = ([self.p[0] / self.n, self.p[1] / self.n], [self.q[0] / self.n, self.q[1] / self.n]);
        Some(Similarity {
            a: a as f32,
            b: b as f32,
            tx: (mq[0] - (a * mp[0] - b * mp[1])) as f32,
            ty: (mq[1] - (b * mp[0] + a * mp[1])) as f32,
        })
    }

    /// The mean squared residual `Σ|S(p) − q|² / n` of the least-squares similarity (pixels²);
    /// with one distinct `p`, that of the best translation. 0 for no pairs.
    pub fn mean_squared_residual(&self) -> f64 {
        if self.n == 0.0 {
            return 0.0;
        }
        let [var, qq, dot, cross] = self.centred();
        let explained = if var > 1e-9 * self.n {
            (dot * dot + cross * cross) / var
        } else {
            0.0
        };
        (qq - explained).max(0.0) / self.n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_and_inverse_agree_with_pointwise_application() {
        let f = Similarity::new(0.7, 1.3, [4.0, -2.0]);
        let g = Similarity::new(-2.1, 0.6, [-1.0, 9.0]);
        let p = [3.5, -7.25];
        let fg = f.compose(&g).apply(p);
        let direct = f.apply(g.apply(p));
        assert!((fg[0] - direct[0]).abs() < 1e-4 && (fg[1] - direct[1]).abs() < 1e-4);
        let back = f.inverse().apply(f.apply(p));
        assert!((back[0] - p[0]).abs() < 1e-4 && (back[1] - p[1]).abs() < 1e-4);
        assert!((f.compose(&g).scale() - 1.3 * 0.6).abs() < 1e-5);
        assert!((f.compose(&g).angle() - (0.7 - 2.1)).abs() < 1e-5);
    }

    #[test]
    fn fit_recovers_a_similarity_and_refuses_degenerate_sets() {
        let truth = Similarity::new(-0.9, 1.7, [12.0, -5.0]);
        let from: Vec<[f32; 2]> = (0..20).map(|k| [(k * 7 % 11) as f32, (k * 5 % 13) as f32 - 3.0]).collect();
        let to: Vec<[f32; 2]> = from.iter().map(|&p| truth.apply(p)).collect();
        let fitted = Similarity::fit(&from, &to).expect("twenty distinct points");
        for (x, y) in [
            (fitted.a, truth.a),
            (fitted.b, truth.b),
            (fitted.tx, truth.tx),
            (fitted.ty, truth.ty),
        ] {
            assert!((x - y).abs() < 1e-4, "{fitted:?} vs {truth:?}");
        }
        assert_eq!(Similarity::fit(&from[..1], &to[..1]), None);
        let mut m = Moments::default();
        for (&p, &q) in from.iter().zip(&to) {
            m.add(p, q);
        }
        assert!(m.mean_squared_residual() < 1e-6);
        // A second set moved otherwise: the union's residual is the direct one's.
        let other = Similarity::new(0.4, 1.0, [3.0, 3.0]);
        let mut n = Moments::default();
        let mut all_from = from.clone();
        let mut all_to = to.clone();
        for &p in &from {
            n.add(p, other.apply(p));
            all_from.push(p);
            all_to.push(other.apply(p));
        }
        let union = Similarity::fit(&all_from, &all_to).expect("forty points");
        let direct: f64 = all_from
            .iter()
            .zip(&all_to)
            .map(|(&p, &q)| {
                let s = union.apply(p);
                f64::from((s[0] - q[0]).powi(2) + (s[1] - q[1]).powi(2))
            })
            .sum::<f64>()
            / all_from.len() as f64;
        let merged = m.merged(&n).mean_squared_residual();
        assert!((merged - direct).abs() < 1e-3 * direct.max(1.0), "{merged} vs {direct}");
        assert_eq!(Similarity::fit(&[[2.0, 3.0]; 4], &to[..4]), None);
    }

    #[test]
    fn positive_angle_turns_clockwise_on_screen() {
        // y down: rotating +x by +90° gives +y, i.e. pointing down the screen.
        let r = Similarity::new(std::f32::consts::FRAC_PI_2, 1.0, [0.0, 0.0]).apply([1.0, 0.0]);
        assert!(r[0].abs() < 1e-6 && (r[1] - 1.0).abs() < 1e-6);
    }
}
