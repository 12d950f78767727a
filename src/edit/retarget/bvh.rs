//! Biovision Hierarchy (BVH) motion files: a skeleton (`HIERARCHY`: joints with offsets from
//! their parents and the channels each animates) and its motion (`MOTION`: one line of channel
//! values per frame). Read here within limits, so that a malformed or hostile file is an error
//! naming the file and the line, never a panic or an unbounded allocation.
//!
//! Conventions of the format, as written by motion-capture tools: right-handed, y up; rotation
//! channels in degrees, applied in the order they are listed (`Zrotation Xrotation Yrotation`
//! is `R = Rz · Rx · Ry`, intrinsic); a joint's place is its parent's place plus the parent's
//! rotation applied to its offset (and to its translation channels, if it has any).

use std::path::Path;

use crate::error::{Error, Result};
use crate::user_file;

/// The most joints a skeleton may have (a full-body capture with fingers has about 70).
pub const MAX_JOINTS: usize = 1024;

/// The most frames a motion may have (an hour at 30 frames a second).
pub const MAX_FRAMES: usize = 108_000;

/// The most channel values a motion may hold (frames × channels: 128 MB as `f64`; ten minutes
/// of a 100-channel capture at 120 frames a second is 7.2 million).
pub const MAX_VALUES: usize = 16_000_000;

/// The deepest a joint may be nested (a spine with a tail is a few dozen).
const MAX_DEPTH: usize = 256;

/// The largest BVH file read: [`MAX_VALUES`] numbers of up to eight characters.
const MAX_BYTES: u64 = 144 << 20;

/// One animated degree of freedom of a joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    /// A translation along the axis (0 = x, 1 = y, 2 = z), in the file's units.
    Position(usize),
    /// A rotation about the axis, in degrees.
    Rotation(usize),
}

/// One joint of the skeleton.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// Its name as the file gives it.
    pub name: String,
    /// Its parent's index (joints are listed parents first); `None` for the root.
    pub parent: Option<usize>,
    /// Its place relative to its parent at rest, in the file's units.
    pub offset: [f64; 3],
    /// The channels it animates, in the order of the motion's values.
    pub channels: Vec<Channel>,
    /// Where its channels start in a frame's values.
    pub first_channel: usize,
    /// The offsets of its `End Site`s (the tips of bones with no joint beyond them).
    pub ends: Vec<[f64; 3]>,
}

/// A skeleton and its motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh {
    /// The joints, parents before children.
    pub joints: Vec<Joint>,
    /// Seconds per frame.
    pub frame_time: f64,
    /// Channel values per frame.
    pub frames: Vec<Vec<f64>>,
}

/// A joint's posed place and orientation in the file's space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    /// Its position.
    pub position: [f64; 3],
    /// Its rotation (row-major 3 × 3), the product of its ancestors' and its own.
    pub rotation: [[f64; 3]; 3],
}

/// The words of a BVH file, read a line at a time (a motion's text is never held as a list of
/// words), with the line of the last word read.
struct Words<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    /// The words of the current line not yet read, last first.
    pending: Vec<&'a str>,
    /// The line of the current words (from 1).
    line: usize,
    path: &'a Path,
}

impl<'a> Words<'a> {
    fn new(text: &'a str, path: &'a Path) -> Self {
        Words {
            lines: text.lines().enumerate(),
            pending: Vec::new(),
            line: 1,
            path,
        }
    }

    fn error(&self, problem: impl Into<String>) -> Error {
        Error::format(self.path, format!("line {}: {}", self.line, problem.into()))
    }

    /// Moves to the next line holding a word; false at the end of the text.
    fn fill(&mut self) -> bool {
        while self.pending.is_empty() {
            let Some((n, line)) = self.lines.next() else {
                return false;
            };
            self.line = n + 1;
            self.pending = line.split_whitespace().rev().collect();
        }
        true
    }

    fn next(&mut self, expected: &str) -> Result<&'a str> {
        if !self.fill() {
            return Err(self.error(format!("the file ends where {expected} was expected")));
        }
        Ok(self.pending.pop().expect("filled"))
    }

    /// The next word, which must be `keyword` (case-insensitive).
    fn expect(&mut self, keyword: &str) -> Result<()> {
        let w = self.next(&format!("{keyword:?}"))?;
        if w.eq_ignore_ascii_case(keyword) {
            Ok(())
        } else {
            Err(self.error(format!("{w:?} where {keyword:?} was expected")))
        }
    }

    fn peek(&mut self) -> Option<&'a str> {
        self.fill().then(|| self.pending.last().copied()).flatten()
    }

    fn number(&mut self, what: &str) -> Result<f64> {
        let w = self.next(what)?;
        number(w).ok_or_else(|| self.error(format!("{what}: {w:?} is not a finite number")))
    }

    fn offset(&mut self) -> Result<[f64; 3]> {
        self.expect("OFFSET")?;
        Ok([self.number("OFFSET x")?, self.number("OFFSET y")?, self.number("OFFSET z")?])
    }

    /// The rest of the current line and every line after it that holds a word, each with its
    /// number.
    fn rest_lines(mut self) -> impl Iterator<Item = (usize, Vec<&'a str>)> {
        let first = (!self.pending.is_empty()).then(|| (self.line, self.pending.drain(..).rev().collect()));
        first.into_iter().chain(
            self.lines
                .map(|(n, line)| (n + 1, line.split_whitespace().collect::<Vec<_>>()))
                .filter(|(_, words)| !words.is_empty()),
        )
    }
}

