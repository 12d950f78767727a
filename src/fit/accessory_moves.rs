//! Accessories drawn off the rig's rule (issue 14). With an accessory rig the fit poses the body,
//! and the rig puts every accessory where its pins and bounded biharmonic weights say. A drawn
//! accessory is seldom exactly there — hair swings, a sleeve rides up, a back view shows the hair
//! from behind — and the rig, a linear map of the body, cannot follow. So after the body's fit the
//! accessory vertices may move from where the rig puts them, the body held: the pins stay exactly
//! on the rig's points (what the rig promises — the occlusion pins keep covering the parent's
//! outline — still holds), and the accessory as placed and moved pays the ARAP energy against its
//! rest shape that a body layer pays, at the same weight: it bends as a body layer may. Where the
//! rig's skinning stretches an accessory the moves may relax it too. Measured against paying for
//! the moves alone (the ARAP energy of the rest shape moved by them; docs/results.md "The
//! dressed walk"), this keeps the
//! accessories nearer their truth and on their parents at the same L2.

use std::sync::Arc;

use burn::tensor::{Device, Int, Tensor, TensorData};

use crate::error::Result;
use crate::geom::arap::ArapEnergy;
use crate::model::Model;
use crate::objective::arap_op::arap_loss;
use crate::puppet::{LayerKind, Puppet};

/// What the moves of a rigged model's accessories need on a device: which vertices may move,
/// where the accessories are among all vertices, and the ARAP energy of their rest shape.
#[derive(Clone, Debug)]
pub struct AccessoryMoves {
    /// `[1, Va, 1]`: 0 at the pins, 1 at every other accessory vertex (rows of the rig's map).
    movable: Tensor<3>,
    /// `[Va]`: the accessory vertices' global indices, in the rows of the rig's map.
    rows: Tensor<1, Int>,
    /// The ARAP energy of the accessories' triangles at rest (NDC of the working square).
    energy: Arc<ArapEnergy<f32>>,
    /// Working pixels → NDC.
    ndc_scale: f32,
}

impl AccessoryMoves {
    /// The moves of `model`'s accessories, or `None` if the model has no rig (its accessories,
    /// if any, are fitted like body layers).
    ///
    /// # Errors
    /// [`crate::Error::Geometry`] if an accessory's rest mesh is degenerate.
    pub fn new(model: &Model, device: &Device) -> Result<Option<Self>> {
        let (Some(map), Some(rig)) = (model.expansion.rig_map(), model.puppet.rig.as_ref()) else {
            return Ok(None);
        };
        let puppet = &model.puppet;
        let mut row_of = vec![u32::MAX; puppet.vertex_count()];
        for (r, &g) in map.rows.iter().enumerate() {
            row_of[g] = r as u32;
        }
        let triangles: Vec<[u32; 3]> = accessory_triangles(puppet).into_iter().map(|t| t.map(|g| row_of[g])).collect();
        let offsets = puppet.vertex_offsets();
        let mut movable = vec![1.0f32; map.rows.len()];
        for acc in &rig.accessories {
            for pin in &acc.pins {
                movable[row_of[offsets[acc.layer] + pin.vertex as usize] as usize] = 0.0;
            }
        }
        let ndc_scale = 2.0 / model.letterbox.size as f32;
        let all_rest = model.rest_work_points();
        let rest: Vec<[f32; 2]> = map.rows.iter().map(|&g| all_rest[g].map(|c| c * ndc_scale)).collect();
        let va = rest.len();
        let rows: Vec<i64> = map.rows.iter().map(|&g| g as i64).collect();
        Ok(Some(AccessoryMoves {
            movable: Tensor::from_data(TensorData::new(movable, [1, va, 1]), device),
            rows: Tensor::from_data(TensorData::new(rows, [va]), device),
            energy: Arc::new(ArapEnergy::new(&rest, &triangles)?),
            ndc_scale,
        }))
    }

    /// Number of accessory vertices (the rows of the rig's map).
    pub fn count(&self) -> usize {
        self.rows.dims()[0]
    }

    /// Moves `[B, Va, 2]` (working pixels) with the pins' zeroed: what is added to the rig's
    /// placement.
    pub fn pinned(&self, moves: Tensor<3>) -> Tensor<3> {
        moves * self.movable.clone()
    }

    /// The batch mean of the ARAP energy of the accessories of poses `[B, V, 2]` (every vertex,
    /// working pixels) against their rest shape, in the objective's units.
    ///
    /// # Errors
    /// As [`arap_loss`].
    pub fn energy(&self, poses: Tensor<3>) -> Result<Tensor<1>> {
        Ok(arap_loss(poses.select(1, self.rows.clone()).mul_scalar(self.ndc_scale), &self.energy)?.mean())
    }
}

