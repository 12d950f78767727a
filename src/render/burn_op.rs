//! The soft rasterizer as a differentiable Burn operation (neural-puppet.md §3.2: `R` inside the
//! training graph, so eq. 1, 10 and 11 written with Burn tensors backpropagate to `V_pred`).
//!
//! Burn 0.22 tensors carry no backend type; [`Tensor::try_into_primitive`] recovers the
//! concrete primitive. On an autodiff device we register a custom [`Backward`] step whose
//! backward reads `dL/d(output)` to the host and calls [`SoftRasterizer::backward_saved`] on the
//! forward's records; on a plain device we only render. Tensors ↔ slices only; all arithmetic
//! lives in `soft_raster`.

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::autodiff::NodeId;
use burn::backend::ops::FloatTensorOps;
use burn::backend::tensor::FloatTensor;
use burn::backend::{Autodiff, Backend, TensorMetadata};
use burn::tensor::{read_sync, Tensor, TensorData};

use super::soft_raster::{Params, RasterFrames, Saved, SoftRasterizer};
use crate::backend::Inner;
use crate::error::{Error, Result};

/// A rendered batch as Burn tensors.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// Premultiplied RGBA, `[B, 4, H, W]` (see `soft_raster` for the conventions).
    pub image: Tensor<4>,
    /// Silhouette `R(V, F, I¹)` of eq. 10–11, `[B, 1, H, W]`.
    pub mask: Tensor<4>,
}

/// Renders a batch of poses `vertices` (`[B, V, 2]`, output pixels) with `raster` into a
/// `width × height` image and silhouette. If `vertices` lives on an autodiff device (see
/// [`crate::backend::train_device`]) the result is differentiable w.r.t. it.
///
/// # Errors
/// [`Error::Mismatch`] if the shape is not `[B, V, 2]` for this puppet, [`Error::Geometry`] if a
/// coordinate is not finite, [`Error::Setting`] if `params` are invalid, [`Error::Backend`] if the
/// tensor is not on the compiled-in backend.
pub fn soft_raster(vertices: Tensor<3>, raster: &Arc<SoftRasterizer>, width: usize, height: usize, params: Params) -> Result<Rendered> {
    let [batch, v, two] = vertices.dims();
    if v != raster.vertex_count() || two != 2 {
        return Err(Error::mismatch(
            "render: the vertex tensor",
            format!("[{batch}, {v}, {two}]"),
            format!("[B, {}, 2]", raster.vertex_count()),
        ));
    }
    params.validate()?;
    let call = Call {
        raster: raster.clone(),
        batch,
        width,
        height,
        params,
    };
    let out: Tensor<4> = if let Ok(ad) = vertices.clone().try_into_primitive::<Autodiff<Inner>>() {
        match RasterBackward.prepare::<NoCheckpointing>([ad.node()]).compute_bound().stateful() {
            OpsKind::Tracked(prep) => {
                let verts = host::<Inner>(ad.primitive().clone());
                let (frames, saved) = call.raster.forward_saving(&verts, batch, width, height, &params)?;
                let rendered = call.pack(&frames);
                prep.finish(Arc::new(State { call, saved }), rendered)
            }
            OpsKind::UnTracked(prep) => {
                let rendered = call.forward(&host::<Inner>(ad.into_primitive()))?;
                prep.finish(rendered)
            }
        }
        .pipe(Tensor::from_primitive::<Autodiff<Inner>>)
    } else if let Ok(plain) = vertices.try_into_primitive::<Inner>() {
        Tensor::from_primitive::<Inner>(call.forward(&host::<Inner>(plain))?)
    } else {
        return Err(Error::backend(
            "render",
            "the vertex tensor is not on the compiled-in backend (crate::backend::device)",
        ));
    };
    Ok(Rendered {
        image: out.clone().narrow(1, 0, 4),
        mask: out.narrow(1, 4, 1),
    })
}

/// `x.pipe(f) = f(x)`, to keep the match above readable.
trait Pipe: Sized {
    fn pipe<R>(self, f: impl FnOnce(Self) -> R) -> R {
        f(self)
    }
}
impl<T> Pipe for T {}

/// Registers `values` shaped `dims` as the gradient of `node` (if the operation's parent is
/// tracked), on `device`: the last step of a custom operation's backward.
pub(crate) fn register_gradient<B: Backend>(
    grads: &mut Gradients,
    node: Option<NodeId>,
    values: Vec<f32>,
    dims: Vec<usize>,
    device: &B::Device,
) {
    if let Some(id) = node {
        grads.register::<B>(id, B::float_from_data(TensorData::new(values, dims), device));
    }
}

