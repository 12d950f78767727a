//! A 2D similarity transform (rotation, uniform scale, translation): how a part's local frame
//! sits in the rest frame or in a drawn frame (pixels, y down).

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
    fn positive_angle_turns_clockwise_on_screen() {
        // y down: rotating +x by +90° gives +y, i.e. pointing down the screen.
        let r = Similarity::new(std::f32::consts::FRAC_PI_2, 1.0, [0.0, 0.0]).apply([1.0, 0.0]);
        assert!(r[0].abs() < 1e-6 && (r[1] - 1.0).abs() < 1e-6);
    }
}