/// Takes back the moves that turn accessory triangles over: while some accessory triangle is
/// turned over (or flat) against its rest orientation in `moved` but not in `rigged`, the same
/// pose without the moves, its corners go back to their places in `rigged`. Adam's steps are a
/// fixed length, and an accessory's thin triangles along its outline can flip in one; the ARAP
/// term only pays for a flip afterwards. A triangle the rig's own placement turns over is left to
/// the moves (they may turn it back). Ends within one pass per vertex (each pass returns at least
/// one).
pub fn unfold(puppet: &Puppet, rigged: &[[f32; 2]], moved: &mut [[f32; 2]]) {
    let triangles = accessory_triangles(puppet);
    let area = |pose: &[[f32; 2]], t: [usize; 3]| {
        let [a, b, c] = t.map(|i| pose[i]);
        (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    };
    let rest = puppet.rest_vertices();
    let turned = |pose: &[[f32; 2]], t: [usize; 3]| area(pose, t) * area(&rest, t).signum() <= 0.0;
    let watched: Vec<[usize; 3]> = triangles.into_iter().filter(|&t| !turned(rigged, t)).collect();
    loop {
        let mut returned = false;
        for &t in &watched {
            if turned(moved, t) {
                for i in t {
                    returned |= moved[i] != rigged[i];
                    moved[i] = rigged[i];
                }
            }
        }
        if !returned {
            break;
        }
    }
}

/// Every accessory layer's triangles, global vertex numbering.
fn accessory_triangles(puppet: &Puppet) -> Vec<[usize; 3]> {
    let offsets = puppet.vertex_offsets();
    puppet
        .layers
        .iter()
        .zip(offsets)
        .filter(|(layer, _)| layer.kind == LayerKind::Accessory)
        .flat_map(|(layer, o)| layer.mesh.triangles.iter().map(move |t| t.map(|i| o + i as usize)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{fit, FitOptions};
    use crate::progress::Silent;
    use crate::render::render_crisp;

    #[test]
    fn moves_fit_an_accessory_drawn_off_the_rig_with_the_body_and_pins_held() {
        let (model, device) = crate::test_util::untrained_model(crate::test_util::dressed_puppet(), 48);
        let puppet = &model.puppet;
        let rig = puppet.rig.as_ref().unwrap();
        let acc = &rig.accessories[0];
        let offsets = puppet.vertex_offsets();
        let (first, last) = (offsets[acc.layer], offsets[acc.layer + 1]);
        let pins: Vec<usize> = acc.pins.iter().map(|p| first + p.vertex as usize).collect();
        // The untrained model decodes the rest pose; the frame shows the body at rest and the
        // accessory turned by 10° about its pins' centre, where no rig of that body puts it.
        let rest = puppet.rest_vertices();
        let centre = pins.iter().fold([0.0f32; 2], |c, &g| [c[0] + rest[g][0], c[1] + rest[g][1]]);
        let centre = centre.map(|c| c / pins.len() as f32);
        let (s, c) = 10f32.to_radians().sin_cos();
        let mut drawn = rest.clone();
        for p in &mut drawn[first..last] {
            let d = [p[0] - centre[0], p[1] - centre[1]];
            *p = [centre[0] + c * d[0] - s * d[1], centre[1] + s * d[0] + c * d[1]];
        }
        let frame = render_crisp(puppet, &drawn, puppet.width, puppet.height).unwrap();
        let fit_with = |accessory_steps: usize| {
            let options = FitOptions {
                latent_steps: 0,
                vertex_steps: 1,
                vertex_rounds: 1,
                limb_search: None,
                accessory_steps,
                ..FitOptions::default()
            };
            fit(&model, &[&frame], &options, &device, &Silent).unwrap().remove(0)
        };
        let l2 = |pose: &[[f32; 2]]| crate::metrics::l2(&render_crisp(puppet, pose, puppet.width, puppet.height).unwrap(), &frame);
        let (rigged, moved) = (fit_with(0), fit_with(60));
        assert!(l2(&moved) < 0.6 * l2(&rigged), "{} → {}", l2(&rigged), l2(&moved));
        for (g, (a, b)) in rigged.iter().zip(&moved).enumerate() {
            if g < first || g >= last || pins.contains(&g) {
                assert_eq!(a, b, "vertex {g} is the body's or a pin");
            }
        }
        assert!((first..last).any(|g| rigged[g] != moved[g]), "the accessory moved");
        // What commands draw keeps the moves (the model's own outfit); another outfit's rig
        // places its accessories anew.
        assert_eq!(model.pose_from(&model, &moved), moved);
        let other = model.wearing(puppet.clone()).unwrap();
        let apart = crate::test_util::largest_distance(&other.pose_from(&model, &moved), &rigged);
        assert!(apart < 1e-3, "{apart} px from the rig's placement");
    }

    #[test]
    fn moves_that_turn_triangles_over_are_taken_back_and_the_others_kept() {
        let puppet = crate::test_util::dressed_puppet();
        let rigged = puppet.rest_vertices();
        let layer = puppet.rig.as_ref().unwrap().accessories[0].layer;
        let first = puppet.vertex_offsets()[layer];
        let mesh = &puppet.layers[layer].mesh;
        let t = mesh.triangles[0];
        let [a, b, c] = t.map(|i| first + i as usize);
        let mut moved = rigged.clone();
        // Corner a thrown past the opposite side turns triangle 0 over; a small move elsewhere
        // (a vertex of no triangle that turns) stays.
        let far = [
            2.0 * rigged[b][0] + 2.0 * rigged[c][0] - 3.0 * rigged[a][0],
            2.0 * rigged[b][1] + 2.0 * rigged[c][1] - 3.0 * rigged[a][1],
        ];
        moved[a] = [(rigged[a][0] + far[0]) / 2.0, (rigged[a][1] + far[1]) / 2.0];
        let last = first + mesh.vertices.len() - 1;
        moved[last][0] += 0.05;
        let mut unfolded = moved.clone();
        unfold(&puppet, &rigged, &mut unfolded);
        assert_eq!(unfolded[a], rigged[a], "the thrown corner is back");
        assert_eq!(unfolded[last], moved[last], "the small move stays");
        let area = |p: &[[f32; 2]], t: [u32; 3]| {
            let [a, b, c] = t.map(|i| p[first + i as usize]);
            (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        };
        assert!(mesh.triangles.iter().all(|&t| area(&unfolded, t) * area(&rigged, t) > 0.0));
        assert!(area(&moved, t) * area(&rigged, t) < 0.0, "the test turns a triangle over");
        // A triangle the rig's placement turns over, which the moves turn back, keeps its moves.
        // (The rig's placement is `moved` now, the moves bring the rest pose back.)
        let mut turned_back = rigged.clone();
        unfold(&puppet, &moved, &mut turned_back);
        assert_eq!(turned_back, rigged, "moves that turn the rig's flipped triangle back stay");
    }

    #[test]
    fn a_model_without_a_rig_has_no_moves_and_only_bending_accessories_costs() {
        let (plain, device) = crate::test_util::untrained_model(crate::test_util::layered_puppet(), 48);
        assert!(AccessoryMoves::new(&plain, &device).unwrap().is_none());
        let (dressed, device) = crate::test_util::untrained_model(crate::test_util::dressed_puppet(), 48);
        let moves = AccessoryMoves::new(&dressed, &device).unwrap().unwrap();
        // The rest pose, the same turned by 0.3 rad and shifted, and squashed vertically.
        let rest = dressed.rest_work_points();
        let (s, c) = 0.3f32.sin_cos();
        let poses: Vec<f32> = [
            rest.clone(),
            rest.iter()
                .map(|p| [c * p[0] - s * p[1] + 3.0, s * p[0] + c * p[1] - 2.0])
                .collect(),
            rest.iter().map(|p| [p[0], 0.7 * p[1]]).collect(),
        ]
        .concat()
        .into_iter()
        .flatten()
        .collect();
        let poses = Tensor::<3>::from_data(TensorData::new(poses, [3, rest.len(), 2]), &device);
        let each = |k: usize| -> f32 { moves.energy(poses.clone().narrow(0, k, 1)).unwrap().into_scalar() };
        assert!(each(0).abs() < 1e-9 && each(1).abs() < 1e-6, "{} {}", each(0), each(1));
        assert!(each(2) > 1e-4, "squashing costs {}", each(2));
        let ones = moves.pinned(Tensor::<3>::ones([1, moves.count(), 2], &device));
        let kept: f32 = ones.sum().into_scalar();
        let pins = dressed
            .puppet
            .rig
            .as_ref()
            .unwrap()
            .accessories
            .iter()
            .map(|a| a.pins.len())
            .sum::<usize>();
        assert_eq!(kept as usize, 2 * (moves.count() - pins), "pins do not move");
    }
}
