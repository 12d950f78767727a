//! `puppet serve [--model DIR] [--port 8080] [--host 127.0.0.1]`: the web editor (issue 18) —
//! a local HTTP server with a page that poses the model's puppet by drag pins.

use std::net::IpAddr;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context as _;
use puppet::model::Model;
use puppet::progress::Progress as _;
use puppet::serve::{folder_frames, model_frames, App, ServeOptions};

use super::args::LatentFitArgs;
use super::Session;

/// Where `puppet demo` leaves its model: the editor's model when none is given.
const DEMO_MODEL: &str = "out/demo/model";

/// Serve the web editor: a page that draws the model's puppet from its meshes and textures and
/// poses it by drag pins (click the character to pin a point, drag it; right-click removes it).
/// The frames to pose are those the model trained on (from its split.json) or --frames.
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
    let fit = args.fit.options(&dir)?;
    let device = puppet::backend::device();
    let model = Model::load(&dir, &device)?;
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
    let app = Arc::new(App::new(model, frames, ServeOptions::new(fit), &device)?);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_io()
        .build()
        .context("cannot start the server's runtime")?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind((args.host, args.port))
            .await
            .with_context(|| format!("cannot listen on {}:{} (--host, --port)", args.host, args.port))?;
        let address = listener.local_addr().context("the server's address")?;
        s.ui.print(format!(
            "puppet editor for {} ({offered}) at http://{address}/ — Ctrl-C stops it",
            dir.display()
        ))?;
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
        ]);
        for bad in [vec!["serve", "--port", "70000"], vec!["serve", "--host", "localhost:1"]] {
            let args = std::iter::once("puppet").chain(bad.iter().copied());
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
