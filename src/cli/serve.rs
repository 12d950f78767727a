//! `puppet serve [--model DIR] [--port 8080] [--host 127.0.0.1] [--outfit ARTWORK]… [--open]
//! [--appearance]`:
//! the web editor (issue 18) — a local HTTP server with a page that poses the model's puppet by
//! drag pins and sliders, plays in-betweens and motions, swaps outfits, downloads what it shows,
//! and says what to draw next (issue 57).

use std::net::IpAddr;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context as _;
use puppet::appearance::AppearanceStage;
use puppet::fit::{FitOptions, DEFAULT_LATENT_STEPS, DEFAULT_VERTEX_STEPS};
use puppet::model::Model;
use puppet::progress::Progress as _;
use puppet::puppet::artwork;
use puppet::puppet::build::BuildOptions;
use puppet::rig::outfit::dress;
use puppet::rig::RigOptions;
use puppet::serve::{folder_frames, model_frames, model_outfits, App, ServeOptions, UploadPrior};

use super::args::LatentFitArgs;
use super::Session;

/// Where `puppet demo` leaves its model: the editor's model when none is given.
const DEMO_MODEL: &str = "out/demo/model";

/// Serve the web editor: a page that draws the model's puppet from its meshes and textures,
/// poses it by drag pins (click the character to pin a point, drag it; right-click removes it)
/// and sliders, plays in-betweens of two frames, swaps outfits and downloads PNG, GIF, APNG,
/// sprite sheets and Spine skeletons; with --appearance, each pose also as the model's
/// appearance stage redraws it. The frames to pose are those the model trained on (from
/// its split.json) or --frames; the outfits are --outfit, or the outfits/ folder beside the
/// frames the model trained on.
///
/// "What to draw next" suggests the poses whose drawings would teach the model most (as
/// `puppet suggest`), with pictures to trace over; a drawing sent back joins a copy of the
/// model's frames in MODEL-next/frames/ (beside the model, which is only read), and the page
/// continues the model on them in the background into MODEL-next/model (`puppet train --from`).
/// "Motion" plays a BVH file on the character in a loop (as `puppet retarget`).
#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// The model folder written by `puppet train` (default: out/demo/model, from `puppet demo`).
    #[arg(long, value_name = "DIR")]
    pub model: Option<PathBuf>,
    /// The frames to offer for posing (a folder of PNG frames of the puppet's size), instead of
    /// those the model trained on.
    #[arg(long, value_name = "DIR")]
    pub frames: Option<PathBuf>,
    /// The port to listen on (0: any free port).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// The address to listen on: 127.0.0.1 keeps the editor to this machine; 0.0.0.0 opens it
    /// to the network (the editor has no login).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Another outfit the page can swap to (PNG layers + character.toml, .ora or .psd of the
    /// same body in other accessories); repeat for more. Default: each folder in the outfits/
    /// folder beside the frames the model trained on, if there is one.
    #[arg(long = "outfit", value_name = "ARTWORK")]
    pub outfits: Vec<PathBuf>,
    /// Open the page in the default web browser once the server is listening.
    #[arg(long)]
    pub open: bool,
    /// Let the page show each pose as the model's appearance stage redraws it (`puppet
    /// appearance train`), beside the render, and download those frames.
    #[arg(long)]
    pub appearance: bool,
    /// Fit an uploaded frame by the network alone. By default it is also fitted by the prior
    /// puppet ships (as `puppet fit --puppet`) and that fit pulled onto the model's manifold,
    /// and the session starts from whichever draws closer to the frame (about a second more
    /// per upload).
    #[arg(long)]
    pub no_prior: bool,
    /// Another prior than the built-in one: a `puppet prior train` run folder.
    #[arg(long, value_name = "DIR", conflicts_with = "no_prior")]
    pub prior_net: Option<PathBuf>,
    #[command(flatten)]
    pub fit: LatentFitArgs,
}

