//! The InfoNCE loss that trains the correspondence network (apes-part-extraction.md §3.1; van den
//! Oord et al. 2018), as one differentiable operation over slices. Each term is a block of rows
//! of raw (not yet unit) pixel features: its anchors, then as many candidates that are their
//! matches, then shared negatives; every anchor must pick its match among all the candidates by
//! cosine similarity over a temperature τ. The loss is the mean over terms of the mean over
//! anchors of −log softmax(match). Burn composed it from a dozen tensor operations per term
//! (normalisation, product, max, exp, sums, log) and as many again backward, nearly all on one
//! core while the other waited (benches/README.md "parts"); here the terms run in parallel and the
//! exponentials vectorise. Forward and gradient are computed together (the gradient costs two
//! more small products), and backward scales the saved gradient.

use std::sync::Arc;

use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::NoCheckpointing;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::ops::FloatTensorOps;
use burn::backend::{Autodiff, Backend, TensorMetadata};
use burn::tensor::{Tensor, TensorData};
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rayon::prelude::*;

use crate::backend::Inner;
use crate::error::{Error, Result};
use crate::model::lanes::{exp, lane_max, lane_sum};
use crate::render::burn_op::{host, HostValues};

/// Added under the square root of a feature's norm, so an all-zero feature has a gradient (as
/// `model::correspondence::unit_length`).
const NORM_EPSILON: f32 = 1e-6;

/// One InfoNCE term: `anchors` rows from `start`, then `candidates` rows whose first `anchors`
/// are the anchors' matches in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Term {
    /// The term's first row.
    pub start: usize,
    /// Anchor rows.
    pub anchors: usize,
    /// Candidate rows (matches, then negatives); at least `anchors`.
    pub candidates: usize,
}

impl Term {
    fn rows(&self) -> usize {
        self.anchors + self.candidates
    }
}

/// The loss `[1]` of `raw` feature rows `[R, F]` split into `terms` (consecutive, covering the
/// rows), with `temperature` τ. Differentiable w.r.t. `raw` on the autodiff device.
///
/// # Errors
/// [`Error::Mismatch`] if the terms do not tile the rows or a term has no anchor or fewer
/// candidates than anchors; [`Error::Backend`] if `raw` is not on the compiled-in backend.
pub fn info_nce(raw: Tensor<2>, terms: &[Term], temperature: f32) -> Result<Tensor<1>> {
    let [rows, features] = raw.dims();
    let mut next = 0;
    for t in terms {
        if t.start != next || t.anchors == 0 || t.candidates < t.anchors {
            return Err(Error::mismatch(
                "info_nce: the terms",
                format!("{t:?} after row {next}"),
                "consecutive terms with anchors ≤ candidates",
            ));
        }
        next += t.rows();
    }
    if next != rows || terms.is_empty() {
        return Err(Error::mismatch(
            "info_nce: the terms",
            format!("{next} rows"),
            format!("the features' {rows}"),
        ));
    }
    let loss = |value: f32| Inner::float_from_data(TensorData::new(vec![value], [1]), &Default::default());
    if let Ok(ad) = raw.clone().try_into_primitive::<Autodiff<Inner>>() {
        let x = HostValues::new(ad.primitive().clone());
        let (value, gradient) = loss_and_gradient(x.values(), features, terms, temperature);
        let out = match InfoNceBackward.prepare::<NoCheckpointing>([ad.node()]).compute_bound().stateful() {
            OpsKind::Tracked(prep) => prep.finish(Arc::new(Saved { rows, features, gradient }), loss(value as f32)),
            OpsKind::UnTracked(prep) => prep.finish(loss(value as f32)),
        };
        Ok(Tensor::from_primitive::<Autodiff<Inner>>(out))
    } else if let Ok(plain) = raw.try_into_primitive::<Inner>() {
        let x = HostValues::new(plain);
        let (value, _) = loss_and_gradient(x.values(), features, terms, temperature);
        Ok(Tensor::from_primitive::<Inner>(loss(value as f32)))
    } else {
        Err(Error::backend(
            "info_nce",
            "the features are not on the compiled-in backend (crate::backend::device)",
        ))
    }
}

