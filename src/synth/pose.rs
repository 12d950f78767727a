//! Poses of a synthetic character over a sequence (issue 4 item 3): joint angles from smooth
//! cycles (walk, wave, jump) or drawn independently from ranges (random, as APES §5.1 does:
//! every joint in [−0.3π, 0.3π]), plus a global translation, rotation and scale of the torso.

use std::f32::consts::{PI, TAU};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::character::{Character, Role, Side};
use crate::error::{Error, Result};
use crate::geom::similarity::Similarity;
use crate::rng::Rng;

/// How the character moves over the sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Motion {
    /// A walk cycle drifting to the right, with body bob and arm swing.
    Walk,
    /// The front arm raised and waving, the rest idling.
    Wave,
    /// Crouch, leap with arms up, land.
    Jump,
    /// An independent random pose per frame (APES §5.1 ranges).
    Random,
}

impl Motion {
    /// Every motion, in `--help` order.
    pub const ALL: [Motion; 4] = [Motion::Walk, Motion::Wave, Motion::Jump, Motion::Random];

    /// The motion's name on the command line and in truth.json.
    pub fn name(self) -> &'static str {
        match self {
            Motion::Walk => "walk",
            Motion::Wave => "wave",
            Motion::Jump => "jump",
            Motion::Random => "random",
        }
    }
}

impl FromStr for Motion {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        Motion::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| Error::setting("motion", format!("{s:?}"), "walk, wave, jump or random"))
    }
}

/// A character's pose in one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// Torso local frame → frame pixels.
    pub root: Similarity,
    /// Per part, rotation relative to its parent added to the rest angle, radians.
    pub delta: Vec<f32>,
    /// Phase of the cycle in radians for cyclic motions (`None` for random poses).
    pub phase: Option<f32>,
}

/// Per-character amplitudes of the cycles and the sequence's global motion.
#[derive(Clone, Debug)]
pub struct Animator {
    motion: Motion,
    frames: usize,
    cycles: f32,
    hip: f32,
    knee: f32,
    arm: f32,
    elbow: f32,
    bob: f32,
    drift: f32,
    scale: f32,
    width: f32,
    height: f32,
    rng: Rng,
}

/// `sin²` bump on [a, b], 0 outside.
fn bump(u: f32, a: f32, b: f32) -> f32 {
    if u <= a || u >= b {
        0.0
    } else {
        libm::sinf(PI * (u - a) / (b - a)).powi(2)
    }
}

impl Animator {
    /// Plans `frames` frames of `motion` for a character in a `width × height` frame; `seed`
    /// picks the amplitudes (and every random pose).
    pub fn new(motion: Motion, frames: usize, seed: u64, width: u32, height: u32) -> Self {
        let root = Rng::new(seed);
        let mut rng = root.fork(2);
        let per_cycle = if motion == Motion::Jump { 20.0 } else { 14.0 };
        let cycles = (frames as f32 / per_cycle).round().max(1.0);
        Animator {
            motion,
            frames,
            cycles,
            hip: rng.range(0.35, 0.55),
            knee: rng.range(0.5, 0.85),
            arm: rng.range(0.35, 0.65),
            elbow: rng.range(0.2, 0.5),
            bob: rng.range(0.012, 0.025) * height as f32,
            drift: rng.range(0.04, 0.1) * width as f32,
            scale: rng.range(0.92, 1.04),
            width: width as f32,
            height: height as f32,
            rng: root.fork(3),
        }
    }

