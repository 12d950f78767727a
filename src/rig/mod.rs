//! Accessory rigs (accessory-rigs.md, "Automated Accessory Rigs for Layered 2D Character
//! Illustrations", UIST'21): when the body layers of a layered character move or change shape,
//! every accessory layer (hair, clothes, glasses, face features) follows, so that what it hid
//! stays hidden and nothing floats off.
//!
//! [`rig_puppet`] builds the rig of a puppet at rest:
//! 1. the layer DAG ([`dag`], §3.2): which layer each accessory follows;
//! 2. pins ([`pins`], §3.3–3.4): per edge, points of the accessory on the parent's outline under
//!    it (occlusion), on a shared outline (coincident, overlap) or at one point;
//! 3. the accessory is meshed again with its pins as vertices, and each pin bound to its
//!    parent's rest mesh ([`deform::bind_point`]);
//! 4. bounded biharmonic weights over the accessory's mesh, one handle per pin
//!    ([`crate::geom::bbw()`], §3.5).
//!
//! [`deform::RigMap`] then carries any body pose to the accessories (§3.5). The rig is stored in
//! the puppet ([`crate::puppet::rig_data`]); accessories have no hinge joints. [`outfit`] takes
//! accessories off and puts others on the same body.

pub mod bridge;
pub mod dag;
pub mod deform;
pub mod mask;
pub mod outfit;
pub mod pins;
pub mod preview;

use crate::error::{Error, Result};
use crate::geom::bbw::{bbw, BbwOptions};
use crate::geom::{component_labels, triangle_edges};
use crate::progress::Progress;
use crate::puppet::artwork::Artwork;
use crate::puppet::build::{build, BuildOptions};
use crate::puppet::mesh::{mesh_alpha, MeshOptions};
use crate::puppet::rig_data::{AccessoryRig, Constraint, RigData, RigOverrides, RigPin, Skinning, RIG_VERSION};
use crate::puppet::{LayerKind, Mesh, Puppet};
use dag::{layer_dag, topological_order, DagOptions};
use deform::bind_point;
use mask::Mask;
use pins::{pin_sites, PinContext, PinOptions, PinSite};

/// How a rig is built.
#[derive(Clone, Debug, PartialEq)]
pub struct RigOptions {
    /// How parents are chosen.
    pub dag: DagOptions,
    /// How densely pins are placed; `None`: [`PinOptions::for_size`] of the canvas (and the
    /// override's `pin_spacing`).
    pub pins: Option<PinOptions>,
    /// Pixels count as covered above this alpha.
    pub alpha_threshold: f32,
    /// Weights below this are dropped (and each vertex's row renormalised), to keep the stored
    /// rig and its map sparse.
    pub weight_floor: f32,
    /// How accessories follow their pins, unless the overrides say (`[rig] skinning`).
    pub skinning: Skinning,
    /// How each accessory's bounded biharmonic weights are solved.
    pub weights: BbwOptions,
    /// The weights are solved with the accessory's gaps narrower than about twice this closed
    /// ([`bridge`]), pixels; `None`: `max(width, height) / 128` of the canvas (2 px at 256²), 0:
    /// not at all. The `[rig] bridge_gaps` override wins.
    pub bridge_gaps: Option<f32>,
}

impl RigOptions {
    /// The gap-bridging radius for a `width` × `height` canvas ([`RigOptions::bridge_gaps`]).
    pub fn bridge_radius(&self, width: u32, height: u32) -> f32 {
        self.bridge_gaps.unwrap_or(width.max(height) as f32 / 128.0)
    }
}

impl Default for RigOptions {
    fn default() -> Self {
        RigOptions {
            dag: DagOptions::default(),
            pins: None,
            alpha_threshold: 0.5,
            weight_floor: 1e-3,
            // The paper's. Affine skinning follows a body that moves on its own far better, but
            // a network trained through it learns far worse (docs/results.md "Affine skinning"): a small
            // turn of a body triangle under a pin swings the whole accessory.
            skinning: Skinning::Translation,
            // The weights are stored as f32 and dropped below `weight_floor`, so the active-set
            // stopping test need not be as fine as the solver's default: thin accessories (a
            // glasses' frame), whose weights are nearly free along the stroke, spent about half
            // their iterations below 1e-6 (benches/README.md "rig" measures both).
            weights: BbwOptions::DEFAULT.with_tolerance(1e-6),
            bridge_gaps: None,
        }
    }
}

