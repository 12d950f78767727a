//! Building a [`Puppet`] from [`Artwork`] (neural-puppet.md §3.1): find hinge joints on the
//! artwork, mesh every layer with its joint points as required vertices, attach textures and UVs.

use rayon::prelude::*;

use super::artwork::Artwork;
use super::joints::{find_joints, unconnected_body_layers, JointOptions, JointSite};
use super::mesh::{mesh_alpha, MeshOptions};
use super::{Joint, Layer, Puppet, VertexRef};
use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;

/// Options of `puppet build`.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Largest triangle area in px²; `None` picks `(max(width, height) / 32)²`, about 16 px²
    /// for a 128-pixel frame, so a puppet has a few hundred vertices whatever the resolution.
    pub max_area: Option<f32>,
    /// Smallest triangle angle in degrees.
    pub min_angle: f32,
    /// Rounds of midpoint subdivision after refinement (the paper's finer meshes).
    pub subdivide: u32,
    /// Largest distance in pixels a simplified boundary may stray from the traced contour;
    /// `None` picks `max(width, height) / 256`, at least 0.5 px, so outlines keep as many
    /// vertices at 640² as at 128² (a pixel-exact outline of big artwork makes tens of thousands
    /// of tiny boundary triangles).
    pub simplify_tolerance: Option<f32>,
    /// How joints are found.
    pub joints: JointOptions,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            max_area: None,
            min_angle: 30.0,
            subdivide: 0,
            simplify_tolerance: None,
            joints: JointOptions::default(),
        }
    }
}

impl BuildOptions {
    /// The mesh options for artwork of the given size.
    pub fn mesh_options(&self, width: u32, height: u32) -> MeshOptions {
        let side = width.max(height) as f32;
        let auto = (side / 32.0).powi(2);
        MeshOptions {
            alpha_threshold: self.joints.alpha_threshold,
            simplify_tolerance: self.simplify_tolerance.unwrap_or((side / 256.0).max(0.5)),
            max_area: self.max_area.unwrap_or(auto),
            min_angle: self.min_angle,
            subdivide: self.subdivide,
        }
    }
}

/// What the build found besides the puppet: joint sites and warnings for the user.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildReport {
    /// Where each joint was placed, with its overlap area.
    pub sites: Vec<JointSite>,
    /// Body layers no joint connects to the root (they will drift apart when trained).
    pub unconnected: Vec<String>,
}

/// Builds the puppet of `artwork`; body layers no joint connects to the root are reported as a
/// warning through `progress` (and in the [`BuildReport`]).
///
/// # Errors
/// [`Error::Layer`] for every layer that cannot be meshed (empty, too small — naming the layer
/// and its size), and for explicitly listed joints whose layers do not overlap.
pub fn build(artwork: &Artwork, opts: &BuildOptions, progress: &dyn Progress) -> Result<(Puppet, BuildReport)> {
    let (width, height) = artwork.size();
    let mesh_opts = opts.mesh_options(width, height);
    let (sites, missing) = find_joints(artwork, &opts.joints);
    let mut problems: Vec<Error> = missing
        .iter()
        .map(|&[a, b]| {
            Error::layer(
                &artwork.source,
                &artwork.layers[a].name,
                format!("listed joint with {:?}, but the layers do not overlap", artwork.layers[b].name),
            )
        })
        .collect();

    progress.stage("meshing", artwork.layers.len() as u64);
    let meshed: Vec<_> = artwork
        .layers
        .par_iter()
        .enumerate()
        .map(|(i, layer)| {
            // This layer's joint points, in the order of `sites`.
            let required: Vec<[f32; 2]> = sites.iter().filter(|s| s.a == i || s.b == i).map(|s| s.point).collect();
            let result = mesh_alpha(&layer.picture.alpha(), width, height, &required, &mesh_opts);
            progress.advance(1);
            result.map_err(|e| Error::layer(&artwork.source, &layer.name, e.to_string()))
        })
        .collect();

    let mut layers = Vec::with_capacity(meshed.len());
    let mut required_vertices = Vec::with_capacity(meshed.len());
    for (art, result) in artwork.layers.iter().zip(meshed) {
        match result {
            Ok(lm) => {
                if let Err(problem) = lm.mesh.check_invariants() {
                    problems.push(Error::layer(
                        &artwork.source,
                        &art.name,
                        format!("internal meshing error: {problem}"),
                    ));
                }
                let uvs = lm
                    .mesh
                    .vertices
                    .iter()
                    .map(|v| [v[0] / width as f32, v[1] / height as f32])
                    .collect();
                let texture = bleed_colours(&art.picture, 2);
                layers.push(Layer {
                    name: art.name.clone(),
                    kind: art.kind,
                    mesh: lm.mesh,
                    uvs,
                    texture,
                });
                required_vertices.push(lm.required);
            }
            Err(e) => problems.push(e),
        }
    }
    Error::collect(problems)?;

    // Each layer's required points were passed in `sites` order; walk them in the same order.
    let mut next = vec![0usize; layers.len()];
    let mut take = |layer: usize| {
        let v = required_vertices[layer][next[layer]];
        next[layer] += 1;
        VertexRef { layer, vertex: v }
    };
    let joints = sites
        .iter()
        .map(|s| Joint {
            a: take(s.a),
            b: take(s.b),
        })
        .collect();
    let unconnected = unconnected_body_layers(artwork, &sites);
    if !unconnected.is_empty() {
        progress.warn(&format!(
            "{}: no joint connects these body layers to the root {:?}: {} (they will drift apart; make them overlap or list joints in character.toml)",
            artwork.source.display(),
            artwork.layers[artwork.root].name,
            unconnected.join(", ")
        ));
    }
    let puppet = Puppet {
        width,
        height,
        layers,
        root: artwork.root,
        joints,
        rig: None,
    };
    Ok((puppet, BuildReport { sites, unconnected }))
}

/// Copies colours into fully transparent pixels up to `radius` pixels from the opaque region
/// (alpha untouched), so bilinear sampling at the boundary never mixes in the arbitrary colour
/// of transparent pixels.
fn bleed_colours(picture: &Picture, radius: u32) -> Picture {
    let (w, h) = (picture.width as usize, picture.height as usize);
    let mut out = picture.clone();
    let mut filled: Vec<bool> = picture.pixels.iter().map(|p| p[3] > 0.0).collect();
    for _ in 0..radius {
        let before = filled.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if before[i] {
                    continue;
                }
                // Copy (not average) a neighbour's colour so 8-bit textures stay exact on disk.
                let source = [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)].into_iter().find_map(|(dx, dy)| {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    let inside = nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h;
                    inside.then(|| ny as usize * w + nx as usize).filter(|&j| before[j])
                });
                if let Some(j) = source {
                    let p = out.pixels[j];
                    out.pixels[i] = [p[0], p[1], p[2], 0.0];
                    filled[i] = true;
                }
            }
        }
    }
    out
}
