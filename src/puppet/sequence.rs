//! [`Frames`]: a sequence of drawn frames (DESIGN.md "Formats": a folder of frames in natural
//! order), read within limits and checked against the size they must have before any pixel is
//! decoded.
//!
//! A sequence folder either holds the PNG frames directly or a `frames/` subfolder (what `puppet
//! synth` writes, with `truth.json` and other files beside it).

use std::path::{Path, PathBuf};

use crate::error::{Context, Error, FolderKind, Result};
use crate::picture::{ImageLimits, Picture};

/// How many frames, and how many pixels in all, a sequence may hold by default: frames take 16
/// bytes per pixel in memory, so 64 Mpx is 1 GB (4096 frames at 128², 163 at 640²).
pub const DEFAULT_MAX_FRAMES: usize = 4096;
/// See [`DEFAULT_MAX_FRAMES`].
pub const DEFAULT_MAX_TOTAL_PIXELS: u64 = 64 << 20;

/// What frames a sequence must be, checked before decoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameCheck {
    /// The size every frame must have (the puppet's); `None`: the first frame's.
    pub size: Option<(u32, u32)>,
    /// The largest single frame.
    pub image: ImageLimits,
    /// The most frames.
    pub max_frames: usize,
    /// The most pixels over all frames.
    pub max_total_pixels: u64,
}

impl Default for FrameCheck {
    fn default() -> Self {
        FrameCheck {
            size: None,
            image: ImageLimits::default(),
            max_frames: DEFAULT_MAX_FRAMES,
            max_total_pixels: DEFAULT_MAX_TOTAL_PIXELS,
        }
    }
}

impl FrameCheck {
    /// Frames that must be `width` × `height` (a puppet's frames), default limits otherwise.
    pub fn of_size(width: u32, height: u32) -> Self {
        FrameCheck {
            size: Some((width, height)),
            ..FrameCheck::default()
        }
    }
}

/// Frames of one character, all the same size.
#[derive(Clone, Debug)]
pub struct Frames {
    /// The folder given (a synthetic sequence's root, with `truth.json`, or the frames' folder).
    pub root: PathBuf,
    /// The folder holding the frame files.
    pub dir: PathBuf,
    /// Frame files in natural order.
    pub files: Vec<PathBuf>,
    /// The decoded frames, same order.
    pub frames: Vec<Picture>,
}

impl Frames {
    /// The frame files of `path` (or of `path/frames`), in natural order.
    ///
    /// # Errors
    /// [`Error::Io`] if the folder cannot be read; [`Error::WrongFolder`] if it has no PNG;
    /// [`Error::Limit`] for more than `check.max_frames`.
    pub fn list(path: &Path, check: &FrameCheck) -> Result<(PathBuf, Vec<PathBuf>)> {
        let dir = if path.join("frames").is_dir() {
            path.join("frames")
        } else {
            path.to_path_buf()
        };
        if !dir.is_dir() {
            return Err(Error::WrongFolder {
                path: path.to_path_buf(),
                expected: FolderKind::Sequence,
                problem: if path.exists() { "not a folder" } else { "no such folder" }.into(),
            });
        }
        let entries = std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))?;
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file() && p.extension().is_some_and(|x| x.eq_ignore_ascii_case("png")))
            .collect();
        if files.is_empty() {
            return Err(Error::WrongFolder {
                path: dir,
                expected: FolderKind::Sequence,
                problem: "no PNG frames in this folder".into(),
            });
        }
        if files.len() > check.max_frames {
            return Err(Error::limit("the sequence", files.len() as u64, check.max_frames as u64, "frames").with_path(&dir));
        }
        files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
        Ok((dir, files))
    }

    /// Loads every frame of `path` (or of `path/frames`), in natural order; every frame must load.
    ///
    /// # Errors
    /// As [`Frames::list`]; otherwise every frame that does not decode or has the wrong size,
    /// each naming its file ([`Error::Partial`] when several).
    pub fn load(path: &Path, check: &FrameCheck) -> Result<Self> {
        let (frames, problems) = Self::load_each(path, check)?;
        Error::collect(problems.into_iter().map(|(_, e)| e).collect())?;
        Ok(frames)
    }

    /// Loads the frames of `path` that can be loaded, and each file that cannot with its error
    /// (so a command over many frames can do the rest and report the bad ones).
    ///
    /// # Errors
    /// As [`Frames::list`]; [`Error::Limit`] if the frames hold more pixels than
    /// `check.max_total_pixels`; every frame is bad.
    pub fn load_each(path: &Path, check: &FrameCheck) -> Result<(Self, Vec<(PathBuf, Error)>)> {
        let (dir, all) = Self::list(path, check)?;
        let mut size = check.size;
        let (mut files, mut frames, mut problems) = (Vec::new(), Vec::new(), Vec::new());
        let mut total = 0u64;
        for file in all {
            let loaded = match Picture::file_size(&file) {
                Err(e) => Err(e),
                Ok((w, h)) => {
                    let expected = *size.get_or_insert((w, h));
                    if (w, h) == expected {
                        total += u64::from(w) * u64::from(h);
                        if total > check.max_total_pixels {
                            // The sequence as a whole is too large: no frame is worth reading.
                            return Err(Error::limit("the sequence's frames", total, check.max_total_pixels, "pixels").with_path(&dir));
                        }
                        Picture::load_within(&file, &check.image)
                    } else {
                        let which = if check.size.is_some() {
                            "the puppet's"
                        } else {
                            "the first frame's"
                        };
                        let expected = format!("{}×{} ({which})", expected.0, expected.1);
                        Err(Error::mismatch("the frame", format!("{w}×{h}"), expected).with_path(&file))
                    }
                }
            };
            match loaded {
                Ok(picture) => {
                    files.push(file);
                    frames.push(picture);
                }
                Err(e) => problems.push((file, e)),
            }
        }
        if frames.is_empty() {
            let errors = problems.into_iter().map(|(_, e)| e).collect();
            return Err(Error::collect(errors)
                .err()
                .unwrap_or_else(|| Error::format(&dir, "no frame could be read")));
        }
        Ok((
            Frames {
                root: path.to_path_buf(),
                dir,
                files,
                frames,
            },
            problems,
        ))
    }

    /// File names (no folder) of the frames, for logs, split records and output names.
    pub fn names(&self) -> Vec<String> {
        self.files
            .iter()
            .map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())
            .collect()
    }
}

