//! Weights solved across an accessory's narrow gaps.
//!
//! Bounded biharmonic weights spread along the mesh, so the two sides of a narrow notch (two
//! strands of hair a pixel apart, a pupil and the stroke under it) take the weights of pins far
//! apart round it. Under a turn or a squash their translations differ by more than the gap, the
//! notch pinches shut and encloses a hole. So the weights are solved on the layer with its gaps
//! narrower than about twice a radius closed (a morphological closing of its mask, which only
//! adds pixels), and read back at the layer's own vertices: what lies that close moves together
//! (the two sides of a notch, a pupil and its stroke). The layer keeps its own mesh and outline;
//! only the weights see the bridge.

use super::deform::bind_point;
use super::mask::Mask;
use crate::geom::triangle::barycentric;
use crate::geom::triangle_grid::TriangleGrid;
use crate::puppet::Mesh;

/// `alpha` (a `width` × `height` layer) with its gaps narrower than about `2 · radius` pixels
/// filled (alpha 1 where closing its mask above `threshold` adds a pixel), or `None` if that
/// adds no pixel.
pub fn closed_alpha(alpha: &[f32], width: u32, height: u32, threshold: f32, radius: f32) -> Option<Vec<f32>> {
    let mask = |inside: Vec<bool>| Mask { width, height, inside };
    let layer = mask(alpha.iter().map(|&a| a > threshold).collect());
    let grown = mask(layer.distance().into_iter().map(|d| d > radius).collect());
    let beyond = grown.distance();
    let mut added = false;
    let closed = alpha
        .iter()
        .zip(&layer.inside)
        .zip(&beyond)
        .map(|((&a, &inside), &d)| {
            if !inside && d > radius {
                added = true;
                1.0
            } else {
                a
            }
        })
        .collect();
    added.then_some(closed)
}

