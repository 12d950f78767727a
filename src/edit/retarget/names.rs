//! The built-in humanoid name table: a BVH joint's or a puppet layer's name read as a part of a
//! figure (pelvis, torso, upper arm, …) and a side, so that `LeftForeArm`, `lForeArm`,
//! `forearm_l` and `Forearm.L` all say "a forearm, on the left". The two tables differ where
//! skeletons and drawings use a word differently: in a skeleton `LeftLeg` is the shin below
//! `LeftUpLeg`, while a drawn `leg_l` is the whole leg, hinged at the hip.

/// A part of a humanoid figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Part {
    /// The hips: a skeleton's root.
    Pelvis,
    /// The trunk above the hips.
    Torso,
    /// The neck.
    Neck,
    /// The head.
    Head,
    /// The collarbone, between the torso and the upper arm.
    Collar,
    /// The upper arm (a drawn `arm`).
    UpperArm,
    /// The forearm.
    Forearm,
    /// The hand.
    Hand,
    /// The thigh (a drawn `leg`).
    Thigh,
    /// The shin (a skeleton's `Leg`).
    Shin,
    /// The foot.
    Foot,
    /// The toes.
    Toe,
}

/// Which side of the figure a part is on, as its name says.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Side {
    /// A part on the middle line (or named without a side).
    Middle,
    /// Named left.
    Left,
    /// Named right.
    Right,
}

/// Whose names are read: the words mean different parts in a skeleton and in a drawing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Naming {
    /// A motion-capture skeleton's joints (BVH).
    Skeleton,
    /// A puppet's layers.
    Layer,
}

/// The words each part goes by in a skeleton's joint names (after the side and any digits are
/// taken off, lowercase, without separators). `shoulder` is the upper arm: where a skeleton also
/// has an `arm` joint below it (Mixamo's `LeftShoulder`, a collarbone), the joint farther from
/// the root takes the part.
const SKELETON: &[(Part, &[&str])] = &[
    (Part::Pelvis, &["hips", "hip", "pelvis", "root"]),
    (
        Part::Torso,
        &["spine", "chest", "upperchest", "abdomen", "lowerback", "upperback", "torso", "back"],
    ),
    (Part::Neck, &["neck", "lowerneck", "upperneck"]),
    (Part::Head, &["head"]),
    (Part::Collar, &["collar", "clavicle"]),
    (Part::UpperArm, &["arm", "uparm", "upperarm", "shldr", "shoulder", "humerus"]),
    (Part::Forearm, &["forearm", "lowarm", "lowerarm", "elbow"]),
    (Part::Hand, &["hand", "wrist"]),
    (Part::Thigh, &["upleg", "upperleg", "thigh", "femur", "hip"]),
    (Part::Shin, &["leg", "lowleg", "lowerleg", "shin", "knee", "calf", "tibia"]),
    (Part::Foot, &["foot", "ankle"]),
    (Part::Toe, &["toe", "toebase", "toes"]),
];

/// The words each part goes by in a puppet's layer names.
const LAYER: &[(Part, &[&str])] = &[
    (Part::Pelvis, &["hips", "hip", "pelvis"]),
    (Part::Torso, &["torso", "body", "chest", "trunk", "spine", "belly", "upperbody"]),
    (Part::Neck, &["neck"]),
    (Part::Head, &["head"]),
    (Part::Collar, &["collar", "clavicle", "shoulder"]),
    (Part::UpperArm, &["arm", "upperarm", "uparm"]),
    (Part::Forearm, &["forearm", "lowerarm", "lowarm"]),
    (Part::Hand, &["hand", "wrist", "claw", "fist"]),
    (Part::Thigh, &["leg", "thigh", "upperleg", "upleg"]),
    (Part::Shin, &["shin", "lowerleg", "lowleg", "calf", "knee"]),
    (Part::Foot, &["foot", "shoe", "boot"]),
    (Part::Toe, &["toe", "toes"]),
];

