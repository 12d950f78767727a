//! Training a character from the prior (issue 56): before the first step the training frames are
//! fitted by a fit that needs no network of the character — the character-agnostic prior's
//! placement, then the fit's latent-free stages ([`crate::prior::fit_untrained`]) — and for the
//! first share of the run a vertex loss pulls the network's poses of those frames toward the
//! fits. The network learns where the template goes on each drawn frame directly instead of
//! finding it through the image loss alone, which reaches a pose slowly and from the rest pose
//! only nearby. The image loss stays on throughout and alone after the guided share, so a fit the
//! prior got wrong (a back view) is not kept. Not in neural-puppet.md.
//!
//! The fit is given to the trainer ([`super::TrainOptions::guide`]) rather than called here: the
//! prior sits above training (it fits through [`mod@crate::fit`], which uses training's optimiser).

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::model::Model;
use crate::picture::{contact_sheet, Picture};
use crate::progress::Progress;
use crate::render::render_crisp;

/// `[train.guide]`: how strongly and for how long the network's poses of the training frames are
/// pulled toward the untrained fits. Off (weight 0) unless a config or `puppet train --prior`
/// asks for it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Guide {
    /// Weight of the vertex loss: the mean squared distance, in working pixels², between the
    /// network's vertices of a training frame and the frame's untrained fit (0: off).
    pub weight: f64,
    /// The schedule: the guide is on for this share of the run's steps (`train.steps`).
    pub until: f64,
}

impl Default for Guide {
    /// Off; `until` is the share that measured best on the Kenney robot at a third of its steps
    /// (docs/results.md "Training from the prior"), with [`PRIOR_WEIGHT`].
    fn default() -> Self {
        Guide { weight: 0.0, until: 0.2 }
    }
}

/// The weight `puppet train --prior` sets when the config leaves the guide off (docs/results.md
/// "Training from the prior": against 10 for half the run and 100 for a tenth).
pub const PRIOR_WEIGHT: f64 = 30.0;

impl Guide {
    /// Whether no guide is used (the config's table may then be left out).
    pub fn is_off(&self) -> bool {
        self.weight == 0.0
    }

    /// Whether step `step` (from 0) of a run of `steps` is guided.
    pub fn shown_at(&self, step: u64, steps: u64) -> bool {
        !self.is_off() && (step as f64) < self.until * steps as f64
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the first key out of range.
    pub fn validate(&self) -> Result<()> {
        if !(self.weight.is_finite() && self.weight >= 0.0) {
            return Err(Error::setting("train.guide.weight", self.weight, "a finite weight ≥ 0"));
        }
        if !(self.until > 0.0 && self.until <= 1.0) {
            return Err(Error::setting(
                "train.guide.until",
                self.until,
                "a share of the run's steps above 0, at most 1",
            ));
        }
        Ok(())
    }
}

/// A fit of drawn frames that needs no trained network of the character (the prior's zero-shot
/// fit): what [`Guide`] pulls the network toward.
pub trait UntrainedFit: std::fmt::Debug {
    /// Every template vertex of each of `frames` (frame pixels), as placed on the frame for
    /// `model`'s puppet; `model`'s network is not used.
    ///
    /// # Errors
    /// Whatever the fit reports (a frame of another size, a puppet it cannot read).
    fn fit(&self, model: &Model, frames: &[&Picture], progress: &dyn Progress) -> Result<Vec<Vec<[f32; 2]>>>;
}

/// A sheet of the guide: the training frames in the top row, the untrained fits rendered below
/// each, so a fit the prior got wrong can be seen before the run is trusted.
///
/// # Errors
/// As [`render_crisp`].
pub fn guide_sheet(model: &Model, frames: &[&Picture], fits: &[Vec<[f32; 2]>]) -> Result<Picture> {
    let puppet = &model.puppet;
    let renders = fits
        .iter()
        .map(|pose| render_crisp(puppet, pose, puppet.width, puppet.height))
        .collect::<Result<Vec<_>>>()?;
    let cells: Vec<&Picture> = frames.iter().copied().chain(&renders).collect();
    Ok(contact_sheet(&cells, frames.len().max(1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_guide_is_on_for_its_share_of_the_run_and_checks_its_settings() {
        let guide = Guide { weight: 5.0, until: 0.3 };
        let on: Vec<bool> = (0..10).map(|step| guide.shown_at(step, 10)).collect();
        assert_eq!(on, [true, true, true, false, false, false, false, false, false, false]);
        assert!((0..10).all(|step| !Guide::default().shown_at(step, 10)), "off is never on");
        assert!(Guide::default().validate().is_ok() && Guide::default().is_off());
        for (bad, key) in [
            (Guide { weight: -1.0, until: 0.5 }, "weight"),
            (Guide { weight: 1.0, until: 0.0 }, "until"),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains(&format!("train.guide.{key}")), "{e}");
        }
    }
}