/// Runs `puppet serve` until interrupted.
pub fn run(args: ServeArgs, s: &Session) -> anyhow::Result<()> {
    let dir = match &args.model {
        Some(dir) => dir.clone(),
        None => {
            let demo = PathBuf::from(DEMO_MODEL);
            anyhow::ensure!(
                demo.is_dir(),
                "no --model given and no {DEMO_MODEL} here: run `puppet demo` first (it trains the bundled robot), or pass --model DIR"
            );
            demo
        }
    };
    let device = puppet::backend::device();
    let model = Model::load(&dir, &device)?;
    let fit = args.fit.options(&dir)?;
    let mut options = ServeOptions::new(fit).with_model_folder(&dir);
    if !args.no_prior {
        let net = puppet::prior::load_or_shipped(args.prior_net.as_deref(), &device)?;
        let zero_shot = FitOptions::for_model(&dir, DEFAULT_LATENT_STEPS, DEFAULT_VERTEX_STEPS)?;
        options = options.with_prior(UploadPrior::new(net, zero_shot));
    }
    if args.appearance {
        options = options.with_appearance(AppearanceStage::load(&dir, &model, &device)?);
    }
    let (frames, bad) = match &args.frames {
        Some(frames) => folder_frames(frames, &model, &[]).context("--frames")?,
        None => model_frames(&dir, &model)?,
    };
    for e in &bad {
        s.ui.warn(&format!("{e} (left out of the editor)"));
    }
    let offered = if frames.is_empty() {
        "the rest pose (the model's frames are not known here: pass --frames DIR to pose others)".to_string()
    } else {
        format!("{} frames", frames.len())
    };
    let explicit = !args.outfits.is_empty();
    let mut outfits = Vec::new();
    let paths = if explicit { args.outfits.clone() } else { model_outfits(&dir)? };
    for path in paths {
        let name = path
            .file_stem()
            .map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
        let dressed = artwork::load_reporting(&path, &artwork::ImportOptions::default(), &s.ui)
            .and_then(|art| dress(&model.puppet, &art, &BuildOptions::default(), &RigOptions::default(), &s.ui));
        match dressed {
            Ok(puppet) => outfits.push((name, puppet)),
            // Outfits given by hand must load; those found beside the frames are a courtesy.
            Err(e) if explicit => return Err(anyhow::Error::new(e).context(format!("--outfit {}", path.display()))),
            Err(e) => s.ui.warn(&format!("outfit {}: {e} (left out of the editor)", path.display())),
        }
    }
    let outfit_count = outfits.len();
    let app = Arc::new(App::new(model, frames, outfits, options, &device)?);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_io()
        .build()
        .context("cannot start the server's runtime")?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind((args.host, args.port))
            .await
            .with_context(|| format!("cannot listen on {}:{} (--host, --port)", args.host, args.port))?;
        let address = listener.local_addr().context("the server's address")?;
        let url = format!("http://{address}/");
        let worn = match outfit_count {
            0 => String::new(),
            n => format!(", {n} more outfits"),
        };
        s.ui.print(format!(
            "puppet editor for {} ({offered}{worn}) at {url} — Ctrl-C stops it",
            dir.display()
        ))?;
        if args.open {
            if let Err(e) = webbrowser::open(&url) {
                s.ui.warn(&format!("cannot open a web browser ({e}): open {url} yourself"));
            }
        }
        puppet::serve::serve(listener, app).await.context("the server stopped")
    })
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_model_port_and_host() {
        parses(&["serve"]);
        parses(&[
            "serve",
            "--model",
            "m",
            "--port",
            "0",
            "--host",
            "0.0.0.0",
            "--frames",
            "f",
            "--latent-steps",
            "0",
            "--outfit",
            "a",
            "--outfit",
            "b.ora",
            "--open",
            "--appearance",
        ]);
        for bad in [vec!["serve", "--port", "70000"], vec!["serve", "--host", "localhost:1"]] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
