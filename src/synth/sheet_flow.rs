//! Exact correspondences and part labels of a synthetic sprite sheet, from its truth: the oracle
//! that `puppet parts --truth` runs the part finder on (issue 16 stage a), so what the back end
//! loses is measured apart from what a correspondence method loses.

use std::path::Path;

use rayon::prelude::*;

use super::deformation::InverseMap;
use super::truth::Truth;
use crate::error::{Error, Result};
use crate::parts::flow::{Correspondences, Flow};
use crate::parts::learn::{PairSource, TrainingPair};
use crate::parts::matching::WorkingPose;
use crate::parts::pose::{check, crop_like, SheetPose};
use crate::parts::superpixels::NONE;
use crate::picture::Picture;

/// The part index of each pixel of a label map drawn in the truth's label colours ([`NONE`]
/// where it is transparent).
///
/// # Errors
/// [`Error::Format`] naming `path` for an opaque colour that is no part's label.
pub fn true_labels(truth: &Truth, labels: &Picture, path: &Path) -> Result<Vec<u32>> {
    let colours: Vec<[u8; 3]> = truth.parts.iter().map(|p| hex_rgb(&p.label)).collect();
    labels
        .pixels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if p[3] < 0.5 {
                return Ok(NONE);
            }
            let rgb = [p[0], p[1], p[2]].map(|c| (c * 255.0).round() as u8);
            colours.iter().position(|&c| c == rgb).map(|k| k as u32).ok_or_else(|| {
                Error::format(
                    path,
                    format!(
                        "pixel ({}, {}) has colour {rgb:?}, which labels no part of truth.json",
                        i as u32 % labels.width,
                        i as u32 / labels.width
                    ),
                )
            })
        })
        .collect()
}

fn hex_rgb(hex: &str) -> [u8; 3] {
    let v = u32::from_str_radix(hex.trim_start_matches('#'), 16).unwrap_or(0x808080);
    [(v >> 16) as u8, (v >> 8) as u8, v as u8]
}

/// For every ordered pair of frames of `truth`, where each labelled pixel of the first frame is
/// in the second: back through its part's placement and deformation to the rest frame, then
/// forward into the other frame (pixel centres; positions stored in the pixel-index convention
/// of `parts`, centre of pixel (x, y) at (x, y)). `labels[k]` is frame `k`'s true part per pixel.
///
/// # Errors
/// [`Error::Mismatch`] if the label count or sizes differ from the truth.
pub fn true_correspondences(truth: &Truth, labels: &[Vec<u32>]) -> Result<Correspondences> {
    let (w, h) = (truth.width as usize, truth.height as usize);
    if labels.len() != truth.frames.len() || labels.iter().any(|l| l.len() != w * h) {
        return Err(Error::mismatch(
            "label maps",
            format!("{} of {:?} pixels", labels.len(), labels.first().map(Vec::len)),
            format!("{} of {} pixels", truth.frames.len(), w * h),
        ));
    }
    let n = truth.frames.len();
    // Each labelled pixel's rest-local point (in its part's local frame, undeformed).
    let rest_local: Vec<Vec<Option<[f32; 2]>>> = (0..n)
        .into_par_iter()
        .map(|s| {
            let inverses: Vec<Option<InverseMap>> = truth
                .parts
                .iter()
                .zip(&truth.frames[s].parts)
                .map(|(part, placed)| placed.deformed.as_ref().map(|d| InverseMap::new(&part.grid, d)))
                .collect();
            labels[s]
                .iter()
                .enumerate()
                .map(|(i, &l)| {
                    if l == NONE || l as usize >= truth.parts.len() {
                        return None;
                    }
                    let p = l as usize;
                    let centre = [(i % w) as f32 + 0.5, (i / w) as f32 + 0.5];
                    let local = truth.frames[s].parts[p].world.inverse().apply(centre);
                    match &inverses[p] {
                        Some(inverse) => inverse.rest_of(local),
                        None => Some(local),
                    }
                })
                .collect()
        })
        .collect();
    let mut out = Correspondences::new(n, w * h);
    for s in 0..n {
        for t in (0..n).filter(|&t| t != s) {
            let to = rest_local[s]
                .iter()
                .zip(&labels[s])
                .map(|(r, &l)| match r {
                    Some(r) => {
                        let p = l as usize;
                        let placed = &truth.frames[t].parts[p];
                        let moved = match &placed.deformed {
                            Some(d) => truth.parts[p].grid.map(d, *r),
                            None => *r,
                        };
                        let q = placed.world.apply(moved);
                        [q[0] - 0.5, q[1] - 0.5]
                    }
                    None => [f32::NAN; 2],
                })
                .collect();
            out.set(s, t, Flow { to })?;
        }
    }
    Ok(out)
}

