//! Correspondences between the poses of a sheet (apes-part-extraction.md §3.1): for every ordered
//! pair of poses, where each foreground pixel of the first lies in the second. They come from
//! the generator's truth (the oracle, `synth`), or from a correspondence method.

use super::pose::SheetPose;
use super::superpixels::{Superpixels, NONE};
use crate::error::{Error, Result};
use crate::geom::similarity::{Moments, Similarity};

/// Where each pixel of a source pose lies in a target pose, pixels; NaN where it has no
/// correspondence (background, or a pixel the method could not place).
#[derive(Clone, Debug, PartialEq)]
pub struct Flow {
    /// Row-major target positions, one per source pixel.
    pub to: Vec<[f32; 2]>,
}

impl Flow {
    /// The target of pixel `i`, if it has one.
    pub fn at(&self, i: usize) -> Option<[f32; 2]> {
        let p = self.to[i];
        (p[0].is_finite() && p[1].is_finite()).then_some(p)
    }
}

/// The flows between every ordered pair of `poses` poses of `width × height` pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Correspondences {
    poses: usize,
    pixels: usize,
    flows: Vec<Option<Flow>>,
}

impl Correspondences {
    /// No flow yet between `poses` poses of `pixels` pixels each.
    pub fn new(poses: usize, pixels: usize) -> Self {
        Correspondences {
            poses,
            pixels,
            flows: vec![None; poses * poses],
        }
    }

    /// Number of poses.
    pub fn poses(&self) -> usize {
        self.poses
    }

    /// Stores the flow from pose `s` to pose `t`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `s == t`, either is out of range, or the flow has the wrong size.
    pub fn set(&mut self, s: usize, t: usize, flow: Flow) -> Result<()> {
        if s == t || s >= self.poses || t >= self.poses {
            return Err(Error::mismatch(
                "flow between poses",
                format!("{s} → {t}"),
                format!("two different poses below {}", self.poses),
            ));
        }
        if flow.to.len() != self.pixels {
            return Err(Error::mismatch("flow size", flow.to.len(), self.pixels));
        }
        self.flows[s * self.poses + t] = Some(flow);
        Ok(())
    }

    /// The flow from `s` to `t`, if one was stored.
    pub fn get(&self, s: usize, t: usize) -> Option<&Flow> {
        self.flows.get(s * self.poses + t).and_then(Option::as_ref)
    }

    /// The flow from `s` to `t` to change, if one was stored.
    pub fn get_mut(&mut self, s: usize, t: usize) -> Option<&mut Flow> {
        self.flows.get_mut(s * self.poses + t).and_then(Option::as_mut)
    }

    /// Drops correspondences that do not come back: pixel `x` of pose `s` keeps its target `q`
    /// only if the flow from `t` at `q`'s pixel returns within `tolerance` pixels of `x` (the
    /// forward–backward check of optical flow; it removes most of a flow's mistakes, and every
    /// correspondence into a part hidden in the other pose, which flow cannot give anyway).
    /// Returns the share of correspondences kept.
    pub fn keep_consistent(&mut self, width: usize, tolerance: f32) -> f64 {
        let mut kept = (0usize, 0usize);
        let mut checked = self.flows.clone();
        let n = self.poses;
        self.round_trips(width, tolerance, |s, t, i, back| {
            kept.1 += 1;
            if back {
                kept.0 += 1;
            } else if let Some(flow) = checked[s * n + t].as_mut() {
                flow.to[i] = [f32::NAN; 2];
            }
        });
        self.flows = checked;
        if kept.1 == 0 {
            1.0
        } else {
            kept.0 as f64 / kept.1 as f64
        }
    }

    /// For each pose, the share of its correspondences into the other poses that come back
    /// within `tolerance` pixels (the check of [`Correspondences::keep_consistent`]; 1 for a pose
    /// with none). A pose no articulation of the others explains — a back view, a turn — has
    /// few that do.
    pub fn consistency(&self, width: usize, tolerance: f32) -> Vec<f64> {
        let mut counts = vec![(0usize, 0usize); self.poses];
        self.round_trips(width, tolerance, |s, _, _, back| {
            counts[s].1 += 1;
            counts[s].0 += usize::from(back);
        });
        counts
            .into_iter()
            .map(|(back, all)| if all == 0 { 1.0 } else { back as f64 / all as f64 })
            .collect()
    }