/// The part and side `name` names, if the table knows its words; a sided word alone on the
/// middle line (`hip` with no side) is read as the middle part (the pelvis).
pub fn part_of(name: &str, naming: Naming) -> Option<(Part, Side)> {
    // A namespace before a colon (Mixamo's `mixamorig:`) is not part of the name.
    let name = name.rsplit(':').next().unwrap_or(name);
    let mut words = split_words(name);
    let side_of = |w: &str| match w {
        "left" | "l" => Some(Side::Left),
        "right" | "r" => Some(Side::Right),
        _ => None,
    };
    let mut side = Side::Middle;
    if words.len() > 1 {
        if let Some(s) = side_of(&words[0]) {
            side = s;
            words.remove(0);
        } else if let Some(s) = words.last().and_then(|w| side_of(w)) {
            side = s;
            words.pop();
        }
    }
    words.retain(|w| w != "joint" && w != "bone");
    let core: String = words.concat();
    let core = core.trim_end_matches(|c: char| c.is_ascii_digit());
    let table = match naming {
        Naming::Skeleton => SKELETON,
        Naming::Layer => LAYER,
    };
    let parts: Vec<Part> = table
        .iter()
        .filter(|(_, names)| names.contains(&core))
        .map(|(part, _)| *part)
        .collect();
    // `hip` is the pelvis on the middle line and a thigh on a side.
    let part = match (parts.as_slice(), side) {
        ([], _) => return None,
        ([one], _) => *one,
        ([middle, ..], Side::Middle) => *middle,
        ([.., sided], _) => *sided,
    };
    Some((part, side))
}

/// The lowercase words of a name: split at separators, digits kept with their word, and at
/// case changes (`LeftForeArm` → left, fore, arm; `lShldr` → l, shldr; `LHipJoint` → l, hip,
/// joint).
fn split_words(name: &str) -> Vec<String> {
    let chars: Vec<char> = name.chars().collect();
    let mut words: Vec<String> = Vec::new();
    let mut word = String::new();
    for (i, &c) in chars.iter().enumerate() {
        if !c.is_alphanumeric() {
            if !word.is_empty() {
                words.push(std::mem::take(&mut word));
            }
            continue;
        }
        let prev = i.checked_sub(1).map(|k| chars[k]);
        let next = chars.get(i + 1);
        let boundary = c.is_uppercase()
            && (prev.is_some_and(|p| p.is_lowercase() || p.is_ascii_digit())
                || (prev.is_some_and(char::is_uppercase) && next.is_some_and(|n| n.is_lowercase())));
        if boundary && !word.is_empty() {
            words.push(std::mem::take(&mut word));
        }
        word.extend(c.to_lowercase());
    }
    if !word.is_empty() {
        words.push(word);
    }
    words
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn common_skeleton_and_layer_names_are_read() {
        use Naming::{Layer, Skeleton};
        use Part::*;
        use Side::*;
        // A skeleton's LeftLeg is a shin, a drawing's leg_r a whole leg.
        for (name, naming, want) in [
            ("Hips", Skeleton, (Pelvis, Middle)),
            ("LeftArm", Skeleton, (UpperArm, Left)),
            ("LeftForeArm", Skeleton, (Forearm, Left)),
            ("RightUpLeg", Skeleton, (Thigh, Right)),
            ("LeftLeg", Skeleton, (Shin, Left)),
            ("lShldr", Skeleton, (UpperArm, Left)),
            ("rThigh", Skeleton, (Thigh, Right)),
            ("rShin", Skeleton, (Shin, Right)),
            ("LHipJoint", Skeleton, (Thigh, Left)),
            ("Spine1", Skeleton, (Torso, Middle)),
            ("Neck1", Skeleton, (Neck, Middle)),
            ("LeftToeBase", Skeleton, (Toe, Left)),
            ("mixamorig:LeftHand", Skeleton, (Hand, Left)),
            ("arm_l", Layer, (UpperArm, Left)),
            ("leg_r", Layer, (Thigh, Right)),
            ("Forearm.L", Layer, (Forearm, Left)),
            ("left_hand", Layer, (Hand, Left)),
            ("torso", Layer, (Torso, Middle)),
            ("head", Layer, (Head, Middle)),
        ] {
            assert_eq!(part_of(name, naming), Some(want), "{name}");
        }
        assert_eq!(part_of("LeftHandThumb1", Skeleton), None);
        assert_eq!(part_of("hair", Layer), None);
        assert_eq!(part_of("l", Layer), None);
    }
}
