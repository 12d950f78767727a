//! The poses of a sprite sheet (apes-part-extraction.md §3: "P sprite raster images and their
//! foreground masks"): a sheet split into equal cells by the user's grid or by its alpha, or a
//! folder of pose images, checked to be at least two poses of one size with something drawn.

use std::path::Path;

use crate::error::{Error, Result};
use crate::geom::component_labels;
use crate::picture::Picture;
use crate::puppet::sequence::{FrameCheck, Frames};

/// Alpha at and above which a pixel is foreground (the mask of §3).
pub const FOREGROUND_ALPHA: f32 = 0.5;

/// Alpha above which a pixel joins pieces of one drawing when a sheet is split by its alpha:
/// lower than [`FOREGROUND_ALPHA`], so antialiased seams do not cut a pose in two.
const JOIN_ALPHA: f32 = 0.05;

/// The most poses a sheet may hold (every pair is compared, so the work grows with the square).
pub const MAX_POSES: usize = 64;

/// The most pixels of correspondences a sheet may need: one target per pixel of every pose
/// towards every other pose, 8 bytes each, so 2 GiB (64 poses of 64² or 10 poses of 1700²).
pub const MAX_PAIR_PIXELS: u64 = 1 << 28;

/// The most grid cells a sheet may be cut into (empty cells are skipped, so a grid may have
/// more cells than poses).
pub const MAX_CELLS: usize = 4096;

/// One pose: its picture and foreground mask.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// Where it came from, for messages and outputs (`sheet.png#3`, `walk_02.png`).
    pub name: String,
    /// The pose, straight alpha.
    pub image: Picture,
    /// Row-major foreground mask (alpha ≥ [`FOREGROUND_ALPHA`]).
    pub mask: Vec<bool>,
    /// Where the pose's top-left pixel sits on its sheet (may lie off the sheet for a pose
    /// centred in its cell); `[0, 0]` for a pose read from its own file.
    pub origin: [i64; 2],
}

impl Pose {
    /// A pose of `image`, its mask from the alpha.
    pub fn new(name: impl Into<String>, image: Picture) -> Self {
        let mask = image.pixels.iter().map(|p| p[3] >= FOREGROUND_ALPHA).collect();
        Pose {
            name: name.into(),
            image,
            mask,
            origin: [0, 0],
        }
    }

    /// The same pose, placed at `origin` on its sheet.
    #[must_use]
    pub fn at(mut self, origin: [i64; 2]) -> Self {
        self.origin = origin;
        self
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.image.width as usize
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.image.height as usize
    }

    /// Number of foreground pixels.
    pub fn area(&self) -> usize {
        self.mask.iter().filter(|&&m| m).count()
    }
}

/// How a sprite sheet is cut into poses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Equal cells, `columns × rows`; empty cells are skipped.
    Grid {
        /// Cells per row.
        columns: u32,
        /// Rows.
        rows: u32,
    },
    /// One pose per group of drawn pixels: pieces whose boxes touch (within a small gap) are one
    /// pose, each centred in a cell the size of the largest.
    Alpha,
}

/// Cuts `sheet` (read from `path`, named in errors) into poses and checks them ([`check`]).
///
/// # Errors
/// [`Error::Format`] naming `path` when the grid does not divide the sheet, when nothing is
/// drawn, when there is a single pose, or when drawn groups differ so much in size that poses
/// must be touching (then a grid is needed).
pub fn split_sheet(sheet: &Picture, path: &Path, layout: Layout) -> Result<Vec<Pose>> {
    let poses = match layout {
        Layout::Grid { columns, rows } => split_grid(sheet, path, columns, rows)?,
        Layout::Alpha => split_alpha(sheet, path)?,
    };
    check(&poses, path)?;
    Ok(poses)
}

fn split_grid(sheet: &Picture, path: &Path, columns: u32, rows: u32) -> Result<Vec<Pose>> {
    if columns == 0 || rows == 0 || !sheet.width.is_multiple_of(columns) || !sheet.height.is_multiple_of(rows) {
        return Err(Error::format(
            path,
            format!(
                "a {}×{} sheet cannot be cut into a {columns}×{rows} grid of equal cells",
                sheet.width, sheet.height
            ),
        ));
    }
    if columns as usize * rows as usize > MAX_CELLS {
        return Err(Error::format(
            path,
            format!("a {columns}×{rows} grid has more than {MAX_CELLS} cells"),
        ));
    }
    let (w, h) = (sheet.width / columns, sheet.height / rows);
    let mut poses = Vec::new();
    for r in 0..rows {
        for c in 0..columns {
            let cell = crop(sheet, [c * w, r * h], [w, h], |_, _| true);
            let pose = Pose::new(cell_name(path, (r * columns + c) as usize), cell).at([(c * w) as i64, (r * h) as i64]);
            if pose.area() > 0 {
                poses.push(pose);
            }
        }
    }
    Ok(poses)
}

