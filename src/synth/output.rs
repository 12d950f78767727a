//! Writing a generated sequence to disk (issue 4 item 5): frames/, labels/, masks/, the
//! template artwork (template/character.toml + one PNG per layer, which `puppet build` reads),
//! truth.json and a contact sheet; or, in sprite-sheet mode, one sheet of poses and its label
//! sheet (for APES).

use std::path::{Path, PathBuf};

use super::character::Role;
use super::labels::label_picture;
use super::sequence::{frame_name, Sequence};
use super::truth::SheetLayout;
use crate::atomic_file::write_atomic;
use crate::error::{Error, Result};
use crate::picture::{contact_sheet, Picture};
use crate::progress::Progress;

/// What was written, for the CLI's report.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    /// The output folder.
    pub dir: PathBuf,
    /// Number of image files written.
    pub images: usize,
    /// The truth.json path.
    pub truth: PathBuf,
    /// The template's character.toml.
    pub template: PathBuf,
}

/// Writes the template artwork: `dir/character.toml` and `dir/<layer>.png`, layers back to
/// front, the torso the root, joints listed explicitly (parent and child of every pivot) so that
/// layers that merely touch at rest are not joined. Accessory parts are `kind = "accessory"`
/// layers, and `dir/rig_truth.json` (`{"attach_to": {accessory: parent}}`, what `puppet
/// eval-rig` scores a rig's layer DAG against) names the part each one follows.
///
/// # Errors
/// [`Error::Io`] or [`Error::Image`] naming the file.
pub fn write_template(seq: &Sequence, dir: &Path) -> Result<PathBuf> {
    let mut toml = String::new();
    toml.push_str(&format!("name = {:?}\nroot = \"torso\"\njoints = [\n", seq.character.name));
    for [a, b] in seq.character.joints() {
        toml.push_str(&format!("  [{a:?}, {b:?}],\n"));
    }
    toml.push_str("]\n");
    let mut attach_to = std::collections::BTreeMap::new();
    for (part, layer) in seq.character.parts.iter().zip(&seq.template) {
        let file = format!("{}.png", part.name);
        layer.save_png(&dir.join(&file))?;
        let kind = if part.role == Role::Accessory {
            if let Some(parent) = part.parent {
                attach_to.insert(part.name.clone(), seq.character.parts[parent].name.clone());
            }
            "accessory"
        } else {
            "body"
        };
        toml.push_str(&format!(
            "\n[[layer]]\nname = {:?}\nkind = \"{kind}\"\nfile = {file:?}\n",
            part.name
        ));
    }
    if !attach_to.is_empty() {
        let path = dir.join("rig_truth.json");
        let text = serde_json::json!({ "attach_to": attach_to }).to_string();
        write_atomic(&path, text.as_bytes())?;
    }
    let path = dir.join("character.toml");
    write_atomic(&path, toml.as_bytes())?;
    Ok(path)
}

/// The alpha channel as an opaque grey picture (white = covered).
pub fn mask_picture(image: &Picture) -> Picture {
    Picture {
        width: image.width,
        height: image.height,
        pixels: image.pixels.iter().map(|p| [p[3], p[3], p[3], 1.0]).collect(),
    }
}

/// Tiles same-size pictures into a `columns`-wide sheet without gutters, keeping alpha.
fn tile(pictures: &[Picture], columns: usize) -> Picture {
    let (w, h) = (pictures[0].width as usize, pictures[0].height as usize);
    let rows = pictures.len().div_ceil(columns);
    let sw = columns * w;
    let mut sheet = Picture::filled(sw as u32, (rows * h) as u32, [0.0; 4]);
    for (k, p) in pictures.iter().enumerate() {
        let (ox, oy) = ((k % columns) * w, (k / columns) * h);
        for y in 0..h {
            sheet.pixels[(oy + y) * sw + ox..(oy + y) * sw + ox + w].copy_from_slice(&p.pixels[y * w..(y + 1) * w]);
        }
    }
    sheet
}

fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Writes the sequence into `dir`: `frames/frame_NNN.png`, `labels/label_NNN.png`,
/// `masks/mask_NNN.png` (alpha as grey), `template/`, `truth.json` and `contact_sheet.png`.
///
/// # Errors
/// [`Error::Io`] or [`Error::Image`] naming the file that could not be written.
pub fn write_sequence(seq: &Sequence, dir: &Path, progress: &dyn Progress) -> Result<Written> {
    for sub in ["frames", "labels", "masks", "template"] {
        create_dir(&dir.join(sub))?;
    }
    let n = seq.frames.len();
    progress.stage("writing", n as u64);
    for (t, frame) in seq.frames.iter().enumerate() {
        frame.image.save_png(&dir.join("frames").join(frame_name("frame", t, n)))?;
        label_picture(&seq.character, frame).save_png(&dir.join("labels").join(frame_name("label", t, n)))?;
        mask_picture(&frame.image).save_png(&dir.join("masks").join(frame_name("mask", t, n)))?;
        progress.advance(1);
    }
    let template = write_template(seq, &dir.join("template"))?;
    let frames: Vec<&Picture> = seq.frames.iter().map(|f| &f.image).collect();
    contact_sheet(&frames, 8).save_png(&dir.join("contact_sheet.png"))?;
    let truth = dir.join("truth.json");
    seq.truth.save(&truth)?;
    Ok(Written {
        dir: dir.to_path_buf(),
        images: 3 * n + seq.template.len() + 1,
        truth,
        template,
    })
}

/// Writes the sequence as a sprite sheet into `dir`: `sheet.png` (poses in a grid of `columns`),
/// `sheet_labels.png` (their part labels), `template/` and `truth.json` (with the sheet layout;
/// frame coordinates are cell coordinates).
///
/// # Errors
/// [`Error::Io`] or [`Error::Image`] naming the file; [`Error::Setting`] if `columns` is 0.
pub fn write_sprite_sheet(seq: &Sequence, dir: &Path, columns: usize) -> Result<Written> {
    if columns == 0 {
        return Err(Error::setting("sprite sheet columns", 0, "at least 1"));
    }
    create_dir(dir)?;
    let columns = columns.min(seq.frames.len());
    let images: Vec<Picture> = seq.frames.iter().map(|f| f.image.clone()).collect();
    let labels: Vec<Picture> = seq.frames.iter().map(|f| label_picture(&seq.character, f)).collect();
    tile(&images, columns).save_png(&dir.join("sheet.png"))?;
    tile(&labels, columns).save_png(&dir.join("sheet_labels.png"))?;
    let template = write_template(seq, &dir.join("template"))?;
    let mut truth = seq.truth.clone();
    for (k, f) in truth.frames.iter_mut().enumerate() {
        f.file = format!("sheet.png#{k}");
        f.labels = format!("sheet_labels.png#{k}");
    }
    truth.sheet = Some(SheetLayout {
        file: "sheet.png".into(),
        labels: "sheet_labels.png".into(),
        columns: columns as u32,
        rows: seq.frames.len().div_ceil(columns) as u32,
    });
    let path = dir.join("truth.json");
    truth.save(&path)?;
    Ok(Written {
        dir: dir.to_path_buf(),
        images: 2 + seq.template.len(),
        truth: path,
        template,
    })
}
