//! Generating a whole synthetic sequence: the character, its template layers (rest pose), and
//! every frame drawn from the posed, deformed and wobbling shapes, with the ground truth that
//! relates them (issue 4 items 2–4).

use super::character::{Character, Role};
use super::deformation::Grid;
use super::draw::{draw, draw_part, Drawing, Placed};
use super::labels::label_hex;
use super::look::Wobble;
use super::part_arap::PartArap;
use super::pose::{Animator, Motion};
use super::truth::{FrameTruth, PartFrame, PartTruth, Truth, TRUTH_VERSION};
use crate::error::{Error, Result};
use crate::geom::similarity::Similarity;
use crate::picture::Picture;
use crate::progress::Progress;
use crate::rng::Rng;

/// Smallest frame side: below this a character's limbs are a pixel or two wide.
pub const MIN_SIDE: u32 = 64;
/// Largest frame side.
pub const MAX_SIDE: u32 = 4096;
/// Most frames in one sequence.
pub const MAX_FRAMES: usize = 100_000;
/// The most pixels over all frames of a sequence: what a training run reads by default
/// ([`crate::puppet::sequence::DEFAULT_MAX_TOTAL_PIXELS`]).
pub const MAX_TOTAL_PIXELS: u64 = crate::puppet::sequence::DEFAULT_MAX_TOTAL_PIXELS;

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthOptions {
    /// Seed: the same options give byte-identical output.
    pub seed: u64,
    /// The motion's own seed (its amplitudes and random poses), so that characters of different
    /// seeds can move alike; `None`: `seed`'s.
    pub motion_seed: Option<u64>,
    /// Number of frames (or sprite-sheet cells).
    pub frames: usize,
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// How the character moves.
    pub motion: Motion,
    /// σ of the ARAP handle offsets as a fraction of max(width, height) (APES appendix B: 0.02);
    /// 0 keeps every part rigid.
    pub deform_sigma: f32,
    /// Per-frame line wobble amplitude, pixels (0: none).
    pub wobble: f32,
    /// Dress the character in accessory layers ([`Character::dressed`]).
    pub accessories: bool,
    /// With `accessories`, also a trim on the vest, an accessory on an accessory
    /// ([`Character::trimmed`]).
    pub trim: bool,
    /// A character of wider variety ([`Character::varied`]: half bodies, robots, front views,
    /// held objects, some dressed) instead of the one humanoid.
    pub varied: bool,
}

impl Default for SynthOptions {
    fn default() -> Self {
        SynthOptions {
            seed: 42,
            motion_seed: None,
            frames: 24,
            width: 256,
            height: 256,
            motion: Motion::Walk,
            deform_sigma: 0.02,
            wobble: 0.35,
            accessories: false,
            trim: false,
            varied: false,
        }
    }
}

impl SynthOptions {
    /// Checks the options.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the bad option and the accepted range.
    pub fn validate(&self) -> Result<()> {
        let mut problems = Vec::new();
        if self.frames == 0 || self.frames > MAX_FRAMES {
            problems.push(Error::setting("frames", self.frames, format!("1 to {MAX_FRAMES}")));
        }
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(MIN_SIDE..=MAX_SIDE).contains(&v) {
                problems.push(Error::setting(
                    name.to_string(),
                    format!("{v} px"),
                    format!("{MIN_SIDE} to {MAX_SIDE}"),
                ));
            }
        }
        let pixels = self.frames as u64 * u64::from(self.width) * u64::from(self.height);
        if problems.is_empty() && pixels > MAX_TOTAL_PIXELS {
            // The whole sequence is drawn in memory (and training reads it all back).
            problems.push(Error::limit(
                format!("{} frames of {}×{}", self.frames, self.width, self.height),
                pixels,
                MAX_TOTAL_PIXELS,
                "pixels",
            ));
        }
        if !(0.0..=0.1).contains(&self.deform_sigma) {
            problems.push(Error::setting("deformation σ", self.deform_sigma, "0 to 0.1 of the image size"));
        }
        if !(0.0..=2.0).contains(&self.wobble) {
            problems.push(Error::setting("wobble", format!("{} px", self.wobble), "0 to 2"));
        }
        if self.varied && self.accessories {
            problems.push(Error::setting(
                "varied",
                "with accessories",
                "alone (a varied character is dressed or not by its seed)",
            ));
        }
        if self.trim && !self.accessories {
            problems.push(Error::setting(
                "trim",
                "without accessories",
                "with accessories (it goes on the vest)",
            ));
        }
        Error::collect(problems)
    }
}

/// A generated sequence in memory.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// The character.
    pub character: Character,
    /// One rest-pose layer image per part, back to front (the template artwork).
    pub template: Vec<Picture>,
    /// The drawn frames with their label maps.
    pub frames: Vec<Drawing>,
    /// The ground truth.
    pub truth: Truth,
}

/// File name of frame `t` of `n` inside `frames/` (or `labels/`, with `prefix`).
pub fn frame_name(prefix: &str, t: usize, n: usize) -> String {
    let digits = n.saturating_sub(1).to_string().len().max(3);
    format!("{prefix}_{t:0digits$}.png")
}

