//! Sprite-sheet pages and their atlases. Frames go into a grid of untrimmed cells, page by page
//! (at most [`MAX_SHEET_SIDE`] px a side); beside each page `<page>.json` describes it in the
//! TexturePacker "JSON hash" form — what Phaser's `load.atlas`, PixiJS's `Spritesheet` and
//! Godot's and Aseprite's importers read: each frame's rectangle, source size, pivot and
//! duration, plus the animation's frame list (PixiJS `animations`) and its tag (Aseprite
//! `frameTags`, with "pingpong" for an animation that plays there and back). As TexturePacker's
//! multipack does, the first page of several lists the other pages' atlases in
//! `meta.related_multi_packs`, which PixiJS's `Assets.load` follows: loading the first atlas loads
//! every page, and its `animations` entry names frames on all of them.

use std::path::{Path, PathBuf};

use serde_json::{json, Map, Value};

use crate::atomic_file::write_atomic;
use crate::error::{Error, Result};
use crate::picture::Picture;

/// The largest side of a sprite-sheet page: frames past it go on further pages (4096 px is the
/// texture size every engine and GPU takes; a page is 64 MB while it is filled).
pub const MAX_SHEET_SIDE: u32 = 4096;

/// The sprite-sheet page being filled, and the plan of all pages.
pub(super) struct SpritePages {
    pages: Vec<PathBuf>,
    columns: usize,
    per_page: usize,
    cell: (u32, u32),
    page: image::RgbaImage,
    total: usize,
    delay_ms: u32,
    there_and_back: bool,
}

/// `path` with its extension replaced by `.json`: the atlas of a page.
pub fn atlas_path(page: &Path) -> PathBuf {
    page.with_extension("json")
}

impl SpritePages {
    /// Plans the pages of `total` frames of `width` × `height` in rows of at most `columns`
    /// (fewer if a page would pass [`MAX_SHEET_SIDE`]).
    pub(super) fn plan(path: &Path, columns: usize, total: usize, size: (u32, u32), delay_ms: u32, there_and_back: bool) -> Result<Self> {
        let (width, height) = size;
        if columns == 0 {
            return Err(Error::setting("sprite sheet columns", 0, "at least 1"));
        }
        if width > MAX_SHEET_SIDE || height > MAX_SHEET_SIDE {
            return Err(Error::limit(
                format!("a {width}×{height} frame on a sprite sheet"),
                u64::from(width.max(height)),
                u64::from(MAX_SHEET_SIDE),
                "px",
            ));
        }
        let columns = columns.min(total).min((MAX_SHEET_SIDE / width) as usize).max(1);
        let rows_per_page = (MAX_SHEET_SIDE / height) as usize;
        let per_page = columns * rows_per_page;
        let count = total.div_ceil(per_page);
        let stem = stem_of(path);
        let pages = (0..count)
            .map(|p| {
                if p == 0 {
                    path.to_path_buf()
                } else {
                    path.with_file_name(format!("{stem}_{}.png", p + 1))
                }
            })
            .collect();
        Ok(SpritePages {
            pages,
            columns,
            per_page,
            cell: size,
            page: image::RgbaImage::new(0, 0),
            total,
            delay_ms,
            there_and_back,
        })
    }

