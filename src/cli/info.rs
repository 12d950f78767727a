//! `puppet info <dir>`: what a puppet holds — layers, sizes, mesh quality, joints — or, for a
//! trained model folder, its network, training and split, then its puppet.

use std::path::PathBuf;

use puppet::model::ModelFolder;
use puppet::puppet::{format, Puppet};
use puppet::train::checkpoint;
use puppet::train::trainer::SplitRecord;

use super::Session;

/// Show what a puppet folder (or a trained model folder) holds.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// A puppet folder (puppet.json), or a model folder written by `puppet train`.
    pub folder: PathBuf,
}

/// Runs `puppet info`.
pub fn run(args: InfoArgs, s: &Session) -> anyhow::Result<()> {
    let puppet_dir = if args.folder.join(ModelFolder::NET).is_file() {
        let folder = ModelFolder::open(&args.folder)?;
        model_lines(&folder, s)?;
        folder.puppet()
    } else {
        args.folder.clone()
    };
    let puppet = format::load(&puppet_dir)?;
    for line in puppet_lines(&puppet) {
        s.ui.print(line)?;
    }
    Ok(())
}

fn model_lines(folder: &ModelFolder, s: &Session) -> anyhow::Result<()> {
    let net = puppet::user_file::read_text(&folder.net(), puppet::user_file::CONFIG)?;
    let config: serde_json::Value = serde_json::from_str(&net).unwrap_or_default();
    let field = |k: &str| config.get(k).map_or("?".to_string(), |v| v.to_string());
    s.ui.print(format!(
        "model {}: input {}², latent {}, {} vertices",
        folder.dir().display(),
        field("input_size"),
        field("latent"),
        field("vertices")
    ))?;
    if let Some(dir) = checkpoint::latest(folder.dir())? {
        let c = checkpoint::load(&dir)?;
        let planned = c
            .state
            .config
            .get("train")
            .and_then(|t| t.get("steps"))
            .map_or("?".to_string(), |v| v.to_string());
        s.ui.print(format!("trained {} of {planned} steps ({:.0} s)", c.state.step, c.state.elapsed))?;
    }
    if let Some(split) = SplitRecord::load(folder.dir())? {
        s.ui.print(format!(
            "frames: {} trained, {} held out ({}), from {}",
            split.train.len(),
            split.test.len(),
            split.test.join(", "),
            split.frames.display()
        ))?;
    }
    Ok(())
}

fn puppet_lines(puppet: &Puppet) -> Vec<String> {
    let mut lines = vec![
        format!(
            "puppet {}×{} px, root layer {:?}",
            puppet.width, puppet.height, puppet.layers[puppet.root].name
        ),
        format!(
            "{:<3} {:<20} {:<9} {:>8} {:>9} {:>9}",
            "#", "layer", "kind", "vertices", "triangles", "min angle"
        ),
    ];
    for (i, layer) in puppet.layers.iter().enumerate() {
        let kind = format!("{:?}", layer.kind).to_lowercase();
        lines.push(format!(
            "{i:<3} {:<20} {kind:<9} {:>8} {:>9} {:>8.1}°",
            layer.name,
            layer.mesh.vertices.len(),
            layer.mesh.triangles.len(),
            layer.mesh.min_angle_degrees()
        ));
    }
    lines.push(format!("joints ({}):", puppet.joints.len()));
    for joint in &puppet.joints {
        let p = puppet.layers[joint.a.layer].mesh.vertices[joint.a.vertex as usize];
        lines.push(format!(
            "  {} ↔ {} at ({:.1}, {:.1})",
            puppet.layers[joint.a.layer].name, puppet.layers[joint.b.layer].name, p[0], p[1]
        ));
    }
    let triangles: usize = puppet.layers.iter().map(|l| l.mesh.triangles.len()).sum();
    let min_angle = puppet.layers.iter().map(|l| l.mesh.min_angle_degrees()).fold(180.0, f32::min);
    lines.push(format!(
        "total: {} vertices, {triangles} triangles, min angle {min_angle:.1}°",
        puppet.vertex_count()
    ));
    lines
}

#[cfg(test)]
mod tests {
    use crate::cli::tests::parses;

    #[test]
    fn parses_one_folder() {
        parses(&["info", "runs/x"]);
        assert!(clap::Parser::try_parse_from(["puppet", "info"])
            .map(|_: crate::cli::Cli| ())
            .is_err());
    }
}
