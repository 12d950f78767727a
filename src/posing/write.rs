//! A character's poses on disk, for training away from the engine and for eyes: its puppet, its
//! rest render, and per pose the frame, the label image and the truth, plus a contact sheet.
//!
//! ```text
//! DIR/rest.png                   the rest pose
//! DIR/puppet.json, textures/     the puppet posed (`puppet::format`)
//! DIR/layers.json                each layer's name, kind, first vertex and label colour
//! DIR/pose_NNN.png               a posed frame (straight alpha)
//! DIR/pose_NNN_labels.png        the layer in front at each pixel, in its label colour
//! DIR/pose_NNN.json              {"seed", "vertices": [[x, y], …], "visible": [bool, …]}
//! DIR/sheet.png                  the first poses side by side, shown vertices dotted green,
//!                                hidden ones red
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{pose_seed, truth, PoseEngine, PosedFrame, NO_LAYER};
use crate::atomic_file::Outputs;
use crate::error::{Error, Result};
use crate::picture::{contact_sheet, draw, Picture};
use crate::puppet::{format, LayerKind};
use crate::render::render_crisp;
use crate::user_file;

/// The most poses the contact sheet shows.
const SHEET_POSES: usize = 24;

/// Poses made and written at a time, so a long run holds only these in memory.
const CHUNK: usize = 32;

/// The truth file of one pose.
#[derive(Serialize)]
struct PoseFile<'a> {
    seed: u64,
    vertices: &'a [[f32; 2]],
    visible: &'a [bool],
}

/// A pose's truth read back: every template vertex's place and whether it shows.
#[derive(Clone, Debug, Deserialize)]
pub struct PoseTruth {
    /// The pose's seed.
    pub seed: u64,
    /// Every template vertex, frame pixels.
    pub vertices: Vec<[f32; 2]>,
    /// Per vertex: whether the frame shows it.
    pub visible: Vec<bool>,
}

impl PoseTruth {
    /// Reads the truth file `path` of a pose of a puppet of `vertex_count` vertices.
    ///
    /// # Errors
    /// [`Error::Io`] if unreadable; [`Error::Format`] naming the file for anything but a truth
    /// file of that many vertices, all finite.
    pub fn load(path: &Path, vertex_count: usize) -> Result<Self> {
        Self::parse(&user_file::read_bytes(path, user_file::DATA)?, path, vertex_count)
    }

    /// Parses the bytes of a truth file; `path` only names it in errors.
    ///
    /// # Errors
    /// As [`PoseTruth::load`], but for reading.
    pub fn parse(bytes: &[u8], path: &Path, vertex_count: usize) -> Result<Self> {
        let truth: PoseTruth = serde_json::from_slice(bytes).map_err(|e| Error::format(path, format!("not a pose's truth: {e}")))?;
        if truth.vertices.len() != vertex_count || truth.visible.len() != vertex_count {
            return Err(Error::format(
                path,
                format!(
                    "{} vertices and {} visibility flags for a puppet of {vertex_count} vertices",
                    truth.vertices.len(),
                    truth.visible.len()
                ),
            ));
        }
        if truth.vertices.iter().flatten().any(|c| !c.is_finite()) {
            return Err(Error::format(path, "a vertex is not finite"));
        }
        Ok(truth)
    }
}

/// The pose files of a folder [`write_character`] wrote: `pose_000` on, as long as the next
/// one's truth is there (stems, without `.png` or `.json`).
pub fn pose_stems(dir: &Path) -> Vec<PathBuf> {
    (0..)
        .map(|k| dir.join(format!("pose_{k:03}")))
        .take_while(|stem| stem.with_extension("json").is_file())
        .collect()
}

/// One layer in `layers.json`.
#[derive(Serialize)]
struct LayerEntry<'a> {
    name: &'a str,
    kind: LayerKind,
    first_vertex: usize,
    label_colour: [u8; 3],
}

/// The files [`write_character`] writes into `dir` for `count` poses, besides the puppet's own
/// (`puppet.json` and its textures): to claim them all before anything is written.
pub fn character_files(dir: &Path, count: usize) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = ["rest.png", "layers.json", "sheet.png"].iter().map(|f| dir.join(f)).collect();
    for k in 0..count {
        files.extend(
            [
                format!("pose_{k:03}.png"),
                format!("pose_{k:03}_labels.png"),
                format!("pose_{k:03}.json"),
            ]
            .map(|f| dir.join(f)),
        );
    }
    files
}

