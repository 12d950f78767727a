//! The layered deformable puppet of neural-puppet.md §3.1: one triangle mesh per layer, ordered
//! back to front, each textured by its layer image, connected to other layers at hinge joints.
//!
//! Conventions (DESIGN.md): positions are pixels of the reference frame, origin top-left, y down.
//! Triangles wind counter-clockwise *as seen on screen with y down* — i.e. their signed area
//! computed with the usual formula on (x, y) is positive. Per the paper every layer is one
//! connected component of "one mesh"; [`Puppet::vertex_offsets`] gives the global numbering.

pub mod artwork;
pub mod build;
pub mod character;
pub mod format;
pub mod joints;
pub mod layers;
pub mod limbs;
pub mod mesh;
pub mod ora;
pub mod pose_file;
pub mod psd;
pub mod rig_data;
pub mod sequence;
pub mod visibility;

use crate::picture::Picture;

/// Whether a layer is part of the articulated body or something worn (accessory-rigs.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LayerKind {
    /// A body part: deformed by the network, may be the root.
    Body,
    /// Clothing or an accessory: follows the body (accessory rigs).
    Accessory,
}

/// A 2D triangle mesh over flat slices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions in pixels, `[x, y]`.
    pub vertices: Vec<[f32; 2]>,
    /// Triangles as vertex indices, counter-clockwise (positive signed area with y down).
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Signed area of triangle `t` (positive for the winding this crate uses).
    pub fn signed_area(&self, t: [u32; 3]) -> f32 {
        let [a, b, c] = t.map(|i| self.vertices[i as usize]);
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
    }

    /// The area the triangles cover (each counted once, whatever its winding).
    pub fn area(&self) -> f32 {
        self.triangles.iter().map(|&t| self.signed_area(t).abs()).sum()
    }

    /// The smallest interior angle over all triangles, in degrees (180 for an empty mesh).
    pub fn min_angle_degrees(&self) -> f32 {
        self.triangles
            .iter()
            .flat_map(|t| {
                let p = t.map(|i| self.vertices[i as usize]);
                (0..3).map(move |k| angle_at(p[k], p[(k + 1) % 3], p[(k + 2) % 3]))
            })
            .fold(180.0, f32::min)
    }

    /// Checks the invariants every mesh in a puppet keeps: indices in range, positive finite
    /// area, finite coordinates, and every vertex used by some triangle.
    ///
    /// # Errors
    /// A description of the first broken invariant.
    pub fn check_invariants(&self) -> Result<(), String> {
        if let Some(i) = self.vertices.iter().position(|v| !v[0].is_finite() || !v[1].is_finite()) {
            return Err(format!("vertex {i} is not finite"));
        }
        let mut used = vec![false; self.vertices.len()];
        for (k, &t) in self.triangles.iter().enumerate() {
            if t.iter().any(|&i| i as usize >= self.vertices.len()) {
                return Err(format!("triangle {k} {t:?} indexes past {} vertices", self.vertices.len()));
            }
            let area = self.signed_area(t);
            // Finite coordinates can still overflow f32 in the area (3e38 apart: inf, or inf - inf).
            if !area.is_finite() {
                return Err(format!("triangle {k} {t:?} is too large (its area is {area})"));
            }
            if area <= 0.0 {
                return Err(format!("triangle {k} {t:?} is not counter-clockwise (area {area})"));
            }
            t.iter().for_each(|&i| used[i as usize] = true);
        }
        match used.iter().position(|u| !u) {
            Some(i) => Err(format!("vertex {i} is used by no triangle")),
            None => Ok(()),
        }
    }
}