fn cell_name(path: &Path, k: usize) -> String {
    let file = path
        .file_name()
        .map_or_else(|| "sheet".into(), |n| n.to_string_lossy().into_owned());
    format!("{file}#{k}")
}

/// A `size` crop of `sheet` at `origin`, keeping only the pixels `keep(x, y)` accepts (sheet
/// coordinates); outside the sheet is transparent.
fn crop(sheet: &Picture, origin: [u32; 2], size: [u32; 2], keep: impl Fn(u32, u32) -> bool) -> Picture {
    let mut out = Picture::filled(size[0], size[1], [0.0; 4]);
    for y in 0..size[1] {
        for x in 0..size[0] {
            let (sx, sy) = (origin[0] + x, origin[1] + y);
            if sx < sheet.width && sy < sheet.height && keep(sx, sy) {
                out.pixels[(y * size[0] + x) as usize] = sheet.get(sx, sy);
            }
        }
    }
    out
}

/// A group of drawn pixels: its bounding box `[x0, y0, x1, y1]` (inclusive) and pixel count.
#[derive(Clone, Copy, Debug)]
struct Group {
    bounds: [u32; 4],
    area: usize,
}

fn split_alpha(sheet: &Picture, path: &Path) -> Result<Vec<Pose>> {
    let (w, h) = (sheet.width as usize, sheet.height as usize);
    let drawn: Vec<bool> = sheet.pixels.iter().map(|p| p[3] > JOIN_ALPHA).collect();
    let mut edges = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !drawn[i] {
                continue;
            }
            // 8-connectivity: right, down-left, down, down-right.
            let right = (x + 1 < w).then(|| i + 1);
            let below = (y + 1 < h).then(|| [(x > 0).then(|| i + w - 1), Some(i + w), (x + 1 < w).then(|| i + w + 1)]);
            for j in right.into_iter().chain(below.into_iter().flatten().flatten()) {
                if drawn[j] {
                    edges.push((i, j));
                }
            }
        }
    }
    let (component, count) = component_labels(w * h, edges);
    let mut groups: Vec<Option<Group>> = vec![None; count];
    for (i, _) in drawn.iter().enumerate().filter(|(_, &d)| d) {
        let (x, y) = ((i % w) as u32, (i / w) as u32);
        let g = groups[component[i]].get_or_insert(Group {
            bounds: [x, y, x, y],
            area: 0,
        });
        g.bounds = [g.bounds[0].min(x), g.bounds[1].min(y), g.bounds[2].max(x), g.bounds[3].max(y)];
        g.area += 1;
    }
    // Pieces of one drawing (a detached hand, a hat) sit within a few pixels of its box.
    let gap = (sheet.width.max(sheet.height) / 100).max(2);
    let pieces: Vec<(usize, Group)> = groups.iter().enumerate().filter_map(|(c, g)| g.map(|g| (c, g))).collect();
    if pieces.is_empty() {
        return Err(Error::format(path, "nothing is drawn: every pixel is transparent"));
    }
    let near = |a: &Group, b: &Group| {
        a.bounds[0] <= b.bounds[2] + gap
            && b.bounds[0] <= a.bounds[2] + gap
            && a.bounds[1] <= b.bounds[3] + gap
            && b.bounds[1] <= a.bounds[3] + gap
    };
    let mut joins = Vec::new();
    for a in 0..pieces.len() {
        for b in a + 1..pieces.len() {
            if near(&pieces[a].1, &pieces[b].1) {
                joins.push((a, b));
            }
        }
    }
    let (pose_of_piece, pose_count) = component_labels(pieces.len(), joins);
    let mut poses: Vec<Option<Group>> = vec![None; pose_count];
    let mut pose_of_component = vec![usize::MAX; count];
    for (k, (c, g)) in pieces.iter().enumerate() {
        let p = pose_of_piece[k];
        pose_of_component[*c] = p;
        match &mut poses[p] {
            None => poses[p] = Some(*g),
            Some(m) => {
                m.bounds = [
                    m.bounds[0].min(g.bounds[0]),
                    m.bounds[1].min(g.bounds[1]),
                    m.bounds[2].max(g.bounds[2]),
                    m.bounds[3].max(g.bounds[3]),
                ];
                m.area += g.area;
            }
        }
    }
    let mut found: Vec<Group> = poses.into_iter().flatten().collect();
    let mut order: Vec<usize> = (0..found.len()).collect();
    // Reading order: rows by the tops of the boxes (a new row starts below half a pose's
    // height), left to right within a row.
    let mean_height = found.iter().map(|g| (g.bounds[3] - g.bounds[1] + 1) as f32).sum::<f32>() / found.len() as f32;
    order.sort_by_key(|&k| (found[k].bounds[1] as f32 / (mean_height * 0.5).max(1.0)) as u32 * 1_000_000 + found[k].bounds[0]);
    found = order.iter().map(|&k| found[k]).collect();
    let remap: Vec<usize> = {
        let mut inv = vec![0; order.len()];
        for (new, &old) in order.iter().enumerate() {
            inv[old] = new;
        }
        inv
    };
    // Before any cell is allocated: each is as large as the largest drawing.
    if found.len() > MAX_POSES {
        return Err(Error::format(
            path,
            format!(
                "{} separate drawings, more than the {MAX_POSES} poses a sheet may hold (specks of paint count too)",
                found.len()
            ),
        ));
    }
    check_group_sizes(&found, path)?;
    let side = |g: &Group, axis: usize| g.bounds[axis + 2] - g.bounds[axis] + 1;
    let margin = gap * 2;
    let cell = [
        found.iter().map(|g| side(g, 0)).max().unwrap_or(1) + 2 * margin,
        found.iter().map(|g| side(g, 1)).max().unwrap_or(1) + 2 * margin,
    ];
    let poses = found
        .iter()
        .enumerate()
        .map(|(k, g)| {
            // Centred in the cell; the origin may lie left of or above the sheet.
            let origin = [
                g.bounds[0] as i64 - ((cell[0] - side(g, 0)) / 2) as i64,
                g.bounds[1] as i64 - ((cell[1] - side(g, 1)) / 2) as i64,
            ];
            let mut image = Picture::filled(cell[0], cell[1], [0.0; 4]);
            for y in g.bounds[1]..=g.bounds[3] {
                for x in g.bounds[0]..=g.bounds[2] {
                    let i = y as usize * w + x as usize;
                    if drawn[i] && remap[pose_of_component[component[i]]] == k {
                        let (cx, cy) = ((x as i64 - origin[0]) as u32, (y as i64 - origin[1]) as u32);
                        image.pixels[(cy * cell[0] + cx) as usize] = sheet.get(x, y);
                    }
                }
            }
            Pose::new(cell_name(path, k), image).at(origin)
        })
        .collect();
    Ok(poses)
}

