//! The appearance stage's training config (`puppet appearance train --model M [config.toml]`).
//! Every key is optional; the defaults are pix2pix's and WGAN-GP's where the paper
//! (neural-puppet.md §3.3) is silent, which is everywhere but the loss:
//!
//! ```toml
//! size = "small"            # ours: 16 base channels, 64 max; "full" is pix2pix's 64 / 512
//! loss = "wgan-gp"          # the paper's eq. 6; or "l1" (no critic), "lsgan", "hinge", "r1"
//! l1_weight = 100.0         # γ1 on the per-pixel mean L1 (pix2pix's λ = 100)
//! penalty_weight = 10.0     # γ2 (WGAN-GP's λ = 10; R1's γ for loss = "r1")
//! critic_steps = 1          # critic steps per generator step (pix2pix: 1; WGAN-GP's paper: 5)
//! conditioned = false       # the critic also sees the render (pix2pix's does; eq. 6's does not)
//! dropout = 0.5             # in the generator's inner decoder blocks (pix2pix)
//! residual = true           # ours: G draws a correction added to the render (pix2pix: false)
//! epochs = 200              # passes over the training frames
//! batch = 1                 # frames per step (pix2pix's; docs/appearance.md says why)
//! learning_rate = 2e-4      # both optimisers, constant (pix2pix's first half)
//! fit = "default"           # how training frames are fitted: "default" (eval's) or "one-pass"
//! seed = 1
//! checkpoint_every = 50     # steps
//! eval_every = 25           # steps; the held-out frames' L1, logged and plotted
//!
//! [adam]                    # both optimisers (pix2pix: β = (0.5, 0.999)); a partial table
//!                           # starts from PyTorch's defaults (β1 = 0.9), so give both βs
//! beta_1 = 0.5
//! beta_2 = 0.999
//! epsilon = 1e-8
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::model::appearance::AppearanceNetConfig;
use crate::objective::adversarial::AdversarialLoss;
use crate::train::config::parse_checked;
use crate::train::optim::AdamSettings;
use crate::user_file;

/// The networks' width.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NetSize {
    /// 16 base channels, 64 at most: trains in minutes on two cores.
    #[default]
    Small,
    /// pix2pix's 64 and 512 (41.8 M + 2.8 M parameters at 128²).
    Full,
}

/// Which fit of the training frames the generator learns to redraw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TrainingFit {
    /// The default fit of `puppet eval` (latent steps, limb search, vertex steps).
    #[default]
    Default,
    /// The encoder's one pass (the paper's fit).
    OnePass,
}

/// The whole config.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AppearanceConfig {
    /// The networks' width.
    pub size: NetSize,
    /// The adversarial loss.
    pub loss: AdversarialLoss,
    /// γ1.
    pub l1_weight: f64,
    /// γ2.
    pub penalty_weight: f64,
    /// Critic steps per generator step.
    pub critic_steps: usize,
    /// Whether the critic sees the render.
    pub conditioned: bool,
    /// Generator dropout.
    pub dropout: f64,
    /// Whether the generator draws a correction to the render.
    pub residual: bool,
    /// Passes over the training frames.
    pub epochs: u64,
    /// Frames per step.
    pub batch: usize,
    /// Adam's step size, both networks.
    pub learning_rate: f64,
    /// Adam's other settings.
    pub adam: AdamSettings,
    /// The fit of the training frames.
    pub fit: TrainingFit,
    /// Seeds the weights, the batch order, dropout and the penalty's mixing.
    pub seed: u64,
    /// Steps between checkpoints.
    pub checkpoint_every: u64,
    /// Steps between held-out measurements.
    pub eval_every: u64,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        AppearanceConfig {
            size: NetSize::Small,
            loss: AdversarialLoss::WganGp,
            l1_weight: 100.0,
            penalty_weight: 10.0,
            critic_steps: 1,
            conditioned: false,
            dropout: 0.5,
            residual: true,
            epochs: 200,
            batch: 1,
            learning_rate: 2e-4,
            adam: AdamSettings::new().with_beta_1(0.5).with_beta_2(0.999).with_epsilon(1e-8),
            fit: TrainingFit::Default,
            seed: 1,
            checkpoint_every: 50,
            eval_every: 25,
        }
    }
}