    /// These correspondences among the poses `keep` only, renumbered in that order.
    ///
    /// # Panics
    /// If a pose of `keep` is out of range (a caller bug).
    pub fn subset(&self, keep: &[usize]) -> Correspondences {
        let n = keep.len();
        let mut out = Correspondences::new(n, self.pixels);
        for (a, &s) in keep.iter().enumerate() {
            for (b, &t) in keep.iter().enumerate() {
                out.flows[a * n + b] = self.flows[s * self.poses + t].clone();
            }
        }
        out
    }

    /// Calls `visit(s, t, i, back)` for every pixel `i` of every pose `s` with a correspondence
    /// into another pose `t`: `back` when the flow from `t` at its target's pixel returns
    /// within `tolerance` pixels of `i` (poses `width` wide).
    fn round_trips(&self, width: usize, tolerance: f32, mut visit: impl FnMut(usize, usize, usize, bool)) {
        let n = self.poses;
        for s in 0..n {
            for t in (0..n).filter(|&t| t != s) {
                let (Some(forward), Some(backward)) = (self.get(s, t), self.get(t, s)) else {
                    continue;
                };
                let height = forward.to.len() / width.max(1);
                for i in 0..forward.to.len() {
                    let Some(p) = forward.at(i) else { continue };
                    let (x, y) = (p[0].round(), p[1].round());
                    let back = (x >= 0.0 && y >= 0.0 && (x as usize) < width && (y as usize) < height)
                        .then(|| backward.at(y as usize * width + x as usize))
                        .flatten();
                    let home = [(i % width) as f32, (i / width) as f32];
                    visit(s, t, i, back.is_some_and(|b| (b[0] - home[0]).hypot(b[1] - home[1]) <= tolerance));
                }
            }
        }
    }

    /// Drops correspondences their superpixel's motion does not explain: for every ordered pair
    /// and every superpixel of the source pose (`superpixels[s]`, poses `width` wide), the
    /// least-squares similarity of its correspondences is fitted, those landing more than
    /// `tolerance` pixels from it are set aside, the similarity is refitted to the rest, and
    /// every correspondence more than `tolerance` from the refit goes. A superpixel is nearly
    /// rigid, so what no similarity of it explains is a matching error (a learned or optical
    /// flow's stray matches, which the part finder's least squares would otherwise read as
    /// motion). Returns the share kept.
    pub fn keep_rigid(&mut self, superpixels: &[Superpixels], width: usize, tolerance: f32) -> f64 {
        let n = self.poses;
        let (mut kept, mut total) = (0usize, 0usize);
        for (s, pixels) in superpixels.iter().enumerate().take(n) {
            let (labels, count) = (&pixels.labels, pixels.count);
            for t in (0..n).filter(|&t| t != s) {
                let Some(flow) = self.flows[s * n + t].as_mut() else { continue };
                let home = |i: usize| [(i % width) as f32, (i / width) as f32];
                let fit = |keep: &dyn Fn(usize, [f32; 2]) -> bool| -> Vec<Option<Similarity>> {
                    let mut moments = vec![Moments::default(); count];
                    for (i, &l) in labels.iter().enumerate() {
                        if let Some(q) = flow.at(i).filter(|&q| l != NONE && keep(i, q)) {
                            moments[l as usize].add(home(i), q);
                        }
                    }
                    moments.iter().map(Moments::fit).collect()
                };
                let near = |fits: &[Option<Similarity>], i: usize, q: [f32; 2]| {
                    fits[labels[i] as usize].is_none_or(|f| {
                        let p = f.apply(home(i));
                        (p[0] - q[0]).hypot(p[1] - q[1]) <= tolerance
                    })
                };
                let first = fit(&|_, _| true);
                let second = fit(&|i, q| near(&first, i, q));
                for (i, &l) in labels.iter().enumerate() {
                    let Some(q) = flow.at(i) else { continue };
                    total += 1;
                    if l == NONE || near(&second, i, q) {
                        kept += 1;
                    } else {
                        flow.to[i] = [f32::NAN; 2];
                    }
                }
            }
        }
        if total == 0 {
            1.0
        } else {
            kept as f64 / total as f64
        }
    }

