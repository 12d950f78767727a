//! `puppet info <dir>`: what a puppet holds — layers, sizes, mesh quality, joints.

use std::path::PathBuf;

use puppet::puppet::format;

use super::Ui;

/// Print a puppet's layers (vertices, triangles, smallest angle), joints and totals.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The puppet folder (holding puppet.json) or the puppet.json file.
    pub puppet: PathBuf,
}

/// Runs `puppet info`.
pub fn run(args: InfoArgs, ui: &Ui) -> anyhow::Result<()> {
    let puppet = format::load(&args.puppet)?;
    ui.say(format!(
        "puppet {}×{} px, root layer {:?}",
        puppet.width, puppet.height, puppet.layers[puppet.root].name
    ));
    ui.say(format!(
        "{:<3} {:<20} {:<9} {:>8} {:>9} {:>9}",
        "#", "layer", "kind", "vertices", "triangles", "min angle"
    ));
    for (i, layer) in puppet.layers.iter().enumerate() {
        let kind = format!("{:?}", layer.kind).to_lowercase();
        ui.say(format!(
            "{i:<3} {:<20} {kind:<9} {:>8} {:>9} {:>8.1}°",
            layer.name,
            layer.mesh.vertices.len(),
            layer.mesh.triangles.len(),
            layer.mesh.min_angle_degrees()
        ));
    }
    ui.say(format!("joints ({}):", puppet.joints.len()));
    for joint in &puppet.joints {
        let p = puppet.layers[joint.a.layer].mesh.vertices[joint.a.vertex as usize];
        ui.say(format!(
            "  {} ↔ {} at ({:.1}, {:.1})",
            puppet.layers[joint.a.layer].name, puppet.layers[joint.b.layer].name, p[0], p[1]
        ));
    }
    let triangles: usize = puppet.layers.iter().map(|l| l.mesh.triangles.len()).sum();
    let min_angle = puppet.layers.iter().map(|l| l.mesh.min_angle_degrees()).fold(180.0, f32::min);
    ui.say(format!(
        "total: {} vertices, {triangles} triangles, min angle {min_angle:.1}°",
        puppet.vertex_count()
    ));
    Ok(())
}
