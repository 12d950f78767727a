//! Ground truth of a synthetic sequence (issue 4 item 4), stored as `truth.json`: for every
//! frame and part, the map from rest-frame pixels to frame pixels — the part's rest placement
//! inverted, its ARAP deformation field (a grid, interpolated linearly in its triangles, see
//! [`Grid::map`]) and its rigid placement in the frame — so the true position of any rest point,
//! in particular every template vertex of a puppet built from the template, can be computed
//! ([`true_positions`]).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::deformation::Grid;
use super::pose::Motion;
use crate::error::{Error, Result};
use crate::geom::similarity::Similarity;
use crate::puppet::Puppet;
use crate::user_file;

/// The ground-truth file a synthetic sequence carries beside its frames.
pub const TRUTH_FILE: &str = "truth.json";

/// The truth.json schema version this build writes and reads.
pub const TRUTH_VERSION: u32 = 1;

/// Everything known about a generated sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Truth {
    /// Schema version, [`TRUTH_VERSION`].
    pub version: u32,
    /// Character name (`synth-<seed>`), also the template's name.
    pub name: String,
    /// The seed.
    pub seed: u64,
    /// The motion.
    pub motion: Motion,
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// σ of the ARAP handle offsets as a fraction of max(width, height) (0: rigid parts).
    pub deform_sigma: f32,
    /// Line wobble amplitude, pixels.
    pub wobble: f32,
    /// Parts back to front, as the template's layers.
    pub parts: Vec<PartTruth>,
    /// One entry per frame.
    pub frames: Vec<FrameTruth>,
    /// Where frames sit when they were written as a sprite sheet instead of separate files.
    pub sheet: Option<SheetLayout>,
}

/// What does not change over the sequence for one part.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartTruth {
    /// Layer name in template/character.toml.
    pub name: String,
    /// The parent part's name (`None` for the root).
    pub parent: Option<String>,
    /// The part's colour in the label maps, `"#rrggbb"`.
    pub label: String,
    /// Part local frame → rest-frame (template) pixels.
    pub rest: Similarity,
    /// The deformation grid, local units.
    pub grid: Grid,
}

/// One frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameTruth {
    /// The frame image, relative to the sequence folder.
    pub file: String,
    /// The label map, relative to the sequence folder.
    pub labels: String,
    /// One entry per part, in [`Truth::parts`] order.
    pub parts: Vec<PartFrame>,
}

/// One part in one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartFrame {
    /// Part local frame → frame pixels (rigid skeleton placement, global scale included).
    pub world: Similarity,
    /// Deformed grid vertices in local units (`None`: undeformed).
    pub deformed: Option<Vec<[f32; 2]>>,
}

/// A sprite sheet's cell layout: frame `k` is the cell at column `k % columns`, row
/// `k / columns`, each `width × height`; frame pixel (x, y) is sheet pixel
/// (x + column·width, y + row·height).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SheetLayout {
    /// The sheet image.
    pub file: String,
    /// The label sheet.
    pub labels: String,
    /// Cells per row.
    pub columns: u32,
    /// Rows of cells.
    pub rows: u32,
}

impl Truth {
    /// Where rest-frame point `p` of part `part` is in frame `frame`.
    ///
    /// # Panics
    /// If `frame` or `part` is out of range (a caller bug; [`true_positions`] checks).
    pub fn map_point(&self, frame: usize, part: usize, p: [f32; 2]) -> [f32; 2] {
        let info = &self.parts[part];
        let placed = &self.frames[frame].parts[part];
        let local = info.rest.inverse().apply(p);
        let moved = match &placed.deformed {
            Some(d) => info.grid.map(d, local),
            None => local,
        };
        placed.world.apply(moved)
    }

    /// Index of the frame whose image file is named `name` (its file name, without folders).
    pub fn frame_named(&self, name: &str) -> Option<usize> {
        self.frames
            .iter()
            .position(|f| Path::new(&f.file).file_name().is_some_and(|n| n == name))
    }

