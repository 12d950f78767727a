//! Artwork import: the forms of DESIGN.md "Formats", all turned into same-size layer images.
//!
//! - a folder with `character.toml` and one RGBA PNG per layer;
//! - a label map (one flat colour per part) + the reference image + a legend in `character.toml`;
//! - an OpenRaster `.ora` file (see [`super::ora`]) or a Photoshop `.psd` file (see [`super::psd`]).
//!
//! Every bad layer of an import is reported at once ([`Error::Partial`]). Sizes are checked
//! against [`ImportOptions`]' limits from image headers, before any layer is decoded.

use std::path::{Path, PathBuf};

use super::character::{parse_color, CharacterFile};
// The import's types live in `layers`, below the .ora and .psd readers that build them too;
// callers know them from here.
pub use super::layers::{over, ArtLayer, Artwork, ImportOptions, DEFAULT_MAX_LAYERS, DEFAULT_MAX_TOTAL_PIXELS};
use crate::error::{Context, Error, Result};
use crate::picture::Picture;
use crate::progress::Progress;
use crate::user_file;

/// Reads artwork from a folder holding `character.toml`, a `character.toml` file, a `.ora` or a
/// `.psd`, dropping warnings (see [`load_reporting`]).
///
/// # Errors
/// As [`load_reporting`].
pub fn load(path: &Path, opts: &ImportOptions) -> Result<Artwork> {
    load_reporting(path, opts, &crate::progress::Silent)
}

/// Reads artwork from a folder holding `character.toml`, a `character.toml` file, a `.ora` or a
/// `.psd`; what the import cannot reproduce but goes on without (a Photoshop blend mode other than
/// normal, a layer mask) is reported to `progress` as a warning.
///
/// # Errors
/// A missing or unreadable file, a bad `character.toml`, layers of different sizes, a fully
/// transparent layer, label-map colours missing from the legend or legend colours missing from
/// the map, unlabelled opaque pixels, or a corrupt or unsupported `.ora` / `.psd` — each naming
/// the file and layer.
pub fn load_reporting(path: &Path, opts: &ImportOptions, progress: &dyn Progress) -> Result<Artwork> {
    if !path.exists() {
        return Err(Error::WrongFolder {
            path: path.to_path_buf(),
            expected: crate::error::FolderKind::Artwork,
            problem: "no such file or folder".into(),
        });
    }
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ora")) {
        return super::ora::load(path, opts, progress);
    }
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("psd")) {
        return super::psd::load(path, opts, progress);
    }
    let toml_path = if path.is_dir() {
        path.join("character.toml")
    } else {
        path.to_path_buf()
    };
    let character = CharacterFile::load(&toml_path)?;
    let dir = toml_path.parent().unwrap_or(Path::new("."));
    let name = character.name.clone().unwrap_or_else(|| folder_name(dir));
    let layers = match &character.labels {
        Some(labels) => {
            let map_path = dir.join(&labels.map);
            let image_path = dir.join(&labels.image);
            let read = |path: &Path| user_file::read_bytes(path, opts.image.max_file_bytes());
            let image = read(&image_path)?;
            let map = read(&map_path)?;
            label_map_layers(&character, &map, &map_path, &image, &image_path, opts)?
        }
        None => load_layer_pngs(&character, dir, &toml_path, opts)?,
    };
    let index = |n: &str| character.layers.iter().position(|l| l.name == n).expect("validated joint names");
    let joint_pairs = character
        .joints
        .as_ref()
        .map(|pairs| pairs.iter().map(|[a, b]| [index(a), index(b)]).collect());
    Ok(Artwork {
        source: toml_path.clone(),
        name,
        layers,
        root: character.root_index(),
        joint_pairs,
        rig: character.rig,
    })
}

fn folder_name(dir: &Path) -> String {
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    dir.file_name()
        .map_or_else(|| "character".into(), |n| n.to_string_lossy().into_owned())
}