/// A generated sprite sheet in memory: `poses` random poses of seed `seed`'s character at
/// `size`² (the generator's default deformation and wobble, as `puppet synth --sprite-sheet`
/// draws them; with `varied`, the character of [`super::character::Character::varied`]), with
/// the true part of each pixel of each pose.
#[derive(Clone, Debug)]
pub struct GeneratedSheet {
    /// The generated sequence (character, frames, truth).
    pub sequence: super::Sequence,
    /// Its frames as poses.
    pub poses: Vec<SheetPose>,
    /// The true part of each pixel of each pose ([`NONE`] on the background).
    pub labels: Vec<Vec<u32>>,
}

impl GeneratedSheet {
    /// Generates the sheet.
    ///
    /// # Errors
    /// As [`super::generate`].
    pub fn new(seed: u64, poses: usize, size: u32, varied: bool) -> Result<Self> {
        let options = super::SynthOptions {
            seed,
            frames: poses,
            width: size,
            height: size,
            motion: super::Motion::Random,
            varied,
            ..super::SynthOptions::default()
        };
        let sequence = super::generate(&options, &crate::progress::Silent)?;
        let labels = sequence
            .frames
            .iter()
            .map(|f| {
                f.labels
                    .iter()
                    .map(|&l| if l == super::draw::BACKGROUND { NONE } else { u32::from(l) })
                    .collect()
            })
            .collect();
        let poses = sequence
            .frames
            .iter()
            .enumerate()
            .map(|(k, f)| SheetPose::new(format!("pose {k}"), f.image.clone()))
            .collect();
        Ok(GeneratedSheet { sequence, poses, labels })
    }

    /// The exact correspondences between its poses.
    ///
    /// # Errors
    /// As [`true_correspondences`].
    pub fn correspondences(&self) -> Result<Correspondences> {
        true_correspondences(&self.sequence.truth, &self.labels)
    }
}

/// Training pairs for the correspondence network: pair `index` is two random poses of the
/// character of seed `first_seed + index`, drawn at `size`², with every pixel of the first whose
/// point shows in the second (same part there: not hidden).
#[derive(Clone, Copy, Debug)]
pub struct SyntheticPairs {
    /// The generator's seed of pair 0.
    pub first_seed: u64,
    /// Pose side, pixels (the network's working size).
    pub size: u32,
    /// Characters of wider variety ([`super::character::Character::varied`]).
    pub varied: bool,
}

impl PairSource for SyntheticPairs {
    fn size(&self) -> usize {
        self.size as usize
    }

    fn pair(&self, index: u64) -> Result<TrainingPair> {
        let sheet = GeneratedSheet::new(self.first_seed.wrapping_add(index), 2, self.size, self.varied)?;
        let flows = sheet.correspondences()?;
        let flow = flows.get(0, 1).expect("the truth holds every pair");
        let w = self.size as usize;
        let labels = &sheet.labels;
        let matches = (0..labels[0].len())
            .filter_map(|i| {
                let q = flow.at(i)?;
                let (x, y) = (q[0].round(), q[1].round());
                if x < 0.0 || y < 0.0 || x >= w as f32 || y >= w as f32 {
                    return None;
                }
                let j = y as usize * w + x as usize;
                (labels[1][j] == labels[0][i]).then_some([i as u32, j as u32])
            })
            .collect();
        let [a, b] = [0, 1].map(|k| WorkingPose::new(&sheet.poses[k], self.size));
        Ok(TrainingPair {
            a: a.planes,
            b: b.planes,
            matches,
            masks: [a.mask, b.mask],
        })
    }
}