/// Poses that touch each other come out as one group several times the size of the others.
fn check_group_sizes(groups: &[Group], path: &Path) -> Result<()> {
    if groups.len() < 3 {
        return Ok(());
    }
    let mut areas: Vec<usize> = groups.iter().map(|g| g.area).collect();
    areas.sort_unstable();
    let median = areas[areas.len() / 2];
    if let Some((k, g)) = groups.iter().enumerate().find(|(_, g)| g.area * 10 > median * 18) {
        return Err(Error::format(
            path,
            format!(
                "the poses cannot be split by their alpha: drawing {k} (at {}, {}) covers {} pixels, \
                 {:.1}× the median pose, so poses must be touching; give the grid (--grid COLUMNSxROWS)",
                g.bounds[0],
                g.bounds[1],
                g.area,
                g.area as f32 / median.max(1) as f32
            ),
        ));
    }
    Ok(())
}

/// Poses read from a sheet or folder, and the sheet's size (`None` for a folder).
pub type LoadedPoses = (Vec<Pose>, Option<(u32, u32)>);

/// The poses at `path`: a folder of pose images (natural order), or a sheet cut by `layout`
/// (by its alpha when `None`), checked ([`check`]); and the sheet's size for a sheet.
///
/// # Errors
/// As [`Frames::load`], [`Picture::load`] and [`split_sheet`].
pub fn load_poses(path: &Path, layout: Option<Layout>) -> Result<LoadedPoses> {
    if path.is_dir() {
        let frames = Frames::load(path, &FrameCheck::default())?;
        let poses: Vec<Pose> = frames
            .names()
            .into_iter()
            .zip(frames.frames)
            .map(|(name, image)| Pose::new(name, image))
            .collect();
        check(&poses, path)?;
        Ok((poses, None))
    } else {
        let sheet = Picture::load(path)?;
        let poses = split_sheet(&sheet, path, layout.unwrap_or(Layout::Alpha))?;
        Ok((poses, Some((sheet.width, sheet.height))))
    }
}

