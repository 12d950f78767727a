//! Procedural cartoon characters (issue 4 item 2): a skeleton of parts — torso (root), head,
//! two-segment arms and legs, optional tail and ears — each an analytic [`Shape`] with random
//! proportions and a [`Look`](super::look::Look), seen in three-quarter view facing right, layered back to front
//! (back limbs behind the torso, head and front limbs in front).
//!
//! Each part has a local frame: the torso's origin is its centre; every other part's origin is
//! its pivot (the joint with its parent) and its bone runs along local +y. Local units are
//! "character units" (a character is about 100 tall); [`Character::rest_root`] places the torso
//! frame in the rest frame's pixels, scaling the character to fit.
//!
//! `part.rs` holds the part types, `palette.rs` the colours, `body.rs` the torso and what every
//! part shares, `head.rs` the heads, `limbs.rs` arms and legs, `accessories.rs` the clothes.

mod accessories;
mod body;
mod head;
mod limbs;
mod palette;
mod part;

use std::f32::consts::PI;

use serde::{Deserialize, Serialize};

use super::look::{Feature, FeatureShape, Pattern};
use super::shape::{Primitive, Shape};
use crate::geom::similarity::Similarity;
use crate::rng::Rng;
use body::{boxy, circle, inset, plain_look, sleeve_look, torso_look, torso_shape, Build};
use limbs::{arm_lower, hold, leg_lower, limb_upper, straighten_limbs};
use palette::{lighten, scale_rgb, Palette};
pub use part::{Part, Role, Side};

/// A generated character, parts ordered back to front.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Character {
    /// Name, `synth-<seed>`.
    pub name: String,
    /// Parts, back (index 0) to front.
    pub parts: Vec<Part>,
    /// Torso local frame → rest-frame pixels.
    pub rest_root: Similarity,
}

/// Layer order back → front by name; absent optional parts are skipped.
const Z_ORDER: [&str; 21] = [
    "tail",
    "arm_back_lower",
    "arm_back_upper",
    "leg_back_lower",
    "leg_back_upper",
    "torso",
    "vest",
    "trim",
    "leg_front_lower",
    "leg_front_upper",
    "hair_back",
    "ear_back",
    "ear_front",
    "head",
    "freckles",
    "glasses",
    "hat",
    "arm_front_lower",
    "bracelet",
    "arm_front_upper",
    "sleeve",
];

impl Character {
    /// Generates the character for `seed`, scaled to stand in a `width × height` frame.
    pub fn generate(seed: u64, width: u32, height: u32) -> Self {
        Self::build(seed, width, height, Dress::Bare, Plan::HUMANOID)
    }

    /// A character of wider variety than [`Character::generate`]'s one three-quarter-view
    /// humanoid, for training what must not learn one skeleton (the correspondence network of
    /// `puppet parts`): seed `seed` also draws a body plan — half bodies without legs, robots
    /// (boxy torso and head, straight limbs, metal colours, an antenna), front views (head,
    /// face and limbs symmetric), an object in the front hand — and dresses three in ten in the
    /// accessories of [`Character::dressed`] (back hair among them).
    pub fn varied(seed: u64, width: u32, height: u32) -> Self {
        let mut rng = Rng::new(seed).fork(11);
        let plan = Plan::random(&mut rng);
        let dress = if rng.chance(0.3) { Dress::Dressed } else { Dress::Bare };
        Self::build(seed, width, height, dress, plan)
    }

    /// The character of [`Character::generate`] wearing seven accessory layers (a vest, back hair,
    /// freckles, sunglasses, a hat, a bracelet and a sleeve, each fixed in its parent part's frame):
    /// the same body, scaled anew so that the hat fits in the frame too.
    pub fn dressed(seed: u64, width: u32, height: u32) -> Self {
        Self::build(seed, width, height, Dress::Dressed, Plan::HUMANOID)
    }

