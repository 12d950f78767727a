//! From latents to every vertex of the puppet (issue 14): the network predicts the puppet's free
//! vertices ([`Puppet::free_vertices`]: all of them, or with an accessory rig the body's), and
//! the rig's affine map ([`RigMap`]) places the accessories on them inside the tensor graph, so
//! a loss on the rendered accessories reaches the body vertices under them.
//!
//! The map works in frame pixels, `a = M·b + c`; the network in working pixels, `w = s·f + o`
//! (the letterbox). In working pixels the same map reads `a_w = M·b_w + (s·c + o·(1 − Σ_k m_k))`,
//! so only the constant changes. The rows of M are dense here: accessories are a few hundred
//! vertices and their rows touch most of a body part, and one `[Va, Vb]` matrix product per batch
//! is cheaper than a gather of scattered terms.

use burn::tensor::{Device, Int, Tensor, TensorData};

use super::deformation::{rest_tensor, DeformationNet};
use super::letterbox::Letterbox;
use crate::puppet::Puppet;
use crate::rig::deform::RigMap;

/// How a puppet's vertices follow the network's outputs: the rest pose of the free vertices, and
/// with a rig its map to the accessories. Plain data; [`Expansion::decoder`] puts it on a device.
#[derive(Clone, Debug, PartialEq)]
pub struct Expansion {
    /// Global indices of the free vertices, in the network's output order.
    free: Vec<usize>,
    /// Rest positions of the free vertices, working pixels.
    rest: Vec<[f32; 2]>,
    /// The rig's map (frame pixels), if the puppet has a rig.
    rig: Option<RigMap>,
    /// `[Va, Vb]` row-major: the map's coefficients over the free vertices.
    matrix: Vec<f32>,
    /// `[Va, 2]`: the map's constants in working pixels.
    offsets: Vec<f32>,
    /// For each global vertex, its row in `[free; accessories]`.
    order: Vec<i64>,
    vertex_count: usize,
}

impl Expansion {
    /// The expansion of `puppet` under `letterbox`.
    pub fn new(puppet: &Puppet, letterbox: &Letterbox) -> Self {
        let free = puppet.free_vertices();
        let all_rest = puppet.rest_vertices();
        let rest = free.iter().map(|&g| letterbox.to_work(all_rest[g])).collect();
        let rig = puppet.rig.as_ref().map(|rig| RigMap::new(puppet, rig));
        let mut column = vec![usize::MAX; all_rest.len()];
        for (k, &g) in free.iter().enumerate() {
            column[g] = k;
        }
        let (mut matrix, mut offsets) = (Vec::new(), Vec::new());
        let mut order = vec![0i64; all_rest.len()];
        for (k, &g) in free.iter().enumerate() {
            order[g] = k as i64;
        }
        if let Some(map) = &rig {
            matrix = vec![0.0f32; map.rows.len() * free.len()];
            for (r, ((&g, terms), c)) in map.rows.iter().zip(&map.coefficients).zip(&map.offsets).enumerate() {
                let mut sum = 0.0f32;
                for &(k, m) in terms {
                    matrix[r * free.len() + column[k]] += m;
                    sum += m;
                }
                let (s, o) = (letterbox.scale, letterbox.offset);
                offsets.extend([s * c[0] + o[0] * (1.0 - sum), s * c[1] + o[1] * (1.0 - sum)]);
                order[g] = (free.len() + r) as i64;
            }
        }
        Expansion {
            free,
            rest,
            rig,
            matrix,
            offsets,
            order,
            vertex_count: all_rest.len(),
        }
    }

    /// Number of free vertices (the network's outputs).
    pub fn free_count(&self) -> usize {
        self.free.len()
    }

    /// Whether accessories follow a rig.
    pub fn is_rigged(&self) -> bool {
        self.rig.is_some()
    }

    /// The rig's map in frame pixels, if any.
    pub fn rig_map(&self) -> Option<&RigMap> {
        self.rig.as_ref()
    }