/// Builds the puppet of `artwork` and, if it has accessory layers, rigs them with the artwork's
/// `[rig]` overrides: what `puppet build` and training do with artwork.
///
/// # Errors
/// As [`build`] and [`rig_puppet`].
pub fn build_rigged(artwork: &Artwork, build_options: &BuildOptions, options: &RigOptions, progress: &dyn Progress) -> Result<Puppet> {
    let (puppet, _) = build(artwork, build_options, progress)?;
    let mesh = build_options.mesh_options(puppet.width, puppet.height);
    rig_puppet(&puppet, &artwork.rig, &mesh, options, progress)
}

/// `puppet` with its accessories rigged: meshed again with their pins as vertices, hinge joints
/// to accessories removed, and [`Puppet::rig`] set. A puppet without accessories comes back
/// unchanged.
///
/// # Errors
/// As [`layer_dag`]; [`Error::Layer`]-style errors naming an accessory that cannot be meshed or
/// whose pins all fall outside its mesh.
pub fn rig_puppet(
    puppet: &Puppet,
    overrides: &RigOverrides,
    mesh_options: &MeshOptions,
    options: &RigOptions,
    progress: &dyn Progress,
) -> Result<Puppet> {
    if puppet.layers.iter().all(|l| l.kind == LayerKind::Body) {
        return Ok(puppet.clone());
    }
    let masks: Vec<Mask> = puppet.layers.iter().map(|l| Mask::of_layer(l, options.alpha_threshold)).collect();
    let edges = layer_dag(puppet, &masks, overrides, &options.dag, progress)?;
    let order = topological_order(puppet, &edges)?;
    overrides.check()?;
    let mut pin_options = options.pins.unwrap_or_else(|| PinOptions::for_size(puppet.width, puppet.height));
    pin_options.spacing = overrides.pin_spacing.unwrap_or(pin_options.spacing);
    pin_options.separation = overrides.pin_separation.unwrap_or(pin_options.separation);
    let bridge_radius = overrides
        .bridge_gaps
        .unwrap_or_else(|| options.bridge_radius(puppet.width, puppet.height));
    let mut body_part: Vec<usize> = (0..puppet.layers.len()).collect();
    for &child in &order {
        if let Some(e) = edges.iter().find(|e| e.child == child) {
            body_part[child] = body_part[e.parent];
        }
    }
    let is_body = |l: usize| puppet.layers[l].kind == LayerKind::Body;
    let adjacent: Vec<[usize; 2]> = puppet
        .joints
        .iter()
        .filter(|j| is_body(j.a.layer) && is_body(j.b.layer))
        .map(|j| [j.a.layer, j.b.layer])
        .collect();
    let mut out = puppet.clone();
    out.joints.retain(|j| is_body(j.a.layer) && is_body(j.b.layer));
    let cx = PinContext {
        puppet,
        masks: &masks,
        body_part: &body_part,
        adjacent: &adjacent,
    };
    progress.stage("rigging", order.len() as u64);
    let mut accessories = Vec::with_capacity(order.len());
    for &child in &order {
        let child_edges: Vec<_> = edges.iter().filter(|e| e.child == child).collect();
        let sites = pin_sites(&cx, child, &child_edges, overrides, &pin_options);
        accessories.push(rig_accessory(&mut out, child, &sites, mesh_options, options, bridge_radius)?);
        progress.advance(1);
    }
    out.rig = Some(RigData {
        version: RIG_VERSION,
        edges,
        accessories,
        skinning: overrides.skinning.unwrap_or(options.skinning),
    });
    Ok(out)
}

