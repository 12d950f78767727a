//! `puppet render <puppet> [--pose vertices.json] -o out.png`: one pose to one PNG.

use std::path::PathBuf;

use puppet::puppet::{format, pose_file::PoseFile};
use puppet::render::{render_pose, Background};

use super::args::{parse_background, parse_size};
use super::Session;

/// Render a pose of a puppet (default: its rest pose) to a PNG through the soft rasterizer.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The puppet folder (puppet.json).
    pub puppet: PathBuf,
    /// Vertex positions to render (a *_vertices.json written by fit, pose or inbetween).
    #[arg(long, value_name = "FILE")]
    pub pose: Option<PathBuf>,
    /// The PNG to write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output size WxH (default: the puppet's); the pose is scaled with it.
    #[arg(long, value_parser = parse_size, value_name = "WxH")]
    pub size: Option<(u32, u32)>,
    /// Soft-rasterizer σ in px² (0 = crisp).
    #[arg(long, default_value_t = 0.0)]
    pub sigma: f32,
    /// What the picture is drawn on: `transparent`, or an opaque colour #RRGGBB.
    #[arg(long, default_value = "transparent", value_parser = parse_background, value_name = "transparent|#RRGGBB")]
    pub background: Background,
}

/// Runs `puppet render`.
pub fn run(args: RenderArgs, s: &Session) -> anyhow::Result<()> {
    s.outputs.claim(&args.output)?;
    let puppet = format::load(&args.puppet)?;
    let vertices = match &args.pose {
        Some(path) => PoseFile::load(path, &puppet)?.vertices,
        None => puppet.rest_vertices(),
    };
    let (w, h) = args.size.unwrap_or((puppet.width, puppet.height));
    let (sx, sy) = (w as f32 / puppet.width as f32, h as f32 / puppet.height as f32);
    let scaled: Vec<[f32; 2]> = vertices.iter().map(|v| [v[0] * sx, v[1] * sy]).collect();
    let picture = render_pose(&puppet, &scaled, w, h, args.sigma, args.background)?;
    s.save_png(&args.output, &picture)?;
    s.ui.say(format!("rendered {w}×{h} (σ = {} px²) → {}", args.sigma, args.output.display()))
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_size_sigma_and_background() {
        parses(&[
            "render",
            "p",
            "-o",
            "x.png",
            "--size",
            "64x32",
            "--sigma",
            "1",
            "--background",
            "#ffffff",
        ]);
        for bad in [["--size", "0x3"], ["--background", "white"]] {
            let args = ["puppet", "render", "p", "-o", "x.png", bad[0], bad[1]];
            assert!(clap::Parser::try_parse_from(args).map(|_: crate::cli::Cli| ()).is_err(), "{bad:?}");
        }
    }
}
