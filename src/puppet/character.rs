//! `character.toml`: how a character's artwork is laid out (DESIGN.md "Formats").
//!
//! ```toml
//! name = "robot"                  # optional; defaults to the folder name
//! root = "torso"                  # the root body layer (required)
//! joints = [["torso", "head"]]    # optional: join only these pairs (default: every overlapping pair)
//!
//! [labels]                        # label-map form only
//! map = "robot_labels.png"        # one flat colour per part, transparent background
//! image = "robot_idle.png"        # the reference frame the parts are cut from
//!
//! [[layer]]                       # one per layer, back → front
//! name = "leg_l"
//! kind = "body"                   # or "accessory"; default "body"
//! file = "leg_l.png"              # layer-PNG form: the layer's image
//! color = "#ff0000"               # label-map form: the part's colour in the map
//!
//! [rig]                           # optional: overrides of the accessory rig (see `RigOverrides`)
//! ```
//!
//! Unknown keys are errors, so a misspelt key is never silently ignored.
//!
//! Beside a layered file (`.ora`, `.psd`), a `character.toml` with neither `[labels]` nor any
//! layer's `file` or `color` is that file's [`LayeredOverrides`]: its `[[layer]]` entries name
//! layers of the file and set their `kind`, and `name`, `root`, `joints` and `[rig]` apply as
//! above; the file keeps its pixels and order. (A `character.toml` of the other forms describes
//! other artwork in the same folder and is not applied.)

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::rig_data::RigOverrides;
use super::LayerKind;
use crate::error::{Error, Result};
use crate::user_file;

/// The parsed and validated `character.toml`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CharacterFile {
    /// Display name.
    pub name: Option<String>,
    /// Name of the root body layer.
    pub root: Option<String>,
    /// Pairs of layer names to join; `None` joins every overlapping pair.
    pub joints: Option<Vec<[String; 2]>>,
    /// Present for the label-map form.
    pub labels: Option<Labels>,
    /// Layers back → front.
    #[serde(rename = "layer", default)]
    pub layers: Vec<LayerSpec>,
    /// Overrides of the automatic accessory rig.
    #[serde(default)]
    pub rig: RigOverrides,
}

/// The label-map form's two images.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Labels {
    /// The label map, relative to the folder of `character.toml`.
    pub map: PathBuf,
    /// The reference image, relative to the folder of `character.toml`.
    pub image: PathBuf,
}

/// One `[[layer]]` entry.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerSpec {
    /// The layer's name.
    pub name: String,
    /// Body part or accessory.
    #[serde(default = "body")]
    pub kind: LayerKind,
    /// Layer-PNG form: the image file, relative to the folder of `character.toml`.
    pub file: Option<PathBuf>,
    /// Label-map form: the part's colour, `"#rrggbb"`.
    pub color: Option<String>,
}

fn body() -> LayerKind {
    LayerKind::Body
}

impl CharacterFile {
    /// Reads and validates `path`.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable; [`Error::Limit`] if larger than [`user_file::CONFIG`];
    /// [`Error::Format`] for text that is not UTF-8, bad TOML, unknown keys, or a structural
    /// problem (see [`CharacterFile::parse`]).
    pub fn load(path: &Path) -> Result<Self> {
        let text = user_file::read_text(path, user_file::CONFIG)?;
        Self::parse(&text, path)
    }