/// Meshes accessory `child` of `puppet` with its pin `sites` as vertices (those the mesh can
/// hold), binds each pin to its parent, adds a pin to every piece of the mesh without one, and
/// computes the weights.
fn rig_accessory(
    puppet: &mut Puppet,
    child: usize,
    sites: &[PinSite],
    mesh_options: &MeshOptions,
    options: &RigOptions,
    bridge_radius: f32,
) -> Result<AccessoryRig> {
    let name = puppet.layers[child].name.clone();
    let layer_error = |problem: String| Error::setting(format!("rig: layer {name:?}"), problem, "an accessory the rig can pin");
    let (w, h) = (puppet.width, puppet.height);
    let alpha: Vec<f32> = puppet.layers[child].texture.pixels.iter().map(|p| p[3]).collect();
    let plain = mesh_alpha(&alpha, w, h, &[], mesh_options).map_err(|e| layer_error(e.to_string()))?;
    // Sites in a piece the mesher drops (a speck under 2 px²) cannot be vertices.
    let kept: Vec<PinSite> = sites.iter().copied().filter(|s| inside_mesh(&plain.mesh, s.at)).collect();
    if kept.is_empty() {
        return Err(layer_error(format!("all {} of its pins fall outside its mesh", sites.len())));
    }
    let points: Vec<[f32; 2]> = kept.iter().map(|s| s.at).collect();
    let meshed = mesh_alpha(&alpha, w, h, &points, mesh_options).map_err(|e| layer_error(e.to_string()))?;
    let mut pins: Vec<RigPin> = Vec::with_capacity(kept.len());
    for (site, &vertex) in kept.iter().zip(&meshed.required) {
        if pins.iter().any(|p| p.vertex == vertex) {
            continue;
        }
        let (triangle, weights) = bind_point(&puppet.layers[site.parent].mesh, site.at);
        pins.push(RigPin {
            vertex,
            parent: site.parent,
            triangle,
            weights,
            constraint: site.constraint,
        });
    }
    // A piece of the mesh no pin reached (the mesher's pieces can differ from the mask's) follows
    // the first parent at its vertex nearest its centroid.
    let first_parent = kept[0].parent;
    for piece in mesh_pieces(&meshed.mesh) {
        if !piece.iter().any(|&v| pins.iter().any(|p| p.vertex == v)) {
            let n = piece.len() as f32;
            let c = piece.iter().fold([0.0f32; 2], |s, &v| {
                let p = meshed.mesh.vertices[v as usize];
                [s[0] + p[0] / n, s[1] + p[1] / n]
            });
            let vertex = *piece
                .iter()
                .min_by(|&&a, &&b| dist(meshed.mesh.vertices[a as usize], c).total_cmp(&dist(meshed.mesh.vertices[b as usize], c)))
                .expect("a piece has vertices");
            let (triangle, weights) = bind_point(&puppet.layers[first_parent].mesh, meshed.mesh.vertices[vertex as usize]);
            pins.push(RigPin {
                vertex,
                parent: first_parent,
                triangle,
                weights,
                constraint: Constraint::Point,
            });
        }
    }
    let handles: Vec<u32> = pins.iter().map(|p| p.vertex).collect();
    // One handle weighs 1 everywhere, however the layer is meshed: nothing to bridge.
    let bridged = (handles.len() > 1)
        .then(|| bridge::closed_alpha(&alpha, w, h, options.alpha_threshold, bridge_radius))
        .flatten()
        .and_then(|closed| bridged_weights(&meshed.mesh, &handles, &closed, (w, h), mesh_options, options));
    let dense = bridged
        .unwrap_or_else(|| solve_weights(&meshed.mesh, &handles, options))
        .map_err(|e| Error::Solver {
            what: format!("rig: layer {name:?}: weights"),
            err: Box::new(e),
        })?;
    let weights = sparse_rows(&dense, handles.len(), options.weight_floor);
    let layer = &mut puppet.layers[child];
    layer.uvs = meshed.mesh.vertices.iter().map(|v| [v[0] / w as f32, v[1] / h as f32]).collect();
    layer.mesh = meshed.mesh;
    Ok(AccessoryRig {
        layer: child,
        pins,
        weights,
    })
}

