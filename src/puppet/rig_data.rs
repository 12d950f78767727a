//! An accessory rig as stored with a puppet (accessory-rigs.md §3.2–3.5; `puppet.json`'s `rig`
//! section): the layer DAG's edges with their constraint, and per accessory its pins — vertices of
//! the accessory's mesh bound to a point of a parent layer's rest mesh — and the bounded
//! biharmonic weights that spread the pins' displacements over the accessory. The algorithms that
//! make and apply it are in `crate::rig`; this is plain data, checked against the puppet.

use serde::{Deserialize, Serialize};

use super::Puppet;
use crate::error::{Error, Result};

/// The rig section's schema version.
pub const RIG_VERSION: u32 = 1;

/// How a child layer follows a parent (accessory-rigs.md §3.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Constraint {
    /// Pins along the parent's outline where it passes under the child: what the child hid stays
    /// hidden.
    Occlusion,
    /// One pin: the child moves rigidly with a point of the parent.
    Point,
    /// Pins along the child's outline where it runs within a few pixels of the parent's.
    Coincident,
    /// Pins along the outline of the region the two layers share.
    Overlap,
}

impl Constraint {
    /// Every constraint, in a fixed order.
    pub const ALL: [Constraint; 4] = [
        Constraint::Occlusion,
        Constraint::Point,
        Constraint::Coincident,
        Constraint::Overlap,
    ];

    /// The constraint's name as `character.toml` and `puppet.json` spell it.
    pub fn name(self) -> &'static str {
        match self {
            Constraint::Occlusion => "occlusion",
            Constraint::Point => "point",
            Constraint::Coincident => "coincident",
            Constraint::Overlap => "overlap",
        }
    }
}

/// How an accessory vertex follows its pins (`v` its rest position, `w_j` its weights).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Skinning {
    /// By their translations, `v + Σ_j w_j d_j` (accessory-rigs.md §3.5): a turn, a stretch or
    /// a squash of the parent reaches the accessory only as far as the pins' translations differ.
    /// Rigs stored without a skinning are read as this.
    #[default]
    Translation,
    /// By each pin's parent triangle carried on to `v`, `Σ_j w_j A_j(v)` with `A_j` the affine
    /// map of pin `j`'s parent triangle from rest to pose: any affine motion of the parent
    /// (turn, stretch, squash) moves the accessory exactly with it. Still linear in the body's
    /// vertices, with the same terms per pin.
    Affine,
}

/// Who chose an edge or a constraint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Origin {
    /// The automatic rules (§3.2, §3.4).
    Auto,
    /// A `[rig]` override in `character.toml`.
    User,
}

/// One DAG edge: `child` follows `parent` under `constraints`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigEdge {
    /// The parent layer (index into the puppet's layers).
    pub parent: usize,
    /// The child layer, an accessory.
    pub child: usize,
    /// The constraints whose pins tie them (one, or coincident + overlap).
    pub constraints: Vec<Constraint>,
    /// Who chose the edge.
    pub origin: Origin,
}

/// One pin: vertex `vertex` of the accessory follows the point of the parent's rest mesh given by
/// `triangle` and barycentric `weights` (the point may lie just outside it: a projection).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigPin {
    /// The accessory's vertex (index into its mesh).
    pub vertex: u32,
    /// The parent layer.
    pub parent: usize,
    /// The parent triangle (index into the parent's mesh).
    pub triangle: u32,
    /// Barycentric coordinates in that triangle, summing to 1.
    pub weights: [f32; 3],
    /// The constraint that placed it.
    pub constraint: Constraint,
}

/// The rig of one accessory layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccessoryRig {
    /// The accessory layer.
    pub layer: usize,
    /// Its pins (BBW handles).
    pub pins: Vec<RigPin>,
    /// Per accessory vertex, its (pin index, weight) pairs: non-negative, summing to 1.
    pub weights: Vec<Vec<(u32, f32)>>,
}

