//! Arms and legs, and an object held in the front hand.

use std::f32::consts::PI;

use super::body::{circle, plain_look, Build};
use super::palette::{hsv, lighten, scale_rgb, Palette};
use super::part::{Part, Role, Side};
use crate::rng::Rng;
use crate::synth::look::{Feature, FeatureShape, Look, Pattern, Rgb};
use crate::synth::shape::{Primitive, Shape};

/// An upper arm or thigh hanging from `pivot` on the part `parent`, `len` long and `r` wide.
#[allow(clippy::too_many_arguments)]
pub(super) fn limb_upper(
    name: &str,
    role: Role,
    side: Side,
    parent: usize,
    pivot: [f32; 2],
    rest_angle: f32,
    [len, r]: [f32; 2],
    look: Look,
) -> Part {
    let bone = Bone {
        pivot,
        rest_angle,
        len,
        radii: [r, 0.9 * r],
    };
    segment(name, role, side, parent, bone, None, look)
}

/// Where a limb segment hangs and how it is shaped: from `pivot` in its parent's frame, turned by
/// `rest_angle` from it, a capsule `len` long along local +y, `radii` wide at its two ends.
struct Bone {
    pivot: [f32; 2],
    rest_angle: f32,
    len: f32,
    radii: [f32; 2],
}

impl Bone {
    /// A forearm or shin `len` long, hanging from the end of its upper segment (`upper` long),
    /// 0.9 of the limb's width `r` there and `taper` · `r` at its own end.
    fn lower(upper: f32, rest_angle: f32, len: f32, r: f32, taper: f32) -> Bone {
        Bone {
            pivot: [0.0, upper],
            rest_angle,
            len,
            radii: [0.9 * r, taper * r],
        }
    }
}

/// A limb segment: its bone's capsule, then `end` (a hand, a foot) if any.
fn segment(name: &str, role: Role, side: Side, parent: usize, bone: Bone, end: Option<Primitive>, look: Look) -> Part {
    let capsule = Primitive::Capsule {
        a: [0.0, 0.0],
        b: [0.0, bone.len],
        ra: bone.radii[0],
        rb: bone.radii[1],
    };
    Part {
        name: name.into(),
        role,
        side,
        parent: Some(parent),
        pivot: bone.pivot,
        rest_angle: bone.rest_angle,
        shape: Shape {
            primitives: std::iter::once(capsule).chain(end).collect(),
        },
        look,
    }
}

/// A forearm with its hand, hanging from the upper arm `parent`, `fill` with a `hand` of its own
/// colour, darkened by `shade`.
#[allow(clippy::too_many_arguments)]
pub(super) fn arm_lower(
    name: &str,
    side: Side,
    parent: usize,
    b: &Build,
    rest_angle: f32,
    fill: Rgb,
    hand: Rgb,
    shade: f32,
    pal: &Palette,
) -> Part {
    let [upper, len, r] = b.arm;
    let hc = [0.0, len + 0.5 * b.hand];
    let mut look = plain_look(scale_rgb(fill, shade), pal, b.outline_px, r);
    look.features.push(Feature {
        shape: FeatureShape::Fill(circle(hc, b.hand)),
        color: scale_rgb(hand, shade),
        ink: b.outline_px,
    });
    let bone = Bone::lower(upper, rest_angle, len, r, 0.8);
    segment(name, Role::LowerArm, side, parent, bone, Some(circle(hc, b.hand)), look)
}

/// A shin with its foot (round or boxy; half of them striped), hanging from the thigh `parent`.
#[allow(clippy::too_many_arguments)]
pub(super) fn leg_lower(
    name: &str,
    side: Side,
    parent: usize,
    b: &Build,
    rest_angle: f32,
    fill: Rgb,
    shade: f32,
    pal: &Palette,
    rng: &mut Rng,
) -> Part {
    let [upper, len, r] = b.leg;
    let [fl, fh] = b.foot;
    let foot = if rng.chance(0.5) {
        Primitive::Superellipse {
            center: [0.3 * fl, len + 0.2 * fh],
            radii: [0.5 * fl, 0.5 * fh + 1.0],
            exponent: 2.5,
            angle: 0.0,
        }
    } else {
        Primitive::RoundedBox {
            center: [0.3 * fl, len + 0.2 * fh],
            half: [0.5 * fl, 0.5 * fh + 1.0],
            radius: 0.45 * fh,
            angle: 0.0,
        }
    };
    let mut look = plain_look(scale_rgb(fill, shade), pal, b.outline_px, r);
    if rng.chance(0.5) {
        look.pattern = Pattern::Stripes {
            angle: PI / 2.0,
            period: rng.range(3.5, 5.5),
            width: 1.6,
            color: scale_rgb(lighten(pal.accent, 0.3), shade),
        };
    }
    look.features.push(Feature {
        shape: FeatureShape::Fill(foot.clone()),
        color: scale_rgb(pal.shoes, shade),
        ink: b.outline_px,
    });
    let bone = Bone::lower(upper, rest_angle, len, r, 0.75);
    segment(name, Role::LowerLeg, side, parent, bone, Some(foot), look)
}

/// Puts an object in a forearm's hand — a stick, a sword or a staff with a knob — as part of
/// the forearm's silhouette (it moves as the hand does: one articulated part with it).
pub(super) fn hold(forearm: &mut Part, b: &Build, rng: &mut Rng) {
    let [_, len, _] = b.arm;
    let hand = [0.0, len + 0.5 * b.hand];
    let angle = rng.range(-0.9, 0.9) + PI / 2.0;
    let (reach, back) = (rng.range(14.0, 26.0), rng.range(2.0, 6.0));
    let dir = [libm::cosf(angle), libm::sinf(angle)];
    let a = [hand[0] - back * dir[0], hand[1] - back * dir[1]];
    let tip = [hand[0] + reach * dir[0], hand[1] + reach * dir[1]];
    let r = rng.range(0.9, 1.8);
    let mut pieces = vec![Primitive::Capsule { a, b: tip, ra: r, rb: r }];
    if rng.chance(0.5) {
        pieces.push(circle(tip, rng.range(2.0, 3.5)));
    }
    let colour = hsv(rng.unit(), rng.range(0.2, 0.8), rng.range(0.35, 0.9));
    for piece in pieces {
        forearm.shape.primitives.push(piece.clone());
        forearm.look.features.push(Feature {
            shape: FeatureShape::Fill(piece),
            color: colour,
            ink: b.outline_px,
        });
    }
}

/// A robot's limbs are straight tubes: each capsule as wide at both ends.
pub(super) fn straighten_limbs(parts: &mut [Part]) {
    let limbs = parts
        .iter_mut()
        .filter(|p| matches!(p.role, Role::UpperArm | Role::LowerArm | Role::UpperLeg | Role::LowerLeg));
    for part in limbs {
        if let Some(Primitive::Capsule { ra, rb, .. }) = part.shape.primitives.first_mut() {
            *rb = *ra;
        }
    }
}