/// The bounded biharmonic weights (`V × H`, row-major) of `mesh` with a handle at each of
/// `handles`.
fn solve_weights(mesh: &Mesh, handles: &[u32], options: &RigOptions) -> Result<Vec<f64>, crate::geom::BbwError> {
    let positions: Vec<[f64; 2]> = mesh.vertices.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
    Ok(bbw(&positions, &mesh.triangles, handles, &options.weights)?.weights)
}

/// The weights of `mesh` solved on the layer with its gaps closed (`closed`, its alpha; see
/// [`bridge`]), or `None` where that layer cannot carry them: it does not mesh with the pins as
/// vertices, two pins fall on one of its vertices, or a piece of it has no pin (the closing can
/// give a speck the mesher dropped the area to be meshed).
fn bridged_weights(
    mesh: &Mesh,
    handles: &[u32],
    closed: &[f32],
    (w, h): (u32, u32),
    mesh_options: &MeshOptions,
    options: &RigOptions,
) -> Option<Result<Vec<f64>, crate::geom::BbwError>> {
    let points: Vec<[f32; 2]> = handles.iter().map(|&v| mesh.vertices[v as usize]).collect();
    let wide = mesh_alpha(closed, w, h, &points, mesh_options).ok()?;
    let mut distinct = wide.required.clone();
    distinct.sort_unstable();
    distinct.dedup();
    let pinned = |piece: &Vec<u32>| piece.iter().any(|v| distinct.binary_search(v).is_ok());
    if distinct.len() != handles.len() || !mesh_pieces(&wide.mesh).iter().all(pinned) {
        return None;
    }
    Some(solve_weights(&wide.mesh, &wide.required, options).map(|weights| bridge::read_back(mesh, handles, &wide.mesh, &weights)))
}

/// Dense `V × H` weights as sparse rows: entries below `floor` dropped, each row renormalised
/// to sum to 1 (a row that would be empty keeps its largest entry).
fn sparse_rows(dense: &[f64], handles: usize, floor: f32) -> Vec<Vec<(u32, f32)>> {
    dense
        .chunks_exact(handles.max(1))
        .map(|row| {
            let mut kept: Vec<(u32, f32)> = row
                .iter()
                .enumerate()
                .filter(|(_, &w)| w as f32 >= floor)
                .map(|(j, &w)| (j as u32, w as f32))
                .collect();
            if kept.is_empty() {
                let (j, &w) = row
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.total_cmp(b.1))
                    .expect("a row has an entry");
                kept.push((j as u32, w.max(1.0) as f32));
            }
            let sum: f32 = kept.iter().map(|&(_, w)| w).sum();
            kept.iter_mut().for_each(|e| e.1 /= sum);
            kept
        })
        .collect()
}

/// Whether `p` lies in a triangle of `mesh`.
fn inside_mesh(mesh: &Mesh, p: [f32; 2]) -> bool {
    mesh.triangles
        .iter()
        .any(|t| crate::geom::triangle::contains(t.map(|i| mesh.vertices[i as usize]), p, 1e-5))
}