    /// Every file the sheet will write: pages and their atlases.
    pub(super) fn files(&self) -> impl Iterator<Item = PathBuf> + '_ {
        self.pages.iter().flat_map(|p| [p.clone(), atlas_path(p)])
    }

    /// Puts frame `k` in its cell, writing the previous page when `k` starts a new one; a page
    /// is as large as the frames it will hold.
    pub(super) fn put(&mut self, k: usize, frame: &Picture) -> Result<()> {
        let (w, h) = self.cell;
        if k.is_multiple_of(self.per_page) {
            if k > 0 {
                self.write(k / self.per_page - 1)?;
            }
            let on_page = (self.total - k).min(self.per_page);
            let columns = self.columns.min(on_page) as u32;
            let rows = on_page.div_ceil(self.columns) as u32;
            self.page = image::RgbaImage::new(columns * w, rows * h);
        }
        let (ox, oy) = self.origin(k);
        image::imageops::replace(&mut self.page, &frame.to_rgba8(), i64::from(ox), i64::from(oy));
        Ok(())
    }

    /// The top-left corner of frame `k`'s cell on its page.
    fn origin(&self, k: usize) -> (u32, u32) {
        let cell = k % self.per_page;
        let (w, h) = self.cell;
        ((cell % self.columns) as u32 * w, (cell / self.columns) as u32 * h)
    }

    /// The name of frame `k` in the atlases.
    fn frame_name(&self, k: usize) -> String {
        let digits = (self.total - 1).to_string().len().max(3);
        format!("{}_{k:0digits$}", self.animation_name())
    }

    /// The animation's name in the atlases: the first page's file stem.
    fn animation_name(&self) -> String {
        stem_of(&self.pages[0])
    }

    /// The atlas of page `page` (its frames, as written into the page now in memory).
    fn atlas(&self, page: usize) -> Value {
        let (w, h) = self.cell;
        let first = page * self.per_page;
        let frames: Map<String, Value> = (first..self.total.min(first + self.per_page))
            .map(|k| {
                let (x, y) = self.origin(k);
                let frame = json!({
                    "frame": {"x": x, "y": y, "w": w, "h": h},
                    "rotated": false,
                    "trimmed": false,
                    "spriteSourceSize": {"x": 0, "y": 0, "w": w, "h": h},
                    "sourceSize": {"w": w, "h": h},
                    // Phaser reads "pivot", PixiJS "anchor"; cells are untrimmed and share one
                    // frame, so the frame's centre keeps every pose in place.
                    "pivot": {"x": 0.5, "y": 0.5},
                    "anchor": {"x": 0.5, "y": 0.5},
                    "duration": self.delay_ms,
                });
                (self.frame_name(k), frame)
            })
            .collect();
        let forward: Vec<usize> = (0..self.total).collect();
        let back: Vec<usize> = if self.there_and_back {
            (1..self.total.saturating_sub(1)).rev().collect()
        } else {
            Vec::new()
        };
        let name = self.animation_name();
        let played: Vec<String> = forward.iter().chain(&back).map(|&k| self.frame_name(k)).collect();
        let file_name = |p: &Path| p.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let image = file_name(&self.pages[page]);
        let mut atlas = json!({
            "frames": frames,
            "animations": {name.clone(): played},
            "meta": {
                "app": "puppet",
                "version": env!("CARGO_PKG_VERSION"),
                "image": image,
                "format": "RGBA8888",
                "size": {"w": self.page.width(), "h": self.page.height()},
                "scale": "1",
                "frameTags": [{
                    "name": name,
                    "from": 0,
                    "to": self.total - 1,
                    "direction": if self.there_and_back { "pingpong" } else { "forward" },
                }],
            },
        });
        if page == 0 && self.pages.len() > 1 {
            let others: Vec<String> = self.pages[1..].iter().map(|p| file_name(&atlas_path(p))).collect();
            atlas["meta"]["related_multi_packs"] = json!(others);
        }
        atlas
    }

    fn write(&self, page: usize) -> Result<()> {
        let path = &self.pages[page];
        let mut bytes = Vec::new();
        self.page
            .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
            .map_err(|e| Error::image(path, format!("cannot encode PNG: {e}")))?;
        write_atomic(path, &bytes)?;
        let atlas = serde_json::to_vec_pretty(&self.atlas(page)).map_err(|e| Error::image(path, format!("cannot write the atlas: {e}")))?;
        write_atomic(&atlas_path(path), &atlas)
    }

    /// Writes the last page and returns every file written (pages, each followed by its atlas).
    pub(super) fn finish(self) -> Result<Vec<PathBuf>> {
        self.write(self.pages.len() - 1)?;
        Ok(self.files().collect())
    }
}

/// A file's stem, or "sprites".
fn stem_of(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "sprites".into(), |s| s.to_string_lossy().into_owned())
}
