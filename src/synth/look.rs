//! How a synthetic part is coloured (issue 4 item 2): a flat cartoon fill, an interior pattern
//! (stripes, dots, gradient), cel shading, features (eyes, mouth, buttons, hands, shoes, hair)
//! and a dark outline, all defined in the part's local frame so they move with the part, and
//! [`paint`], which evaluates them at one point into an anti-aliased straight-alpha colour.

use serde::{Deserialize, Serialize};

use super::shape::{Primitive, Shape};

/// Linear RGB in [0, 1].
pub type Rgb = [f32; 3];

/// The interior fill pattern of a part.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Pattern {
    /// The fill colour only.
    Plain,
    /// Parallel stripes across direction `angle`, `period` local units apart, each `width` wide.
    Stripes {
        /// Direction the stripes repeat along, radians.
        angle: f32,
        /// Distance between stripe centres, local units.
        period: f32,
        /// Stripe width, local units.
        width: f32,
        /// Stripe colour.
        color: Rgb,
    },
    /// Polka dots on a staggered grid.
    Dots {
        /// Grid spacing, local units.
        period: f32,
        /// Dot radius, local units.
        radius: f32,
        /// Dot colour.
        color: Rgb,
    },
    /// A linear blend from the fill colour at `from` to `color` at `to`.
    Gradient {
        /// Where the fill colour is pure.
        from: [f32; 2],
        /// Where `color` is pure.
        to: [f32; 2],
        /// The far colour.
        color: Rgb,
    },
}

/// The region a feature covers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum FeatureShape {
    /// A filled primitive.
    Fill(Primitive),
    /// The lower half of a ring: a smile.
    Smile {
        /// Centre of the ring.
        center: [f32; 2],
        /// Ring radius.
        radius: f32,
        /// Line thickness.
        thickness: f32,
    },
}

/// A detail painted over the fill: an eye, a pupil, a mouth, a button, a hand, a shoe, hair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Feature {
    /// Where it is.
    pub shape: FeatureShape,
    /// Its colour.
    pub color: Rgb,
    /// Width in pixels of the outline drawn inside its edge (0: none).
    pub ink: f32,
}

/// Everything about a part's colouring.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Look {
    /// Base colour.
    pub fill: Rgb,
    /// Interior pattern over the fill.
    pub pattern: Pattern,
    /// Colour of the shaded crescent (cel shading).
    pub shadow: Rgb,
    /// Offset, local units, of the lit copy of the silhouette: the part of the shape not
    /// covered by the copy moved by this offset is in shadow.
    pub shadow_offset: [f32; 2],
    /// Details, painted in order.
    pub features: Vec<Feature>,
    /// Outline colour.
    pub outline: Rgb,
    /// Outline width in pixels at scale 1.
    pub outline_px: f32,
}

/// Mild per-frame line wobble (issue 4 item 3): the silhouette moves by up to `amplitude`
/// pixels and the outline width by up to ±25 %, as low-frequency waves over the part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wobble {
    /// Largest silhouette displacement in pixels.
    pub amplitude: f32,
    /// Wave vectors (radians per local unit) and phases of the two silhouette waves and the
    /// width wave.
    pub waves: [[f32; 3]; 3],
}

impl Wobble {
    /// No wobble.
    pub const NONE: Wobble = Wobble {
        amplitude: 0.0,
        waves: [[0.0; 3]; 3],
    };

    fn wave(&self, k: usize, p: [f32; 2]) -> f32 {
        let [fx, fy, phase] = self.waves[k];
        libm::sinf(fx * p[0] + fy * p[1] + phase)
    }

    /// Silhouette displacement at local point `p`, pixels (positive shrinks the part).
    pub fn silhouette(&self, p: [f32; 2]) -> f32 {
        if self.amplitude == 0.0 {
            return 0.0;
        }
        self.amplitude * (0.6 * self.wave(0, p) + 0.4 * self.wave(1, p))
    }

    /// Outline width factor at local point `p`.
    pub fn width(&self, p: [f32; 2]) -> f32 {
        if self.amplitude == 0.0 {
            return 1.0;
        }
        1.0 + 0.25 * self.wave(2, p)
    }
}

/// Coverage of a pixel whose centre is `d` pixels from an edge (negative inside): a one-pixel
/// linear ramp, the analytic coverage of a straight edge crossing an axis-aligned pixel at 45°
/// to within a few per cent and exact for edges through the centre.
pub fn coverage(d: f32) -> f32 {
    (0.5 - d).clamp(0.0, 1.0)
}

fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

impl FeatureShape {
    /// Signed distance, local units.
    pub fn sdf(&self, p: [f32; 2]) -> f32 {
        match self {
            FeatureShape::Fill(prim) => prim.sdf(p),
            FeatureShape::Smile { center, radius, thickness } => {
                let (dx, dy) = (p[0] - center[0], p[1] - center[1]);
                let ring = ((dx * dx + dy * dy).sqrt() - radius).abs() - 0.5 * thickness;
                // Only the lower part (y down) of the ring: below the centre line + 0.25 r.
                ring.max(center[1] + 0.25 * radius - p[1])
            }
        }
    }
}

