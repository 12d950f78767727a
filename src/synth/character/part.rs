//! The parts a character is made of: what each is, which side, where it hangs.

use serde::{Deserialize, Serialize};

use crate::synth::look::Look;
use crate::synth::shape::Shape;

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
    /// Index of the parent part in [`Character::parts`](super::Character::parts) (`None` for the torso).
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
