//! The torso and head of a character, and what every part's drawing shares: its proportions,
//! plain looks, circles.

use std::f32::consts::PI;

use super::palette::{lighten, scale_rgb, Palette};
use crate::rng::Rng;
use crate::synth::look::{Feature, FeatureShape, Look, Pattern, Rgb};
use crate::synth::shape::{Primitive, Shape};

/// A disc of radius `r` about `center`.
pub(super) fn circle(center: [f32; 2], r: f32) -> Primitive {
    Primitive::Superellipse {
        center,
        radii: [r, r],
        exponent: 2.0,
        angle: 0.0,
    }
}

/// Random proportions of one character, in character units.
pub(super) struct Build {
    pub(super) torso: [f32; 2],
    pub(super) head: [f32; 2],
    pub(super) arm: [f32; 3],
    pub(super) leg: [f32; 3],
    pub(super) hand: f32,
    pub(super) foot: [f32; 2],
    pub(super) outline_px: f32,
}

/// Moves `p` toward the origin until it is at least `depth` inside `shape`.
pub(super) fn inset(shape: &Shape, p: [f32; 2], depth: f32) -> [f32; 2] {
    let mut q = p;
    for _ in 0..50 {
        if shape.sdf(q) <= -depth {
            break;
        }
        q = [q[0] * 0.95, q[1] * 0.95];
    }
    q
}

/// A torso `w` wide and `h` tall about the origin: an ellipse, a superellipse, a rounded box or a
/// pear.
pub(super) fn torso_shape(rng: &mut Rng, [w, h]: [f32; 2]) -> Shape {
    let prim = match rng.below(4) {
        0 => Primitive::Superellipse {
            center: [0.0, 0.0],
            radii: [0.5 * w, 0.5 * h],
            exponent: 2.0,
            angle: 0.0,
        },
        1 => Primitive::Superellipse {
            center: [0.0, 0.0],
            radii: [0.5 * w, 0.5 * h],
            exponent: rng.range(2.6, 4.0),
            angle: 0.0,
        },
        2 => Primitive::RoundedBox {
            center: [0.0, 0.0],
            half: [0.5 * w, 0.5 * h],
            radius: rng.range(0.3, 0.5) * w.min(h),
            angle: 0.0,
        },
        _ => {
            // A pear: narrow shoulders, wide hips.
            let (rt, rb) = (rng.range(0.3, 0.4) * w, 0.5 * w);
            Primitive::Capsule {
                a: [0.0, -0.5 * h + rt],
                b: [0.0, 0.5 * h - rb],
                ra: rt,
                rb,
            }
        }
    };
    Shape { primitives: vec![prim] }
}

/// `fill` with the palette's outline and a shadow offset by the part's `size`, no pattern.
pub(super) fn plain_look(fill: Rgb, pal: &Palette, outline_px: f32, size: f32) -> Look {
    Look {
        fill,
        pattern: Pattern::Plain,
        shadow: scale_rgb(fill, 0.78),
        shadow_offset: [-0.35 * size, -0.2 * size],
        features: Vec::new(),
        outline: pal.outline,
        outline_px,
    }
}

/// The torso's look: the shirt's colour in a random pattern, with buttons, a belly patch or a belt.
pub(super) fn torso_look(rng: &mut Rng, pal: &Palette, b: &Build, shape: &Shape) -> Look {
    let [w, h] = b.torso;
    let mut look = plain_look(pal.shirt, pal, b.outline_px, 0.4 * w);
    look.shadow_offset = [-0.12 * w, -0.08 * h];
    look.pattern = match rng.below(4) {
        0 => Pattern::Stripes {
            angle: PI / 2.0 + rng.range(-0.3, 0.3),
            period: rng.range(5.0, 8.0),
            width: rng.range(1.8, 3.0),
            color: pal.accent,
        },
        1 => Pattern::Dots {
            period: rng.range(6.0, 9.0),
            radius: rng.range(1.2, 2.0),
            color: pal.accent,
        },
        2 => Pattern::Gradient {
            from: [0.0, -0.5 * h],
            to: [0.0, 0.5 * h],
            color: scale_rgb(pal.shirt, 0.6),
        },
        _ => Pattern::Plain,
    };
    if rng.chance(0.6) {
        // Buttons down the front.
        let x = 0.18 * w;
        for k in 0..3 {
            let y = -0.2 * h + k as f32 * 0.18 * h;
            if shape.sdf([x, y]) < -2.5 {
                look.features.push(Feature {
                    shape: FeatureShape::Fill(circle([x, y], 1.4)),
                    color: lighten(pal.accent, 0.5),
                    ink: 0.8 * b.outline_px,
                });
            }
        }
    } else {
        // A belly patch.
        look.features.push(Feature {
            shape: FeatureShape::Fill(Primitive::Superellipse {
                center: [0.12 * w, 0.08 * h],
                radii: [0.25 * w, 0.3 * h],
                exponent: 2.0,
                angle: 0.0,
            }),
            color: lighten(pal.shirt, 0.55),
            ink: 0.0,
        });
    }
    if rng.chance(0.5) {
        // A belt.
        look.features.push(Feature {
            shape: FeatureShape::Fill(Primitive::RoundedBox {
                center: [0.0, 0.32 * h],
                half: [w, 0.06 * h],
                radius: 0.0,
                angle: 0.0,
            }),
            color: pal.shoes,
            ink: 0.0,
        });
    }
    look
}

/// A sleeve continues the shirt's stripes or dots (a gradient would not line up: plain).
pub(super) fn sleeve_look(pal: &Palette, shirt: &Pattern, shade: f32, outline_px: f32, r: f32) -> Look {
    let mut look = plain_look(scale_rgb(pal.shirt, shade), pal, outline_px, r);
    look.pattern = match shirt.clone() {
        Pattern::Stripes { period, width, color, .. } => Pattern::Stripes {
            angle: PI / 2.0,
            period,
            width,
            color: scale_rgb(color, shade),
        },
        Pattern::Dots { period, radius, color } => Pattern::Dots {
            period,
            radius,
            color: scale_rgb(color, shade),
        },
        _ => Pattern::Plain,
    };
    look
}

/// A box `size` wide and tall around `center`, its corners rounded by `round` of its smaller
/// side: a robot's torso or head.
pub(super) fn boxy(size: [f32; 2], center: [f32; 2], round: f32) -> Shape {
    Shape {
        primitives: vec![Primitive::RoundedBox {
            center,
            half: [0.5 * size[0], 0.5 * size[1]],
            radius: round * size[0].min(size[1]),
            angle: 0.0,
        }],
    }
}
