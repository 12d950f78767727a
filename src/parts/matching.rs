//! Correspondences from the correspondence network (apes-part-extraction.md §3.1): every pose is
//! letterboxed into the network's square, its pixels get unit features, and each foreground
//! pixel of one pose lands on the foreground pixel of the other whose feature is most similar
//! (a nearest neighbour by cosine, as APES matches). Landings go back to the poses' pixels
//! through the letterbox.

use burn::tensor::{Device, Int, Tensor, TensorData};
use rayon::prelude::*;

use super::flow::{nearest_foreground, Correspondences, Flow};
use super::pose::SheetPose;
use crate::error::Result;
use crate::model::correspondence::CorrespondenceNet;
use crate::model::letterbox::Letterbox;
use crate::progress::Progress;

/// Poses the network sees at once (bounds the activations' memory).
const BATCH: usize = 8;
/// Rows of one similarity block when matching (bounds the `rows × pixels` similarity matrix).
const ROWS: usize = 2048;

/// A pose in the network's working square: its premultiplied planes `[4, S, S]` and which
/// working pixels hold the character.
#[derive(Clone, Debug)]
pub struct WorkingPose {
    /// The map between the pose's pixels and the working square.
    pub letterbox: Letterbox,
    /// Premultiplied RGBA, channel-major.
    pub planes: Vec<f32>,
    /// Working pixels with any coverage.
    pub mask: Vec<bool>,
}

impl WorkingPose {
    /// The pose letterboxed into `size`².
    pub fn new(pose: &SheetPose, size: u32) -> Self {
        let letterbox = Letterbox::new(pose.width() as u32, pose.height() as u32, size);
        let planes = letterbox.premultiplied_planes(&pose.image);
        let pixels = (size * size) as usize;
        let mask = planes[3 * pixels..].iter().map(|&a| a > 0.0).collect();
        WorkingPose { letterbox, planes, mask }
    }
}

/// The network's features of each of `planes` (`[4, S, S]` each), channel-major `[F, S, S]`.
pub fn features(net: &CorrespondenceNet, planes: &[&[f32]], size: usize, device: &Device) -> Vec<Vec<f32>> {
    let mut out = Vec::with_capacity(planes.len());
    for chunk in planes.chunks(BATCH) {
        let data: Vec<f32> = chunk.iter().flat_map(|p| p.iter().copied()).collect();
        let x = Tensor::<4>::from_data(TensorData::new(data, [chunk.len(), 4, size, size]), device);
        let f = net.forward(x);
        let [_, channels, _, _] = f.dims();
        let values = f.into_data().convert::<f32>().try_to_vec::<f32>().unwrap_or_default();
        out.extend(values.chunks(channels * size * size).map(<[f32]>::to_vec));
    }
    out
}

/// A pose's foreground pixels and their features as rows, ready to be matched.
#[derive(Clone, Debug)]
pub struct Foreground {
    /// The pose's pixel count.
    pixels: usize,
    /// Feature length.
    channels: usize,
    /// Each foreground pixel's index.
    index: Vec<usize>,
    /// Their features, `channels` each.
    rows: Vec<f32>,
}

impl Foreground {
    /// The pixels of `mask` from channel-major `features` of `channels` each.
    pub fn new(features: &[f32], mask: &[bool], channels: usize) -> Self {
        let pixels = mask.len();
        let index: Vec<usize> = (0..pixels).filter(|&i| mask[i]).collect();
        let rows = index
            .iter()
            .flat_map(|&i| (0..channels).map(move |c| features[c * pixels + i]))
            .collect();
        Foreground {
            pixels,
            channels,
            index,
            rows,
        }
    }
}

/// For each pixel of pose `a`, the pixel of pose `b` whose feature is most similar (None off
/// `a`'s foreground, or if `b` has none).
pub fn nearest(a: &Foreground, b: &Foreground, device: &Device) -> Vec<Option<usize>> {
    nearest_scored(a, b, device).into_iter().map(|m| m.map(|(q, _)| q)).collect()
}

/// [`nearest`] with each match's similarity (the features' dot product: their cosine, as the
/// network's features are unit vectors).
pub fn nearest_scored(a: &Foreground, b: &Foreground, device: &Device) -> Vec<Option<(usize, f32)>> {
    let channels = a.channels;
    let mut out = vec![None; a.pixels];
    if a.index.is_empty() || b.index.is_empty() {
        return out;
    }
    let targets = Tensor::<2>::from_data(TensorData::new(b.rows.clone(), [b.index.len(), channels]), device).transpose();
    for (block, pixels) in a.rows.chunks(ROWS * channels).zip(a.index.chunks(ROWS)) {
        let sources = Tensor::<2>::from_data(TensorData::new(block.to_vec(), [pixels.len(), channels]), device);
        let similarity = sources.matmul(targets.clone());
        let best: Tensor<2, Int> = similarity.clone().argmax(1);
        let score = similarity.max_dim(1);
        let best = best.into_data().convert::<i64>().try_to_vec::<i64>().unwrap_or_default();
        let score = score.into_data().convert::<f32>().try_to_vec::<f32>().unwrap_or_default();
        for ((&p, &q), &v) in pixels.iter().zip(&best).zip(&score) {
            out[p] = b.index.get(q as usize).map(|&j| (j, v));
        }
    }
    out
}