    /// Checks that every ordered pair of different poses has a flow.
    ///
    /// # Errors
    /// [`Error::Mismatch`] naming the first missing pair.
    pub fn check_complete(&self) -> Result<()> {
        for s in 0..self.poses {
            for t in (0..self.poses).filter(|&t| t != s) {
                if self.get(s, t).is_none() {
                    return Err(Error::mismatch(
                        "correspondences",
                        format!("none from pose {s} to pose {t}"),
                        "one for every pair of poses",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// The magic number that opens a Middlebury `.flo` file (the float 202021.25, "PIEH").
const FLO_MAGIC: f32 = 202_021.25;

/// Displacements past this size mark "unknown" in `.flo` files (Middlebury's convention).
const FLO_UNKNOWN: f32 = 1e9;

/// Reads the bytes of a Middlebury `.flo` optical-flow file (what OpenCV's `writeOpticalFlow`
/// writes: magic, width, height as little-endian 32-bit values, then `(dx, dy)` per pixel,
/// row-major) that must be `width × height`; `path` only names the file in errors. Returns the
/// displacement of each pixel, NaN where the file marks it unknown or holds a non-finite value.
///
/// # Errors
/// [`Error::Format`] naming `path` for a wrong magic number, another size, or a length that is
/// not the header plus `width × height` pairs.
pub fn parse_flo(bytes: &[u8], path: &std::path::Path, width: u32, height: u32) -> Result<Vec<[f32; 2]>> {
    let word = |k: usize| bytes.get(4 * k..4 * k + 4).map(|b| [b[0], b[1], b[2], b[3]]);
    let (Some(magic), Some(w), Some(h)) = (word(0), word(1), word(2)) else {
        return Err(Error::format(path, "too short for a .flo header (12 bytes)"));
    };
    if f32::from_le_bytes(magic) != FLO_MAGIC {
        return Err(Error::format(
            path,
            "not a Middlebury .flo file (its first four bytes are not \"PIEH\")",
        ));
    }
    let (w, h) = (i32::from_le_bytes(w), i32::from_le_bytes(h));
    if i64::from(w) != i64::from(width) || i64::from(h) != i64::from(height) {
        return Err(Error::format(path, format!("the flow is {w}×{h}, the poses are {width}×{height}")));
    }
    let pixels = width as usize * height as usize;
    if bytes.len() != 12 + 8 * pixels {
        return Err(Error::format(
            path,
            format!("{} bytes, expected {} for a {width}×{height} flow", bytes.len(), 12 + 8 * pixels),
        ));
    }
    Ok(bytes[12..]
        .chunks_exact(8)
        .map(|c| {
            let d = [
                f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                f32::from_le_bytes([c[4], c[5], c[6], c[7]]),
            ];
            if d.iter().all(|v| v.is_finite() && v.abs() < FLO_UNKNOWN) {
                d
            } else {
                [f32::NAN; 2]
            }
        })
        .collect())
}

impl Flow {
    /// The flow from pose `from` to pose `to` given per-pixel displacements (optical flow):
    /// each foreground pixel of `from` goes to `x + d`, moved to the nearest foreground pixel of
    /// `to` when it lands off the character (as APES does for RAFT and COTR, §5.3).
    ///
    /// # Panics
    /// If the sizes differ (a caller bug).
    pub fn from_displacements(displacement: &[[f32; 2]], from: &SheetPose, to: &SheetPose) -> Flow {
        Self::snapped(displacement, from, &nearest_foreground(&to.mask, to.width(), to.height()))
    }

    /// [`Flow::from_displacements`] with the target pose's nearest-foreground map already made
    /// (one per pose, not one per pair).
    pub(super) fn snapped(displacement: &[[f32; 2]], from: &SheetPose, nearest: &[usize]) -> Flow {
        let (w, h) = (from.width(), from.height());
        assert!(
            displacement.len() == w * h && nearest.len() == w * h,
            "flow and poses differ in size"
        );
        let to = from
            .mask
            .iter()
            .zip(displacement)
            .enumerate()
            .map(|(i, (&m, d))| {
                if !m || !d[0].is_finite() || !d[1].is_finite() {
                    return [f32::NAN; 2];
                }
                let q = [(i % w) as f32 + d[0], (i / w) as f32 + d[1]];
                let (x, y) = (
                    q[0].round().clamp(0.0, (w - 1) as f32) as usize,
                    q[1].round().clamp(0.0, (h - 1) as f32) as usize,
                );
                match nearest[y * w + x] {
                    k if k == usize::MAX => [f32::NAN; 2],
                    k if k == y * w + x && (q[0] - x as f32).abs() <= 0.5 && (q[1] - y as f32).abs() <= 0.5 => q,
                    k => [(k % w) as f32, (k / w) as f32],
                }
            })
            .collect();
        Flow { to }
    }
}

/// For every pixel, the index of a nearest foreground pixel (8-connected breadth-first search
/// from all foreground pixels at once), `usize::MAX` if there is none.
pub(super) fn nearest_foreground(mask: &[bool], w: usize, h: usize) -> Vec<usize> {
    let mut nearest = vec![usize::MAX; mask.len()];
    let mut queue = std::collections::VecDeque::new();
    for (i, &m) in mask.iter().enumerate() {
        if m {
            nearest[i] = i;
            queue.push_back(i);
        }
    }
    while let Some(i) = queue.pop_front() {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, -1), (-1, 1), (1, 1)] {
            let (nx, ny) = (x + dx, y + dy);
            if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h {
                let j = ny as usize * w + nx as usize;
                if nearest[j] == usize::MAX {
                    nearest[j] = nearest[i];
                    queue.push_back(j);
                }
            }
        }
    }
    nearest
}

/// Reads the flows between every ordered pair of `poses` from `dir`: `flow_SSS_TTT.flo` from
/// pose `SSS` to pose `TTT` (numbered from 0 in the poses' order, three digits), as optical
/// flow ([`Flow::from_displacements`]).
///
/// # Errors
/// [`Error::Io`] naming a missing or unreadable file; as [`parse_flo`].
pub fn read_flows(dir: &std::path::Path, poses: &[SheetPose]) -> Result<Correspondences> {
    let (w, h) = (poses[0].image.width, poses[0].image.height);
    let mut out = Correspondences::new(poses.len(), w as usize * h as usize);
    let nearest: Vec<Vec<usize>> = poses.iter().map(|p| nearest_foreground(&p.mask, p.width(), p.height())).collect();
    for s in 0..poses.len() {
        for t in (0..poses.len()).filter(|&t| t != s) {
            let path = dir.join(format!("flow_{s:03}_{t:03}.flo"));
            let bytes = crate::user_file::read_bytes(&path, 12 + 8 * u64::from(w) * u64::from(h))?;
            let displacement = parse_flo(&bytes, &path, w, h)?;
            out.set(s, t, Flow::snapped(&displacement, &poses[s], &nearest[t]))?;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::picture::Picture;

    /// Identity flows between `n` poses of 4×1 pixels, but pose `odd`'s flows into the others,
    /// which send every pixel to pixel 0.
    fn flows_with_one_odd(n: usize, odd: usize) -> Correspondences {
        let mut flows = Correspondences::new(n, 4);
        for s in 0..n {
            for t in (0..n).filter(|&t| t != s) {
                let to = (0..4).map(|i| if s == odd { [0.0, 0.0] } else { [i as f32, 0.0] }).collect();
                flows.set(s, t, Flow { to }).unwrap();
            }
        }
        flows
    }

    #[test]
    fn a_pose_whose_matches_do_not_come_back_scores_low_and_a_subset_renumbers() {
        let flows = flows_with_one_odd(4, 2);
        let shares = flows.consistency(4, 0.5);
        // Pose 2's pixels 1–3 land on pixel 0, whose way back is home only for pixel 0.
        assert_eq!(shares[2], 0.25);
        for k in [0, 1, 3] {
            // Into pose 2, only pixel 0 comes back; into the others, all do.
            assert!((shares[k] - (2.0 * 4.0 + 1.0) / 12.0).abs() < 1e-9, "pose {k}: {}", shares[k]);
        }
        let kept = flows.subset(&[3, 0]);
        assert_eq!(kept.poses(), 2);
        assert_eq!(kept.get(0, 1), flows.get(3, 0));
        assert_eq!(kept.get(1, 0), flows.get(0, 3));
        assert!(kept.get(0, 0).is_none());
    }

    #[test]
    fn stray_matches_go_and_the_superpixels_motion_stays() {
        // One 10×10 superpixel moved by a rotation and shift; two of its correspondences are
        // strays 6 px off, and a second superpixel of one pixel has nothing to be checked by.
        let (w, h) = (12, 10);
        let motion = Similarity::new(0.3, 1.1, [2.0, 1.0]);
        let mut labels = vec![0u32; w * h];
        labels[11] = 1;
        labels[23] = NONE;
        let superpixels = Superpixels {
            labels: labels.clone(),
            count: 2,
            sizes: vec![w * h - 2, 1],
            centroids: vec![[5.0, 5.0], [11.0, 0.0]],
        };
        let to: Vec<[f32; 2]> = (0..w * h)
            .map(|i| {
                let q = motion.apply([(i % w) as f32, (i / w) as f32]);
                if i == 40 || i == 77 {
                    [q[0] + 6.0, q[1]]
                } else {
                    q
                }
            })
            .collect();
        let mut flows = Correspondences::new(2, w * h);
        flows.set(0, 1, Flow { to: to.clone() }).unwrap();
        flows.set(1, 0, Flow { to }).unwrap();
        let kept = flows.keep_rigid(&[superpixels.clone(), superpixels], w, 2.0);
        let forward = flows.get(0, 1).unwrap();
        assert!(forward.at(40).is_none() && forward.at(77).is_none());
        assert!((0..w * h).filter(|&i| i != 40 && i != 77).all(|i| forward.at(i).is_some()));
        assert!((kept - (w * h - 2) as f64 / (w * h) as f64).abs() < 1e-9, "{kept}");
    }

    fn flo(w: i32, h: i32, d: &[[f32; 2]]) -> Vec<u8> {
        let mut bytes = Vec::new();
        bytes.extend(FLO_MAGIC.to_le_bytes());
        bytes.extend(w.to_le_bytes());
        bytes.extend(h.to_le_bytes());
        for p in d {
            bytes.extend(p[0].to_le_bytes());
            bytes.extend(p[1].to_le_bytes());
        }
        bytes
    }

    #[test]
    fn flo_files_are_read_and_landings_off_the_character_move_onto_it() {
        let path = std::path::Path::new("f.flo");
        // 4 × 1 poses: pixel 0 drawn in the first, pixels 2 and 3 in the second.
        let mut a = Picture::filled(4, 1, [0.0; 4]);
        a.pixels[0] = [1.0; 4];
        let mut b = Picture::filled(4, 1, [0.0; 4]);
        b.pixels[2] = [1.0; 4];
        b.pixels[3] = [1.0; 4];
        let (a, b) = (SheetPose::new("a", a), SheetPose::new("b", b));
        let d = parse_flo(&flo(4, 1, &[[1.0, 0.0], [0.0, 0.0], [2e9, 0.0], [0.0, 0.0]]), path, 4, 1).expect("a valid file");
        assert!(d[2][0].is_nan(), "unknown flow is NaN");
        // Pixel 0 lands on pixel 1, off the character: moved to pixel 2.
        let flow = Flow::from_displacements(&d, &a, &b);
        assert_eq!(flow.at(0), Some([2.0, 0.0]));
        assert_eq!(flow.at(1), None);
        let d = parse_flo(&flo(4, 1, &[[2.25, 0.0], [0.0; 2], [0.0; 2], [0.0; 2]]), path, 4, 1).expect("valid");
        assert_eq!(
            Flow::from_displacements(&d, &a, &b).at(0),
            Some([2.25, 0.0]),
            "a landing on the character is kept"
        );
        // Forward–backward: pixel 0 goes to 2 and comes back; a flow whose way back from 2
        // lands on 3 fails the check.
        let mut flows = Correspondences::new(2, 4);
        flows
            .set(
                0,
                1,
                Flow {
                    to: vec![[2.0, 0.0], [f32::NAN; 2], [f32::NAN; 2], [f32::NAN; 2]],
                },
            )
            .expect("a pair");
        flows
            .set(
                1,
                0,
                Flow {
                    to: vec![[f32::NAN; 2], [f32::NAN; 2], [0.0, 0.0], [0.0, 0.0]],
                },
            )
            .expect("a pair");
        assert_eq!(flows.clone().keep_consistent(4, 1.0), 1.0);
        flows
            .set(
                1,
                0,
                Flow {
                    to: vec![[f32::NAN; 2], [f32::NAN; 2], [3.0, 0.0], [0.0, 0.0]],
                },
            )
            .expect("a pair");
        let kept = flows.keep_consistent(4, 1.0);
        assert!((kept - 1.0 / 3.0).abs() < 1e-9, "{kept}");
        assert_eq!(flows.get(0, 1).and_then(|f| f.at(0)), None);
        assert_eq!(flows.get(1, 0).and_then(|f| f.at(3)), Some([0.0, 0.0]));
        for (bytes, needle) in [
            (flo(4, 1, &[[0.0; 2]; 3]), "bytes"),
            (flo(5, 1, &[[0.0; 2]; 5]), "5×1"),
            (b"PIEX0000".to_vec(), "header"),
            (vec![0u8; 44], "PIEH"),
        ] {
            let err = parse_flo(&bytes, path, 4, 1).expect_err(needle).to_string();
            assert!(err.contains("f.flo") && err.contains(needle), "{err}");
        }
    }
}
