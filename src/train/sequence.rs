//! [`Frames`]: a sequence of drawn frames (DESIGN.md "Formats": a folder of frames in natural order) and its
//! seeded train/test split (the paper's 70/30).
//!
//! A sequence folder either holds the PNG frames directly or a `frames/` subfolder (what `puppet
//! synth` writes, with `truth.json` beside it, which is then loaded too).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::picture::Picture;
use crate::synth::rng::Rng;
use crate::synth::Truth;

/// The ground-truth file a synthetic sequence carries.
pub const TRUTH_FILE: &str = "truth.json";

/// Frames of one character, all the same size.
#[derive(Clone, Debug)]
pub struct Frames {
    /// The folder holding the frame files.
    pub dir: PathBuf,
    /// Frame files in natural order.
    pub files: Vec<PathBuf>,
    /// The decoded frames, same order.
    pub frames: Vec<Picture>,
    /// Ground truth, for synthetic sequences.
    pub truth: Option<Truth>,
}

impl Frames {
    /// Loads every PNG of `path` (or of `path/frames`), in natural order.
    ///
    /// # Errors
    /// [`Error::Io`] if the folder cannot be read; [`Error::Format`] naming the folder if it has
    /// no PNG, or naming the frame whose size differs from the first; [`Error::Image`] for a
    /// frame that does not decode; truth.json problems name that file.
    pub fn load(path: &Path) -> Result<Self> {
        let dir = if path.join("frames").is_dir() { path.join("frames") } else { path.to_path_buf() };
        let entries = std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))?;
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file() && p.extension().is_some_and(|x| x.eq_ignore_ascii_case("png")))
            .collect();
        files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
        if files.is_empty() {
            return Err(Error::format(&dir, "no PNG frames in this folder"));
        }
        let frames = files.iter().map(|f| Picture::load(f)).collect::<Result<Vec<_>>>()?;
        let (w, h) = (frames[0].width, frames[0].height);
        if let Some((file, f)) = files.iter().zip(&frames).find(|(_, f)| (f.width, f.height) != (w, h)) {
            return Err(Error::format(
                file,
                format!("frame is {}×{}, the sequence's first frame is {w}×{h}", f.width, f.height),
            ));
        }
        let truth_path = path.join(TRUTH_FILE);
        let truth = if truth_path.is_file() {
            let truth = Truth::load(&truth_path)?;
            if truth.frames.len() != files.len() {
                return Err(Error::format(
                    &truth_path,
                    format!("describes {} frames, the folder has {}", truth.frames.len(), files.len()),
                ));
            }
            Some(truth)
        } else {
            None
        };
        Ok(Frames { dir, files, frames, truth })
    }

    /// File names (no folder) of the frames, for logs and split records.
    pub fn names(&self) -> Vec<String> {
        self.files.iter().map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()).collect()
    }
}

/// A seeded split of `n` frames into (train, test) indices, each sorted. `round(n · fraction)`
/// frames are held out, at least one when `fraction > 0`.
///
/// # Errors
/// [`Error::Invalid`] if the split would leave no training frame, or no test frame although one
/// was asked for.
pub fn split(n: usize, test_fraction: f64, seed: u64) -> Result<(Vec<usize>, Vec<usize>)> {
    let tests = if test_fraction > 0.0 { ((n as f64 * test_fraction).round() as usize).max(1) } else { 0 };
    if n == 0 || tests >= n {
        return Err(Error::Invalid(format!(
            "{n} frames cannot be split with test_fraction {test_fraction}: no frame would be left for training"
        )));
    }
    let order = shuffled(n, &mut Rng::new(seed));
    let (mut test, mut train) = (order[..tests].to_vec(), order[tests..].to_vec());
    test.sort_unstable();
    train.sort_unstable();
    Ok((train, test))
}

/// `0..n` in a seeded random order (Fisher–Yates on the platform-independent SplitMix stream).
pub fn shuffled(n: usize, rng: &mut Rng) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        order.swap(i, rng.below(i + 1));
    }
    order
}

/// Natural order: digit runs compare as numbers, so `frame2` < `frame10`.
fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
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
                let ord = ta.len().cmp(&tb.len()).then_with(|| ta.cmp(tb)).then_with(|| na.len().cmp(&nb.len()));
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
    fn split_is_seeded_disjoint_and_rejects_empty_sides() {
        let (train, test) = split(10, 0.3, 7).unwrap();
        assert_eq!((train.len(), test.len()), (7, 3));
        assert!(test.iter().all(|t| !train.contains(t)));
        assert_eq!(split(10, 0.3, 7).unwrap(), (train.clone(), test.clone()));
        assert_ne!(split(10, 0.3, 8).unwrap().1, test, "another seed, another split");
        assert_eq!(split(3, 0.1, 1).unwrap().1.len(), 1, "at least one test frame");
        assert!(split(1, 0.3, 1).is_err());
        assert!(split(0, 0.0, 1).is_err());
        assert_eq!(split(4, 0.0, 1).unwrap(), (vec![0, 1, 2, 3], vec![]));
    }

    #[test]
    fn sequences_load_in_natural_order_and_reject_mixed_sizes() {
        let dir = tempfile::tempdir().unwrap();
        for (name, w) in [("f10.png", 4), ("f2.png", 4)] {
            Picture::filled(w, 3, [1.0; 4]).save_png(&dir.path().join(name)).unwrap();
        }
        let seq = Frames::load(dir.path()).unwrap();
        assert_eq!(seq.names(), ["f2.png", "f10.png"]);
        Picture::filled(5, 3, [1.0; 4]).save_png(&dir.path().join("f3.png")).unwrap();
        let err = Frames::load(dir.path()).unwrap_err().to_string();
        assert!(err.contains("f3.png") && err.contains("5×3"), "{err}");
        let empty = tempfile::tempdir().unwrap();
        assert!(Frames::load(empty.path()).unwrap_err().to_string().contains("no PNG"));
    }
}
