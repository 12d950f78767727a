//! Procedural cartoon characters (issue 4 item 2): a skeleton of parts — torso (root), head,
//! two-segment arms and legs, optional tail and ears — each an analytic [`Shape`] with random
//! proportions and a [`Look`], seen in three-quarter view facing right, layered back to front
//! (back limbs behind the torso, head and front limbs in front).
//!
//! Each part has a local frame: the torso's origin is its centre; every other part's origin is
//! its pivot (the joint with its parent) and its bone runs along local +y. Local units are
//! "character units" (a character is about 100 tall); [`Character::rest_root`] places the torso
//! frame in the rest frame's pixels, scaling the character to fit.

use std::f32::consts::PI;

use serde::{Deserialize, Serialize};

use super::look::{Feature, FeatureShape, Look, Pattern, Rgb};
use super::shape::{Primitive, Shape};
use crate::geom::similarity::Similarity;
use crate::rng::Rng;

/// What a part is, which decides how it moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// The root.
    Torso,
    /// The head, child of the torso.
    Head,
    /// Upper arm, child of the torso.
    UpperArm,
    /// Forearm with hand, child of the upper arm.
    LowerArm,
    /// Thigh, child of the torso.
    UpperLeg,
    /// Shin with foot, child of the thigh.
    LowerLeg,
    /// Tail, child of the torso.
    Tail,
    /// Ear, child of the head.
    Ear,
    /// Clothing or an accessory (hat, glasses, sleeve…): a layer of its own, fixed in its
    /// parent's local frame and carried by the parent's deformation — never a joint.
    Accessory,
}

/// Which of a pair of limbs: the one farther from the viewer or the nearer one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Farther from the viewer (drawn behind).
    Back,
    /// Nearer the viewer (drawn in front).
    Front,
    /// Not paired.
    Middle,
}

/// One part of a character.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// Layer name (e.g. `"arm_front_lower"`).
    pub name: String,
    /// What it is.
    pub role: Role,
    /// Which of a pair.
    pub side: Side,
    /// Index of the parent part in [`Character::parts`] (`None` for the torso).
    pub parent: Option<usize>,
    /// The pivot in the parent's local frame.
    pub pivot: [f32; 2],
    /// Rotation relative to the parent at rest, radians.
    pub rest_angle: f32,
    /// The silhouette, local units.
    pub shape: Shape,
    /// Colouring.
    pub look: Look,
}

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