/// Interior angle at `a` of triangle (a, b, c), in degrees.
fn angle_at(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> f32 {
    let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
    let cross = u[0] * v[1] - u[1] * v[0];
    let dot = u[0] * v[0] + u[1] * v[1];
    cross.abs().atan2(dot).to_degrees()
}

/// One layer of the puppet: a mesh in rest pose and the texture it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// The layer's name as the artwork gives it (e.g. `"arm_l"`).
    pub name: String,
    /// Body part or accessory.
    pub kind: LayerKind,
    /// The rest-pose mesh, in reference-frame pixels.
    pub mesh: Mesh,
    /// Texture coordinates per vertex, in [0, 1]² of `texture` (u right, v down).
    pub uvs: Vec<[f32; 2]>,
    /// The layer's image (straight alpha); colours are extended past its edge so that bilinear
    /// sampling near the boundary does not pick up the colour of transparent pixels.
    pub texture: Picture,
}

/// A vertex of one layer's mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct VertexRef {
    /// Index into [`Puppet::layers`].
    pub layer: usize,
    /// Index into that layer's `mesh.vertices`.
    pub vertex: u32,
}

/// A hinge joint (neural-puppet.md §3.1, eq. 3): two vertices of different layers that coincide
/// at rest and are pulled together during deformation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Joint {
    /// The vertex in one layer.
    pub a: VertexRef,
    /// The coinciding vertex in the other layer.
    pub b: VertexRef,
}

/// A layered puppet: layers back to front, joints, and the reference frame size.
#[derive(Clone, Debug, PartialEq)]
pub struct Puppet {
    /// Width of the reference frame in pixels.
    pub width: u32,
    /// Height of the reference frame in pixels.
    pub height: u32,
    /// Layers in depth order, back (index 0) to front.
    pub layers: Vec<Layer>,
    /// Index of the root body layer.
    pub root: usize,
    /// Hinge joints between layers.
    pub joints: Vec<Joint>,
    /// How the accessory layers follow the body (accessory-rigs.md); `None` without accessories
    /// or for a puppet built before rigs existed.
    pub rig: Option<rig_data::RigData>,
}

impl Puppet {
    /// Index of each layer's first vertex in the global numbering (paper: "one mesh"), plus the
    /// total vertex count as the last entry (`layers.len() + 1` entries).
    pub fn vertex_offsets(&self) -> Vec<usize> {
        let mut offsets = Vec::with_capacity(self.layers.len() + 1);
        let mut total = 0;
        for layer in &self.layers {
            offsets.push(total);
            total += layer.mesh.vertices.len();
        }
        offsets.push(total);
        offsets
    }

    /// All rest vertices in the global numbering.
    pub fn rest_vertices(&self) -> Vec<[f32; 2]> {
        self.layers.iter().flat_map(|l| l.mesh.vertices.iter().copied()).collect()
    }

    /// Total number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.layers.iter().map(|l| l.mesh.vertices.len()).sum()
    }

    /// Global indices of the vertices a pose sets freely: every vertex, or with an accessory rig
    /// the body layers' (the rig places the accessories on them).
    pub fn free_vertices(&self) -> Vec<usize> {
        let offsets = self.vertex_offsets();
        self.layers
            .iter()
            .enumerate()
            .filter(|(_, l)| self.rig.is_none() || l.kind == LayerKind::Body)
            .flat_map(|(k, _)| offsets[k]..offsets[k + 1])
            .collect()
    }

    /// Global indices of the accessory layers' vertices.
    pub fn accessory_vertices(&self) -> Vec<usize> {
        let offsets = self.vertex_offsets();
        (0..self.layers.len())
            .filter(|&l| self.layers[l].kind == LayerKind::Accessory)
            .flat_map(|l| offsets[l]..offsets[l + 1])
            .collect()
    }

    /// Global index of a layer vertex.
    pub fn global_index(&self, v: VertexRef) -> usize {
        self.layers[..v.layer].iter().map(|l| l.mesh.vertices.len()).sum::<usize>() + v.vertex as usize
    }

    /// Index of the layer called `name`.
    pub fn layer_index(&self, name: &str) -> Option<usize> {
        self.layers.iter().position(|l| l.name == name)
    }
}