/// A puppet's accessory rig: the DAG edges and each accessory's pins and weights, accessories in
/// an order where every parent comes before its children.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigData {
    /// Schema version, [`RIG_VERSION`].
    pub version: u32,
    /// The DAG's edges.
    pub edges: Vec<RigEdge>,
    /// Per accessory, in topological order.
    pub accessories: Vec<AccessoryRig>,
    /// How accessories follow their pins.
    pub skinning: Skinning,
}

impl RigData {
    /// Checks every index against `puppet` and the order and weights against the rules above.
    ///
    /// # Errors
    /// The first problem, as a sentence naming the layer.
    pub fn check(&self, puppet: &Puppet) -> Result<(), String> {
        if self.version != RIG_VERSION {
            return Err(format!("rig version {} (this build reads version {RIG_VERSION})", self.version));
        }
        let n = puppet.layers.len();
        let name = |l: usize| {
            puppet
                .layers
                .get(l)
                .map_or_else(|| format!("#{l}"), |layer| format!("{:?}", layer.name))
        };
        for e in &self.edges {
            if e.parent >= n || e.child >= n || e.parent == e.child {
                return Err(format!("edge {} → {}: no such pair of layers", name(e.parent), name(e.child)));
            }
        }
        let mut done = vec![false; n];
        for (l, layer) in puppet.layers.iter().enumerate() {
            done[l] = layer.kind == super::LayerKind::Body;
        }
        for acc in &self.accessories {
            let Some(layer) = puppet.layers.get(acc.layer) else {
                return Err(format!("accessory #{}: no such layer", acc.layer));
            };
            let vertices = layer.mesh.vertices.len();
            if acc.weights.len() != vertices {
                return Err(format!(
                    "layer {}: {} weight rows for {vertices} vertices",
                    name(acc.layer),
                    acc.weights.len()
                ));
            }
            for pin in &acc.pins {
                let parent = puppet
                    .layers
                    .get(pin.parent)
                    .ok_or_else(|| format!("layer {}: a pin's parent #{} does not exist", name(acc.layer), pin.parent))?;
                if !done.get(pin.parent).copied().unwrap_or(false) {
                    return Err(format!(
                        "layer {}: pinned to {}, which comes later",
                        name(acc.layer),
                        name(pin.parent)
                    ));
                }
                if pin.vertex as usize >= vertices || pin.triangle as usize >= parent.mesh.triangles.len() {
                    return Err(format!("layer {}: a pin indexes past a mesh", name(acc.layer)));
                }
                if !pin.weights.iter().all(|w| w.is_finite()) || (pin.weights.iter().sum::<f32>() - 1.0).abs() > 1e-3 {
                    return Err(format!("layer {}: a pin's barycentric weights do not sum to 1", name(acc.layer)));
                }
            }
            for row in &acc.weights {
                let sum: f32 = row.iter().map(|&(_, w)| w).sum();
                let bad = row
                    .iter()
                    .any(|&(p, w)| p as usize >= acc.pins.len() || !(w.is_finite() && w >= 0.0));
                if bad || (!acc.pins.is_empty() && (sum - 1.0).abs() > 1e-3) {
                    return Err(format!(
                        "layer {}: a vertex's weights are not a partition of unity",
                        name(acc.layer)
                    ));
                }
            }
            done[acc.layer] = true;
        }
        Ok(())
    }
}