/// Reads one frame that must be `check.size` (checked from the header before decoding).
///
/// # Errors
/// [`Error::Io`]/[`Error::Image`] if it cannot be read; [`Error::Mismatch`] (about `path`) for
/// another size; [`Error::Limit`] if it is too large.
pub fn load_frame(path: &Path, check: &FrameCheck) -> Result<Picture> {
    let (w, h) = Picture::file_size(path)?;
    if let Some((ew, eh)) = check.size {
        if (w, h) != (ew, eh) {
            return Err(Error::mismatch(
                "the frame",
                format!("{w}×{h}"),
                format!("{ew}×{eh} (the puppet's)"),
            ))
            .at_path(path);
        }
    }
    Picture::load_within(path, &check.image)
}

/// Natural order: digit runs compare as numbers, so `frame2` < `frame10`.
pub(super) fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    let (mut a, mut b) = (a.chars().peekable(), b.chars().peekable());
    loop {
        match (a.peek().copied(), b.peek().copied()) {
            (None, None) => return std::cmp::Ordering::Equal,
            (None, Some(_)) => return std::cmp::Ordering::Less,
            (Some(_), None) => return std::cmp::Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let take = |it: &mut std::iter::Peekable<std::str::Chars>| {
                    let mut s = String::new();
                    while let Some(c) = it.peek().copied().filter(char::is_ascii_digit) {
                        s.push(c);
                        it.next();
                    }
                    s
                };
                let (na, nb) = (take(&mut a), take(&mut b));
                let (ta, tb) = (na.trim_start_matches('0'), nb.trim_start_matches('0'));
                let ord = ta
                    .len()
                    .cmp(&tb.len())
                    .then_with(|| ta.cmp(tb))
                    .then_with(|| na.len().cmp(&nb.len()));
                if ord != std::cmp::Ordering::Equal {
                    return ord;
                }
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(&y);
                }
                a.next();
                b.next();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order_compares_numbers_by_value() {
        let mut names = vec!["walk10.png", "walk2.png", "walk1.png", "idle.png", "walk02b.png"];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(names, ["idle.png", "walk1.png", "walk2.png", "walk02b.png", "walk10.png"]);
    }

    #[test]
    fn sequences_load_in_natural_order_and_name_every_bad_frame() {
        let dir = tempfile::tempdir().unwrap();
        for (name, w) in [("f10.png", 4), ("f2.png", 4)] {
            Picture::filled(w, 3, [1.0; 4]).save_png(&dir.path().join(name)).unwrap();
        }
        let seq = Frames::load(dir.path(), &FrameCheck::default()).unwrap();
        assert_eq!(seq.names(), ["f2.png", "f10.png"]);
        Picture::filled(5, 3, [1.0; 4]).save_png(&dir.path().join("f3.png")).unwrap();
        std::fs::write(dir.path().join("f4.png"), b"\x89PNG truncated").unwrap();
        let err = Frames::load(dir.path(), &FrameCheck::default()).unwrap_err().to_string();
        assert!(err.contains("f3.png") && err.contains("5×3") && err.contains("f4.png"), "{err}");
        let (good, bad) = Frames::load_each(dir.path(), &FrameCheck::default()).unwrap();
        assert_eq!((good.names(), bad.len()), (vec!["f2.png".to_string(), "f10.png".to_string()], 2));
        let puppet_size = FrameCheck::of_size(5, 3);
        let (good, bad) = Frames::load_each(dir.path(), &puppet_size).unwrap();
        assert_eq!((good.names(), bad.len()), (vec!["f3.png".to_string()], 3));
        let empty = tempfile::tempdir().unwrap();
        let err = Frames::load(empty.path(), &FrameCheck::default()).unwrap_err();
        assert!(
            matches!(
                err,
                Error::WrongFolder {
                    expected: FolderKind::Sequence,
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn frame_count_and_total_pixels_are_bounded_before_decoding() {
        let dir = tempfile::tempdir().unwrap();
        for k in 0..3 {
            Picture::filled(10, 10, [1.0; 4])
                .save_png(&dir.path().join(format!("f{k}.png")))
                .unwrap();
        }
        let few = FrameCheck {
            max_frames: 2,
            ..FrameCheck::default()
        };
        assert!(matches!(
            Frames::load(dir.path(), &few).unwrap_err().innermost(),
            Error::Limit { amount: 3, limit: 2, .. }
        ));
        let small = FrameCheck {
            max_total_pixels: 250,
            ..FrameCheck::default()
        };
        assert!(matches!(
            Frames::load_each(dir.path(), &small).unwrap_err().innermost(),
            Error::Limit { amount: 300, .. }
        ));
    }
}