/// The weights (`V × H`, row-major) of `mesh`'s vertices read off `wide_weights`, solved on
/// `wide` (a mesh of the same layer with its gaps closed): a pin's own vertex (`handles[j]`)
/// gets exactly handle `j`, any other vertex the interpolation of the `wide` triangle holding
/// it (or nearest it), so each row sums to one as the wide rows do.
pub fn read_back(mesh: &Mesh, handles: &[u32], wide: &Mesh, wide_weights: &[f64]) -> Vec<f64> {
    let h = handles.len();
    let corners = |t: &[u32; 3]| t.map(|i| wide.vertices[i as usize]);
    let grid = TriangleGrid::new(wide.triangles.iter().map(corners).collect(), 4.0);
    let mut out = vec![0.0; mesh.vertices.len() * h];
    for (v, (row, &p)) in out.chunks_exact_mut(h).zip(&mesh.vertices).enumerate() {
        if let Some(j) = handles.iter().position(|&hv| hv as usize == v) {
            row[j] = 1.0;
            continue;
        }
        let held = grid
            .holding(p)
            .and_then(|t| Some((t, barycentric(corners(&wide.triangles[t]), p)?)));
        let (t, b) = held.unwrap_or_else(|| {
            let (t, b) = bind_point(wide, p);
            (t as usize, b)
        });
        for (&corner, &bk) in wide.triangles[t].iter().zip(&b) {
            let from = &wide_weights[corner as usize * h..(corner as usize + 1) * h];
            row.iter_mut().zip(from).for_each(|(r, &w)| *r += f64::from(bk) * w);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::bbw::{bbw, BbwOptions};
    use crate::puppet::mesh::{mesh_alpha, MeshOptions};

    /// A 40 × 40 layer: a bar 24 px wide with a notch `notch` px wide cut 16 px into it from
    /// the top, and a separate block `gap` px to its right.
    fn notched(notch: u32, gap: u32) -> Vec<f32> {
        let (w, h) = (40u32, 40u32);
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let bar = (4..28).contains(&x) && (4..28).contains(&y) && !((16..16 + notch).contains(&x) && y < 20);
                let block = (28 + gap..38).contains(&x) && (4..28).contains(&y);
                if bar || block {
                    1.0
                } else {
                    0.0
                }
            })
            .collect()
    }

    #[test]
    fn closing_fills_a_notch_and_not_a_wider_gap() {
        let alpha = notched(2, 6);
        let closed = closed_alpha(&alpha, 40, 40, 0.5, 2.0).expect("the notch is filled");
        let at = |a: &[f32], x: u32, y: u32| a[(y * 40 + x) as usize];
        assert_eq!(at(&alpha, 17, 10), 0.0);
        assert_eq!(at(&closed, 17, 10), 1.0, "inside the 2-px notch");
        assert_eq!(at(&closed, 31, 10), 0.0, "the 6-px gap stays open");
        assert!(closed.iter().zip(&alpha).all(|(c, a)| c >= a), "a closing only adds");
        assert!(closed_alpha(&notched(8, 6), 40, 40, 0.5, 2.0).is_none_or(|c| at(&c, 19, 10) == 0.0));
        assert!(closed_alpha(&alpha, 40, 40, 0.5, 0.0).is_none(), "radius 0 closes nothing");
    }

    #[test]
    fn weights_read_back_keep_pins_exact_and_rows_summing_to_one() {
        let alpha = notched(2, 6);
        let closed = closed_alpha(&alpha, 40, 40, 0.5, 2.0).unwrap();
        // One pin either side of the notch's mouth, one at the bottom, one on the block.
        let points = [[14.5, 5.5], [19.5, 5.5], [16.5, 26.5], [35.5, 16.5]];
        let options = MeshOptions::default();
        let own = mesh_alpha(&alpha, 40, 40, &points, &options).unwrap();
        let wide = mesh_alpha(&closed, 40, 40, &points, &options).unwrap();
        let positions: Vec<[f64; 2]> = wide.mesh.vertices.iter().map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
        let solved = bbw(&positions, &wide.mesh.triangles, &wide.required, &BbwOptions::DEFAULT).unwrap();
        let weights = read_back(&own.mesh, &own.required, &wide.mesh, &solved.weights);
        let h = points.len();
        for (v, row) in weights.chunks_exact(h).enumerate() {
            assert!(
                (row.iter().sum::<f64>() - 1.0).abs() < 1e-5,
                "row {v} sums to {}",
                row.iter().sum::<f64>()
            );
            assert!(row.iter().all(|&w| (-1e-5..=1.0 + 1e-5).contains(&w)), "row {v}: {row:?}");
            if let Some(j) = own.required.iter().position(|&r| r as usize == v) {
                assert!(row.iter().enumerate().all(|(k, &w)| w == if k == j { 1.0 } else { 0.0 }));
            }
        }
        // Across the notch's mouth the two sides weigh the two pins alike once bridged; on the
        // layer's own mesh each side leans on its own pin.
        let near = |mesh: &Mesh, p: [f32; 2]| {
            (0..mesh.vertices.len())
                .min_by(|&a, &b| {
                    let d = |v: usize| (mesh.vertices[v][0] - p[0]).hypot(mesh.vertices[v][1] - p[1]);
                    d(a).total_cmp(&d(b))
                })
                .unwrap()
        };
        let (left, right) = (near(&own.mesh, [15.5, 12.0]), near(&own.mesh, [18.5, 12.0]));
        let lean = |w: &[f64], v: usize| w[v * h] - w[v * h + 1];
        let plain = bbw(
            &own.mesh
                .vertices
                .iter()
                .map(|p| [f64::from(p[0]), f64::from(p[1])])
                .collect::<Vec<_>>(),
            &own.mesh.triangles,
            &own.required,
            &BbwOptions::DEFAULT,
        )
        .unwrap()
        .weights;
        let apart = |w: &[f64]| (lean(w, left) - lean(w, right)).abs();
        assert!(
            apart(&weights) < 0.5 * apart(&plain),
            "bridged {} against plain {}",
            apart(&weights),
            apart(&plain)
        );
    }
}