/// The pixels of `sheet` where each of `poses` lies (its origin and size), for a second sheet
/// laid out like the first (a label map of the same poses); named as the poses.
pub fn crop_like(sheet: &Picture, poses: &[Pose]) -> Vec<Pose> {
    poses
        .iter()
        .map(|p| {
            let (w, h) = (p.image.width, p.image.height);
            let mut image = Picture::filled(w, h, [0.0; 4]);
            for y in 0..h {
                for x in 0..w {
                    let (sx, sy) = (p.origin[0] + i64::from(x), p.origin[1] + i64::from(y));
                    if sx >= 0 && sy >= 0 && sx < i64::from(sheet.width) && sy < i64::from(sheet.height) {
                        image.pixels[(y * w + x) as usize] = sheet.get(sx as u32, sy as u32);
                    }
                }
            }
            Pose::new(p.name.clone(), image).at(p.origin)
        })
        .collect()
}

/// Checks that `poses` can be compared: at least two, at most [`MAX_POSES`], one size, each with
/// something drawn. `source` names the sheet or folder in errors.
///
/// # Errors
/// [`Error::Format`] naming `source` and the pose.
pub fn check(poses: &[Pose], source: &Path) -> Result<()> {
    match poses {
        [] => return Err(Error::format(source, "nothing is drawn: every pixel is transparent")),
        [only] => {
            return Err(Error::format(
                source,
                format!(
                    "only one pose ({}): parts are found from how a character moves between at least two poses",
                    only.name
                ),
            ))
        }
        _ if poses.len() > MAX_POSES => {
            return Err(Error::format(
                source,
                format!("{} poses, more than the {MAX_POSES} this command compares", poses.len()),
            ))
        }
        _ => {}
    }
    let (w, h) = (poses[0].image.width, poses[0].image.height);
    let pairs = (poses.len() * (poses.len() - 1)) as u64;
    if pairs * u64::from(w) * u64::from(h) > MAX_PAIR_PIXELS {
        return Err(Error::limit(
            format!("correspondences between {} poses of {w}×{h} in {}", poses.len(), source.display()),
            pairs * u64::from(w) * u64::from(h),
            MAX_PAIR_PIXELS,
            "pixels",
        ));
    }
    for pose in poses {
        if (pose.image.width, pose.image.height) != (w, h) {
            return Err(Error::format(
                source,
                format!(
                    "pose {} is {}×{}, pose {} is {w}×{h}: every pose must be the same size",
                    pose.name, pose.image.width, pose.image.height, poses[0].name
                ),
            ));
        }
        if pose.area() == 0 {
            return Err(Error::format(
                source,
                format!("pose {} is empty: no pixel is at least half opaque", pose.name),
            ));
        }
    }
    Ok(())
}

/// Below this histogram intersection with every other pose, a pose is taken for another
/// character (poses of one character share their colours; see the test).
pub const SAME_PALETTE: f32 = 0.25;

/// The colour histogram of a pose's foreground: 8 levels per channel, summing to 1.
fn palette(pose: &Pose) -> Vec<f32> {
    let mut h = vec![0.0f32; 512];
    for (p, &m) in pose.image.pixels.iter().zip(&pose.mask) {
        if m {
            let q = |c: f32| ((c.clamp(0.0, 1.0) * 7.999) as usize).min(7);
            h[q(p[0]) * 64 + q(p[1]) * 8 + q(p[2])] += 1.0;
        }
    }
    let total: f32 = h.iter().sum::<f32>().max(1.0);
    h.iter().map(|v| v / total).collect()
}