    /// The free vertices of a pose of every vertex (any units).
    pub fn free_of(&self, pose: &[[f32; 2]]) -> Vec<[f32; 2]> {
        self.free.iter().map(|&g| pose[g]).collect()
    }

    /// Every vertex, frame pixels, from the free vertices in frame pixels.
    ///
    /// # Panics
    /// If `free` is not one position per free vertex (a caller bug).
    pub fn expand_frame(&self, free: &[[f32; 2]]) -> Vec<[f32; 2]> {
        assert_eq!(free.len(), self.free.len(), "one position per free vertex");
        let mut pose = vec![[0.0f32; 2]; self.vertex_count];
        for (&g, &p) in self.free.iter().zip(free) {
            pose[g] = p;
        }
        if let Some(map) = &self.rig {
            map.apply(&mut pose);
        }
        pose
    }

    /// The tensors of the expansion on `device`.
    pub fn decoder(&self, device: &Device) -> Decoder {
        let (vb, va) = (self.free.len(), self.offsets.len() / 2);
        let rest = rest_tensor(&self.rest, device);
        let rig = (va > 0).then(|| RigTensors {
            matrix: Tensor::from_data(TensorData::new(self.matrix.clone(), [va, vb]), device),
            offsets: Tensor::from_data(TensorData::new(self.offsets.clone(), [va, 2]), device),
            order: Tensor::from_data(TensorData::new(self.order.clone(), [self.order.len()]), device),
        });
        Decoder { rest, rig }
    }
}

/// [`Expansion`] on a device: turns the network's displacements of the free vertices into every
/// vertex, working pixels.
#[derive(Clone, Debug)]
pub struct Decoder {
    /// `[Vb, 2]` rest positions of the free vertices.
    pub rest: Tensor<2>,
    rig: Option<RigTensors>,
}

#[derive(Clone, Debug)]
struct RigTensors {
    matrix: Tensor<2>,
    offsets: Tensor<2>,
    order: Tensor<1, Int>,
}

impl Decoder {
    /// Every vertex `[B, V, 2]` (working pixels) the network `net` puts at latents `z [B, Z]`.
    pub fn vertices(&self, net: &DeformationNet, z: Tensor<2>) -> Tensor<3> {
        self.expand(net.vertices(z, &self.rest))
    }

    /// Free vertices `[B, Vb, 2]` → every vertex `[B, V, 2]` (working pixels); the identity
    /// without a rig.
    pub fn expand(&self, free: Tensor<3>) -> Tensor<3> {
        self.place(free, None)
    }

    /// [`Decoder::expand`] with every accessory vertex moved by `moves` `[B, Va, 2]` (working
    /// pixels, in the rows of the rig's map) from where the rig puts it; `free` alone without a
    /// rig.
    pub fn expand_moved(&self, free: Tensor<3>, moves: Tensor<3>) -> Tensor<3> {
        self.place(free, Some(moves))
    }