    /// The character of [`Character::dressed`] with an eighth accessory on an accessory: a trim
    /// along the vest's hem, inside the vest, its lower edge the vest's (its true parent is the
    /// vest, and the two share that boundary). Everything else is as dressed.
    pub fn trimmed(seed: u64, width: u32, height: u32) -> Self {
        Self::build(seed, width, height, Dress::Trimmed, Plan::HUMANOID)
    }

    fn build(seed: u64, width: u32, height: u32, dress: Dress, plan: Plan) -> Self {
        let root = Rng::new(seed);
        let mut rng = root.fork(1);
        let mut pal = Palette::random(&mut rng);
        // Draws that only other plans make come from their own stream, so the humanoid of each
        // seed stays the same.
        let mut plan_rng = root.fork(12);
        if plan.robot {
            pal.metallic(&mut plan_rng);
        }
        let chibi = rng.chance(0.35);
        let head_k = if chibi { 1.3 } else { 1.0 };
        let b = Build {
            torso: [rng.range(22.0, 34.0), rng.range(24.0, 36.0)],
            head: [rng.range(11.0, 17.0) * head_k, rng.range(10.0, 15.0) * head_k],
            arm: [rng.range(10.0, 15.0), rng.range(9.0, 13.0), rng.range(3.0, 5.0)],
            leg: [rng.range(11.0, 17.0), rng.range(10.0, 15.0), rng.range(4.0, 6.5)],
            hand: 0.0,
            foot: [rng.range(9.0, 13.0), 0.0],
            outline_px: (0.011 * width.min(height) as f32).max(1.3),
        };
        let b = Build {
            hand: b.arm[2] * rng.range(1.2, 1.6),
            foot: [b.foot[0], b.leg[2] * rng.range(1.0, 1.3)],
            ..b
        };
        let mut parts: Vec<Part> = Vec::new();
        let mut add = |p: Part| {
            parts.push(p);
            parts.len() - 1
        };
        let mut torso_shape = torso_shape(&mut rng, b.torso);
        if plan.robot {
            torso_shape = boxy(b.torso, [0.0, 0.0], plan_rng.range(0.05, 0.15));
        }
        let torso_look = torso_look(&mut rng, &pal, &b, &torso_shape);
        let shirt_pattern = torso_look.pattern.clone();
        let torso = add(Part {
            name: "torso".into(),
            role: Role::Torso,
            side: Side::Middle,
            parent: None,
            pivot: [0.0, 0.0],
            rest_angle: 0.0,
            shape: torso_shape.clone(),
            look: torso_look,
        });
        let [tw, th] = b.torso;
        // Head: pivot at the neck, inside the torso's top.
        let neck_x = if plan.front { 0.0 } else { 0.1 * tw };
        let neck = inset(&torso_shape, [neck_x, -0.5 * th + 3.0], 3.0);
        let (mut head_shape, mut head_look, head_center) = head::head(&mut rng, &pal, &b, plan.front);
        if plan.robot {
            head::robot_head(&mut head_shape, &mut head_look, head_center, &b, &pal, &mut plan_rng);
        }
        let head = add(Part {
            name: "head".into(),
            role: Role::Head,
            side: Side::Middle,
            parent: Some(torso),
            pivot: neck,
            rest_angle: 0.0,
            shape: head_shape,
            look: head_look,
        });
        let long_sleeves = rng.chance(0.4);
        let shorts = rng.chance(0.35);
        for side in [Side::Back, Side::Front] {
            let sign = if side == Side::Back { -1.0 } else { 1.0 };
            let tag = if side == Side::Back { "back" } else { "front" };
            // Back limbs are a little darker, as if in the shade of the body; seen from the
            // front, the limbs hang at the sides, neither behind the other.
            let shade = if side == Side::Back && !plan.front { 0.85 } else { 1.0 };
            let spread = if plan.front { [0.42, 0.22] } else { [0.25, 0.16] };
            let shoulder = inset(
                &torso_shape,
                [sign * spread[0] * tw, -0.5 * th + 0.22 * th.max(4.0 * b.arm[2])],
                1.2 * b.arm[2],
            );
            let upper = add(limb_upper(
                &format!("arm_{tag}_upper"),
                Role::UpperArm,
                side,
                torso,
                shoulder,
                -sign * rng.range(0.45, 0.7),
                [b.arm[0], b.arm[2]],
                sleeve_look(&pal, &shirt_pattern, shade, b.outline_px, b.arm[2]),
            ));
            let lower_fill = if long_sleeves { pal.shirt } else { pal.skin };
            let hand_color = if rng.chance(0.3) { lighten(pal.accent, 0.6) } else { pal.skin };
            let mut forearm = arm_lower(
                &format!("arm_{tag}_lower"),
                side,
                upper,
                &b,
                -rng.range(0.2, 0.5),
                lower_fill,
                hand_color,
                shade,
                &pal,
            );
            if plan.held && side == Side::Front {
                hold(&mut forearm, &b, &mut plan_rng);
            }
            add(forearm);
            if !plan.legs {
                continue;
            }
            let hip = inset(&torso_shape, [sign * spread[1] * tw, 0.5 * th - 1.2 * b.leg[2]], 1.2 * b.leg[2]);
            let thigh = add(limb_upper(
                &format!("leg_{tag}_upper"),
                Role::UpperLeg,
                side,
                torso,
                hip,
                -sign * rng.range(0.08, 0.18),
                [b.leg[0], b.leg[2]],
                plain_look(scale_rgb(pal.pants, shade), &pal, b.outline_px, b.leg[2]),
            ));
            let shin_fill = if shorts { pal.skin } else { pal.pants };
            add(leg_lower(
                &format!("leg_{tag}_lower"),
                side,
                thigh,
                &b,
                rng.range(0.0, 0.12),
                shin_fill,
                shade,
                &pal,
                &mut rng,
            ));
        }
        if rng.chance(0.45) {
            let base = inset(&torso_shape, [-0.45 * tw, 0.2 * th], 2.5);
            let len = rng.range(14.0, 24.0);
            let (r0, r1) = (rng.range(2.5, 4.5), rng.range(1.2, 2.5));
            let mut prims = vec![Primitive::Capsule {
                a: [0.0, 0.0],
                b: [0.0, len],
                ra: r0,
                rb: r1,
            }];
            let mut look = plain_look(pal.skin, &pal, b.outline_px, r0);
            if rng.chance(0.5) {
                prims.push(circle([0.0, len], r1 * 2.0));
                look.features.push(Feature {
                    shape: FeatureShape::Fill(circle([0.0, len], r1 * 2.0)),
                    color: lighten(pal.skin, 0.6),
                    ink: 0.0,
                });
            } else {
                look.pattern = Pattern::Stripes {
                    angle: PI / 2.0,
                    period: rng.range(4.0, 6.0),
                    width: 2.0,
                    color: scale_rgb(pal.skin, 0.7),
                };
            }
            add(Part {
                name: "tail".into(),
                role: Role::Tail,
                side: Side::Middle,
                parent: Some(torso),
                pivot: base,
                rest_angle: rng.range(1.9, 2.5),
                shape: Shape { primitives: prims },
                look,
            });
        }
        if rng.chance(0.45) {
            let [hw, hh] = b.head;
            let (len, wid, n) = (rng.range(8.0, 14.0), rng.range(3.5, 6.0), rng.range(1.5, 2.5));
            let ears = if plan.front {
                [(Side::Back, "back", -0.75, 0.45), (Side::Front, "front", 0.75, -0.45)]
            } else {
                [(Side::Back, "back", -0.4, 0.35), (Side::Front, "front", 0.15, -0.25)]
            };
            for (side, tag, dx, tilt) in ears {
                let base = [head_center[0] + dx * hw, head_center[1] - 0.7 * hh];
                let ear = Primitive::Superellipse {
                    center: [0.0, 0.45 * len],
                    radii: [wid, 0.55 * len],
                    exponent: n,
                    angle: 0.0,
                };
                let inner = Primitive::Superellipse {
                    center: [0.0, 0.5 * len],
                    radii: [0.5 * wid, 0.35 * len],
                    exponent: n,
                    angle: 0.0,
                };
                let mut look = plain_look(pal.skin, &pal, b.outline_px, wid);
                look.features.push(Feature {
                    shape: FeatureShape::Fill(inner),
                    color: lighten([0.95, 0.5, 0.6], 0.3),
                    ink: 0.0,
                });
                add(Part {
                    name: format!("ear_{tag}"),
                    role: Role::Ear,
                    side,
                    parent: Some(head),
                    pivot: base,
                    rest_angle: PI + tilt,
                    shape: Shape { primitives: vec![ear] },
                    look,
                });
            }
        }
        if dress != Dress::Bare {
            let extra = accessories::accessories(&parts, &mut root.fork(7), b.outline_px, dress == Dress::Trimmed);
            parts.extend(extra);
        }
        if plan.robot {
            straighten_limbs(&mut parts);
        }
        let parts = reorder(parts);
        let mut c = Character {
            name: format!("synth-{seed}"),
            parts,
            rest_root: Similarity::IDENTITY,
        };
        c.rest_root = fit(&c, width, height);
        c
    }