    /// The pose of `character` in frame `t` (0-based).
    pub fn pose(&self, character: &Character, t: usize) -> Pose {
        let n = character.parts.len();
        let mut delta = vec![0.0f32; n];
        // Global: translation (dx, dy) px, lean radians, scale factor.
        let (mut dx, mut scale) = (0.0f32, self.scale);
        let (dy, lean): (f32, f32);
        let u = self.cycles * t as f32 / self.frames as f32;
        let phi = TAU * u;
        let mut phase = Some(phi);
        match self.motion {
            Motion::Walk => {
                let progress = if self.frames > 1 {
                    t as f32 / (self.frames - 1) as f32 - 0.5
                } else {
                    0.0
                };
                dx = self.drift * progress;
                dy = -self.bob * (0.5 + 0.5 * libm::cosf(2.0 * phi)) + 0.5 * self.bob;
                lean = 0.05 + 0.02 * libm::sinf(2.0 * phi);
                scale *= 1.0 + 0.03 * libm::sinf(TAU * t as f32 / self.frames as f32);
                for (i, part) in character.parts.iter().enumerate() {
                    let psi = if part.side == Side::Back { phi + PI } else { phi };
                    delta[i] = match part.role {
                        Role::UpperLeg => self.hip * libm::cosf(psi),
                        Role::LowerLeg => self.knee * libm::sinf(psi).max(0.0).powi(2) + 0.05,
                        // Arms hang closer to the body than in the spread rest pose.
                        Role::UpperArm => -0.7 * part.rest_angle - self.arm * libm::cosf(psi),
                        Role::LowerArm => -self.elbow * (0.5 - 0.5 * libm::cosf(psi)) - 0.1,
                        Role::Head => 0.05 * libm::sinf(2.0 * phi),
                        Role::Tail => 0.35 * libm::sinf(phi),
                        Role::Ear => 0.15 * libm::sinf(2.0 * phi + 1.0),
                        Role::Torso | Role::Accessory => 0.0,
                    };
                }
            }
            Motion::Wave => {
                dy = 0.3 * self.bob * libm::sinf(phi);
                lean = 0.03 * libm::sinf(phi);
                for (i, part) in character.parts.iter().enumerate() {
                    let front = part.side == Side::Front;
                    delta[i] = match (part.role, front) {
                        (Role::UpperArm, true) => -2.3 + 0.1 * libm::sinf(phi),
                        (Role::LowerArm, true) => -0.3 + 0.6 * libm::sinf(2.0 * phi),
                        (Role::UpperArm, false) => 0.1 * libm::sinf(phi),
                        (Role::LowerArm, false) => -0.1 - 0.1 * libm::sinf(phi),
                        (Role::UpperLeg, _) => 0.03 * libm::sinf(phi),
                        (Role::Head, _) => 0.1 * libm::sinf(phi),
                        (Role::Tail, _) => 0.4 * libm::sinf(2.0 * phi),
                        (Role::Ear, _) => 0.2 * libm::sinf(2.0 * phi),
                        _ => 0.0,
                    };
                }
            }
            Motion::Jump => {
                let u = u - libm::floorf(u);
                let crouch = bump(u, 0.0, 0.3).max(bump(u, 0.72, 1.0));
                let air = if u > 0.25 && u < 0.78 {
                    libm::sinf(PI * (u - 0.25) / 0.53)
                } else {
                    0.0
                };
                dy = 0.05 * self.height * crouch - 0.11 * self.height * air;
                lean = 0.15 * crouch;
                for (i, part) in character.parts.iter().enumerate() {
                    let k = if part.side == Side::Back { 0.9 } else { 1.0 };
                    delta[i] = match part.role {
                        Role::UpperLeg => k * (-0.7 * crouch - 0.6 * air),
                        Role::LowerLeg => k * (1.2 * crouch + 1.0 * air),
                        Role::UpperArm => 0.6 * crouch - k * 2.4 * air,
                        Role::LowerArm => -0.3 * air,
                        Role::Head => -0.1 * crouch + 0.1 * air,
                        Role::Tail => 0.6 * air,
                        Role::Ear => 0.5 * air,
                        Role::Torso | Role::Accessory => 0.0,
                    };
                }
            }
            Motion::Random => {
                phase = None;
                let mut rng = self.rng.fork(t as u64);
                dx = rng.range(-0.06, 0.06) * self.width;
                dy = rng.range(-0.05, 0.05) * self.height;
                lean = rng.range(-0.1, 0.1);
                scale *= rng.range(0.92, 1.06);
                for (i, part) in character.parts.iter().enumerate() {
                    let range = if part.role == Role::Head { 0.15 * PI } else { 0.3 * PI };
                    delta[i] = if matches!(part.role, Role::Torso | Role::Accessory) {
                        0.0
                    } else {
                        rng.range(-range, range)
                    };
                }
            }
        }
        let rest = character.rest_root;
        let k = rest.scale() * scale;
        let root = Similarity::new(lean, k, [rest.tx + dx, rest.ty + dy]);
        Pose { root, delta, phase }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motion_names_round_trip_and_unknown_is_an_error() {
        for m in Motion::ALL {
            assert_eq!(m.name().parse::<Motion>().unwrap(), m);
        }
        let err = "dance".parse::<Motion>().unwrap_err().to_string();
        assert!(err.contains("motion = \"dance\"") && err.contains("walk"), "{err}");
    }

    #[test]
    fn walk_swings_legs_in_antiphase_and_loops() {
        let c = Character::generate(5, 256, 256);
        let anim = Animator::new(Motion::Walk, 28, 5, 256, 256);
        let back = c.part("leg_back_upper").unwrap();
        let front = c.part("leg_front_upper").unwrap();
        for t in 0..28 {
            let p = anim.pose(&c, t);
            assert!((p.delta[back] + p.delta[front]).abs() < 1e-5, "frame {t}");
        }
        // 28 frames hold two whole cycles: frame 0 and the frame after the last coincide.
        let (first, next) = (anim.pose(&c, 0), anim.pose(&c, 28));
        for (a, b) in first.delta.iter().zip(&next.delta) {
            assert!((a - b).abs() < 1e-4);
        }
    }

    #[test]
    fn random_poses_stay_in_the_apes_range_and_differ_per_frame() {
        let c = Character::generate(9, 128, 128);
        let anim = Animator::new(Motion::Random, 10, 9, 128, 128);
        let (a, b) = (anim.pose(&c, 0), anim.pose(&c, 1));
        assert_ne!(a.delta, b.delta);
        assert!(a.delta.iter().chain(&b.delta).all(|d| d.abs() <= 0.3 * PI));
        assert_eq!(anim.pose(&c, 1), b);
    }
}