    /// Parses and validates TOML text; `path` names the file in errors.
    ///
    /// Checks: at least one layer, no duplicate names, a root that names a body layer, every layer
    /// has `file` (layer-PNG form) or a valid `color` (label-map form) but not both forms, no two
    /// layers share a colour, joints name existing layers, the `[rig]` settings in range.
    ///
    /// # Errors
    /// [`Error::Format`] naming `path`, or [`Error::Partial`] listing every problem found.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let character: CharacterFile =
            toml::from_str(text).map_err(|e| Error::format(path, format!("invalid character.toml: {}", e.message())))?;
        character.validate(path)?;
        Ok(character)
    }

    fn validate(&self, path: &Path) -> Result<()> {
        let mut problems = Vec::new();
        if self.layers.is_empty() {
            problems.push(Error::format(path, "no [[layer]] entries"));
        }
        let mut seen = HashSet::new();
        for layer in &self.layers {
            if !seen.insert(layer.name.as_str()) {
                problems.push(Error::layer(path, &layer.name, "duplicate layer name"));
            }
            match (&self.labels, &layer.file, &layer.color) {
                (None, None, _) => problems.push(Error::layer(path, &layer.name, "no `file` (the layer's PNG)")),
                (None, Some(_), Some(_)) => {
                    problems.push(Error::layer(path, &layer.name, "`color` needs a [labels] table (label-map form)"))
                }
                (Some(_), _, None) => problems.push(Error::layer(path, &layer.name, "no `color` (its colour in the label map)")),
                (Some(_), Some(_), _) => problems.push(Error::layer(
                    path,
                    &layer.name,
                    "`file` is not used in the label-map form (remove it)",
                )),
                (Some(_), None, Some(c)) => {
                    if let Err(problem) = parse_color(c) {
                        problems.push(Error::layer(path, &layer.name, problem));
                    }
                }
                (None, Some(_), None) => {}
            }
        }
        if self.labels.is_some() {
            let mut colors = HashSet::new();
            for layer in &self.layers {
                if let Some(Ok(c)) = layer.color.as_deref().map(parse_color) {
                    if !colors.insert(c) {
                        problems.push(Error::layer(
                            path,
                            &layer.name,
                            format!("colour {} is used by another layer", layer.color.as_deref().unwrap_or_default()),
                        ));
                    }
                }
            }
        }
        match &self.root {
            None => problems.push(Error::format(path, "no root body layer (add `root = \"<layer name>\"`)")),
            Some(root) => match self.layers.iter().find(|l| &l.name == root) {
                None => problems.push(Error::format(path, format!("root {root:?} is not a layer"))),
                Some(l) if l.kind != LayerKind::Body => {
                    problems.push(Error::layer(path, root, "the root must be a body layer, not an accessory"))
                }
                Some(_) => {}
            },
        }
        for pair in self.joints.iter().flatten() {
            for name in pair {
                if !seen.contains(name.as_str()) {
                    problems.push(Error::format(path, format!("joint {pair:?} names {name:?}, which is not a layer")));
                }
            }
            if pair[0] == pair[1] {
                problems.push(Error::format(path, format!("joint {pair:?} joins a layer to itself")));
            }
        }
        if let Err(e) = self.rig.check() {
            problems.push(Error::format(path, e.to_string()));
        }
        Error::collect(problems)
    }

    /// The index of the root layer (validated to exist).
    pub fn root_index(&self) -> usize {
        let root = self.root.as_deref().expect("validated: root is present");
        self.layers
            .iter()
            .position(|l| l.name == root)
            .expect("validated: root names a layer")
    }
}

/// What a `character.toml` beside a `.ora` or `.psd` says of its layers (module doc).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayeredOverrides {
    /// Display name.
    pub name: Option<String>,
    /// Name of the root body layer.
    pub root: Option<String>,
    /// Pairs of layer names to join; `None` joins every overlapping pair.
    pub joints: Option<Vec<[String; 2]>>,
    /// Layers whose kind is set.
    #[serde(rename = "layer", default)]
    pub layers: Vec<LayerKindSpec>,
    /// Overrides of the automatic accessory rig.
    #[serde(default)]
    pub rig: RigOverrides,
}

/// One `[[layer]]` entry of [`LayeredOverrides`].
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerKindSpec {
    /// The layer's name in the file.
    pub name: String,
    /// Body part or accessory.
    pub kind: LayerKind,
}

impl LayeredOverrides {
    /// Reads the `character.toml` at `path` beside a layered file: `None` if there is none or it
    /// is of another form (module doc).
    ///
    /// # Errors
    /// As [`CharacterFile::load`] for an unreadable file or bad TOML; [`Error::Format`] naming the
    /// file for unknown keys or a layer named twice.
    pub fn load_beside(path: &Path) -> Result<Option<Self>> {
        if !path.is_file() {
            return Ok(None);
        }
        Self::parse(&user_file::read_text(path, user_file::CONFIG)?, path)
    }

    /// Parses TOML text as [`LayeredOverrides::load_beside`] does; `path` names the file.
    ///
    /// # Errors
    /// As [`LayeredOverrides::load_beside`].
    pub fn parse(text: &str, path: &Path) -> Result<Option<Self>> {
        let table: toml::Table =
            toml::from_str(text).map_err(|e| Error::format(path, format!("invalid character.toml: {}", e.message())))?;
        let layer_has = |key: &str| {
            table
                .get("layer")
                .and_then(toml::Value::as_array)
                .is_some_and(|layers| layers.iter().any(|l| l.get(key).is_some()))
        };
        if table.contains_key("labels") || layer_has("file") || layer_has("color") {
            return Ok(None);
        }
        let overrides: LayeredOverrides =
            toml::from_str(text).map_err(|e| Error::format(path, format!("invalid character.toml: {}", e.message())))?;
        let mut seen = HashSet::new();
        for layer in &overrides.layers {
            if !seen.insert(layer.name.as_str()) {
                return Err(Error::layer(path, &layer.name, "named twice"));
            }
        }
        overrides.rig.check().map_err(|e| Error::format(path, e.to_string()))?;
        Ok(Some(overrides))
    }
}