/// A sprite sheet written by `puppet synth --sprite-sheet`, read back with its truth.
#[derive(Clone, Debug)]
pub struct TruthSheet {
    /// The poses, cut by the sheet's grid.
    pub poses: Vec<SheetPose>,
    /// The true part of each pixel of each pose.
    pub labels: Vec<Vec<u32>>,
    /// The sheet's size.
    pub sheet_size: (u32, u32),
    /// The truth.
    pub truth: Truth,
}

impl TruthSheet {
    /// Reads `dir/truth.json`, the sheet and its label sheet, and cuts them by the truth's grid.
    ///
    /// # Errors
    /// [`Error::Format`] naming truth.json if it describes no sheet (a frame sequence) or a
    /// grid that does not fit the sheet; as [`Truth::load`], [`Picture::load`] and
    /// [`true_labels`].
    pub fn load(dir: &Path) -> Result<Self> {
        let truth_path = dir.join(super::truth::TRUTH_FILE);
        let truth = Truth::load(&truth_path)?;
        let layout = truth
            .sheet
            .clone()
            .ok_or_else(|| Error::format(&truth_path, "this truth describes a frame sequence, not a sprite sheet"))?;
        let sheet_path = dir.join(&layout.file);
        let sheet = Picture::load(&sheet_path)?;
        let labels_path = dir.join(&layout.labels);
        let label_sheet = Picture::load(&labels_path)?;
        if (sheet.width, sheet.height) != (layout.columns * truth.width, layout.rows * truth.height)
            || (label_sheet.width, label_sheet.height) != (sheet.width, sheet.height)
        {
            return Err(Error::format(
                &truth_path,
                format!(
                    "a {}×{} grid of {}×{} cells does not match {} ({}×{}) and {} ({}×{})",
                    layout.columns,
                    layout.rows,
                    truth.width,
                    truth.height,
                    layout.file,
                    sheet.width,
                    sheet.height,
                    layout.labels,
                    label_sheet.width,
                    label_sheet.height
                ),
            ));
        }
        // Cells by position, not by content: the truth numbers every cell, drawn or not.
        let cells: Vec<SheetPose> = (0..truth.frames.len() as u32)
            .map(|k| {
                let origin = [
                    i64::from(k % layout.columns * truth.width),
                    i64::from(k / layout.columns * truth.height),
                ];
                SheetPose::new(format!("{}#{k}", layout.file), Picture::filled(truth.width, truth.height, [0.0; 4])).at(origin)
            })
            .collect();
        let poses = crop_like(&sheet, &cells);
        check(&poses, &sheet_path)?;
        let labels = crop_like(&label_sheet, &cells)
            .iter()
            .map(|p| true_labels(&truth, &p.image, &labels_path))
            .collect::<Result<Vec<_>>>()?;
        Ok(TruthSheet {
            poses,
            labels,
            sheet_size: (sheet.width, sheet.height),
            truth,
        })
    }

    /// The exact correspondences between its poses.
    ///
    /// # Errors
    /// As [`true_correspondences`].
    pub fn correspondences(&self) -> Result<Correspondences> {
        true_correspondences(&self.truth, &self.labels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;

    /// A dressed character's sprite sheet written to disk reads back with every pixel's part, each
    /// accessory its own: the label sheet's colours tell them apart.
    #[test]
    fn a_dressed_sheet_reads_back_with_the_labels_it_was_drawn_with() {
        let options = super::super::SynthOptions {
            seed: 31,
            frames: 3,
            width: 96,
            height: 96,
            motion: super::super::Motion::Random,
            accessories: true,
            ..super::super::SynthOptions::default()
        };
        let sequence = super::super::generate(&options, &Silent).unwrap();
        let dir = tempfile::tempdir().unwrap();
        super::super::write_sprite_sheet(&sequence, dir.path(), 3).unwrap();
        let read = TruthSheet::load(dir.path()).unwrap();
        for (frame, labels) in sequence.frames.iter().zip(&read.labels) {
            let drawn: Vec<u32> = frame
                .labels
                .iter()
                .map(|&l| if l == super::super::draw::BACKGROUND { NONE } else { u32::from(l) })
                .collect();
            assert_eq!(&drawn, labels);
        }
        let hat = sequence.character.part("hat").unwrap() as u32;
        assert!(read.labels.iter().flatten().any(|&l| l == hat), "no hat pixel read back");
    }
}