    fn place(&self, free: Tensor<3>, moves: Option<Tensor<3>>) -> Tensor<3> {
        let Some(rig) = &self.rig else {
            return free;
        };
        let [batch, vb, _] = free.dims();
        let va = rig.offsets.dims()[0];
        // [B, Vb, 2] → [Vb, 2B], one product for the whole batch, → [B, Va, 2].
        let columns = free.clone().swap_dims(0, 1).reshape([vb, 2 * batch]);
        let mut placed = rig.matrix.clone().matmul(columns).reshape([va, batch, 2]).swap_dims(0, 1) + rig.offsets.clone().unsqueeze::<3>();
        if let Some(moves) = moves {
            placed = placed + moves;
        }
        Tensor::cat(vec![free, placed], 1).select(1, rig.order.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::dressed_puppet as rigged;

    #[test]
    fn the_tensor_expansion_is_the_rig_map_in_working_pixels() {
        let puppet = rigged();
        let letterbox = Letterbox::new(puppet.width, puppet.height, 64);
        let e = Expansion::new(&puppet, &letterbox);
        assert!(e.is_rigged() && e.free_count() < puppet.vertex_count());
        // Two poses of the free vertices (frame pixels): a shear and a turn.
        let free_rest = e.free_of(&puppet.rest_vertices());
        let poses: Vec<Vec<[f32; 2]>> = [(0.2f32, 0.0f32), (0.0, 0.3)]
            .iter()
            .map(|&(shear, turn)| {
                let (s, c) = turn.sin_cos();
                free_rest
                    .iter()
                    .map(|p| [c * p[0] - s * p[1] + shear * p[1], s * p[0] + c * p[1]])
                    .collect()
            })
            .collect();
        let device = crate::backend::device();
        let work: Vec<f32> = poses.iter().flatten().flat_map(|&p| letterbox.to_work(p)).collect();
        let tensor = Tensor::<3>::from_data(TensorData::new(work, [2, e.free_count(), 2]), &device);
        let expanded: Vec<f32> = e.decoder(&device).expand(tensor).into_data().try_into_vec::<f32>().unwrap();
        for (b, pose) in poses.iter().enumerate() {
            let want = e.expand_frame(pose);
            for (g, w) in want.iter().enumerate() {
                let at = (b * puppet.vertex_count() + g) * 2;
                let got = letterbox.to_frame([expanded[at], expanded[at + 1]]);
                assert!(
                    (got[0] - w[0]).abs() < 1e-3 && (got[1] - w[1]).abs() < 1e-3,
                    "pose {b} vertex {g}: {got:?} vs {w:?}"
                );
            }
        }
    }

    #[test]
    fn the_gradient_reaches_the_body_through_the_accessories() {
        let puppet = rigged();
        let letterbox = Letterbox::new(puppet.width, puppet.height, 64);
        let e = Expansion::new(&puppet, &letterbox);
        let device = crate::backend::train_device();
        let decoder = e.decoder(&device);
        let free = decoder.rest.clone().unsqueeze::<3>().require_grad();
        // A loss on the accessory's vertices only: Σ x² + y² over them.
        let arm = puppet.layer_index("arm_front").unwrap();
        let offsets = puppet.vertex_offsets();
        let rows: Vec<i64> = (offsets[arm]..offsets[arm + 1]).map(|g| g as i64).collect();
        let index = Tensor::<1, Int>::from_data(TensorData::new(rows.clone(), [rows.len()]), &device);
        let loss = decoder.expand(free.clone()).select(1, index).powi_scalar(2).sum();
        let grad: Vec<f32> = free.grad(&loss.backward()).unwrap().into_data().try_into_vec::<f32>().unwrap();
        // Finite differences of the same loss through the frame-pixel map.
        let f = |work_free: &[[f32; 2]]| -> f64 {
            let frame: Vec<[f32; 2]> = work_free.iter().map(|&p| letterbox.to_frame(p)).collect();
            let all = e.expand_frame(&frame);
            rows.iter()
                .map(|&g| {
                    let w = letterbox.to_work(all[g as usize]);
                    f64::from(w[0]).powi(2) + f64::from(w[1]).powi(2)
                })
                .sum()
        };
        let rest = e.rest.clone();
        let mut checked = 0;
        for (k, g) in grad.chunks_exact(2).enumerate() {
            if g[0].abs() < 1e-3 {
                continue;
            }
            let h = 1e-2f32;
            let mut plus = rest.clone();
            plus[k][0] += h;
            let mut minus = rest.clone();
            minus[k][0] -= h;
            let fd = (f(&plus) - f(&minus)) / (2.0 * f64::from(h));
            assert!(
                (fd - f64::from(g[0])).abs() < 2e-2 * fd.abs().max(1.0),
                "vertex {k}: {} vs {fd}",
                g[0]
            );
            checked += 1;
        }
        assert!(checked > 3, "the accessory's loss reached {checked} body vertices");
    }
}
