//! `puppet synth`: generate a synthetic cartoon character and a drawn sequence of it with full
//! ground truth (issue 4), or a sprite sheet of random poses with part labels (for APES).

use std::path::PathBuf;

use anyhow::Context;
use puppet::atomic_file::record;
use puppet::synth::{self, Motion, SynthOptions};

use super::args::parse_size;
use super::Session;

/// Generate a synthetic character: drawn frames, template artwork, label maps and ground truth.
///
/// Writes into OUTPUT: frames/frame_NNN.png, labels/label_NNN.png (one flat colour per part),
/// masks/mask_NNN.png (alpha), template/ (character.toml + one PNG per layer, for
/// `puppet build`), truth.json (every part's rest→frame map) and contact_sheet.png.
/// With --sprite-sheet: sheet.png, sheet_labels.png, template/ and truth.json instead.
/// The same seed and options give byte-identical files.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {
    /// Output folder (created if missing; a folder puppet did not make is refused unless --force).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Random seed: picks the character, its colours and its motion amplitudes.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Seed of the motion alone (its amplitudes and random poses; default: --seed's): two
    /// characters of different seeds with one motion seed move alike.
    #[arg(long, value_name = "SEED")]
    pub motion_seed: Option<u64>,
    /// Number of frames (sprite-sheet mode: number of poses).
    #[arg(long, default_value_t = 24)]
    pub frames: usize,
    /// Frame size in pixels, WIDTHxHEIGHT, each side 64 to 4096.
    #[arg(long, default_value = "256x256", value_name = "WxH", value_parser = parse_size)]
    pub size: (u32, u32),
    /// How the character moves.
    #[arg(long, value_enum, default_value_t = MotionArg::Walk)]
    pub motion: MotionArg,
    /// σ of the per-part ARAP handle offsets, as a fraction of the larger image side
    /// (APES appendix B uses 0.02); 0 keeps every part rigid.
    #[arg(long, default_value_t = 0.02, value_name = "FRACTION")]
    pub deform: f32,
    /// Per-frame line wobble amplitude in pixels (0: none).
    #[arg(long, default_value_t = 0.35, value_name = "PX")]
    pub wobble: f32,
    /// Write a sprite sheet of random poses (sheet.png + sheet_labels.png) instead of a frame
    /// sequence; --motion is then ignored (poses are random, APES §5.1 ranges).
    #[arg(long)]
    pub sprite_sheet: bool,
    /// Cells per row of the sprite sheet.
    #[arg(long, default_value_t = 4, value_name = "N")]
    pub columns: usize,
    /// Dress the character: a vest, back hair, freckles, sunglasses, a hat, a bracelet and a
    /// sleeve as accessory layers of the template (kind = "accessory"), each following its
    /// parent part; template/rig_truth.json names every accessory's true parent.
    #[arg(long)]
    pub accessories: bool,
    /// With --accessories, also a trim along the vest's hem: an accessory on an accessory (its
    /// true parent the vest), sharing the vest's lower edge, so that the rig's coincident-boundary
    /// constraint has something to keep. Everything else is drawn as with --accessories alone.
    #[arg(long, requires = "accessories")]
    pub trim: bool,
    /// A character of wider variety than the one three-quarter-view humanoid: the seed also
    /// picks a body plan (half bodies without legs, robots, front views, an object held in the
    /// front hand) and, for three in ten, the accessories of --accessories. The correspondence
    /// network of `puppet parts` trains on such characters (`varied` in its config).
    #[arg(long, conflicts_with = "accessories")]
    pub varied: bool,
}

/// `--motion` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MotionArg {
    /// A walk cycle.
    Walk,
    /// Waving the front arm.
    Wave,
    /// Crouch, jump, land.
    Jump,
    /// An independent random pose per frame.
    Random,
}

