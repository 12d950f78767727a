//! Imported artwork as layers (the common result of every import form of [`super::artwork`]):
//! the layer and artwork types, the import's limits, and what the layered-file readers
//! ([`super::ora`], [`super::psd`]) share — placing a layer on the canvas and finishing the
//! import.

use std::path::{Path, PathBuf};

use super::character::LayeredOverrides;
use super::rig_data::RigOverrides;
use super::LayerKind;
use crate::error::{Error, Result};
use crate::picture::{ImageLimits, Picture};
use crate::progress::Progress;

/// One layer of imported artwork, full reference-frame size, straight alpha.
#[derive(Clone, Debug, PartialEq)]
pub struct ArtLayer {
    /// The layer's name as the artwork gives it.
    pub name: String,
    /// Body part or accessory.
    pub kind: LayerKind,
    /// The layer's pixels, same size as every other layer.
    pub picture: Picture,
}

/// A character's artwork: layers back → front, the root, optional joint pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct Artwork {
    /// Where it was read from (folder, `character.toml` or `.ora`), for messages.
    pub source: PathBuf,
    /// Display name.
    pub name: String,
    /// Layers back (index 0) → front.
    pub layers: Vec<ArtLayer>,
    /// Index of the root body layer.
    pub root: usize,
    /// Pairs of layer indices to join; `None` joins every overlapping pair.
    pub joint_pairs: Option<Vec<[usize; 2]>>,
    /// Overrides of the accessory rig (`character.toml`'s `[rig]`).
    pub rig: RigOverrides,
}

/// How artwork is read: how the label-map form cuts parts, and how large an import may be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportOptions {
    /// Pixels each label-map part extends under the parts in front of it (colours copied from
    /// its nearest own pixel), so parts overlap where they meet — which is where joints go —
    /// and no gap opens when a limb rotates. Holes of a part that lie entirely under parts in
    /// front of it are filled the same way.
    pub label_overlap: u32,
    /// The largest canvas (and layer image).
    pub image: ImageLimits,
    /// The most layers.
    pub max_layers: usize,
    /// The most pixels over all layers (each layer is canvas-sized in memory, 16 bytes a pixel).
    pub max_total_pixels: u64,
}

/// The default [`ImportOptions::max_layers`].
pub const DEFAULT_MAX_LAYERS: usize = 256;
/// The default [`ImportOptions::max_total_pixels`]: 64 Mpx, 1 GB of layers in memory.
pub const DEFAULT_MAX_TOTAL_PIXELS: u64 = 64 << 20;

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions {
            label_overlap: 2,
            image: ImageLimits::default(),
            max_layers: DEFAULT_MAX_LAYERS,
            max_total_pixels: DEFAULT_MAX_TOTAL_PIXELS,
        }
    }
}

impl ImportOptions {
    /// Checks that `layers` canvas-sized layers of `width` × `height` fit the limits.
    ///
    /// # Errors
    /// [`Error::Limit`] naming the limit that is exceeded.
    pub fn check(&self, layers: usize, width: u32, height: u32) -> Result<()> {
        self.image.check(width, height)?;
        if layers > self.max_layers {
            return Err(Error::limit("the layer count", layers as u64, self.max_layers as u64, "layers"));
        }
        let total = layers as u64 * u64::from(width) * u64::from(height);
        if total > self.max_total_pixels {
            return Err(Error::limit(
                format!("{layers} layers of {width}×{height}"),
                total,
                self.max_total_pixels,
                "pixels",
            ));
        }
        Ok(())
    }
}

impl Artwork {
    /// Width and height shared by every layer.
    pub fn size(&self) -> (u32, u32) {
        let p = &self.layers[0].picture;
        (p.width, p.height)
    }

    /// The layers composited back → front ("over"), straight alpha: what the reference frame
    /// looks like.
    pub fn composite(&self) -> Picture {
        let (w, h) = self.size();
        let mut out = Picture::filled(w, h, [0.0; 4]);
        for layer in &self.layers {
            for (dst, src) in out.pixels.iter_mut().zip(&layer.picture.pixels) {
                *dst = over(*src, *dst);
            }
        }
        out
    }
}

/// Straight-alpha "over": `top` composited onto `bottom`.
pub fn over(top: [f32; 4], bottom: [f32; 4]) -> [f32; 4] {
    let a = top[3] + bottom[3] * (1.0 - top[3]);
    if a <= 0.0 {
        return [0.0; 4];
    }
    let mix = |k: usize| (top[k] * top[3] + bottom[k] * bottom[3] * (1.0 - top[3])) / a;
    [mix(0), mix(1), mix(2), a]
}