/// Parses `"#rrggbb"` (or `"rrggbb"`) into bytes.
///
/// # Errors
/// A description of what is wrong with the text.
pub fn parse_color(text: &str) -> std::result::Result<[u8; 3], String> {
    let hex = text.strip_prefix('#').unwrap_or(text);
    if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(format!("colour {text:?} is not of the form \"#rrggbb\""));
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).expect("checked hex digits");
    Ok([byte(0), byte(2), byte(4)])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CharacterFile> {
        CharacterFile::parse(text, Path::new("dir/character.toml"))
    }

    const LAYERS: &str =
        "root = \"torso\"\n[[layer]]\nname = \"arm\"\nfile = \"arm.png\"\n[[layer]]\nname = \"torso\"\nfile = \"torso.png\"\n";

    #[test]
    fn layer_png_form_parses_with_defaults() {
        let c = parse(LAYERS).unwrap();
        assert_eq!(c.layers.len(), 2);
        assert_eq!(c.layers[0].kind, LayerKind::Body);
        assert_eq!(c.root_index(), 1);
    }

    #[test]
    fn label_map_form_parses() {
        let text = "root = \"torso\"\n[labels]\nmap = \"l.png\"\nimage = \"i.png\"\n[[layer]]\nname = \"torso\"\ncolor = \"#FF0000\"\n[[layer]]\nname = \"hat\"\nkind = \"accessory\"\ncolor = \"00ff00\"\n";
        let c = parse(text).unwrap();
        assert_eq!(c.layers[1].kind, LayerKind::Accessory);
        assert_eq!(parse_color(c.layers[0].color.as_deref().unwrap()), Ok([255, 0, 0]));
    }

    #[test]
    fn unknown_key_is_named() {
        let err = parse(&format!("colour_depth = 3\n{LAYERS}")).unwrap_err().to_string();
        assert!(err.contains("dir/character.toml") && err.contains("colour_depth"), "{err}");
    }

    #[test]
    fn missing_root_is_reported() {
        let err = parse(&LAYERS.replace("root = \"torso\"\n", "")).unwrap_err().to_string();
        assert!(err.contains("no root body layer"), "{err}");
    }

    #[test]
    fn accessory_root_is_rejected() {
        let text = LAYERS.replace("name = \"torso\"\n", "name = \"torso\"\nkind = \"accessory\"\n");
        let err = parse(&text).unwrap_err().to_string();
        assert!(err.contains("layer \"torso\"") && err.contains("must be a body layer"), "{err}");
    }

    #[test]
    fn duplicate_names_are_all_reported_with_other_problems() {
        let text = format!("{LAYERS}[[layer]]\nname = \"arm\"\nfile = \"arm2.png\"\n[[layer]]\nname = \"tail\"\n");
        let err = parse(&text).unwrap_err().to_string();
        assert!(err.contains("layer \"arm\": duplicate layer name"), "{err}");
        assert!(err.contains("layer \"tail\": no `file`"), "{err}");
    }

    #[test]
    fn bad_colours_and_shared_colours_are_rejected() {
        let text = "root = \"a\"\n[labels]\nmap = \"l.png\"\nimage = \"i.png\"\n[[layer]]\nname = \"a\"\ncolor = \"#ff0000\"\n[[layer]]\nname = \"b\"\ncolor = \"#ff0000\"\n[[layer]]\nname = \"c\"\ncolor = \"red\"\n";
        let err = parse(text).unwrap_err().to_string();
        assert!(err.contains("layer \"b\": colour #ff0000 is used by another layer"), "{err}");
        assert!(err.contains("layer \"c\": colour \"red\" is not of the form"), "{err}");
    }

    #[test]
    fn joints_must_name_layers() {
        let text = LAYERS.replace("root = \"torso\"\n", "root = \"torso\"\njoints = [[\"torso\", \"head\"]]\n");
        let err = parse(&text).unwrap_err().to_string();
        assert!(err.contains("\"head\", which is not a layer"), "{err}");
    }

    #[test]
    fn a_file_over_the_config_limit_is_refused_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("character.toml");
        let padding = "#".repeat(user_file::CONFIG as usize);
        std::fs::write(&path, format!("{LAYERS}{padding}\n")).unwrap();
        let err = CharacterFile::load(&path).unwrap_err();
        assert!(
            matches!(err.innermost(), Error::Limit { limit, .. } if *limit == user_file::CONFIG),
            "{err}"
        );
        assert!(err.to_string().starts_with(&path.display().to_string()), "{err}");
    }
}