impl From<MotionArg> for Motion {
    fn from(m: MotionArg) -> Self {
        match m {
            MotionArg::Walk => Motion::Walk,
            MotionArg::Wave => Motion::Wave,
            MotionArg::Jump => Motion::Jump,
            MotionArg::Random => Motion::Random,
        }
    }
}

impl SynthArgs {
    /// The validated library options.
    fn options(&self) -> anyhow::Result<SynthOptions> {
        let (width, height) = self.size;
        let motion = if self.sprite_sheet { Motion::Random } else { self.motion.into() };
        let opts = SynthOptions {
            seed: self.seed,
            motion_seed: self.motion_seed,
            frames: self.frames,
            width,
            height,
            motion,
            deform_sigma: self.deform,
            wobble: self.wobble,
            accessories: self.accessories,
            trim: self.trim,
            varied: self.varied,
        };
        opts.validate()?;
        if self.sprite_sheet && self.columns == 0 {
            anyhow::bail!("--columns 0: a sprite sheet needs at least one column");
        }
        Ok(opts)
    }
}

/// Runs `puppet synth`.
pub fn run(args: SynthArgs, s: &Session) -> anyhow::Result<()> {
    let opts = args.options()?;
    s.outputs.claim_folder(&args.output)?;
    let seq = synth::generate(&opts, &s.ui).context("while generating the synthetic sequence")?;
    let written = if args.sprite_sheet {
        synth::write_sprite_sheet(&seq, &args.output, args.columns)
    } else {
        synth::write_sequence(&seq, &args.output, &s.ui)
    }
    .with_context(|| format!("while writing {}", args.output.display()))?;
    record(&std::path::absolute(&args.output)?)?;
    s.ui.say(format!(
        "wrote {} ({} {}×{} {}, {} parts): {} images, {}, {}",
        written.dir.display(),
        opts.frames,
        opts.width,
        opts.height,
        if args.sprite_sheet {
            "poses in a sprite sheet".to_string()
        } else {
            format!("frames, {}", opts.motion.name())
        },
        seq.character.parts.len(),
        written.images,
        written.template.display(),
        written.truth.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        args: SynthArgs,
    }

    fn parse(args: &[&str]) -> Result<SynthArgs, clap::Error> {
        Cli::try_parse_from(std::iter::once("synth").chain(args.iter().copied())).map(|c| c.args)
    }

    #[test]
    fn defaults_give_valid_options() {
        let opts = parse(&["-o", "x"]).unwrap().options().unwrap();
        assert_eq!((opts.width, opts.height, opts.frames, opts.motion), (256, 256, 24, Motion::Walk));
    }

    #[test]
    fn size_and_motion_are_parsed() {
        let opts = parse(&["-o", "x", "--size", "128x96", "--motion", "jump", "--frames", "5"])
            .unwrap()
            .options()
            .unwrap();
        assert_eq!((opts.width, opts.height, opts.frames, opts.motion), (128, 96, 5, Motion::Jump));
    }

    #[test]
    fn bad_inputs_are_clear_errors() {
        let err = parse(&["-o", "x", "--frames", "0"]).unwrap().options().unwrap_err().to_string();
        assert!(err.contains("frames = 0"), "{err}");
        let err = parse(&["-o", "x", "--size", "16x16"]).unwrap().options().unwrap_err().to_string();
        assert!(
            err.contains("width = 16 px (64 to 4096)") && err.contains("height = 16 px"),
            "{err}"
        );
        let err = parse(&["-o", "x", "--size", "big"]).unwrap_err().to_string();
        assert!(err.contains("is not a size WxH"), "{err}");
        let err = parse(&["-o", "x", "--size", "4096x4096", "--frames", "100"])
            .unwrap()
            .options()
            .unwrap_err()
            .to_string();
        assert!(err.contains("100 frames of 4096×4096") && err.contains("above the limit"), "{err}");
        let err = parse(&["-o", "x", "--motion", "dance"]).unwrap_err().to_string();
        assert!(err.contains("dance") && err.contains("walk"), "{err}");
    }
}