    /// Index of the part called `name`.
    pub fn part(&self, name: &str) -> Option<usize> {
        self.parts.iter().position(|p| p.name == name)
    }

    /// Each part's local frame → pixels, given the torso's placement `root` and each part's
    /// rotation relative to its parent on top of the rest angle (`delta[i]`, radians).
    pub fn world_transforms(&self, root: &Similarity, delta: &[f32]) -> Vec<Similarity> {
        let mut out: Vec<Option<Similarity>> = vec![None; self.parts.len()];
        // Parents may sit after children in z-order: resolve by depth-first recursion.
        fn resolve(c: &Character, i: usize, root: &Similarity, delta: &[f32], out: &mut Vec<Option<Similarity>>) -> Similarity {
            if let Some(t) = out[i] {
                return t;
            }
            let part = &c.parts[i];
            let t = match part.parent {
                None => root.compose(&Similarity::new(part.rest_angle + delta[i], 1.0, [0.0, 0.0])),
                Some(p) => {
                    let parent = resolve(c, p, root, delta, out);
                    parent.compose(&Similarity::new(part.rest_angle + delta[i], 1.0, part.pivot))
                }
            };
            out[i] = Some(t);
            t
        }
        (0..self.parts.len()).map(|i| resolve(self, i, root, delta, &mut out)).collect()
    }