impl AppearanceConfig {
    /// Reads and checks a config file.
    ///
    /// # Errors
    /// [`Error::Io`]/[`Error::Limit`] naming the file; as [`AppearanceConfig::parse`].
    pub fn load(path: &Path) -> Result<Self> {
        Self::parse(&user_file::read_text(path, user_file::CONFIG)?, path)
    }

    /// Parses and checks the text of the config file `path` (which only names it in errors).
    ///
    /// # Errors
    /// As [`parse_checked`], with [`AppearanceConfig::validate`].
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        parse_checked(text, path, Self::validate)
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the key, its value and what it must be.
    pub fn validate(&self) -> Result<()> {
        let positive = |key: &str, value: f64| {
            if value > 0.0 && value.is_finite() {
                Ok(())
            } else {
                Err(Error::setting(key, value, "a positive number"))
            }
        };
        positive("learning_rate", self.learning_rate)?;
        if !(self.l1_weight >= 0.0 && self.l1_weight.is_finite()) {
            return Err(Error::setting("l1_weight", self.l1_weight, "a number ≥ 0"));
        }
        if !(self.penalty_weight >= 0.0 && self.penalty_weight.is_finite()) {
            return Err(Error::setting("penalty_weight", self.penalty_weight, "a number ≥ 0"));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(Error::setting("dropout", self.dropout, "0 ≤ p < 1"));
        }
        for (key, value) in [
            ("critic_steps", self.critic_steps as u64),
            ("epochs", self.epochs),
            ("batch", self.batch as u64),
            ("checkpoint_every", self.checkpoint_every),
            ("eval_every", self.eval_every),
        ] {
            if value == 0 {
                return Err(Error::setting(key, value, "at least 1"));
            }
        }
        if self.batch > 256 {
            return Err(Error::setting("batch", self.batch, "at most 256"));
        }
        if self.critic_steps > 100 {
            return Err(Error::setting("critic_steps", self.critic_steps, "at most 100"));
        }
        if self.epochs > 1_000_000 {
            return Err(Error::setting("epochs", self.epochs, "at most 1000000"));
        }
        self.adam.validate()
    }

    /// The networks for a model of working size `input_size`.
    pub fn net(&self, input_size: usize) -> AppearanceNetConfig {
        let (base, max) = match self.size {
            NetSize::Small => (16, 64),
            NetSize::Full => (64, 512),
        };
        AppearanceNetConfig::new(input_size)
            .with_base_channels(base)
            .with_max_channels(max)
            .with_conditioned(self.conditioned)
            .with_dropout(self.dropout)
            .with_residual(self.residual)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_config_is_the_documented_defaults_and_bad_values_are_named() {
        let config: AppearanceConfig = toml::from_str("").unwrap();
        assert_eq!(config, AppearanceConfig::default());
        assert_eq!(config.net(128).base_channels, 16);
        let parsed: AppearanceConfig = toml::from_str("size = \"full\"\nloss = \"lsgan\"\n[adam]\nbeta_1 = 0.9").unwrap();
        assert_eq!(
            (parsed.size, parsed.loss, parsed.adam.beta_1),
            (NetSize::Full, AdversarialLoss::Lsgan, 0.9)
        );
        assert!(toml::from_str::<AppearanceConfig>("los = \"l1\"").is_err());
        let bad = AppearanceConfig {
            dropout: 1.0,
            ..AppearanceConfig::default()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("dropout"));
        let bad = AppearanceConfig {
            epochs: 0,
            ..AppearanceConfig::default()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("epochs"));
    }
}