impl Pattern {
    /// The pattern's colour and its coverage at `p` (`px`: pixels per local unit).
    fn sample(&self, fill: Rgb, p: [f32; 2], px: f32) -> Rgb {
        match *self {
            Pattern::Plain => fill,
            Pattern::Stripes {
                angle,
                period,
                width,
                color,
            } => {
                let u = p[0] * libm::cosf(angle) + p[1] * libm::sinf(angle);
                let f = u / period - libm::floorf(u / period);
                let d = ((f - 0.5).abs() * period - 0.5 * width) * px;
                mix(fill, color, coverage(d))
            }
            Pattern::Dots { period, radius, color } => {
                let row = libm::floorf(p[1] / period);
                let shift = if (row as i64).rem_euclid(2) == 1 { 0.5 * period } else { 0.0 };
                let cx = (libm::floorf((p[0] - shift) / period) + 0.5) * period + shift;
                let cy = (row + 0.5) * period;
                let d = (((p[0] - cx).powi(2) + (p[1] - cy).powi(2)).sqrt() - radius) * px;
                mix(fill, color, coverage(d))
            }
            Pattern::Gradient { from, to, color } => {
                let (ax, ay) = (to[0] - from[0], to[1] - from[1]);
                let t = ((p[0] - from[0]) * ax + (p[1] - from[1]) * ay) / (ax * ax + ay * ay).max(1e-6);
                mix(fill, color, t.clamp(0.0, 1.0))
            }
        }
    }
}

/// The straight-alpha colour of a part at local point `p`.
///
/// `px`: pixels per local unit of the part's placement (the similarity's scale);
/// `wobble`: this frame's line wobble (or [`Wobble::NONE`]). Returns `[r, g, b, a]`.
pub fn paint(look: &Look, shape: &Shape, p: [f32; 2], px: f32, wobble: &Wobble) -> [f32; 4] {
    let d = shape.sdf(p) * px + wobble.silhouette(p);
    let alpha = coverage(d);
    if alpha <= 0.0 {
        return [0.0; 4];
    }
    let mut c = look.pattern.sample(look.fill, p, px);
    let o = look.shadow_offset;
    let lit = shape.sdf([p[0] + o[0], p[1] + o[1]]) * px;
    c = mix(c, look.shadow, coverage(-lit));
    for f in &look.features {
        let df = f.shape.sdf(p) * px;
        let cf = coverage(df);
        if cf > 0.0 {
            let fc = if f.ink > 0.0 {
                mix(f.color, look.outline, coverage(-(df + f.ink)))
            } else {
                f.color
            };
            c = mix(c, fc, cf);
        }
    }
    let width = look.outline_px * wobble.width(p);
    c = mix(c, look.outline, coverage(-(d + width)));
    [c[0], c[1], c[2], alpha]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc_look() -> (Look, Shape) {
        let shape = Shape {
            primitives: vec![Primitive::Superellipse {
                center: [0.0, 0.0],
                radii: [10.0, 10.0],
                exponent: 2.0,
                angle: 0.0,
            }],
        };
        let look = Look {
            fill: [1.0, 0.0, 0.0],
            pattern: Pattern::Plain,
            shadow: [0.5, 0.0, 0.0],
            shadow_offset: [0.0, 0.0],
            features: vec![Feature {
                shape: FeatureShape::Fill(Primitive::Superellipse {
                    center: [0.0, 0.0],
                    radii: [3.0, 3.0],
                    exponent: 2.0,
                    angle: 0.0,
                }),
                color: [0.0, 0.0, 1.0],
                ink: 0.0,
            }],
            outline: [0.0, 0.0, 0.0],
            outline_px: 2.0,
        };
        (look, shape)
    }

    #[test]
    fn paint_layers_fill_feature_outline_and_coverage() {
        let (look, shape) = disc_look();
        let none = Wobble::NONE;
        assert_eq!(paint(&look, &shape, [0.0, 0.0], 1.0, &none), [0.0, 0.0, 1.0, 1.0]); // feature
        assert_eq!(paint(&look, &shape, [6.0, 0.0], 1.0, &none), [1.0, 0.0, 0.0, 1.0]); // fill
        assert_eq!(paint(&look, &shape, [9.0, 0.0], 1.0, &none), [0.0, 0.0, 0.0, 1.0]); // outline
        assert_eq!(paint(&look, &shape, [11.0, 0.0], 1.0, &none)[3], 0.0); // outside
        assert_eq!(paint(&look, &shape, [10.0, 0.0], 1.0, &none)[3], 0.5); // on the edge
                                                                           // At scale 2 the same local point is 2 px from the edge: fully inside.
        assert_eq!(paint(&look, &shape, [9.0, 0.0], 2.0, &none)[3], 1.0);
    }

    #[test]
    fn stripes_and_dots_alternate() {
        let red = [1.0, 0.0, 0.0];
        let white = [1.0, 1.0, 1.0];
        let stripes = Pattern::Stripes {
            angle: 0.0,
            period: 10.0,
            width: 4.0,
            color: white,
        };
        assert_eq!(stripes.sample(red, [5.0, 3.0], 1.0), white);
        assert_eq!(stripes.sample(red, [0.0, 3.0], 1.0), red);
        let dots = Pattern::Dots {
            period: 10.0,
            radius: 2.0,
            color: white,
        };
        assert_eq!(dots.sample(red, [5.0, 5.0], 1.0), white);
        assert_eq!(dots.sample(red, [0.0, 5.0], 1.0), red);
        assert_eq!(dots.sample(red, [10.0, 15.0], 1.0), white); // odd rows are staggered
    }

    #[test]
    fn wobble_moves_the_edge_by_at_most_its_amplitude() {
        let (look, shape) = disc_look();
        let w = Wobble {
            amplitude: 0.4,
            waves: [[0.5, 0.2, 1.0], [-0.3, 0.6, 2.0], [0.1, 0.1, 0.0]],
        };
        for k in 0..64 {
            let t = k as f32 / 64.0 * std::f32::consts::TAU;
            let inside = paint(&look, &shape, [9.0 * t.cos(), 9.0 * t.sin()], 1.0, &w)[3];
            let outside = paint(&look, &shape, [11.0 * t.cos(), 11.0 * t.sin()], 1.0, &w)[3];
            assert_eq!((inside, outside), (1.0, 0.0), "angle {t}");
        }
    }
}