/// The `[rig]` table of `character.toml`: overrides of the automatic rig, kept across rebuilds
/// (they are read from the artwork every time the puppet is built).
///
/// ```toml
/// [rig]
/// pin_spacing = 6.0                 # pixels between pins along an outline (default: from the size)
/// pin_separation = 10.0             # several parents: no pin within 10 px of another parent's (default 0)
/// bridge_gaps = 2.0                 # weights solved with gaps under ~2×2 px closed (default: from the size; 0: off)
/// skinning = "affine"               # carry accessories by their pins' triangles (default: "translation")
///
/// [[rig.edge]]                      # a child's edges replace its automatic one; several = several parents
/// child = "hair_back"
/// parent = "head"
/// constraint = "occlusion"          # occlusion | point | coincident | overlap; omitted: the automatic rule
///
/// [[rig.pin]]                       # an extra pin: the child's point `at` follows the parent there
/// child = "bow"
/// parent = "collar"
/// at = [120.0, 88.0]
///
/// [[rig.unpin]]                     # no pin of the child within `radius` px of `at`
/// child = "hair"
/// at = [40.0, 20.0]
/// radius = 6.0
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigOverrides {
    /// Pixels between pins along an outline.
    pub pin_spacing: Option<f32>,
    /// Least distance in pixels between pins of two parents of one accessory.
    pub pin_separation: Option<f32>,
    /// Radius in pixels of the closing an accessory's weights are solved under
    /// ([`crate::rig::RigOptions::bridge_gaps`]).
    pub bridge_gaps: Option<f32>,
    /// How accessories follow their pins (default: [`crate::rig::RigOptions::skinning`]).
    pub skinning: Option<Skinning>,
    /// Edges chosen by hand.
    #[serde(default, rename = "edge")]
    pub edges: Vec<EdgeOverride>,
    /// Pins added by hand.
    #[serde(default, rename = "pin")]
    pub pins: Vec<PinOverride>,
    /// Pins removed by hand.
    #[serde(default, rename = "unpin")]
    pub unpins: Vec<UnpinOverride>,
}

impl RigOverrides {
    /// Checks the numeric settings: `pin_spacing` at least 1 px, `pin_separation` and
    /// `bridge_gaps` 0 or more (`bridge_gaps` at most 64).
    ///
    /// # Errors
    /// [`Error::Setting`] naming the first setting out of range.
    pub fn check(&self) -> Result<()> {
        let bad = |value: Option<f32>, least: f32| value.is_some_and(|v| !(v.is_finite() && v >= least));
        if bad(self.pin_spacing, 1.0) {
            return Err(Error::setting(
                "rig.pin_spacing",
                self.pin_spacing.unwrap_or_default(),
                "at least 1 pixel",
            ));
        }
        if bad(self.pin_separation, 0.0) {
            return Err(Error::setting(
                "rig.pin_separation",
                self.pin_separation.unwrap_or_default(),
                "0 pixels or more",
            ));
        }
        if bad(self.bridge_gaps, 0.0) || self.bridge_gaps.is_some_and(|r| r > MAX_BRIDGE_GAPS) {
            return Err(Error::setting(
                "rig.bridge_gaps",
                self.bridge_gaps.unwrap_or_default(),
                "0 to 64 pixels",
            ));
        }
        Ok(())
    }
}

/// The largest `[rig] bridge_gaps` accepted, pixels: a closing that wide would fill the space
/// between a character's locks of hair, not the notches in one.
const MAX_BRIDGE_GAPS: f32 = 64.0;

/// `[[rig.edge]]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EdgeOverride {
    /// The accessory.
    pub child: String,
    /// The layer it follows.
    pub parent: String,
    /// The constraint; `None`: the automatic rule for the pair.
    pub constraint: Option<Constraint>,
}

/// `[[rig.pin]]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinOverride {
    /// The accessory.
    pub child: String,
    /// The layer its point follows.
    pub parent: String,
    /// The point, canvas pixels.
    pub at: [f32; 2],
}

/// `[[rig.unpin]]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnpinOverride {
    /// The accessory.
    pub child: String,
    /// The centre of the region cleared of pins, canvas pixels.
    pub at: [f32; 2],
    /// Its radius in pixels.
    #[serde(default = "default_unpin_radius")]
    pub radius: f32,
}

fn default_unpin_radius() -> f32 {
    4.0
}