    /// The pivots of part `i`'s jointed children (not its accessories), in its local frame.
    pub fn child_pivots(&self, i: usize) -> Vec<[f32; 2]> {
        self.parts
            .iter()
            .filter(|p| p.parent == Some(i) && p.role != Role::Accessory)
            .map(|p| p.pivot)
            .collect()
    }

    /// Pairs of body parts joined at a pivot (parent name, child name).
    pub fn joints(&self) -> Vec<[String; 2]> {
        self.parts
            .iter()
            .filter(|p| p.role != Role::Accessory)
            .filter_map(|p| p.parent.map(|q| [self.parts[q].name.clone(), p.name.clone()]))
            .collect()
    }
}

/// The kind of body [`Character::build`] makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Plan {
    /// With legs (else a half body).
    legs: bool,
    /// Seen from the front (else in three-quarter view, facing right).
    front: bool,
    /// A robot.
    robot: bool,
    /// An object in the front hand.
    held: bool,
}

impl Plan {
    /// The generator's one humanoid.
    const HUMANOID: Plan = Plan {
        legs: true,
        front: false,
        robot: false,
        held: false,
    };

    fn random(rng: &mut Rng) -> Plan {
        Plan {
            legs: !rng.chance(0.25),
            front: rng.chance(0.3),
            robot: rng.chance(0.25),
            held: rng.chance(0.3),
        }
    }
}

/// Which accessories [`Character::build`] puts on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Dress {
    Bare,
    Dressed,
    Trimmed,
}