/// The vertex sets of the mesh's connected pieces (through shared triangles).
fn mesh_pieces(mesh: &Mesh) -> Vec<Vec<u32>> {
    let (labels, count) = component_labels(mesh.vertices.len(), triangle_edges(&mesh.triangles));
    let mut pieces = vec![Vec::new(); count];
    for (v, &l) in labels.iter().enumerate() {
        pieces[l].push(v as u32);
    }
    pieces
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use crate::puppet::artwork::ArtLayer;
    use crate::puppet::rig_data::EdgeOverride;
    use crate::test_util::texture;
    use deform::RigMap;

    const W: u32 = 64;

    /// Which pixels (centres) a fixture layer covers.
    type Inside = Box<dyn Fn(f32, f32) -> bool>;

    /// A character on a 64×64 canvas from (name, kind, inside) layers, back to front.
    fn artwork(layers: Vec<(&str, LayerKind, Inside)>, rig: RigOverrides) -> Artwork {
        Artwork {
            source: "fixture".into(),
            name: "fixture".into(),
            layers: layers
                .into_iter()
                .enumerate()
                .map(|(k, (name, kind, inside))| ArtLayer {
                    name: name.into(),
                    kind,
                    picture: texture(W, W, inside, move |_, _| [0.2 * k as f32, 0.5, 0.8]),
                })
                .collect(),
            root: 0,
            joint_pairs: None,
            rig,
        }
    }

    fn rigged(art: &Artwork) -> Result<Puppet> {
        build_rigged(art, &BuildOptions::default(), &RigOptions::default(), &Silent)
    }

    fn disc(cx: f32, cy: f32, r: f32) -> Inside {
        Box::new(move |x, y| (x - cx).hypot(y - cy) < r)
    }

    fn rect(x0: f32, y0: f32, x1: f32, y1: f32) -> Inside {
        Box::new(move |x, y| (x0..x1).contains(&x) && (y0..y1).contains(&y))
    }

    const B: LayerKind = LayerKind::Body;
    const A: LayerKind = LayerKind::Accessory;

    #[test]
    fn a_ring_on_a_disc_is_pinned_by_occlusion_and_follows_it_exactly_when_it_translates() {
        let art = artwork(
            vec![
                ("disc", B, disc(32.0, 32.0, 16.0)),
                (
                    "ring",
                    A,
                    Box::new(|x: f32, y: f32| ((x - 32.0).hypot(y - 32.0) - 16.0).abs() < 4.0),
                ),
            ],
            RigOverrides::default(),
        );
        let puppet = rigged(&art).unwrap();
        let rig = puppet.rig.as_ref().unwrap();
        rig.check(&puppet).unwrap();
        let ring = &rig.accessories[0];
        assert!(
            ring.pins.len() >= 10 && ring.pins.iter().all(|p| p.constraint == Constraint::Occlusion),
            "{:?}",
            ring.pins.len()
        );
        // Partition of unity: a constant displacement of the body moves every accessory vertex
        // by exactly that much.
        let mut pose: Vec<[f32; 2]> = puppet.rest_vertices().iter().map(|p| [p[0] + 3.5, p[1] - 2.0]).collect();
        RigMap::new(&puppet, rig).apply(&mut pose);
        for (p, r) in pose.iter().zip(puppet.rest_vertices()) {
            assert!(
                (p[0] - r[0] - 3.5).abs() < 1e-4 && (p[1] - r[1] + 2.0).abs() < 1e-4,
                "{p:?} from {r:?}"
            );
        }
        // Widening the disc widens the ring with it: its pins stay on the disc's outline.
        let offsets = puppet.vertex_offsets();
        let mut wide = puppet.rest_vertices();
        wide[..offsets[1]].iter_mut().for_each(|p| p[0] = 32.0 + 1.25 * (p[0] - 32.0));
        RigMap::new(&puppet, rig).apply(&mut wide);
        let right = wide[offsets[1]..].iter().map(|p| p[0]).fold(f32::MIN, f32::max);
        assert!(
            right > 32.0 + 1.2 * 16.0,
            "the ring's right edge {right} should pass the wide disc's"
        );
    }

    #[test]
    fn two_rectangles_sharing_an_edge_are_pinned_along_it_and_a_button_at_a_point() {
        let art = artwork(
            vec![
                ("body", B, rect(8.0, 8.0, 56.0, 56.0)),
                ("left", A, rect(10.0, 10.0, 32.0, 50.0)),
                ("right", A, rect(32.0, 10.0, 54.0, 50.0)),
                ("button", A, rect(40.0, 28.0, 44.0, 32.0)),
            ],
            RigOverrides {
                edges: vec![EdgeOverride {
                    child: "right".into(),
                    parent: "left".into(),
                    constraint: Some(Constraint::Coincident),
                }],
                ..RigOverrides::default()
            },
        );
        let puppet = rigged(&art).unwrap();
        let rig = puppet.rig.as_ref().unwrap();
        let of = |name: &str| rig.accessories.iter().find(|a| puppet.layers[a.layer].name == name).unwrap();
        let right = of("right");
        assert!(!right.pins.is_empty() && right.pins.iter().all(|p| p.constraint == Constraint::Coincident));
        let mesh = &puppet.layers[right.layer].mesh;
        assert!(
            right.pins.iter().all(|p| mesh.vertices[p.vertex as usize][0] < 32.0 + 5.5),
            "pins within 5 px of the shared edge x = 32"
        );
        // The button rests on the right panel (in front of the body, behind the button): no
        // outline is shared, so one point pin.
        let button = of("button");
        assert_eq!(button.pins.len(), 1);
        assert_eq!(button.pins[0].constraint, Constraint::Point);
        assert_eq!(puppet.layers[button.pins[0].parent].name, "right");
    }

    #[test]
    fn a_speckled_layer_gets_a_pin_on_every_speck_and_stays_solvable() {
        let specks: Inside = Box::new(|x: f32, y: f32| {
            let (i, j) = ((x / 6.0).floor(), (y / 6.0).floor());
            (2.0..9.0).contains(&i) && (2.0..9.0).contains(&j) && (x - 6.0 * i - 3.0).hypot(y - 6.0 * j - 3.0) < 1.6
        });
        let art = artwork(
            vec![("face", B, disc(32.0, 32.0, 26.0)), ("freckles", A, specks)],
            RigOverrides::default(),
        );
        let puppet = rigged(&art).unwrap();
        let rig = puppet.rig.as_ref().unwrap();
        rig.check(&puppet).unwrap();
        let pieces = mesh_pieces(&puppet.layers[1].mesh);
        assert!(pieces.len() >= 40, "{} pieces", pieces.len());
        let pinned = rig.accessories[0].pins.iter().map(|p| p.vertex).collect::<Vec<_>>();
        assert!(pieces.iter().all(|piece| piece.iter().any(|v| pinned.contains(v))));
    }

    #[test]
    fn bad_overrides_and_an_empty_accessory_are_errors_naming_the_layer() {
        let base = |rig| {
            artwork(
                vec![("body", B, rect(8.0, 8.0, 56.0, 56.0)), ("shirt", A, rect(10.0, 10.0, 50.0, 40.0))],
                rig,
            )
        };
        let edge = |child: &str, parent: &str| EdgeOverride {
            child: child.into(),
            parent: parent.into(),
            constraint: None,
        };
        let missing = base(RigOverrides {
            edges: vec![edge("shirt", "cape")],
            ..RigOverrides::default()
        });
        assert!(rigged(&missing).unwrap_err().to_string().contains("\"cape\""));
        let body_child = base(RigOverrides {
            edges: vec![edge("body", "shirt")],
            ..RigOverrides::default()
        });
        assert!(rigged(&body_child).unwrap_err().to_string().contains("\"body\""));
        let empty = artwork(
            vec![("body", B, rect(8.0, 8.0, 56.0, 56.0)), ("ghost", A, Box::new(|_, _| false))],
            RigOverrides::default(),
        );
        // Building refuses the empty layer before the rig sees it, naming it.
        assert!(rigged(&empty).unwrap_err().to_string().contains("ghost"));
    }

    #[test]
    fn overrides_survive_a_rebuild() {
        let art = artwork(
            vec![
                ("body", B, rect(8.0, 8.0, 56.0, 56.0)),
                ("head", B, disc(32.0, 12.0, 8.0)),
                ("scarf", A, rect(20.0, 14.0, 44.0, 22.0)),
            ],
            RigOverrides {
                edges: vec![EdgeOverride {
                    child: "scarf".into(),
                    parent: "head".into(),
                    constraint: Some(Constraint::Point),
                }],
                ..RigOverrides::default()
            },
        );
        let first = rigged(&art).unwrap();
        let second = rigged(&art).unwrap();
        assert_eq!(first.rig, second.rig, "rigging is deterministic");
        let edge = &first.rig.as_ref().unwrap().edges[0];
        assert_eq!(
            (first.layers[edge.parent].name.as_str(), edge.constraints.as_slice()),
            ("head", &[Constraint::Point][..])
        );
    }
}