/// A backend tensor's values on the host as f32.
pub(crate) fn host<B: Backend>(t: B::FloatTensorPrimitive) -> Vec<f32> {
    read_sync(B::float_into_data(t))
        .map(|d| d.convert::<f32>().try_into_vec::<f32>().expect("converted to f32"))
        .expect("reading a CPU tensor cannot fail")
}

/// A tensor's values on the host as f32, read in place: the backend's own buffer when it is a
/// contiguous f32 buffer (Flex's; the tensor is shared, not copied), a copy otherwise. Custom
/// operations read their inputs and keep them for the backward pass this way; copying them cost
/// a full pass over every activation of the network, on one core, each way.
#[derive(Debug)]
pub(crate) enum HostValues {
    /// The backend's buffer.
    InPlace(FloatTensor<Inner>),
    /// A copy.
    Copied(Vec<f32>),
}

impl HostValues {
    /// The values of `t`.
    pub(crate) fn new(t: FloatTensor<Inner>) -> Self {
        if in_place(&t).is_some() {
            HostValues::InPlace(t)
        } else {
            HostValues::Copied(host::<Inner>(t))
        }
    }

    /// The values, row-major.
    pub(crate) fn values(&self) -> &[f32] {
        match self {
            HostValues::InPlace(t) => in_place(t).expect("checked when made"),
            HostValues::Copied(v) => v,
        }
    }
}

/// The values of a contiguous f32 tensor without copying them, where the backend allows it.
#[cfg(feature = "flex")]
fn in_place(t: &FloatTensor<Inner>) -> Option<&[f32]> {
    t.as_slice::<f32>()
}

/// The values of a contiguous f32 tensor without copying them, where the backend allows it.
#[cfg(not(feature = "flex"))]
fn in_place(_: &FloatTensor<Inner>) -> Option<&[f32]> {
    None
}

/// One rasterizer call's settings.
#[derive(Debug)]
struct Call {
    raster: Arc<SoftRasterizer>,
    batch: usize,
    width: usize,
    height: usize,
    params: Params,
}

impl Call {
    /// Renders and packs image and mask as one `[B, 5, H, W]` tensor of the compiled-in backend (channels RGBA, M).
    fn forward(&self, verts: &[f32]) -> Result<<Inner as burn::backend::BackendTypes>::FloatTensorPrimitive> {
        let f = self.raster.forward(verts, self.batch, self.width, self.height, &self.params)?;
        Ok(self.pack(&f))
    }

    /// Packs rendered frames as one `[B, 5, H, W]` tensor (channels RGBA, M).
    fn pack(&self, f: &RasterFrames<f32>) -> <Inner as burn::backend::BackendTypes>::FloatTensorPrimitive {
        let n = self.width * self.height;
        let mut packed = vec![0f32; self.batch * 5 * n];
        for b in 0..self.batch {
            for i in 0..n {
                for c in 0..4 {
                    packed[(b * 5 + c) * n + i] = f.image[(b * n + i) * 4 + c];
                }
                packed[(b * 5 + 4) * n + i] = f.mask[b * n + i];
            }
        }
        let data = TensorData::new(packed, [self.batch, 5, self.height, self.width]);
        Inner::float_from_data(data, &Default::default())
    }
}

/// What the backward step keeps: the call and the forward pass's records (which hold the
/// vertices it rendered).
#[derive(Debug)]
struct State {
    call: Call,
    saved: Saved<f32>,
}

#[derive(Debug)]
struct RasterBackward;

impl<B: Backend> Backward<B, 1> for RasterBackward {
    type State = Arc<State>;

    fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
        let [parent] = ops.parents;
        let grad = grads.consume::<B>(&ops.node);
        let Some(parent) = parent else { return };
        let s = &ops.state;
        let c = &s.call;
        let device = grad.device();
        let g = host::<B>(grad);
        let n = c.width * c.height;
        let (mut d_image, mut d_mask) = (vec![0f32; c.batch * n * 4], vec![0f32; c.batch * n]);
        for b in 0..c.batch {
            for i in 0..n {
                for ch in 0..4 {
                    d_image[(b * n + i) * 4 + ch] = g[(b * 5 + ch) * n + i];
                }
                d_mask[b * n + i] = g[(b * 5 + 4) * n + i];
            }
        }
        let dv = c
            .raster
            .backward_saved(&s.saved, Some(&d_image), Some(&d_mask))
            .expect("the records and gradient sizes come from the forward call");
        let data = TensorData::new(dv, [c.batch, c.raster.vertex_count(), 2]);
        grads.register::<B>(parent.id, B::float_from_data(data, &device));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Background;
    use crate::test_util::{jittered, layered_puppet, Rng};