/// Generates the sequence `opts` describes, reporting one step per frame.
///
/// # Errors
/// [`Error::Setting`] for bad options ([`SynthOptions::validate`]) or if a part's deformation
/// cannot be set up.
pub fn generate(opts: &SynthOptions, progress: &dyn Progress) -> Result<Sequence> {
    opts.validate()?;
    let (w, h) = (opts.width, opts.height);
    let character = if opts.varied {
        Character::varied(opts.seed, w, h)
    } else if opts.trim {
        Character::trimmed(opts.seed, w, h)
    } else if opts.accessories {
        Character::dressed(opts.seed, w, h)
    } else {
        Character::generate(opts.seed, w, h)
    };
    let n = character.parts.len();
    let k = character.rest_root.scale(); // rest-frame pixels per local unit
                                         // Grids: 3 px of margin (anti-aliasing and wobble stay inside), cells of ≤ 3.5 % of the
                                         // frame's smaller side.
    let grids: Vec<Grid> = character
        .parts
        .iter()
        .map(|p| Grid::covering(p.shape.bounds(), 3.0 / k, 0.035 * w.min(h) as f32 / k))
        .collect();
    let root_rng = Rng::new(opts.seed);
    // One deformer per body part; accessories are carried by their parent's deformation.
    let mut deformers: Vec<Option<PartArap>> = Vec::new();
    if opts.deform_sigma > 0.0 {
        let mut rng = root_rng.fork(4);
        for (i, part) in character.parts.iter().enumerate() {
            if part.role == Role::Accessory {
                deformers.push(None);
                continue;
            }
            let mut pins = vec![[0.0, 0.0]];
            pins.extend(character.child_pivots(i));
            let free = if part.parent.is_none() || part.name == "head" { 2 } else { 1 };
            deformers.push(Some(PartArap::new(&grids[i], &part.shape, &pins, free, &mut rng)?));
        }
    }
    let rest_world = character.world_transforms(&character.rest_root, &vec![0.0; n]);
    progress.stage("template", n as u64);
    let template = (0..n)
        .map(|i| {
            let placed = Placed {
                world: rest_world[i],
                grid: &grids[i],
                deformed: None,
                wobble: Wobble::NONE,
            };
            let layer = draw_part(&character, i, &placed, w, h);
            progress.advance(1);
            layer
        })
        .collect();
    let animator = Animator::new(opts.motion, opts.frames, opts.motion_seed.unwrap_or(opts.seed), w, h);
    let sigma = opts.deform_sigma * w.max(h) as f32 / k;
    progress.stage("drawing", opts.frames as u64);
    let mut frames = Vec::with_capacity(opts.frames);
    let mut frame_truth = Vec::with_capacity(opts.frames);
    for t in 0..opts.frames {
        let pose = animator.pose(&character, t);
        let world = character.world_transforms(&pose.root, &pose.delta);
        let mut rng = root_rng.fork(1000 + t as u64);
        let mut deformed: Vec<Option<Vec<[f32; 2]>>> = deformers
            .iter_mut()
            .map(|d| d.as_mut().map(|d| d.deform(sigma, pose.phase, &mut rng)))
            .chain(std::iter::repeat(None))
            .take(n)
            .collect();
        carry_accessories(&character, &grids, &mut deformed);
        let wobbles: Vec<Wobble> = (0..n).map(|_| wobble(&mut rng, opts.wobble)).collect();
        let placed: Vec<Placed> = (0..n)
            .map(|i| Placed {
                world: world[i],
                grid: &grids[i],
                deformed: deformed[i].as_deref(),
                wobble: wobbles[i],
            })
            .collect();
        frames.push(draw(&character, &placed, w, h));
        frame_truth.push(FrameTruth {
            file: format!("frames/{}", frame_name("frame", t, opts.frames)),
            labels: format!("labels/{}", frame_name("label", t, opts.frames)),
            parts: (0..n)
                .map(|i| PartFrame {
                    world: world[i],
                    deformed: deformed[i].clone(),
                })
                .collect(),
        });
        progress.advance(1);
    }
    let truth = Truth {
        version: TRUTH_VERSION,
        name: character.name.clone(),
        seed: opts.seed,
        motion: opts.motion,
        width: w,
        height: h,
        deform_sigma: opts.deform_sigma,
        wobble: opts.wobble,
        parts: character
            .parts
            .iter()
            .enumerate()
            .map(|(i, p)| PartTruth {
                name: p.name.clone(),
                parent: p.parent.map(|q| character.parts[q].name.clone()),
                label: label_hex(&p.name),
                rest: rest_world[i],
                grid: grids[i].clone(),
            })
            .collect(),
        frames: frame_truth,
        sheet: None,
    };
    Ok(Sequence {
        character,
        template,
        frames,
        truth,
    })
}

/// Gives every accessory its parent's deformation: the parent's grid map (extended linearly
/// beyond the parent's grid) evaluated at the accessory's grid vertices — both grids are in the
/// parent's local frame, the accessory's pivot being the parent's origin.
fn carry_accessories(character: &Character, grids: &[Grid], deformed: &mut [Option<Vec<[f32; 2]>>]) {
    for (i, part) in character.parts.iter().enumerate() {
        if let (Role::Accessory, Some(parent)) = (part.role, part.parent) {
            deformed[i] = deformed[parent]
                .as_ref()
                .map(|d| grids[i].vertices().iter().map(|&v| grids[parent].map(d, v)).collect());
        }
    }
}

/// A fresh wobble: two silhouette waves and one width wave, wavelengths 8–16 local units in
/// random directions, random phases.
fn wobble(rng: &mut Rng, amplitude: f32) -> Wobble {
    let mut waves = [[0.0; 3]; 3];
    for wave in &mut waves {
        let dir = rng.range(0.0, std::f32::consts::TAU);
        let freq = std::f32::consts::TAU / rng.range(8.0, 16.0);
        *wave = [
            freq * libm::cosf(dir),
            freq * libm::sinf(dir),
            rng.range(0.0, std::f32::consts::TAU),
        ];
    }
    Wobble { amplitude, waves }
}

/// The rigid placement of every part for the rest pose (as in the template).
pub fn rest_placements(character: &Character) -> Vec<Similarity> {
    character.world_transforms(&character.rest_root, &vec![0.0; character.parts.len()])
}
