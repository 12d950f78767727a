//! Heads: a cartoon face in three-quarter or front view, or a robot's boxy head.

use super::body::{boxy, circle, plain_look, Build};
use super::palette::{lighten, scale_rgb, Palette};
use crate::rng::Rng;
use crate::synth::look::{Feature, FeatureShape, Look};
use crate::synth::shape::{Primitive, Shape};

/// The head's shape, look and centre (in its local frame, origin at the neck).
/// Seen from the `front`, the head sits on the neck and its face is symmetric.
pub(super) fn head(rng: &mut Rng, pal: &Palette, b: &Build, front: bool) -> (Shape, Look, [f32; 2]) {
    let [hw, hh] = b.head;
    let offset = rng.range(0.0, 0.2) * hw;
    let c = [if front { 0.0 } else { offset }, -0.8 * hh];
    // Feature places across the face, as fractions of the half-width from the centre: hair,
    // far eye, near eye, pupils' glance, mouth, nose.
    let [hair_x, far_eye, near_eye, glance, mouth, nose] = if front {
        [0.0, -0.38, 0.38, 0.0, 0.0, 0.0]
    } else {
        [-0.35, 0.12, 0.55, 0.35, 0.42, 0.9]
    };
    let prim = match rng.below(3) {
        0 => Primitive::Superellipse {
            center: c,
            radii: [hw, hh],
            exponent: 2.0,
            angle: 0.0,
        },
        1 => Primitive::Superellipse {
            center: c,
            radii: [hw, hh],
            exponent: rng.range(2.5, 3.5),
            angle: 0.0,
        },
        _ => Primitive::RoundedBox {
            center: c,
            half: [hw, hh],
            radius: rng.range(0.45, 0.7) * hw.min(hh),
            angle: 0.0,
        },
    };
    let mut look = plain_look(pal.skin, pal, b.outline_px, hw);
    look.shadow_offset = [-0.25 * hw, -0.2 * hh];
    if rng.chance(0.6) {
        // Hair over the top and back of the head.
        look.features.push(Feature {
            shape: FeatureShape::Fill(Primitive::Superellipse {
                center: [c[0] + hair_x * hw, c[1] - 0.75 * hh],
                radii: [1.15 * hw, 0.6 * hh],
                exponent: 2.0,
                angle: rng.range(-0.15, 0.3),
            }),
            color: pal.hair,
            ink: 0.0,
        });
    }
    let eye_r = [rng.range(0.14, 0.22) * hw, rng.range(0.18, 0.28) * hh];
    let eye_y = c[1] - rng.range(-0.05, 0.15) * hh;
    let white = [1.0, 1.0, 1.0];
    let dark = [0.08, 0.06, 0.1];
    for (k, dx) in [(0, far_eye), (1, near_eye)] {
        // The far eye is narrower (three-quarter view).
        let r = if k == 0 && !front { [0.8 * eye_r[0], eye_r[1]] } else { eye_r };
        let e = [c[0] + dx * hw, eye_y];
        look.features.push(Feature {
            shape: FeatureShape::Fill(Primitive::Superellipse {
                center: e,
                radii: r,
                exponent: 2.0,
                angle: 0.0,
            }),
            color: white,
            ink: 0.7 * b.outline_px,
        });
        let pupil = [e[0] + glance * r[0], e[1] + 0.1 * r[1]];
        look.features.push(Feature {
            shape: FeatureShape::Fill(circle(pupil, 0.5 * r[0].min(r[1]))),
            color: dark,
            ink: 0.0,
        });
        look.features.push(Feature {
            shape: FeatureShape::Fill(circle([pupil[0] + 0.2 * r[0], pupil[1] - 0.25 * r[1]], 0.18 * r[0].min(r[1]))),
            color: white,
            ink: 0.0,
        });
    }
    look.features.push(Feature {
        shape: FeatureShape::Smile {
            center: [c[0] + mouth * hw, c[1] + 0.3 * hh],
            radius: rng.range(0.15, 0.25) * hw,
            thickness: 0.06 * hw + 0.6,
        },
        color: dark,
        ink: 0.0,
    });
    if rng.chance(0.6) {
        look.features.push(Feature {
            shape: FeatureShape::Fill(circle([c[0] + 0.75 * hw, c[1] + 0.25 * hh], 0.12 * hw)),
            color: lighten([0.95, 0.45, 0.5], 0.35),
            ink: 0.0,
        });
    }
    if rng.chance(0.5) {
        look.features.push(Feature {
            shape: FeatureShape::Fill(Primitive::Superellipse {
                center: [c[0] + nose * hw, c[1] + 0.05 * hh],
                radii: [0.14 * hw, 0.1 * hh],
                exponent: 2.0,
                angle: 0.0,
            }),
            color: scale_rgb(pal.skin, 0.8),
            ink: 0.6 * b.outline_px,
        });
    }
    (Shape { primitives: vec![prim] }, look, c)
}

/// Makes a head a robot's: a box around its centre `c`, with a visor band across the eyes and
/// an antenna on top (part of the head's silhouette, so it moves with it).
pub(super) fn robot_head(shape: &mut Shape, look: &mut Look, c: [f32; 2], b: &Build, pal: &Palette, rng: &mut Rng) {
    let [hw, hh] = b.head;
    *shape = boxy([2.0 * hw, 2.0 * hh], c, rng.range(0.08, 0.2));
    let tall = rng.range(0.5, 0.9) * hh;
    let top = [c[0] + rng.range(-0.3, 0.3) * hw, c[1] - hh - tall];
    let stalk = Primitive::Capsule {
        a: [top[0], c[1] - hh + 1.0],
        b: top,
        ra: 0.9,
        rb: 0.9,
    };
    let bulb = circle(top, rng.range(1.8, 2.8));
    shape.primitives.extend([stalk.clone(), bulb.clone()]);
    // No hair (the one feature wider than half the head); a visor behind the eyes instead.
    look.features
        .retain(|f| !matches!(f.shape, FeatureShape::Fill(Primitive::Superellipse { radii, .. }) if radii[0] > 0.5 * hw));
    look.features.insert(
        0,
        Feature {
            shape: FeatureShape::Fill(Primitive::RoundedBox {
                center: [c[0], c[1] - 0.05 * hh],
                half: [0.85 * hw, 0.32 * hh],
                radius: 0.1 * hh,
                angle: 0.0,
            }),
            color: scale_rgb(pal.shirt, 0.45),
            ink: b.outline_px,
        },
    );
    look.features.push(Feature {
        shape: FeatureShape::Fill(stalk),
        color: scale_rgb(pal.skin, 0.7),
        ink: 0.0,
    });
    look.features.push(Feature {
        shape: FeatureShape::Fill(bulb),
        color: pal.accent,
        ink: b.outline_px,
    });
}