    const W: usize = 48;
    const H: usize = 40;

    #[test]
    fn burn_loss_backpropagates_to_vertices_as_the_kernel_computes() {
        let puppet = layered_puppet();
        let raster = Arc::new(SoftRasterizer::new(&puppet).unwrap());
        let nv = raster.vertex_count();
        let verts: Vec<f32> = [1u64, 2]
            .iter()
            .flat_map(|&s| jittered(&puppet.rest_vertices(), s, 0.4))
            .map(|x| x as f32)
            .collect();
        let mut rng = Rng::new(4);
        let target: Vec<f32> = (0..2 * 4 * H * W).map(|_| rng.uniform(0.0, 1.0) as f32).collect();
        let params = Params {
            sigma: 0.7,
            background: Background::Transparent,
            ..Params::default()
        };

        let device = crate::backend::train_device();
        let v = Tensor::<3>::from_data(TensorData::new(verts.clone(), [2, nv, 2]), &device).require_grad();
        let t = Tensor::<4>::from_data(TensorData::new(target.clone(), [2, 4, H, W]), &device);
        let out = soft_raster(v.clone(), &raster, W, H, params).unwrap();
        // eq. 1 (L2) plus an area term on the silhouette (eq. 11's Σ R(V, F, I¹)).
        let loss = (out.image.clone() - t).powf_scalar(2.0).sum() + out.mask.clone().sum().mul_scalar(0.3);
        let grads = loss.backward();
        let got: Vec<f32> = v
            .grad(&grads)
            .expect("vertices require grad")
            .into_data()
            .try_to_vec::<f32>()
            .unwrap();

        // The same gradient from a direct kernel call.
        let f = raster.forward(&verts, 2, W, H, &params).unwrap();
        let img: Vec<f32> = out.image.into_data().try_to_vec::<f32>().unwrap();
        let n = W * H;
        let mut d_image = vec![0f32; 2 * n * 4];
        for b in 0..2 {
            for i in 0..n {
                for c in 0..4 {
                    let planar = (b * 4 + c) * n + i;
                    assert!(
                        (img[planar] - f.image[(b * n + i) * 4 + c]).abs() < 1e-6,
                        "image differs from the kernel's"
                    );
                    d_image[(b * n + i) * 4 + c] = 2.0 * (f.image[(b * n + i) * 4 + c] - target[planar]);
                }
            }
        }
        let d_mask = vec![0.3f32; 2 * n];
        let want = raster.backward(&verts, 2, W, H, &params, Some(&d_image), Some(&d_mask)).unwrap();
        let scale = want.iter().fold(0f32, |m, x| m.max(x.abs()));
        let err = got.iter().zip(&want).fold(0f32, |m, (a, b)| m.max((a - b).abs()));
        println!("burn vs kernel vertex gradient: max |Δ| = {err:e} (max |g| = {scale})");
        assert!(scale > 1.0 && err <= 1e-5 * scale, "max |Δ| {err} for gradients up to {scale}");
    }

    #[test]
    fn inference_device_renders_without_autodiff_and_bad_shapes_are_errors() {
        let puppet = layered_puppet();
        let raster = Arc::new(SoftRasterizer::new(&puppet).unwrap());
        let nv = raster.vertex_count();
        let verts: Vec<f32> = puppet.rest_vertices().iter().flatten().copied().collect();
        let v = Tensor::<3>::from_data(TensorData::new(verts.clone(), [1, nv, 2]), &crate::backend::device());
        let out = soft_raster(v.clone(), &raster, W, H, Params::default()).unwrap();
        assert_eq!(out.image.dims(), [1, 4, H, W]);
        assert_eq!(out.mask.dims(), [1, 1, H, W]);
        let mask: Vec<f32> = out.mask.into_data().try_to_vec::<f32>().unwrap();
        let f = raster.forward(&verts, 1, W, H, &Params::default()).unwrap();
        assert_eq!(mask, f.mask);
        let wrong = Tensor::<3>::from_data(TensorData::new(verts, [1, nv / 2, 4]), &crate::backend::device());
        assert!(soft_raster(wrong, &raster, W, H, Params::default()).is_err());
    }
}