/// Sorts parts into [`Z_ORDER`], remapping parent indices.
fn reorder(parts: Vec<Part>) -> Vec<Part> {
    let order: Vec<usize> = Z_ORDER.iter().filter_map(|n| parts.iter().position(|p| p.name == *n)).collect();
    debug_assert_eq!(order.len(), parts.len(), "every generated part is in Z_ORDER");
    let new_index = |old: usize| order.iter().position(|&o| o == old).expect("every part is ordered");
    order
        .iter()
        .map(|&o| {
            let mut p = parts[o].clone();
            p.parent = p.parent.map(new_index);
            p
        })
        .collect()
}

/// The rest placement: scale so the character's rest bounding box is 78 % of the frame height
/// (and at most 80 % of its width), feet toward the bottom, centred horizontally.
fn fit(c: &Character, width: u32, height: u32) -> Similarity {
    let world = c.world_transforms(&Similarity::IDENTITY, &vec![0.0; c.parts.len()]);
    let mut lo = [f32::INFINITY; 2];
    let mut hi = [f32::NEG_INFINITY; 2];
    for (part, t) in c.parts.iter().zip(&world) {
        let [a, b] = part.shape.bounds();
        for corner in [[a[0], a[1]], [b[0], a[1]], [a[0], b[1]], [b[0], b[1]]] {
            let q = t.apply(corner);
            lo = [lo[0].min(q[0]), lo[1].min(q[1])];
            hi = [hi[0].max(q[0]), hi[1].max(q[1])];
        }
    }
    let (w, h) = (width as f32, height as f32);
    let k = (0.78 * h / (hi[1] - lo[1])).min(0.8 * w / (hi[0] - lo[0]));
    let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    Similarity::new(0.0, k, [0.5 * w - k * centre[0], 0.54 * h - k * centre[1]])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(seed: u64, change: fn(&mut Plan)) -> Character {
        let mut plan = Plan::HUMANOID;
        change(&mut plan);
        Character::build(seed, 128, 128, Dress::Bare, plan)
    }

    fn forearm_pieces(c: &Character, name: &str) -> usize {
        c.parts[c.part(name).unwrap()].shape.primitives.len()
    }

    #[test]
    fn every_part_the_generator_makes_has_a_label_colour_of_its_own() {
        for name in Z_ORDER {
            assert_ne!(super::super::labels::label_rgb(name), [128, 128, 128], "{name}");
        }
    }

    /// Each body plan changes what it names and nothing the humanoid draws from its own stream.
    #[test]
    fn body_plans_change_what_they_name() {
        for seed in [3, 17, 40] {
            let base = with(seed, |_| {});
            assert_eq!(base, Character::generate(seed, 128, 128));
            let half = with(seed, |p| p.legs = false);
            assert!(half.parts.iter().all(|p| !matches!(p.role, Role::UpperLeg | Role::LowerLeg)));
            let arms = |c: &Character| c.parts.iter().filter(|p| matches!(p.role, Role::UpperArm | Role::LowerArm)).count();
            assert_eq!((arms(&half), arms(&base)), (4, 4));
            let robot = with(seed, |p| p.robot = true);
            let torso = robot.part("torso").unwrap();
            assert!(matches!(robot.parts[torso].shape.primitives[0], Primitive::RoundedBox { .. }));
            for part in robot.parts.iter().filter(|p| matches!(p.role, Role::UpperArm | Role::LowerLeg)) {
                let Primitive::Capsule { ra, rb, .. } = part.shape.primitives[0] else {
                    panic!("{} is not a tube", part.name)
                };
                assert_eq!(ra, rb, "{}", part.name);
            }
            // Seen from the front the head sits on the torso's axis; in three-quarter view it
            // sits forward of it.
            let front = with(seed, |p| p.front = true);
            assert_eq!(front.parts[front.part("head").unwrap()].pivot[0], 0.0);
            assert!(base.parts[base.part("head").unwrap()].pivot[0] > 0.0);
            let held = with(seed, |p| p.held = true);
            assert!(forearm_pieces(&held, "arm_front_lower") > forearm_pieces(&base, "arm_front_lower"));
            assert_eq!(forearm_pieces(&held, "arm_back_lower"), forearm_pieces(&base, "arm_back_lower"));
        }
    }
}