/// `w` as a finite number.
fn number(w: &str) -> Option<f64> {
    w.parse::<f64>().ok().filter(|v| v.is_finite())
}

impl Bvh {
    /// Reads the BVH file `path`.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable; [`Error::Limit`] past its size limit; as [`Bvh::parse`].
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = user_file::read_bytes(path, MAX_BYTES)?;
        Self::parse(&bytes, path)
    }

    /// Parses the bytes of the BVH file `path` (which only names it in errors).
    ///
    /// # Errors
    /// [`Error::Format`] naming `path` and the line for text that is not a BVH file: a missing
    /// keyword, a channel count other than 0 to 6 or a channel name that is not one, a number
    /// that is not finite, a frame with more or fewer values than the skeleton's channels, fewer
    /// frames than announced, no frame, a frame time that is not positive; [`Error::Limit`] past
    /// [`MAX_JOINTS`], [`MAX_FRAMES`], [`MAX_VALUES`] or the nesting limit.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self> {
        let text = std::str::from_utf8(bytes).map_err(|e| Error::format(path, format!("not text: {e}")))?;
        let mut words = Words::new(text, path);
        words.expect("HIERARCHY")?;
        let mut joints = Vec::new();
        let mut channels = 0;
        words.expect("ROOT")?;
        parse_joint(&mut words, &mut joints, None, &mut channels, 0)?;
        if words.peek().is_some_and(|w| w.eq_ignore_ascii_case("ROOT")) {
            return Err(words.error("a second ROOT: one skeleton per file is read"));
        }
        words.expect("MOTION")?;
        words.expect("Frames:")?;
        let count = words.number("the frame count")?;
        if count < 1.0 || count.fract() != 0.0 {
            return Err(words.error(format!("{count} frames: expected a whole number from 1")));
        }
        if count > MAX_FRAMES as f64 {
            return Err(Error::limit("the motion's frames", count as u64, MAX_FRAMES as u64, "frames").with_path(path));
        }
        let count = count as usize;
        let values = count.saturating_mul(channels.max(1));
        if values > MAX_VALUES {
            return Err(Error::limit("the motion's channel values", values as u64, MAX_VALUES as u64, "values").with_path(path));
        }
        words.expect("Frame")?;
        words.expect("Time:")?;
        let frame_time = words.number("the frame time")?;
        if frame_time <= 0.0 {
            return Err(words.error(format!("a frame time of {frame_time} s: expected a positive number")));
        }
        // Frame lines are counted by line, so a frame short of values is named, not merged
        // with the next.
        let mut frames = Vec::new();
        for (line, values) in words.rest_lines() {
            if frames.len() == count {
                return Err(Error::format(path, format!("line {line}: more frames than the {count} announced")));
            }
            if values.len() != channels {
                return Err(Error::format(
                    path,
                    format!(
                        "line {line}: frame {} has {} values, expected {channels} (one per channel of the skeleton)",
                        frames.len() + 1,
                        values.len()
                    ),
                ));
            }
            let frame = values
                .iter()
                .map(|w| {
                    number(w).ok_or_else(|| {
                        Error::format(
                            path,
                            format!("line {line}: frame {}: {w:?} is not a finite number", frames.len() + 1),
                        )
                    })
                })
                .collect::<Result<Vec<f64>>>()?;
            frames.push(frame);
        }
        if frames.len() < count {
            return Err(Error::format(
                path,
                format!("{count} frames announced, {} found (the file is cut short?)", frames.len()),
            ));
        }
        Ok(Bvh {
            joints,
            frame_time,
            frames,
        })
    }

    /// Every joint's place in frame `frame` (its channels applied; `None`: the rest pose, every
    /// channel zero).
    ///
    /// # Panics
    /// If `frame` is out of range (a caller bug).
    pub fn placed(&self, frame: Option<usize>) -> Vec<Placed> {
        let mut placed: Vec<Placed> = Vec::with_capacity(self.joints.len());
        for joint in &self.joints {
            let values = frame.map(|f| &self.frames[f][joint.first_channel..joint.first_channel + joint.channels.len()]);
            let mut local_rotation = IDENTITY;
            let mut offset = joint.offset;
            for (k, channel) in joint.channels.iter().enumerate() {
                let v = values.map_or(0.0, |v| v[k]);
                match *channel {
                    Channel::Position(axis) => offset[axis] += v,
                    Channel::Rotation(axis) => local_rotation = multiply(&local_rotation, &axis_rotation(axis, v.to_radians())),
                }
            }
            placed.push(match joint.parent {
                None => Placed {
                    position: offset,
                    rotation: local_rotation,
                },
                Some(p) => {
                    let parent = placed[p];
                    let moved = apply(&parent.rotation, offset);
                    Placed {
                        position: [0, 1, 2].map(|k| parent.position[k] + moved[k]),
                        rotation: multiply(&parent.rotation, &local_rotation),
                    }
                }
            });
        }
        placed
    }

    /// Where each joint's bone points, in frame `frame` (`None`: at rest): from the joint to the
    /// mean place of its children and end sites; `None` for a joint with neither, or whose
    /// children sit on it.
    pub fn bone_directions(&self, frame: Option<usize>) -> Vec<Option<[f64; 3]>> {
        let placed = self.placed(frame);
        let mut sums = vec![([0.0f64; 3], 0usize); self.joints.len()];
        for (j, joint) in self.joints.iter().enumerate() {
            if let Some(p) = joint.parent {
                for k in 0..3 {
                    sums[p].0[k] += placed[j].position[k] - placed[p].position[k];
                }
                sums[p].1 += 1;
            }
            for end in &joint.ends {
                let moved = apply(&placed[j].rotation, *end);
                for (sum, m) in sums[j].0.iter_mut().zip(moved) {
                    *sum += m;
                }
                sums[j].1 += 1;
            }
        }
        sums.into_iter()
            .map(|(sum, n)| {
                let d = sum.map(|c| c / n.max(1) as f64);
                (n > 0 && d.iter().map(|c| c * c).sum::<f64>() > 1e-18).then_some(d)
            })
            .collect()
    }
}

