//! What `puppet parts` writes (issue 16 item 3): the reference pose and its label map with a
//! `character.toml` (root, joints, back-to-front layers) that `puppet build` reads, the label
//! map of every pose laid out like the input, and `parts.png`, the poses above their parts and
//! their reconstructions.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::superpixels::NONE;
use super::Parts;
use crate::atomic_file::Outputs;
use crate::error::Result;
use crate::picture::{contact_sheet, draw, Picture};
use crate::puppet::artwork::{label_cut_overlap, ImportOptions};
use crate::puppet::joints::JointOptions;

/// Well-separated colours for the first parts (Trubetskoy's list of 20 distinct colours).
const PALETTE: [[u8; 3]; 20] = [
    [230, 25, 75],
    [60, 180, 75],
    [255, 225, 25],
    [0, 130, 200],
    [245, 130, 48],
    [145, 30, 180],
    [70, 240, 240],
    [240, 50, 230],
    [210, 245, 60],
    [250, 190, 212],
    [0, 128, 128],
    [220, 190, 255],
    [170, 110, 40],
    [255, 250, 200],
    [128, 0, 0],
    [170, 255, 195],
    [128, 128, 0],
    [255, 215, 180],
    [0, 0, 128],
    [128, 128, 128],
];

/// The label colour of part `k` (distinct for every `k` below 4116).
pub fn part_colour(k: usize) -> [u8; 3] {
    match PALETTE.get(k) {
        Some(&c) => c,
        // Past the palette: a grid of the colour cube that skips the palette's neighbourhood
        // only loosely; sheets with more than 20 parts are rare.
        None => {
            let j = k - PALETTE.len();
            [
                (37 + 31 * (j % 7)) as u8,
                (37 + 31 * ((j / 7) % 7)) as u8,
                (37 + 31 * ((j / 49) % 7)) as u8,
            ]
        }
    }
}

/// The layer name of part `k`.
pub fn part_name(k: usize) -> String {
    format!("part_{:02}", k + 1)
}

/// Where [`write_artwork`] put things.
#[derive(Clone, Debug)]
pub struct WrittenArtwork {
    /// `character.toml`, for `puppet build`.
    pub character: PathBuf,
    /// `parts.png`.
    pub preview: PathBuf,
    /// The label map of every pose: `pose_labels.png` laid out like the input sheet, or a
    /// folder of one label map per pose.
    pub pose_labels: PathBuf,
}

fn colour_f32(c: [u8; 3]) -> [f32; 4] {
    [f32::from(c[0]) / 255.0, f32::from(c[1]) / 255.0, f32::from(c[2]) / 255.0, 1.0]
}

/// The label map of one pose's labels (`width` per row): each part's colour, transparent
/// background.
pub fn label_picture(labels: &[u32], width: u32) -> Picture {
    Picture {
        width,
        height: labels.len() as u32 / width.max(1),
        pixels: labels
            .iter()
            .map(|&l| if l == NONE { [0.0; 4] } else { colour_f32(part_colour(l as usize)) })
            .collect(),
    }
}

/// Writes the artwork of `parts` into `dir`: `frame.png`, `labels.png`, `character.toml`,
/// `parts.png`, and the poses' label maps — on a `sheet_size` canvas at each pose's origin when
/// the poses came from one sheet, else as `pose_labels/pose_NNN.png`. Every file is claimed
/// through `outputs` before the first is written, so a file the user made or edited since (an
/// edited `character.toml`) is refused and nothing changes.
///
/// # Errors
/// As [`Outputs::claim`] and [`Outputs::write`]; [`crate::Error::Image`] if a PNG cannot be encoded.
pub fn write_artwork(parts: &Parts, dir: &Path, name: &str, sheet_size: Option<(u32, u32)>, outputs: &Outputs) -> Result<WrittenArtwork> {
    let seg = &parts.segmentation;
    let width = parts.poses[seg.reference].image.width;
    let png = |picture: &Picture, path: PathBuf| -> Result<(PathBuf, Vec<u8>)> { Ok((path.clone(), picture.png_bytes(&path)?)) };
    let character = dir.join("character.toml");
    let preview = dir.join("parts.png");
    let mut files = vec![
        png(&parts.poses[seg.reference].image, dir.join("frame.png"))?,
        png(&label_picture(&seg.labels[seg.reference], width), dir.join("labels.png"))?,
        (character.clone(), character_toml(parts, name).into_bytes()),
        png(&preview_sheet(parts), preview.clone())?,
    ];
    let pose_labels = match sheet_size {
        Some((w, h)) => {
            let mut sheet = Picture::filled(w, h, [0.0; 4]);
            for (pose, labels) in parts.poses.iter().zip(&seg.labels) {
                let pw = pose.width();
                for (i, &l) in labels.iter().enumerate() {
                    let (x, y) = (pose.origin[0] + (i % pw) as i64, pose.origin[1] + (i / pw) as i64);
                    if l != NONE && x >= 0 && y >= 0 && x < i64::from(w) && y < i64::from(h) {
                        sheet.pixels[(y as u32 * w + x as u32) as usize] = colour_f32(part_colour(l as usize));
                    }
                }
            }
            files.push(png(&sheet, dir.join("pose_labels.png"))?);
            dir.join("pose_labels.png")
        }
        None => {
            let folder = dir.join("pose_labels");
            for (k, labels) in seg.labels.iter().enumerate() {
                files.push(png(&label_picture(labels, width), folder.join(format!("pose_{k:03}.png")))?);
            }
            folder
        }
    };
    for (path, _) in &files {
        outputs.claim(path)?;
    }
    for (path, bytes) in &files {
        outputs.write(path, bytes)?;
    }
    Ok(WrittenArtwork {
        character,
        preview,
        pose_labels,
    })
}

