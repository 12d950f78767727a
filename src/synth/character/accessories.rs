//! The accessory layers of a dressed character (issue 13's synthetic data).

use super::palette::{hsv, lighten, scale_rgb};
use super::part::{Part, Role, Side};
use crate::rng::Rng;
use crate::synth::look::{Look, Pattern, Rgb};
use crate::synth::shape::{Primitive, Shape};

/// The accessory set of issue 13's synthetic data, each in its parent's local frame (pivot at
/// the parent's origin, no rest turn) and sized from the parent's silhouette: a vest with a
/// collar over the torso; back hair behind the head; freckles (several pieces in one layer),
/// sunglasses and a hat on the head; a bracelet on the front forearm and a sleeve over the front
/// upper arm. Each covers part of its parent's outline, so the rig has occlusion to keep. With
/// `trim`, also a trim along the vest's hem ([`Character::trimmed`]), drawn without a random
/// draw so that the rest is the same.
pub(super) fn accessories(body: &[Part], rng: &mut Rng, outline_px: f32, trim: bool) -> Vec<Part> {
    let index = |name: &str| body.iter().position(|p| p.name == name).expect("every character has this part");
    let bounds = |i: usize| body[i].shape.bounds();
    let capsule = |i: usize| match body[i].shape.primitives[0] {
        Primitive::Capsule { b, ra, .. } => (b[1], ra),
        _ => unreachable!("limbs are capsules"),
    };
    let colour = |rng: &mut Rng| hsv(rng.unit(), rng.range(0.4, 0.9), rng.range(0.35, 0.9));
    let outline = hsv(rng.unit(), 0.5, 0.12);
    let look = |fill: Rgb, size: f32| Look {
        fill,
        pattern: Pattern::Plain,
        shadow: scale_rgb(fill, 0.78),
        shadow_offset: [-0.3 * size, -0.2 * size],
        features: Vec::new(),
        outline,
        outline_px,
    };
    let part = |name: &str, parent: usize, primitives: Vec<Primitive>, look: Look| Part {
        name: name.into(),
        role: Role::Accessory,
        side: Side::Middle,
        parent: Some(parent),
        pivot: [0.0, 0.0],
        rest_angle: 0.0,
        shape: Shape { primitives },
        look,
    };
    let (torso, head) = (index("torso"), index("head"));
    let [tl, th] = bounds(torso);
    let (tw, tall) = (th[0] - tl[0], th[1] - tl[1]);
    let [hl, hh] = bounds(head);
    let (hw, hgt) = (hh[0] - hl[0], hh[1] - hl[1]);
    let hc = [0.5 * (hl[0] + hh[0]), 0.5 * (hl[1] + hh[1])];
    let mut out = Vec::new();
    let mut vest = look(colour(rng), 0.4 * tw);
    vest.pattern = Pattern::Stripes {
        angle: 0.0,
        period: rng.range(5.0, 7.0),
        width: 1.5,
        color: lighten(vest.fill, 0.4),
    };
    let hem = tl[1] + 0.62 * tall;
    let trim_part = trim.then(|| {
        // Inside the vest, clear of its rounded corners, its lower edge on the vest's hem.
        let shape = Primitive::RoundedBox {
            center: [0.0, hem - 0.04 * tall],
            half: [0.5 * tw, 0.04 * tall],
            radius: 0.02 * tall,
            angle: 0.0,
        };
        part("trim", body.len(), vec![shape], look(scale_rgb(vest.fill, 0.55), 0.1 * tall))
    });
    out.push(part(
        "vest",
        torso,
        vec![
            Primitive::RoundedBox {
                center: [0.0, tl[1] + 0.32 * tall],
                half: [0.56 * tw, 0.3 * tall],
                radius: 0.2 * tw,
                angle: 0.0,
            },
            // The collar, along the neckline.
            Primitive::Superellipse {
                center: [0.1 * tw, tl[1] + 0.03 * tall],
                radii: [0.32 * tw, 0.09 * tall],
                exponent: 2.0,
                angle: 0.0,
            },
        ],
        vest,
    ));
    out.push(part(
        "hair_back",
        head,
        vec![Primitive::Superellipse {
            center: [hc[0] - 0.22 * hw, hc[1] + 0.05 * hgt],
            radii: [0.48 * hw, 0.56 * hgt],
            exponent: 2.2,
            angle: rng.range(-0.2, 0.1),
        }],
        look(hsv(rng.range(0.0, 0.12), rng.range(0.4, 0.9), rng.range(0.15, 0.6)), 0.3 * hw),
    ));
    // Four specks on the far cheek, apart from each other: one layer of four pieces.
    let speck = 0.04 * hw;
    let freckles = (0..4)
        .map(|k| Primitive::Superellipse {
            center: [
                hc[0] + (0.26 + 0.1 * (k / 2) as f32 + 0.05 * (k % 2) as f32) * hw,
                hc[1] + (0.1 + 0.09 * (k % 2) as f32) * hgt,
            ],
            radii: [speck, speck],
            exponent: 2.0,
            angle: 0.0,
        })
        .collect();
    let mut freckle_look = look([0.6, 0.35, 0.25], speck);
    freckle_look.outline_px = 0.0;
    out.push(part("freckles", head, freckles, freckle_look));
    let lens = |x: f32| Primitive::Superellipse {
        center: [hc[0] + x * hw, hc[1] - 0.04 * hgt],
        radii: [0.13 * hw, 0.11 * hgt],
        exponent: 2.6,
        angle: 0.0,
    };
    out.push(part(
        "glasses",
        head,
        vec![
            lens(0.06),
            lens(0.3),
            Primitive::Capsule {
                a: [hc[0] + 0.06 * hw, hc[1] - 0.06 * hgt],
                b: [hc[0] + 0.3 * hw, hc[1] - 0.06 * hgt],
                ra: 0.03 * hgt,
                rb: 0.03 * hgt,
            },
        ],
        look([0.1, 0.1, 0.14], 0.1 * hw),
    ));
    out.push(part(
        "hat",
        head,
        vec![
            Primitive::RoundedBox {
                center: [hc[0] - 0.02 * hw, hl[1] + 0.02 * hgt],
                half: [0.36 * hw, 0.2 * hgt],
                radius: 0.1 * hw,
                angle: 0.0,
            },
            Primitive::RoundedBox {
                center: [hc[0] + 0.05 * hw, hl[1] + 0.22 * hgt],
                half: [0.6 * hw, 0.06 * hgt],
                radius: 0.05 * hgt,
                angle: 0.0,
            },
        ],
        look(colour(rng), 0.3 * hw),
    ));
    // A band around a limb, centred `at` along its bone and `half` long either way (fractions
    // of the bone), `width` times the limb's radius either side, corners rounded by `corner`
    // radii.
    let band = |name: &str, limb: &str, [at, half]: [f32; 2], [width, corner]: [f32; 2], fill: Rgb| {
        let i = index(limb);
        let (len, r) = capsule(i);
        let shape = Primitive::RoundedBox {
            center: [0.0, at * len],
            half: [width * r, half * len],
            radius: corner * r,
            angle: 0.0,
        };
        part(name, i, vec![shape], look(fill, r))
    };
    out.push(band(
        "bracelet",
        "arm_front_lower",
        [0.78, 0.14],
        [1.05, 0.3],
        lighten(colour(rng), 0.3),
    ));
    // Below the shoulder and hardly wider than the arm, so that it lies on the arm about as much
    // as on the vest behind it (the DAG then takes the arm, nearer in z-order).
    out.push(band("sleeve", "arm_front_upper", [0.42, 0.26], [1.08, 0.5], colour(rng)));
    out.extend(trim_part);
    out
}