/// Parses one joint's block after its keyword (`ROOT` or `JOINT`), and its children.
fn parse_joint(words: &mut Words, joints: &mut Vec<Joint>, parent: Option<usize>, channels: &mut usize, depth: usize) -> Result<()> {
    if depth > MAX_DEPTH {
        return Err(Error::limit("the skeleton's nesting", depth as u64, MAX_DEPTH as u64, "levels").with_path(words.path));
    }
    if joints.len() == MAX_JOINTS {
        return Err(Error::limit("the skeleton's joints", MAX_JOINTS as u64 + 1, MAX_JOINTS as u64, "joints").with_path(words.path));
    }
    let name = words.next("a joint's name")?;
    if name == "{" {
        return Err(words.error("a joint without a name"));
    }
    words.expect("{")?;
    let offset = words.offset()?;
    words.expect("CHANNELS")?;
    let n = words.number("the channel count")?;
    if !(0.0..=6.0).contains(&n) || n.fract() != 0.0 {
        return Err(words.error(format!("joint {name:?}: {n} channels, expected 0 to 6")));
    }
    let mut list = Vec::new();
    for _ in 0..n as usize {
        let w = words.next("a channel name")?;
        let Some(channel) = channel(w) else {
            return Err(words.error(format!(
                "joint {name:?}: {w:?} is not a channel (Xposition … Zrotation; is the channel count right?)"
            )));
        };
        list.push(channel);
    }
    let index = joints.len();
    joints.push(Joint {
        name: name.to_string(),
        parent,
        offset,
        first_channel: *channels,
        channels: list,
        ends: Vec::new(),
    });
    *channels += n as usize;
    loop {
        let w = words.next("JOINT, End Site or }")?;
        if w == "}" {
            return Ok(());
        } else if w.eq_ignore_ascii_case("JOINT") {
            parse_joint(words, joints, Some(index), channels, depth + 1)?;
        } else if w.eq_ignore_ascii_case("End") {
            words.expect("Site")?;
            words.expect("{")?;
            let end = words.offset()?;
            words.expect("}")?;
            joints[index].ends.push(end);
        } else {
            let hint = if channel(w).is_some() {
                format!(", a channel past the {} of CHANNELS", joints[index].channels.len())
            } else {
                String::new()
            };
            return Err(words.error(format!("joint {name:?}: {w:?} where JOINT, End Site or }} was expected{hint}")));
        }
    }
}