/// The loss and its gradient w.r.t. `raw` `[R, F]` (row-major), the terms in parallel; each
/// term's loss is added in term order in f64, so the result does not depend on the thread count.
pub fn loss_and_gradient(raw: &[f32], features: usize, terms: &[Term], temperature: f32) -> (f64, Vec<f32>) {
    let mut gradient = vec![0f32; raw.len()];
    let mut blocks = Vec::with_capacity(terms.len());
    let mut rest = gradient.as_mut_slice();
    for t in terms {
        let (block, tail) = rest.split_at_mut(t.rows() * features);
        blocks.push((t, block));
        rest = tail;
    }
    let weight = 1.0 / terms.len() as f32;
    let losses: Vec<f64> = blocks
        .into_par_iter()
        .map(|(t, dx)| {
            term(
                &raw[t.start * features..][..t.rows() * features],
                features,
                *t,
                temperature,
                weight,
                dx,
            )
        })
        .collect();
    (losses.iter().sum::<f64>() * f64::from(weight), gradient)
}

/// One term: writes `weight ×` the gradient of its mean loss into `dx` (its rows) and returns
/// the mean loss.
fn term(x: &[f32], features: usize, t: Term, temperature: f32, weight: f32, dx: &mut [f32]) -> f64 {
    let (n, m) = (t.anchors, t.candidates);
    let norms: Vec<f32> = x
        .chunks_exact(features)
        .map(|row| (row.iter().map(|v| v * v).sum::<f32>() + NORM_EPSILON).sqrt())
        .collect();
    let unit: Vec<f32> = x
        .chunks_exact(features)
        .zip(&norms)
        .flat_map(|(row, &norm)| row.iter().map(move |v| v / norm))
        .collect();
    let (a, b) = unit.split_at(n * features);
    let a = MatRef::from_row_major_slice(a, n, features);
    let b = MatRef::from_row_major_slice(b, m, features);
    let inverse_tau = 1.0 / temperature;
    // Logits, then per anchor row its softmax minus the one-hot of its match, scaled to the
    // gradient of the weighted mean loss.
    let mut g = vec![0f32; n * m];
    matmul(
        MatMut::from_row_major_slice_mut(&mut g, n, m),
        Accum::Replace,
        a,
        b.transpose(),
        inverse_tau,
        Par::Seq,
    );
    let row_weight = weight / n as f32;
    let mut loss = 0f64;
    for (i, row) in g.chunks_exact_mut(m).enumerate() {
        let positive = row[i];
        let peak = lane_max(row);
        for v in row.iter_mut() {
            *v = exp(*v - peak);
        }
        let sum = lane_sum(row, row, |v, _| v);
        loss += sum.ln() + f64::from(peak - positive);
        let scale = (f64::from(row_weight) / sum) as f32;
        row.iter_mut().for_each(|v| *v *= scale);
        row[i] -= row_weight;
    }
    // Through the product: d a = G·b/τ, d b = Gᵀ·a/τ (into dx as the unit features' gradient).
    let (da, db) = dx.split_at_mut(n * features);
    let g = MatRef::from_row_major_slice(&g, n, m);
    matmul(
        MatMut::from_row_major_slice_mut(da, n, features),
        Accum::Replace,
        g,
        b,
        inverse_tau,
        Par::Seq,
    );
    matmul(
        MatMut::from_row_major_slice_mut(db, m, features),
        Accum::Replace,
        g.transpose(),
        a,
        inverse_tau,
        Par::Seq,
    );
    // Through the normalisation: dx = (du − u·(u·du)) / |x|.
    for ((d, u), &norm) in dx.chunks_exact_mut(features).zip(unit.chunks_exact(features)).zip(&norms) {
        let along: f32 = d.iter().zip(u).map(|(d, u)| d * u).sum();
        d.iter_mut().zip(u).for_each(|(d, u)| *d = (*d - u * along) / norm);
    }
    loss / n as f64
}

/// The forward pass's gradient of the loss.
#[derive(Debug)]
struct Saved {
    rows: usize,
    features: usize,
    gradient: Vec<f32>,
}

#[derive(Debug)]
struct InfoNceBackward;

impl<B: Backend> Backward<B, 1> for InfoNceBackward {
    type State = Arc<Saved>;