/// `character.toml` of the label-map form: root, hinges as joints, layers back to front.
fn character_toml(parts: &Parts, name: &str) -> String {
    let sk = &parts.skeleton;
    let mut text = String::new();
    let _ = writeln!(
        text,
        "# Parts found by `puppet parts` from {} poses; the reference is pose {} ({}).",
        parts.poses.len(),
        parts.segmentation.reference,
        parts.poses[parts.segmentation.reference].name
    );
    let _ = writeln!(text, "name = {:?}", name);
    let _ = writeln!(text, "root = {:?}", part_name(sk.root));
    // `puppet build` cuts the layers from labels.png and joins two only where they overlap
    // enough: a hinge between parts that touch along a pixel or two would make it refuse the
    // artwork, so such a hinge is left out (its child joins nothing, which build allows).
    let mut layer = vec![0; sk.order.len()];
    for (position, &part) in sk.order.iter().enumerate() {
        layer[part] = position;
    }
    let reference = &parts.poses[parts.segmentation.reference].image;
    let layer_of: Vec<Option<usize>> = parts.segmentation.labels[parts.segmentation.reference]
        .iter()
        .map(|&l| (l != NONE).then(|| layer[l as usize]))
        .collect();
    let overlaps: Vec<usize> = sk
        .hinges
        .iter()
        .map(|h| {
            label_cut_overlap(
                reference,
                &layer_of,
                [layer[h.parent], layer[h.child]],
                ImportOptions::default().label_overlap,
            )
        })
        .collect();
    let joined = |overlap: usize| overlap >= JointOptions::default().min_overlap;
    let joints: Vec<String> = sk
        .hinges
        .iter()
        .zip(&overlaps)
        .filter(|&(_, &overlap)| joined(overlap))
        .map(|(h, _)| format!("[{:?}, {:?}]", part_name(h.parent), part_name(h.child)))
        .collect();
    let _ = writeln!(
        text,
        "# Hinges, parent first: the pivot each pair's motions share best (RMS miss in pixels)."
    );
    for (h, &overlap) in sk.hinges.iter().zip(&overlaps) {
        let _ = writeln!(
            text,
            "#   {} – {} at ({:.1}, {:.1}), {:.2} px{}",
            part_name(h.parent),
            part_name(h.child),
            h.pivot[0],
            h.pivot[1],
            h.residual,
            if joined(overlap) {
                String::new()
            } else {
                format!(" — not joined: the cut layers overlap in {overlap} px")
            }
        );
    }
    let _ = writeln!(text, "joints = [{}]", joints.join(", "));
    let _ = writeln!(
        text,
        "\n[labels]\nmap = \"labels.png\"\nimage = \"frame.png\"\n\n# Back → front, from occlusion votes over the poses."
    );
    for &k in &sk.order {
        let [r, g, b] = part_colour(k);
        let _ = writeln!(text, "\n[[layer]]\nname = {:?}\ncolor = \"#{r:02x}{g:02x}{b:02x}\"", part_name(k));
    }
    text
}

/// Every pose on white (top row) above its parts (middle row, hinges of the reference marked)
/// and the pose rebuilt from the parts (bottom row, [`Parts::rebuilt_pose`]).
fn preview_sheet(parts: &Parts) -> Picture {
    let seg = &parts.segmentation;
    let width = parts.poses[0].image.width;
    let mut cells: Vec<Picture> = parts.poses.iter().map(|p| p.image.clone()).collect();
    for (k, labels) in seg.labels.iter().enumerate() {
        let mut coloured = label_picture(labels, width);
        // Shade by the drawing's luminance so its lines stay readable under the colours.
        for (c, p) in coloured.pixels.iter_mut().zip(&parts.poses[k].image.pixels) {
            let lum = 0.4 + 0.6 * (0.3 * p[0] + 0.59 * p[1] + 0.11 * p[2]);
            for ch in c.iter_mut().take(3) {
                *ch *= lum;
            }
        }
        if k == seg.reference {
            for h in &parts.skeleton.hinges {
                draw::dot(&mut coloured, h.pivot, 2.5, [0.0, 0.0, 0.0]);
                draw::dot(&mut coloured, h.pivot, 1.2, [1.0, 1.0, 1.0]);
            }
        }
        cells.push(coloured);
    }
    cells.extend((0..parts.poses.len()).map(|t| parts.rebuilt_pose(t)));
    let refs: Vec<&Picture> = cells.iter().collect();
    let sheet = contact_sheet(&refs, parts.poses.len());
    if sheet.width < 600 {
        sheet.upscaled_on_white((600 / sheet.width.max(1)).clamp(1, 4))
    } else {
        sheet
    }
}
