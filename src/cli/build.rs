//! `puppet build <artwork> -o <dir>`: artwork → puppet.json + textures + preview.png.

use std::path::PathBuf;

use puppet::atomic_file::record;
use puppet::puppet::{artwork, build, format};
use puppet::render::preview::wireframe_preview;
use puppet::rig::{build_rigged, RigOptions};

use super::args::positive_f32;
use super::Session;

/// Build a layered puppet (meshes, UVs, textures, hinge joints) from character artwork.
#[derive(Debug, clap::Args)]
pub struct BuildArgs {
    /// The artwork: a folder with character.toml (layer PNGs or a label map), a character.toml,
    /// an OpenRaster .ora file or a Photoshop .psd file (a group named "accessories" marks
    /// accessory layers).
    pub artwork: PathBuf,
    /// Output folder for puppet.json, textures/ and preview.png.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Largest triangle area in px² (default: (max(width, height) / 32)²).
    #[arg(long, value_parser = positive_f32)]
    pub max_area: Option<f32>,
    /// Smallest triangle angle in degrees (25–33).
    #[arg(long, default_value_t = 30.0, value_parser = min_angle)]
    pub min_angle: f32,
    /// Rounds of midpoint subdivision (each splits every triangle into four).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=4))]
    pub subdivide: u32,
    /// Pixels a label-map part extends under the parts in front of it.
    #[arg(long, default_value_t = 2)]
    pub label_overlap: u32,
    /// Fewest shared opaque pixels for two layers to be joined.
    #[arg(long, default_value_t = 4)]
    pub min_overlap: usize,
}

fn min_angle(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if (25.0..=33.0).contains(&v) => Ok(v),
        _ => Err(format!(
            "{s:?}: the minimum angle must be between 25 and 33 degrees (refinement may not end above ~33)"
        )),
    }
}

/// Runs `puppet build`.
pub fn run(args: BuildArgs, s: &Session) -> anyhow::Result<()> {
    let import = artwork::ImportOptions {
        label_overlap: args.label_overlap,
        ..artwork::ImportOptions::default()
    };
    let mut opts = build::BuildOptions {
        max_area: args.max_area,
        min_angle: args.min_angle,
        subdivide: args.subdivide,
        ..Default::default()
    };
    opts.joints.min_overlap = args.min_overlap;
    s.outputs.claim_folder(&args.output)?;
    let preview_path = args.output.join("preview.png");
    s.outputs.claim(&preview_path)?;

    let art = artwork::load_reporting(&args.artwork, &import, &s.ui)?;
    let puppet = build_rigged(&art, &opts, &RigOptions::default(), &s.ui)?;
    s.ui.finish();
    format::save(&puppet, &args.output)?;
    record(&std::path::absolute(&args.output)?)?;
    let composite = art.composite();
    let scale = (768 / puppet.width.max(puppet.height)).clamp(1, 8);
    let preview = wireframe_preview(&puppet, &puppet.rest_vertices(), &composite, scale);
    preview.save_png(&preview_path)?;

    let triangles: usize = puppet.layers.iter().map(|l| l.mesh.triangles.len()).sum();
    let rig = puppet.rig.as_ref().map_or_else(String::new, |r| {
        let pins: usize = r.accessories.iter().map(|a| a.pins.len()).sum();
        format!(", {} accessories rigged with {pins} pins", r.accessories.len())
    });
    s.ui.say(format!(
        "{}: {} layers, {} vertices, {} triangles, {} joints{rig} → {}",
        art.name,
        puppet.layers.len(),
        puppet.vertex_count(),
        triangles,
        puppet.joints.len(),
        args.output.join(format::PUPPET_FILE).display()
    ))?;
    s.ui.say(format!("preview: {}", preview_path.display()))
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use crate::cli::Cli;

    #[test]
    fn parses_options_and_rejects_bad_angles() {
        assert!(Cli::try_parse_from(["puppet", "build", "art", "-o", "out", "--max-area", "9", "--subdivide", "1"]).is_ok());
        let err = Cli::try_parse_from(["puppet", "build", "art", "-o", "out", "--min-angle", "40"])
            .unwrap_err()
            .to_string();
        assert!(err.contains("between 25 and 33"), "{err}");
        assert!(Cli::try_parse_from(["puppet", "build", "art", "-o", "out", "--max-area", "-1"]).is_err());
        assert!(Cli::try_parse_from(["puppet", "build", "art"]).is_err(), "output is required");
    }
}