    fn backward(self, ops: Ops<Self::State, 1>, grads: &mut Gradients, _checkpointer: &mut Checkpointer) {
        let [parent] = ops.parents;
        let upstream = grads.consume::<B>(&ops.node);
        let Some(parent) = parent else { return };
        let device = upstream.device();
        let scale = host::<B>(upstream)[0];
        let s = &ops.state;
        let dx: Vec<f32> = s.gradient.iter().map(|g| g * scale).collect();
        grads.register::<B>(parent.id, B::float_from_data(TensorData::new(dx, [s.rows, s.features]), &device));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Distribution;

    /// Two terms of different sizes over 5-vectors.
    fn terms() -> Vec<Term> {
        vec![
            Term {
                start: 0,
                anchors: 3,
                candidates: 7,
            },
            Term {
                start: 10,
                anchors: 2,
                candidates: 4,
            },
        ]
    }

    /// The loss by its definition, in f64.
    fn definition(x: &[f32], features: usize, terms: &[Term], tau: f64) -> f64 {
        let unit = |r: usize| {
            let row: Vec<f64> = x[r * features..][..features].iter().map(|&v| f64::from(v)).collect();
            let norm = (row.iter().map(|v| v * v).sum::<f64>() + f64::from(NORM_EPSILON)).sqrt();
            row.into_iter().map(|v| v / norm).collect::<Vec<_>>()
        };
        let dot = |p: &[f64], q: &[f64]| p.iter().zip(q).map(|(p, q)| p * q).sum::<f64>();
        let mut total = 0.0;
        for t in terms {
            let mut term = 0.0;
            for i in 0..t.anchors {
                let a = unit(t.start + i);
                let logits: Vec<f64> = (0..t.candidates).map(|j| dot(&a, &unit(t.start + t.anchors + j)) / tau).collect();
                let log_sum = logits.iter().map(|l| l.exp()).sum::<f64>().ln();
                term += log_sum - logits[i];
            }
            total += term / t.anchors as f64;
        }
        total / terms.len() as f64
    }

    fn features() -> Vec<f32> {
        (0..16 * 5).map(|i| ((i * 37 % 101) as f32 / 50.0 - 1.0) * 0.8).collect()
    }

    #[test]
    fn the_loss_matches_its_definition_and_the_gradient_central_differences() {
        let (x, terms, tau) = (features(), terms(), 0.07f32);
        let (loss, gradient) = loss_and_gradient(&x, 5, &terms, tau);
        let want = definition(&x, 5, &terms, f64::from(tau));
        assert!((loss - want).abs() < 1e-4 * want.abs().max(1.0), "{loss} vs {want}");
        let h = 1e-3f32;
        let mut worst = 0f64;
        for i in 0..x.len() {
            let at = |d: f32| {
                let mut y = x.clone();
                y[i] += d;
                definition(&y, 5, &terms, f64::from(tau))
            };
            let numeric = (at(h) - at(-h)) / (2.0 * f64::from(h));
            worst = worst.max((numeric - f64::from(gradient[i])).abs() / (1.0 + numeric.abs()));
        }
        assert!(worst < 2e-3, "relative error {worst}");
    }

    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let x = features();
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            pool.install(|| loss_and_gradient(&x, 5, &terms(), 0.1))
        };
        assert_eq!(run(1), run(3));
    }

    /// Through Burn: the loss as a tensor, its gradient scaled by the upstream one, and terms
    /// that do not tile the rows refused.
    #[test]
    fn the_operation_carries_the_gradient_and_checks_its_terms() {
        let device = crate::backend::train_device();
        let raw = Tensor::<2>::random([16, 5], Distribution::Uniform(-1.0, 1.0), &device).require_grad();
        let values = raw.clone().into_data().try_to_vec::<f32>().unwrap();
        let (want, gradient) = loss_and_gradient(&values, 5, &terms(), 0.07);
        let loss = info_nce(raw.clone(), &terms(), 0.07).unwrap();
        assert!((crate::backend::scalar(&loss) - want).abs() < 1e-5);
        let grads = (loss * 3.0).sum().backward();
        let got = raw.grad(&grads).unwrap().into_data().try_to_vec::<f32>().unwrap();
        assert!(got.iter().zip(&gradient).all(|(g, w)| (g - 3.0 * w).abs() < 1e-5));
        let short = [
            Term {
                candidates: 6,
                ..terms()[0]
            },
            terms()[1],
        ];
        assert!(info_nce(raw.clone(), &short, 0.07).is_err());
        let few = [Term {
            anchors: 8,
            candidates: 2,
            ..terms()[0]
        }];
        assert!(info_nce(raw, &few, 0.07).is_err());
    }
}