fn hsv(h: f32, s: f32, v: f32) -> Rgb {
    let h = (h.rem_euclid(1.0)) * 6.0;
    let i = h.floor();
    let f = h - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match i as i32 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

fn scale_rgb(c: Rgb, k: f32) -> Rgb {
    c.map(|x| (x * k).clamp(0.0, 1.0))
}

fn lighten(c: Rgb, t: f32) -> Rgb {
    c.map(|x| x + (1.0 - x) * t)
}

fn circle(center: [f32; 2], r: f32) -> Primitive {
    Primitive::Superellipse {
        center,
        radii: [r, r],
        exponent: 2.0,
        angle: 0.0,
    }
}

/// The character's colours.
struct Palette {
    skin: Rgb,
    shirt: Rgb,
    pants: Rgb,
    shoes: Rgb,
    hair: Rgb,
    accent: Rgb,
    outline: Rgb,
}

impl Palette {
    fn random(rng: &mut Rng) -> Self {
        let animal = rng.chance(0.5);
        let skin = if animal {
            hsv(rng.unit(), rng.range(0.25, 0.6), rng.range(0.7, 0.95))
        } else {
            rng.pick(&[
                [1.0, 0.86, 0.72],
                [0.96, 0.76, 0.6],
                [0.78, 0.56, 0.4],
                [0.55, 0.38, 0.26],
                [0.99, 0.9, 0.8],
            ])
        };
        let h = rng.unit();
        let shirt = hsv(h, rng.range(0.45, 0.85), rng.range(0.6, 0.95));
        let pants = hsv(h + rng.range(0.3, 0.7), rng.range(0.3, 0.75), rng.range(0.3, 0.7));
        let shoes = hsv(rng.unit(), rng.range(0.2, 0.8), rng.range(0.15, 0.6));
        let hair = hsv(rng.range(0.0, 0.12), rng.range(0.4, 0.9), rng.range(0.15, 0.7));
        let accent = lighten(hsv(h + 0.5, rng.range(0.5, 0.9), 0.95), rng.range(0.0, 0.5));
        let outline = hsv(h, 0.5, rng.range(0.08, 0.18));
        Palette {
            skin,
            shirt,
            pants,
            shoes,
            hair,
            accent,
            outline,
        }
    }

    /// Metal instead of skin and cloth: greys with a faint tint, a brighter accent.
    fn metallic(&mut self, rng: &mut Rng) {
        let tint = rng.unit();
        self.skin = hsv(tint, rng.range(0.03, 0.2), rng.range(0.6, 0.85));
        self.shirt = hsv(tint + rng.range(-0.1, 0.1), rng.range(0.05, 0.35), rng.range(0.45, 0.75));
        self.pants = scale_rgb(self.shirt, 0.8);
        self.shoes = hsv(tint, 0.1, rng.range(0.2, 0.4));
    }
}

/// Random proportions of one character, in character units.
struct Build {
    torso: [f32; 2],
    head: [f32; 2],
    arm: [f32; 3],
    leg: [f32; 3],
    hand: f32,
    foot: [f32; 2],
    outline_px: f32,
}

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
        let (mut head_shape, mut head_look, head_center) = head(&mut rng, &pal, &b, plan.front);
        if plan.robot {
            robot_head(&mut head_shape, &mut head_look, head_center, &b, &pal, &mut plan_rng);
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
            let extra = accessories(&parts, &mut root.fork(7), b.outline_px, dress == Dress::Trimmed);
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

/// Moves `p` toward the origin until it is at least `depth` inside `shape`.
fn inset(shape: &Shape, p: [f32; 2], depth: f32) -> [f32; 2] {
    let mut q = p;
    for _ in 0..50 {
        if shape.sdf(q) <= -depth {
            break;
        }
        q = [q[0] * 0.95, q[1] * 0.95];
    }
    q
}

fn torso_shape(rng: &mut Rng, [w, h]: [f32; 2]) -> Shape {
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

fn plain_look(fill: Rgb, pal: &Palette, outline_px: f32, size: f32) -> Look {
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

fn torso_look(rng: &mut Rng, pal: &Palette, b: &Build, shape: &Shape) -> Look {
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
fn sleeve_look(pal: &Palette, shirt: &Pattern, shade: f32, outline_px: f32, r: f32) -> Look {
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

#[allow(clippy::too_many_arguments)]
fn limb_upper(name: &str, role: Role, side: Side, parent: usize, pivot: [f32; 2], rest_angle: f32, [len, r]: [f32; 2], look: Look) -> Part {
    Part {
        name: name.into(),
        role,
        side,
        parent: Some(parent),
        pivot,
        rest_angle,
        shape: Shape {
            primitives: vec![Primitive::Capsule {
                a: [0.0, 0.0],
                b: [0.0, len],
                ra: r,
                rb: 0.9 * r,
            }],
        },
        look,
    }
}

#[allow(clippy::too_many_arguments)]
fn arm_lower(name: &str, side: Side, parent: usize, b: &Build, rest_angle: f32, fill: Rgb, hand: Rgb, shade: f32, pal: &Palette) -> Part {
    let [upper, len, r] = b.arm;
    let hc = [0.0, len + 0.5 * b.hand];
    let mut look = plain_look(scale_rgb(fill, shade), pal, b.outline_px, r);
    look.features.push(Feature {
        shape: FeatureShape::Fill(circle(hc, b.hand)),
        color: scale_rgb(hand, shade),
        ink: b.outline_px,
    });
    Part {
        name: name.into(),
        role: Role::LowerArm,
        side,
        parent: Some(parent),
        pivot: [0.0, upper],
        rest_angle,
        shape: Shape {
            primitives: vec![
                Primitive::Capsule {
                    a: [0.0, 0.0],
                    b: [0.0, len],
                    ra: 0.9 * r,
                    rb: 0.8 * r,
                },
                circle(hc, b.hand),
            ],
        },
        look,
    }
}

#[allow(clippy::too_many_arguments)]
fn leg_lower(
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
    Part {
        name: name.into(),
        role: Role::LowerLeg,
        side,
        parent: Some(parent),
        pivot: [0.0, upper],
        rest_angle,
        shape: Shape {
            primitives: vec![
                Primitive::Capsule {
                    a: [0.0, 0.0],
                    b: [0.0, len],
                    ra: 0.9 * r,
                    rb: 0.75 * r,
                },
                foot,
            ],
        },
        look,
    }
}

/// The head's shape, look and centre (in its local frame, origin at the neck).
/// Seen from the `front`, the head sits on the neck and its face is symmetric.
fn head(rng: &mut Rng, pal: &Palette, b: &Build, front: bool) -> (Shape, Look, [f32; 2]) {
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

/// A box `size` wide and tall around `center`, its corners rounded by `round` of its smaller
/// side: a robot's torso or head.
fn boxy(size: [f32; 2], center: [f32; 2], round: f32) -> Shape {
    Shape {
        primitives: vec![Primitive::RoundedBox {
            center,
            half: [0.5 * size[0], 0.5 * size[1]],
            radius: round * size[0].min(size[1]),
            angle: 0.0,
        }],
    }
}

/// Makes a head a robot's: a box around its centre `c`, with a visor band across the eyes and
/// an antenna on top (part of the head's silhouette, so it moves with it).
fn robot_head(shape: &mut Shape, look: &mut Look, c: [f32; 2], b: &Build, pal: &Palette, rng: &mut Rng) {
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

/// Puts an object in a forearm's hand — a stick, a sword or a staff with a knob — as part of
/// the forearm's silhouette (it moves as the hand does: one articulated part with it).
fn hold(forearm: &mut Part, b: &Build, rng: &mut Rng) {
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
fn straighten_limbs(parts: &mut [Part]) {
    let limbs = parts
        .iter_mut()
        .filter(|p| matches!(p.role, Role::UpperArm | Role::LowerArm | Role::UpperLeg | Role::LowerLeg));
    for part in limbs {
        if let Some(Primitive::Capsule { ra, rb, .. }) = part.shape.primitives.first_mut() {
            *rb = *ra;
        }
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

/// The accessory set of issue 13's synthetic data, each in its parent's local frame (pivot at
/// the parent's origin, no rest turn) and sized from the parent's silhouette: a vest with a
/// collar over the torso; back hair behind the head; freckles (several pieces in one layer),
/// sunglasses and a hat on the head; a bracelet on the front forearm and a sleeve over the front
/// upper arm. Each covers part of its parent's outline, so the rig has occlusion to keep. With
/// `trim`, also a trim along the vest's hem ([`Character::trimmed`]), drawn without a random
/// draw so that the rest is the same.
fn accessories(body: &[Part], rng: &mut Rng, outline_px: f32, trim: bool) -> Vec<Part> {
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