/// Loads the layer-PNG form, checking every layer's size from its header against the first
/// readable one (and the limits) before decoding it, and every layer for emptiness.
fn load_layer_pngs(character: &CharacterFile, dir: &Path, toml_path: &Path, opts: &ImportOptions) -> Result<Vec<ArtLayer>> {
    let files: Vec<PathBuf> = character
        .layers
        .iter()
        .map(|spec| dir.join(spec.file.as_ref().expect("validated: layer-PNG form has files")))
        .collect();
    let sizes: Vec<Result<(u32, u32)>> = files.iter().map(|f| Picture::file_size(f)).collect();
    // The whole import is sized from the first readable header before any layer is decoded.
    let canvas = sizes
        .iter()
        .zip(&character.layers)
        .find_map(|(s, spec)| s.as_ref().ok().map(|&s| (s, spec)));
    if let Some(((w, h), first)) = canvas {
        let file = dir.join(first.file.as_ref().expect("validated: layer-PNG form has files"));
        opts.check(files.len(), w, h).at_path(file)?;
    }
    let mut layers = Vec::new();
    let mut problems = Vec::new();
    for ((spec, file), size) in character.layers.iter().zip(&files).zip(sizes) {
        let picture = size.and_then(|(w, h)| match canvas {
            Some(((cw, ch), first)) if (w, h) != (cw, ch) => Err(Error::layer(
                file,
                &spec.name,
                format!("{w}×{h}, expected {cw}×{ch} like layer {:?}", first.name),
            )),
            _ => Picture::load_within(file, &opts.image),
        });
        match picture {
            Ok(picture) if picture.pixels.iter().all(|p| p[3] == 0.0) => {
                problems.push(Error::layer(file, &spec.name, "fully transparent (no pixel has alpha > 0)"))
            }
            Ok(picture) => layers.push(ArtLayer {
                name: spec.name.clone(),
                kind: spec.kind,
                picture,
            }),
            Err(e) => problems.push(e),
        }
    }
    if layers.is_empty() && problems.is_empty() {
        problems.push(Error::format(toml_path, "no layers"));
    }
    Error::collect(problems)?;
    Ok(layers)
}

/// The layers of the label-map form: the reference image (`image`, the bytes of the file
/// `image_path`) cut into one layer per colour of the label map (`map`, the bytes of `map_path`)
/// that `character` lists; the paths only name the files in errors. The import is sized from the
/// image's header against `opts` before either image is decoded.
///
/// # Errors
/// [`Error::Image`] for an undecodable image, [`Error::Limit`] for one past the limits,
/// [`Error::Format`]/[`Error::Layer`] naming the map for a size that differs from the image's,
/// colours missing from the legend or legend colours missing from the map, or opaque pixels of
/// the image with no label — every problem at once.
///
/// # Panics
/// If `character` is not of the label-map form (a caller bug: [`CharacterFile::parse`] checks that
/// every layer has a valid colour when `labels` is present).
pub fn label_map_layers(
    character: &CharacterFile,
    map: &[u8],
    map_path: &Path,
    image: &[u8],
    image_path: &Path,
    opts: &ImportOptions,
) -> Result<Vec<ArtLayer>> {
    let (w, h) = Picture::header_size(image, image_path)?;
    opts.check(character.layers.len() + 2, w, h).at_path(image_path)?;
    let map_picture = Picture::decode_within(map, map_path, &opts.image)?;
    let image_picture = Picture::decode_within(image, image_path, &opts.image)?;
    cut_label_map(character, &map_picture, map_path, &image_picture, image_path, opts)
}