/// Checks that the poses look like one character: each shares at least [`SAME_PALETTE`] of its
/// colour histogram with some other pose. `source` names the sheet or folder in errors.
///
/// # Errors
/// [`Error::Format`] naming `source`, the pose and its best overlap.
pub fn check_one_character(poses: &[Pose], source: &Path) -> Result<()> {
    let palettes: Vec<Vec<f32>> = poses.iter().map(palette).collect();
    for (k, a) in palettes.iter().enumerate() {
        let best = palettes
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != k)
            .map(|(_, b)| a.iter().zip(b).map(|(x, y)| x.min(*y)).sum::<f32>())
            .fold(0.0f32, f32::max);
        if best < SAME_PALETTE {
            return Err(Error::format(
                source,
                format!(
                    "pose {} shares at most {:.0} % of its colours with any other pose: the poses look like different \
                     characters (a sheet must show one character)",
                    poses[k].name,
                    best * 100.0
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blob(sheet: &mut Picture, centre: [u32; 2], r: u32) {
        for y in centre[1] - r..=centre[1] + r {
            for x in centre[0] - r..=centre[0] + r {
                let d = (x as f32 - centre[0] as f32).hypot(y as f32 - centre[1] as f32);
                if d <= r as f32 {
                    sheet.pixels[(y * sheet.width + x) as usize] = [1.0, 0.2, 0.1, 1.0];
                }
            }
        }
    }

    #[test]
    fn alpha_split_finds_poses_in_reading_order_with_detached_pieces_kept() {
        let mut sheet = Picture::filled(200, 100, [0.0; 4]);
        for (k, x) in [30u32, 100, 170].into_iter().enumerate() {
            blob(&mut sheet, [x, 30], 12 + k as u32);
            // A detached piece just below each pose: part of it.
            blob(&mut sheet, [x, 45], 2);
        }
        blob(&mut sheet, [60, 80], 12);
        let poses = split_sheet(&sheet, Path::new("s.png"), Layout::Alpha).expect("four poses");
        assert_eq!(poses.len(), 4);
        assert_eq!(poses[0].name, "s.png#0");
        // The first row is read left to right: growing blobs.
        assert!(poses[0].area() < poses[1].area() && poses[1].area() < poses[2].area());
        let mut alone = Picture::filled(100, 100, [0.0; 4]);
        blob(&mut alone, [50, 50], 12);
        blob(&mut alone, [50, 65], 2);
        assert_eq!(
            poses[0].area(),
            Pose::new("", alone).area(),
            "the detached piece belongs to its pose"
        );
    }

    #[test]
    fn bad_sheets_are_refused_with_the_reason() {
        let path = Path::new("sheet.png");
        let empty = Picture::filled(64, 64, [0.0; 4]);
        let err = split_sheet(&empty, path, Layout::Alpha).expect_err("empty").to_string();
        assert!(err.contains("sheet.png") && err.contains("transparent"), "{err}");
        let mut one = empty.clone();
        blob(&mut one, [30, 30], 10);
        let err = split_sheet(&one, path, Layout::Alpha).expect_err("one pose").to_string();
        assert!(err.contains("only one pose"), "{err}");
        let mut touching = Picture::filled(300, 60, [0.0; 4]);
        for x in [30, 80, 130] {
            blob(&mut touching, [x, 30], 12);
        }
        for x in (180..280).step_by(8) {
            blob(&mut touching, [x, 30], 12);
        }
        let err = split_sheet(&touching, path, Layout::Alpha).expect_err("touching").to_string();
        assert!(err.contains("--grid"), "{err}");
        let err = split_sheet(&one, path, Layout::Grid { columns: 5, rows: 1 })
            .expect_err("grid")
            .to_string();
        assert!(err.contains("5×1"), "{err}");
    }

    #[test]
    fn poses_of_one_character_pass_and_a_stranger_is_named() {
        let mut sheet = Picture::filled(200, 60, [0.0; 4]);
        for x in [30, 100] {
            blob(&mut sheet, [x, 30], 12);
        }
        let mut poses = split_sheet(&sheet, Path::new("s.png"), Layout::Alpha).expect("two poses");
        check_one_character(&poses, Path::new("s.png")).expect("one character");
        let stranger = poses[1].image.mapped(|p| if p[3] > 0.0 { [0.1, 0.3, 0.9, 1.0] } else { p });
        poses.push(Pose::new("blue", stranger));
        let err = check_one_character(&poses, Path::new("s.png"))
            .expect_err("a blue stranger")
            .to_string();
        assert!(err.contains("blue") && err.contains("different characters"), "{err}");
    }

    #[test]
    fn sheets_needing_too_many_correspondences_are_refused_before_any_is_made() {
        // 3 poses of 7000 × 7000 pixels: 6 ordered pairs × 49 M pixels, past the limit.
        let big = Pose {
            name: "big".into(),
            image: Picture {
                width: 7000,
                height: 7000,
                pixels: Vec::new(),
            },
            mask: Vec::new(),
            origin: [0, 0],
        };
        let err = check(&[big.clone(), big.clone(), big], Path::new("huge"))
            .expect_err("too big")
            .to_string();
        assert!(err.contains("correspondences between 3 poses") && err.contains("huge"), "{err}");
    }

    #[test]
    fn grid_split_skips_empty_cells() {
        let mut sheet = Picture::filled(120, 80, [0.0; 4]);
        blob(&mut sheet, [20, 20], 8);
        blob(&mut sheet, [60, 60], 8);
        let poses = split_sheet(&sheet, Path::new("g.png"), Layout::Grid { columns: 3, rows: 2 }).expect("two poses");
        assert_eq!(poses.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["g.png#0", "g.png#4"]);
        assert_eq!((poses[0].image.width, poses[0].image.height), (40, 40));
    }
}