/// Draws a layer image whose top-left corner sits at `offset` on a `width`×`height` canvas, its
/// alpha scaled by `opacity` (layered files store each layer at its own bounds).
pub(super) fn place(pic: &Picture, offset: [i64; 2], opacity: f32, width: u32, height: u32) -> Picture {
    let mut out = Picture::filled(width, height, [0.0; 4]);
    for y in 0..pic.height as i64 {
        for x in 0..pic.width as i64 {
            // Saturating: an offset far outside the canvas (`x="1e300"`) leaves the layer off it.
            let (cx, cy) = (x.saturating_add(offset[0]), y.saturating_add(offset[1]));
            if (0..width as i64).contains(&cx) && (0..height as i64).contains(&cy) {
                let mut p = pic.pixels[(y * pic.width as i64 + x) as usize];
                p[3] *= opacity;
                out.pixels[(cy * width as i64 + cx) as usize] = p;
            }
        }
    }
    out
}

/// Finishes the import of a layered file (`.ora`, `.psd`) whose canvas-sized `layers` are back →
/// front: reports duplicate names together with the `problems` found while reading, skips fully
/// transparent layers (layered files often carry an empty one) with a warning naming each, then
/// applies the `character.toml` beside the file if it is one of [`LayeredOverrides`] (kinds,
/// root, name, joints, rig); otherwise takes the body layer with the most opaque pixels as the
/// root and the file's stem as the name, and joins every overlapping pair.
///
/// # Errors
/// Every problem at once ([`Error::collect`]), the transparent layers among them when anything
/// else is wrong or nothing else is left; [`Error::Format`] if no body layer is left;
/// [`Error::Layer`] naming the `character.toml` for a layer, root or joint it names that the
/// file does not have, or an accessory root.
pub(super) fn assemble(path: &Path, layers: Vec<ArtLayer>, mut problems: Vec<Error>, progress: &dyn Progress) -> Result<Artwork> {
    let mut names = std::collections::HashSet::new();
    for layer in &layers {
        if !names.insert(layer.name.as_str()) {
            problems.push(Error::layer(path, &layer.name, "duplicate layer name (rename it in the editor)"));
        }
    }
    let (mut layers, empty): (Vec<ArtLayer>, Vec<ArtLayer>) = layers.into_iter().partition(|l| l.picture.pixels.iter().any(|p| p[3] > 0.0));
    let transparent = |l: &ArtLayer| Error::layer(path, &l.name, "fully transparent (no pixel has alpha > 0)");
    if !problems.is_empty() || layers.is_empty() {
        problems.extend(empty.iter().map(transparent));
    }
    Error::collect(problems)?;
    for layer in &empty {
        progress.warn(&format!("{}; skipped", transparent(layer)));
    }
    let toml_path = path.parent().unwrap_or(Path::new(".")).join("character.toml");
    let overrides = LayeredOverrides::load_beside(&toml_path)?;
    let index = |layers: &[ArtLayer], name: &str| -> Result<usize> {
        layers.iter().position(|l| l.name == name).ok_or_else(|| {
            let why = if empty.iter().any(|l| l.name == name) {
                " (it is fully transparent and was skipped)"
            } else {
                ""
            };
            Error::layer(&toml_path, name, format!("{} has no such layer{why}", path.display()))
        })
    };
    let mut joint_pairs = None;
    let mut chosen_root = None;
    let mut rig = RigOverrides::default();
    let mut name = None;
    if let Some(o) = &overrides {
        for spec in &o.layers {
            let l = index(&layers, &spec.name)?;
            layers[l].kind = spec.kind;
        }
        if let Some(root) = &o.root {
            let l = index(&layers, root)?;
            if layers[l].kind != LayerKind::Body {
                return Err(Error::layer(&toml_path, root, "the root must be a body layer, not an accessory"));
            }
            chosen_root = Some(l);
        }
        if let Some(pairs) = &o.joints {
            joint_pairs = Some(
                pairs
                    .iter()
                    .map(|[a, b]| Ok([index(&layers, a)?, index(&layers, b)?]))
                    .collect::<Result<Vec<_>>>()?,
            );
        }
        rig = o.rig.clone();
        name = o.name.clone();
    }
    let root = match chosen_root {
        Some(root) => root,
        None => layers
            .iter()
            .enumerate()
            .filter(|(_, l)| l.kind == LayerKind::Body)
            .max_by_key(|(_, l)| l.picture.pixels.iter().filter(|p| p[3] > 0.5).count())
            .map(|(i, _)| i)
            .ok_or_else(|| Error::format(path, "no body layer (every layer is hidden or an accessory)"))?,
    };
    let name = name.unwrap_or_else(|| {
        path.file_stem()
            .map_or_else(|| "character".into(), |s| s.to_string_lossy().into_owned())
    });
    Ok(Artwork {
        source: path.to_path_buf(),
        name,
        layers,
        root,
        joint_pairs,
        rig,
    })
}