/// Cuts the reference image into one layer per label-map colour (label-map form).
fn cut_label_map(
    character: &CharacterFile,
    map: &Picture,
    map_path: &Path,
    image: &Picture,
    image_path: &Path,
    opts: &ImportOptions,
) -> Result<Vec<ArtLayer>> {
    if (map.width, map.height) != (image.width, image.height) {
        return Err(Error::format(
            map_path,
            format!(
                "label map is {}×{}, expected {}×{} like {}",
                map.width,
                map.height,
                image.width,
                image.height,
                image_path.display()
            ),
        ));
    }
    let legend: Vec<[u8; 3]> = character
        .layers
        .iter()
        .map(|l| parse_color(l.color.as_deref().expect("validated: colours present")).expect("validated colour"))
        .collect();
    let labels = label_pixels(map, map_path, &legend)?;
    let mut problems = Vec::new();
    let unlabelled: Vec<usize> = (0..labels.len())
        .filter(|&i| labels[i].is_none() && image.pixels[i][3] > 0.5)
        .collect();
    if let Some(&first) = unlabelled.first() {
        let (x, y) = (first as u32 % map.width, first as u32 / map.width);
        problems.push(Error::format(
            map_path,
            format!(
                "{} opaque pixels of {} have no label, first at ({x}, {y})",
                unlabelled.len(),
                image_path.display()
            ),
        ));
    }
    let mut layers = Vec::new();
    for (k, spec) in character.layers.iter().enumerate() {
        if !labels.contains(&Some(k)) {
            problems.push(Error::layer(
                map_path,
                &spec.name,
                format!(
                    "its colour {} does not appear in the label map",
                    spec.color.as_deref().unwrap_or_default()
                ),
            ));
            continue;
        }
        let picture = cut_part(image, &labels, k, opts.label_overlap);
        layers.push(ArtLayer {
            name: spec.name.clone(),
            kind: spec.kind,
            picture,
        });
    }
    Error::collect(problems)?;
    Ok(layers)
}

/// The legend index of every pixel (`None` for transparent background); unknown colours are
/// reported with their pixel counts and first positions.
fn label_pixels(map: &Picture, map_path: &Path, legend: &[[u8; 3]]) -> Result<Vec<Option<usize>>> {
    let mut unknown: Vec<([u8; 3], usize, usize)> = Vec::new(); // colour, count, first pixel
    let labels = map
        .pixels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if p[3] == 0.0 {
                return None;
            }
            let rgb = [p[0], p[1], p[2]].map(|c| (c * 255.0).round() as u8);
            let found = legend.iter().position(|&c| c == rgb);
            if found.is_none() {
                match unknown.iter_mut().find(|u| u.0 == rgb) {
                    Some(u) => u.1 += 1,
                    None => unknown.push((rgb, 1, i)),
                }
            }
            found
        })
        .collect();
    if unknown.is_empty() {
        return Ok(labels);
    }
    unknown.sort_by_key(|u| std::cmp::Reverse(u.1));
    let listed: Vec<String> = unknown
        .iter()
        .take(5)
        .map(|(c, n, i)| {
            format!(
                "#{:02x}{:02x}{:02x} ({n} px, first at ({}, {}))",
                c[0],
                c[1],
                c[2],
                *i as u32 % map.width,
                *i as u32 / map.width
            )
        })
        .collect();
    let more = if unknown.len() > 5 {
        format!(" and {} more", unknown.len() - 5)
    } else {
        String::new()
    };
    Err(Error::format(
        map_path,
        format!(
            "colours not in the legend of character.toml: {}{more} (label maps need flat colours, no anti-aliasing)",
            listed.join(", ")
        ),
    ))
}

/// Label-map part `k` (`labels` give each pixel's part, parts in back-to-front order) cut from
/// `image` and extended `overlap` pixels under the parts in front of it.
fn cut_part(image: &Picture, labels: &[Option<usize>], k: usize, overlap: u32) -> Picture {
    let own: Vec<bool> = labels.iter().map(|&l| l == Some(k)).collect();
    let under_front: Vec<bool> = labels.iter().map(|&l| l.is_some_and(|o| o > k)).collect();
    extend_part(image, &own, &under_front, overlap)
}

/// How many opaque pixels label-map parts `a` and `b` share once cut as `puppet build` cuts them
/// ([`ImportOptions::label_overlap`] = `overlap`): a joint between them needs
/// [`crate::puppet::joints::JointOptions::min_overlap`] of them. `labels` give each pixel's part,
/// parts in back-to-front order.
pub fn label_cut_overlap(image: &Picture, labels: &[Option<usize>], [a, b]: [usize; 2], overlap: u32) -> usize {
    let (pa, pb) = (cut_part(image, labels, a, overlap), cut_part(image, labels, b, overlap));
    pa.pixels.iter().zip(&pb.pixels).filter(|(p, q)| p[3] > 0.5 && q[3] > 0.5).count()
}

