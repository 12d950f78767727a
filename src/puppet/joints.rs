//! Hinge joints (neural-puppet.md §3.1): "a hinge joint at the centroid of overlapping area of
//! two parts". Found on the artwork before meshing, so the joint point can be inserted as a
//! vertex of both meshes and the joint is exact at rest.

use super::artwork::Artwork;
use super::LayerKind;

/// Where two layers are hinged, before meshing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointSite {
    /// The back layer's index.
    pub a: usize,
    /// The front layer's index.
    pub b: usize,
    /// The hinge point in pixels.
    pub point: [f32; 2],
    /// Overlap area in px².
    pub overlap: usize,
}

/// How joints are found.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointOptions {
    /// Pixels count as opaque above this alpha.
    pub alpha_threshold: f32,
    /// Two layers are joined when their opaque regions share at least this many pixels.
    pub min_overlap: usize,
}

impl Default for JointOptions {
    fn default() -> Self {
        JointOptions {
            alpha_threshold: 0.5,
            min_overlap: 4,
        }
    }
}

/// The joint sites of `artwork`: every pair of layers (or every pair in
/// [`Artwork::joint_pairs`]) whose opaque regions overlap by at least `opts.min_overlap` pixels,
/// hinged at the overlap's centroid — moved to the nearest pixel centre inside the overlap (a
/// pixel whose neighbours all overlap too, when there is one) when the centroid falls outside
/// the overlap (a curved overlap) or on its edge, so it lies inside both parts' outlines.
///
/// Returns the sites and, for explicitly listed pairs, the pairs that do not overlap.
pub fn find_joints(artwork: &Artwork, opts: &JointOptions) -> (Vec<JointSite>, Vec<[usize; 2]>) {
    let n = artwork.layers.len();
    let pairs: Vec<[usize; 2]> = match &artwork.joint_pairs {
        Some(p) => p.iter().map(|&[a, b]| [a.min(b), a.max(b)]).collect(),
        None => (0..n).flat_map(|a| (a + 1..n).map(move |b| [a, b])).collect(),
    };
    let opaque: Vec<Vec<bool>> = artwork
        .layers
        .iter()
        .map(|l| l.picture.pixels.iter().map(|p| p[3] > opts.alpha_threshold).collect())
        .collect();
    let width = artwork.layers[0].picture.width as usize;
    let mut sites = Vec::new();
    let mut missing = Vec::new();
    for [a, b] in pairs {
        let overlap: Vec<usize> = (0..opaque[a].len()).filter(|&i| opaque[a][i] && opaque[b][i]).collect();
        if overlap.len() < opts.min_overlap.max(1) {
            if artwork.joint_pairs.is_some() {
                missing.push([a, b]);
            }
            continue;
        }
        let centre = |i: usize| [(i % width) as f32 + 0.5, (i / width) as f32 + 0.5];
        let sum = overlap.iter().fold([0.0f64; 2], |s, &i| {
            let c = centre(i);
            [s[0] + c[0] as f64, s[1] + c[1] as f64]
        });
        let centroid = [(sum[0] / overlap.len() as f64) as f32, (sum[1] / overlap.len() as f64) as f32];
        let in_overlap =
            |x: i64, y: i64| x >= 0 && y >= 0 && (x as usize) < width && overlap.binary_search(&(y as usize * width + x as usize)).is_ok();
        // A pixel whose 3 × 3 neighbourhood is all overlap lies a pixel inside both outlines,
        // which survives contour simplification; an edge pixel of the overlap may not.
        let interior = |i: usize| {
            let (x, y) = ((i % width) as i64, (i / width) as i64);
            (-1..=1).all(|dy| (-1..=1).all(|dx| in_overlap(x + dx, y + dy)))
        };
        let d2 = |i: usize| {
            let c = centre(i);
            (c[0] - centroid[0]).powi(2) + (c[1] - centroid[1]).powi(2)
        };
        let nearest = |candidates: &mut dyn Iterator<Item = usize>| candidates.min_by(|&i, &j| d2(i).total_cmp(&d2(j)));
        let under_centroid = centroid[1].floor() as usize * width + centroid[0].floor() as usize;
        let point = if overlap.binary_search(&under_centroid).is_ok() && interior(under_centroid) {
            centroid
        } else {
            // The nearest interior pixel; a overlap too thin to have one gives its nearest pixel.
            let pick = nearest(&mut overlap.iter().copied().filter(|&i| interior(i))).or_else(|| nearest(&mut overlap.iter().copied()));
            centre(pick.expect("overlap is not empty"))
        };
        sites.push(JointSite {
            a,
            b,
            point,
            overlap: overlap.len(),
        });
    }
    (sites, missing)
}

/// Names of body layers that no chain of joints connects to the root.
pub fn unconnected_body_layers(artwork: &Artwork, sites: &[JointSite]) -> Vec<String> {
    let n = artwork.layers.len();
    let mut reached = vec![false; n];
    reached[artwork.root] = true;
    let mut stack = vec![artwork.root];
    while let Some(l) = stack.pop() {
        for s in sites {
            let other = if s.a == l {
                s.b
            } else if s.b == l {
                s.a
            } else {
                continue;
            };
            if !reached[other] {
                reached[other] = true;
                stack.push(other);
            }
        }
    }
    (0..n)
        .filter(|&i| !reached[i] && artwork.layers[i].kind == LayerKind::Body)
        .map(|i| artwork.layers[i].name.clone())
        .collect()
}
