//! `puppet render <puppet> [--pose vertices.json] -o out.png`: one pose to one PNG.

use std::path::PathBuf;

use puppet::puppet::{format, pose_file::PoseFile};
use puppet::render::{render_pose, Background};

use super::Ui;

/// Render a puppet in its rest pose or a given pose, crisp or soft, to a PNG.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The puppet folder (holding puppet.json).
    pub puppet: PathBuf,
    /// A pose (vertices.json from `puppet fit`); default: the rest pose.
    #[arg(long)]
    pub pose: Option<PathBuf>,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output size WxH (default: the puppet's frame size); the pose is scaled to fit.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// SoftRas sharpness σ in px² of the output (0 = crisp).
    #[arg(long, default_value_t = 0.0)]
    pub sigma: f32,
    /// Background colour "#rrggbb" (default: transparent).
    #[arg(long)]
    pub background: Option<String>,
}

/// Parses `WxH` with both sides in 1..=8192.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let parsed = s
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if (1..=8192).contains(&w) && (1..=8192).contains(&h) => Ok((w, h)),
        _ => Err(format!("{s:?} is not a size WxH with sides from 1 to 8192 (e.g. 256x256)")),
    }
}

/// Runs `puppet render`.
pub fn run(args: RenderArgs, ui: &Ui) -> anyhow::Result<()> {
    let background = match &args.background {
        None => Background::Transparent,
        Some(text) => {
            let rgb = puppet::puppet::character::parse_color(text).map_err(|e| anyhow::anyhow!("--background: {e}"))?;
            Background::Colour(rgb.map(|c| c as f32 / 255.0))
        }
    };
    let puppet = format::load(&args.puppet)?;
    let vertices = match &args.pose {
        Some(path) => PoseFile::load(path, &puppet)?.vertices,
        None => puppet.rest_vertices(),
    };
    let (w, h) = args.size.unwrap_or((puppet.width, puppet.height));
    let (sx, sy) = (w as f32 / puppet.width as f32, h as f32 / puppet.height as f32);
    let scaled: Vec<[f32; 2]> = vertices.iter().map(|v| [v[0] * sx, v[1] * sy]).collect();
    let picture = render_pose(&puppet, &scaled, w, h, args.sigma, background)?;
    picture.save_png(&args.output)?;
    ui.say(format!("rendered {w}×{h} (σ = {} px²) → {}", args.sigma, args.output.display()));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn sizes_parse_and_bad_ones_are_explained() {
        assert_eq!(parse_size("256x128"), Ok((256, 128)));
        assert_eq!(parse_size("64X64"), Ok((64, 64)));
        for bad in ["0x5", "12", "ax3", "9000x10"] {
            assert!(parse_size(bad).unwrap_err().contains("is not a size WxH"), "{bad}");
        }
    }
}