/// The part's own pixels, grown by up to `overlap` pixels into `allowed` (and filling holes made
/// only of `allowed` pixels), new pixels opaque and coloured like their nearest own pixel.
fn extend_part(image: &Picture, own: &[bool], allowed: &[bool], overlap: u32) -> Picture {
    let (w, h) = (image.width as usize, image.height as usize);
    let mut out = Picture::filled(image.width, image.height, [0.0; 4]);
    for ((dst, src), &mine) in out.pixels.iter_mut().zip(&image.pixels).zip(own) {
        if mine {
            *dst = *src;
        }
    }
    let holes = enclosed_holes(own, allowed, w, h);
    // Breadth-first growth: each step takes the colour of an already-owned 4-neighbour.
    let mut owned = own.to_vec();
    let mut frontier: Vec<usize> = (0..own.len()).filter(|&i| own[i]).collect();
    let mut step = 0;
    while !frontier.is_empty() {
        step += 1;
        let mut next = Vec::new();
        for &i in &frontier {
            let (x, y) = (i % w, i / w);
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            for j in neighbours.into_iter().flatten() {
                let reachable = allowed[j] && (step <= overlap as usize || holes[j]);
                if !owned[j] && reachable {
                    owned[j] = true;
                    let c = out.pixels[i];
                    out.pixels[j] = [c[0], c[1], c[2], 1.0];
                    next.push(j);
                }
            }
        }
        frontier = next;
    }
    out
}

/// Pixels not in `own` that cannot reach the image border without crossing `own`, in components
/// made only of `allowed` pixels (a hole that is wholly covered by parts in front).
fn enclosed_holes(own: &[bool], allowed: &[bool], w: usize, h: usize) -> Vec<bool> {
    // Label 4-connected components of !own; a component is a fillable hole if it touches no
    // border and all its pixels are allowed.
    let mut component = vec![usize::MAX; own.len()];
    let mut fillable = Vec::new();
    for start in 0..own.len() {
        if own[start] || component[start] != usize::MAX {
            continue;
        }
        let id = fillable.len();
        let (mut ok, mut stack) = (true, vec![start]);
        component[start] = id;
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            ok &= allowed[i] && x > 0 && y > 0 && x + 1 < w && y + 1 < h;
            let neighbours = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            for j in neighbours.into_iter().flatten() {
                if !own[j] && component[j] == usize::MAX {
                    component[j] = id;
                    stack.push(j);
                }
            }
        }
        fillable.push(ok);
    }
    component.iter().map(|&c| c != usize::MAX && fillable[c]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two label-map parts on a 12 × 6 opaque image: part 0 the left square, part 1 in front of
    /// it either the right square (a 6-pixel seam) or a one-pixel line leaving the square's side.
    /// Cut as `puppet build` cuts them, part 0 grows 2 px under part 1: 6 × 2 pixels shared along
    /// the seam, 2 along the line — too few for a joint.
    #[test]
    fn cut_parts_overlap_where_the_back_one_grows_under_the_front_one() {
        let image = Picture::filled(12, 6, [0.5, 0.5, 0.5, 1.0]);
        let square: Vec<Option<usize>> = (0..72).map(|i| Some(usize::from(i % 12 >= 6))).collect();
        assert_eq!(label_cut_overlap(&image, &square, [0, 1], 2), 12);
        let line: Vec<Option<usize>> = (0..72)
            .map(|i| match (i % 12, i / 12) {
                (x, _) if x < 6 => Some(0),
                (_, 3) => Some(1),
                _ => None,
            })
            .collect();
        assert_eq!(label_cut_overlap(&image, &line, [0, 1], 2), 2);
        assert!(2 < crate::puppet::joints::JointOptions::default().min_overlap);
    }
}