/// Correspondences between every ordered pair of `poses` from the network `net` working at
/// `size`² (landings off the character snap to its nearest pixel, as for optical flow).
///
/// # Errors
/// As [`Correspondences::set`] (a caller bug: poses of different sizes).
pub fn network_correspondences(
    net: &CorrespondenceNet,
    size: u32,
    poses: &[SheetPose],
    device: &Device,
    progress: &dyn Progress,
) -> Result<Correspondences> {
    let working: Vec<WorkingPose> = poses.par_iter().map(|p| WorkingPose::new(p, size)).collect();
    let planes: Vec<&[f32]> = working.iter().map(|w| w.planes.as_slice()).collect();
    let features = features(net, &planes, size as usize, device);
    let channels = features.first().map_or(0, |f| f.len() / (size * size) as usize);
    let foregrounds: Vec<Foreground> = features
        .iter()
        .zip(&working)
        .map(|(f, w)| Foreground::new(f, &w.mask, channels))
        .collect();
    let n = poses.len();
    let snaps: Vec<Vec<usize>> = poses
        .par_iter()
        .map(|p| nearest_foreground(&p.mask, p.width(), p.height()))
        .collect();
    let mut out = Correspondences::new(n, poses.first().map_or(0, |p| p.mask.len()));
    progress.stage("matching", (n * n.saturating_sub(1)) as u64);
    for s in 0..n {
        for t in (0..n).filter(|&t| t != s) {
            let matched = nearest(&foregrounds[s], &foregrounds[t], device);
            out.set(s, t, landing(&poses[s], &snaps[t], &working[s], &working[t], &matched))?;
            progress.advance(1);
        }
    }
    Ok(out)
}

/// The flow from pose `from` to the pose whose nearest-foreground map is `snap`, given each
/// working pixel's nearest match.
fn landing(from: &SheetPose, snap: &[usize], a: &WorkingPose, b: &WorkingPose, nearest: &[Option<usize>]) -> Flow {
    let (width, size) = (from.width(), a.letterbox.size as usize);
    let displacement: Vec<[f32; 2]> = (0..from.mask.len())
        .map(|i| {
            let (x, y) = ((i % width) as f32, (i / width) as f32);
            let w = a.letterbox.to_work([x + 0.5, y + 0.5]);
            let (wx, wy) = (w[0].floor(), w[1].floor());
            let inside = from.mask[i] && wx >= 0.0 && wy >= 0.0 && (wx as usize) < size && (wy as usize) < size;
            let matched = inside.then(|| nearest[wy as usize * size + wx as usize]).flatten();
            match matched {
                Some(q) => {
                    let p = b.letterbox.to_frame([(q % size) as f32 + 0.5, (q / size) as f32 + 0.5]);
                    [p[0] - 0.5 - x, p[1] - 0.5 - y]
                }
                None => [f32::NAN; 2],
            }
        })
        .collect();
    Flow::snapped(&displacement, from, snap)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit features at angle `angle(i)` for each of `n` pixels, channel-major (2 channels).
    fn circle(n: usize, angle: impl Fn(usize) -> f32) -> Vec<f32> {
        let (c, s): (Vec<f32>, Vec<f32>) = (0..n).map(|i| (angle(i).cos(), angle(i).sin())).unzip();
        [c, s].concat()
    }

    #[test]
    fn each_pixel_lands_on_the_most_similar_foreground_pixel() {
        let n = 3000; // more than one block of rows
        let step = std::f32::consts::TAU / n as f32;
        // The second pose is the first shifted by 7 pixels; its pixel 5 is off the character.
        let a = circle(n, |i| i as f32 * step);
        let b = circle(n, |i| (i + n - 7) as f32 * step);
        let mask_a = vec![true; n];
        let mut mask_b = vec![true; n];
        mask_b[12] = false;
        let device = crate::backend::device();
        let from = Foreground::new(&a, &mask_a, 2);
        let nearest = nearest(&from, &Foreground::new(&b, &mask_b, 2), &device);
        for (i, got) in nearest.iter().enumerate() {
            let want = (i + 7) % n;
            if want == 12 {
                assert!(matches!(got, Some(11) | Some(13)), "{i}: {got:?}");
            } else {
                assert_eq!(*got, Some(want), "pixel {i}");
            }
        }
        let none = super::nearest(&from, &Foreground::new(&b, &vec![false; n], 2), &device);
        assert!(none.iter().all(Option::is_none));
    }
}