/// The channel `word` names (`Xposition` … `Zrotation`, any case).
fn channel(word: &str) -> Option<Channel> {
    let axis = match word.as_bytes().first().map(u8::to_ascii_lowercase) {
        Some(b'x') => 0,
        Some(b'y') => 1,
        Some(b'z') => 2,
        _ => return None,
    };
    match word.get(1..).map(str::to_ascii_lowercase).as_deref() {
        Some("position") => Some(Channel::Position(axis)),
        Some("rotation") => Some(Channel::Rotation(axis)),
        _ => None,
    }
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation by `angle` radians about axis `axis` (0 = x, 1 = y, 2 = z), right-handed.
fn axis_rotation(axis: usize, angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

fn multiply(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// `r · v`.
pub(super) fn apply(r: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| r[i][k] * v[k]).sum())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A root with a two-bone arm along +x: the elbow turns about z.
    const ARM: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT LeftArm
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LeftForeArm
    {
      OFFSET 2 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 2 0 0
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 0 0 0 0 0 0 0 0 0 0 0
0 1 0 0 0 0 0 0 0 90 0 0
";

    fn parse(text: &str) -> Result<Bvh> {
        Bvh::parse(text.as_bytes(), Path::new("walk.bvh"))
    }

    #[test]
    fn joints_channels_and_forward_kinematics() {
        let bvh = parse(ARM).unwrap();
        assert_eq!(bvh.joints.len(), 3);
        assert_eq!(bvh.joints[2].parent, Some(1));
        assert_eq!(bvh.joints[2].first_channel, 9);
        assert_eq!(bvh.frames.len(), 2);
        assert!((bvh.frame_time - 0.04).abs() < 1e-12);
        let rest = bvh.placed(Some(0));
        assert_eq!(rest[2].position, [3.0, 0.0, 0.0]);
        // Frame 1: the root up by 1, the forearm turned 90° about z (x → y).
        let moved = bvh.placed(Some(1));
        assert!((moved[2].position[1] - 1.0).abs() < 1e-12);
        let dirs = bvh.bone_directions(Some(1));
        let d = dirs[2].unwrap();
        assert!(d[0].abs() < 1e-12 && (d[1] - 2.0).abs() < 1e-12, "{d:?}");
        assert_eq!(bvh.bone_directions(None)[1], Some([2.0, 0.0, 0.0]));
    }

    #[test]
    fn malformed_files_are_errors_naming_the_file_and_line() {
        let cases = [
            (
                ARM.replace(
                    "CHANNELS 3 Zrotation Xrotation Yrotation\n    JOINT",
                    "CHANNELS 4 Zrotation Xrotation Yrotation\n    JOINT",
                ),
                "is not a channel",
            ),
            (ARM.replace("CHANNELS 6", "CHANNELS 9"), "expected 0 to 6"),
            (ARM.replace("Frames: 2", "Frames: 3"), "3 frames announced, 2 found"),
            (ARM.replace("Frames: 2", "Frames: 1"), "more frames than the 1 announced"),
            (
                ARM.replace("0 1 0 0 0 0 0 0 0 90 0 0", "0 1 0 0 0 0 0 0 0 90 0"),
                "frame 2 has 11 values, expected 12",
            ),
            (ARM.replace("Frame Time: 0.04", "Frame Time: -1"), "expected a positive number"),
            (ARM.replace("Frames: 2", "Frames: 99999999999"), "above the limit"),
            (ARM.replace("OFFSET 1 0 0", "OFFSET 1 nan 0"), "not a finite number"),
            (ARM[..ARM.find("JOINT LeftForeArm").unwrap()].to_string(), "the file ends"),
            ("MOTION".to_string(), "\"HIERARCHY\" was expected"),
            (String::new(), "the file ends"),
        ];
        for (text, want) in cases {
            let err = parse(&text).unwrap_err().to_string();
            assert!(err.starts_with("walk.bvh") && err.contains(want), "{want}: {err}");
        }
        // Fuzz-style: every cut of the file, and every byte replaced by a digit, a brace, a
        // space or a letter, is parsed or refused, never a panic; whatever parses is whole.
        let bytes = ARM.as_bytes();
        for cut in 0..bytes.len() {
            let _ = Bvh::parse(&bytes[..cut], Path::new("cut.bvh"));
        }
        for at in 0..bytes.len() {
            for b in [b'9', b'{', b' ', b'x'] {
                let mut changed = bytes.to_vec();
                changed[at] = b;
                if let Ok(bvh) = Bvh::parse(&changed, Path::new("flip.bvh")) {
                    let channels: usize = bvh.joints.iter().map(|j| j.channels.len()).sum();
                    assert!(bvh.frames.iter().all(|f| f.len() == channels), "byte {at} = {b}");
                    let _ = bvh.bone_directions(Some(bvh.frames.len() - 1));
                }
            }
        }
        let deep = format!(
            "HIERARCHY\nROOT a {{ OFFSET 0 0 0 CHANNELS 0 {}",
            "JOINT b { OFFSET 0 0 0 CHANNELS 0 ".repeat(300)
        );
        assert!(parse(&deep).unwrap_err().to_string().contains("nesting"));
    }
}