    /// The `truth.json` of the sequence at `root`, if it has one.
    ///
    /// # Errors
    /// As [`Truth::load`].
    pub fn for_sequence(root: &Path) -> Result<Option<Self>> {
        let path = root.join(TRUTH_FILE);
        if path.is_file() {
            Self::load(&path).map(Some)
        } else {
            Ok(None)
        }
    }

    /// Index of the part called `name`.
    pub fn part_index(&self, name: &str) -> Option<usize> {
        self.parts.iter().position(|p| p.name == name)
    }

    /// Reads and checks a truth.json.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable; [`Error::Limit`] if larger than [`user_file::DATA`]; as
    /// [`Truth::parse`] for its contents.
    pub fn load(path: &Path) -> Result<Self> {
        Self::parse(&user_file::read_bytes(path, user_file::DATA)?, path)
    }

    /// Parses and checks the bytes of a truth.json; `path` only names the file in errors.
    ///
    /// # Errors
    /// [`Error::Format`] for bad JSON, another schema version, or inconsistent contents (part
    /// counts, grid sizes).
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self> {
        let truth: Truth = serde_json::from_slice(bytes).map_err(|e| Error::format(path, format!("invalid truth.json: {e}")))?;
        if truth.version != TRUTH_VERSION {
            return Err(Error::format(
                path,
                format!("truth.json version {} (this build reads version {TRUTH_VERSION})", truth.version),
            ));
        }
        truth.check().map_err(|problem| Error::format(path, problem))?;
        Ok(truth)
    }

    /// Writes truth.json atomically.
    ///
    /// # Errors
    /// [`Error::Io`] naming `path`.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(self).map_err(|e| Error::format(path, format!("cannot encode truth: {e}")))?;
        crate::atomic_file::write_atomic(path, text.as_bytes())
    }

    fn check(&self) -> std::result::Result<(), String> {
        for (f, frame) in self.frames.iter().enumerate() {
            if frame.parts.len() != self.parts.len() {
                return Err(format!("frame {f}: {} parts, expected {}", frame.parts.len(), self.parts.len()));
            }
            for (p, placed) in frame.parts.iter().enumerate() {
                let n = self.parts[p].grid.vertex_count();
                if let Some(d) = &placed.deformed {
                    if d.len() != n {
                        return Err(format!(
                            "frame {f}: part {:?}: {} deformed vertices, expected {n}",
                            self.parts[p].name,
                            d.len()
                        ));
                    }
                }
                if placed.world.scale() <= 0.0 || !placed.world.scale().is_finite() {
                    return Err(format!("frame {f}: part {:?}: placement has no positive scale", self.parts[p].name));
                }
            }
        }
        Ok(())
    }
}

/// The true position in frame `frame` of every vertex of `puppet`, in its global numbering
/// ([`Puppet::vertex_offsets`]): each layer's rest vertices are mapped by the part of the same
/// name (rest placement⁻¹, then that frame's deformation and placement).
///
/// # Errors
/// [`Error::Mismatch`] if `frame` is out of range or a layer names no part of the truth (all
/// such layers are listed).
pub fn true_positions(truth: &Truth, frame: usize, puppet: &Puppet) -> Result<Vec<[f32; 2]>> {
    if frame >= truth.frames.len() {
        return Err(Error::mismatch(
            "the truth's frame count",
            truth.frames.len(),
            format!("more than {frame}"),
        ));
    }
    let mut problems = Vec::new();
    let mut out = Vec::with_capacity(puppet.vertex_count());
    for layer in &puppet.layers {
        match truth.part_index(&layer.name) {
            Some(p) => out.extend(layer.mesh.vertices.iter().map(|&v| truth.map_point(frame, p, v))),
            None => problems.push(Error::mismatch(
                format!("layer {:?}", layer.name),
                "not a part of the truth",
                format!(
                    "one of {}",
                    truth.parts.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            )),
        }
    }
    Error::collect(problems)?;
    Ok(out)
}