/// Poses `engine`'s puppet `count` times (pose `k` from [`pose_seed`]`(seed, k)`) and writes the
/// folder the module doc describes into `dir` through `outputs`.
///
/// # Errors
/// As [`PoseEngine::poses`]; [`crate::Error::WouldOverwrite`] or [`crate::Error::Io`] naming a
/// file that cannot be written.
pub fn write_character(engine: &PoseEngine, seed: u64, count: usize, dir: &Path, outputs: &Outputs) -> Result<()> {
    let puppet = engine.puppet();
    outputs.claim_folder(dir)?;
    let offsets = puppet.vertex_offsets();
    let layers: Vec<LayerEntry> = puppet
        .layers
        .iter()
        .enumerate()
        .map(|(l, layer)| LayerEntry {
            name: &layer.name,
            kind: layer.kind,
            first_vertex: offsets[l],
            label_colour: truth::label_colour(l).map(|c| (c * 255.0).round() as u8),
        })
        .collect();
    let json = serde_json::to_vec_pretty(&layers).expect("plain data serialises");
    outputs.write(&dir.join("layers.json"), &json)?;
    format::save(puppet, dir)?;
    let rest = render_crisp(puppet, &puppet.rest_vertices(), puppet.width, puppet.height)?;
    save_png(outputs, &dir.join("rest.png"), &rest)?;
    let mut sheet = Vec::new();
    for start in (0..count).step_by(CHUNK) {
        let seeds: Vec<u64> = (start..count.min(start + CHUNK)).map(|k| pose_seed(seed, k)).collect();
        let frames = engine.poses(&seeds)?;
        for ((k, frame), &seed) in (start..).zip(&frames).zip(&seeds) {
            save_png(outputs, &dir.join(format!("pose_{k:03}.png")), &frame.picture)?;
            save_png(
                outputs,
                &dir.join(format!("pose_{k:03}_labels.png")),
                &label_picture(frame, puppet.width, puppet.height),
            )?;
            let truth = PoseFile {
                seed,
                vertices: &frame.vertices,
                visible: &frame.visible,
            };
            let json = serde_json::to_vec(&truth).expect("plain data serialises");
            outputs.write(&dir.join(format!("pose_{k:03}.json")), &json)?;
            if sheet.len() < SHEET_POSES {
                sheet.push(dotted(frame));
            }
        }
    }
    if !sheet.is_empty() {
        let cells: Vec<&Picture> = sheet.iter().collect();
        let columns = (cells.len() as f64).sqrt().ceil() as usize;
        save_png(outputs, &dir.join("sheet.png"), &contact_sheet(&cells, columns))?;
    }
    Ok(())
}

fn save_png(outputs: &Outputs, path: &Path, picture: &Picture) -> Result<()> {
    outputs.write(path, &picture.png_bytes(path)?)
}

/// The label image of a frame: each layer's pixels in its label colour, the rest transparent.
pub fn label_picture(frame: &PosedFrame, width: u32, height: u32) -> Picture {
    let pixels = frame
        .labels
        .iter()
        .map(|&l| match l {
            NO_LAYER => [0.0; 4],
            l => {
                let [r, g, b] = truth::label_colour(usize::from(l));
                [r, g, b, 1.0]
            }
        })
        .collect();
    Picture { width, height, pixels }
}

/// A frame enlarged for eyes on white, its shown vertices dotted green and its hidden ones red.
fn dotted(frame: &PosedFrame) -> Picture {
    let side = frame.picture.width.max(frame.picture.height).max(1);
    let s = (256 / side).clamp(1, 4);
    let mut pic = frame.picture.upscaled_on_white(s);
    let s = s as f32;
    for (p, &shown) in frame.vertices.iter().zip(&frame.visible) {
        let at = [p[0] * s, p[1] * s];
        if shown {
            draw::dot(&mut pic, at, 0.6 * s, [0.1, 0.75, 0.2]);
        } else {
            draw::put(&mut pic, at[0].floor() as i64, at[1].floor() as i64, [0.9, 0.1, 0.1]);
        }
    }
    pic
}
