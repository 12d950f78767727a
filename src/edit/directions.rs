//! The principal directions of a set of latents — the training frames' — so a person can move
//! a pose along the ways the drawn frames differ most, one slider each: `z = z₀ + Σ wᵢ·σᵢ·dᵢ`
//! with `dᵢ` the directions (unit length, largest spread first) and `σᵢ` the frames' standard
//! deviation along each, so a slider's ±1 spans what the drawn frames span.

use faer::Mat;

use crate::error::{Error, Result};

/// Principal directions of latents (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct LatentDirections {
    /// The latents' mean.
    pub mean: Vec<f32>,
    /// Unit directions, largest spread first.
    pub directions: Vec<Vec<f32>>,
    /// The standard deviation of the latents along each direction.
    pub sigma: Vec<f32>,
}

/// Directions whose spread is below this share of the largest are left out: they are rounding,
/// not a way the frames differ.
const NEGLIGIBLE: f32 = 1e-4;

impl LatentDirections {
    /// The at most `most` principal directions of `latents` (rows of one length). Fewer than
    /// two latents have no spread, hence no directions.
    ///
    /// # Errors
    /// [`Error::Mismatch`] for rows of different lengths; [`Error::Geometry`] for a value that
    /// is not finite or a decomposition that fails.
    pub fn of(latents: &[Vec<f32>], most: usize) -> Result<Self> {
        let dim = latents.first().map_or(0, Vec::len);
        if let Some(row) = latents.iter().find(|r| r.len() != dim) {
            return Err(Error::mismatch("a latent's length", row.len(), dim));
        }
        if latents.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::geometry("a latent", "is not finite"));
        }
        let n = latents.len();
        let mean: Vec<f32> = (0..dim)
            .map(|j| latents.iter().map(|r| r[j] as f64).sum::<f64>() as f32 / n.max(1) as f32)
            .collect();
        if n < 2 || dim == 0 {
            return Ok(LatentDirections {
                mean,
                directions: Vec::new(),
                sigma: Vec::new(),
            });
        }
        let centred = Mat::<f64>::from_fn(n, dim, |i, j| (latents[i][j] - mean[j]) as f64);
        let svd = centred
            .thin_svd()
            .map_err(|e| Error::geometry("the latents' principal directions", format!("cannot be computed: {e:?}")))?;
        let singular: Vec<f64> = svd.S().column_vector().iter().copied().collect();
        let largest = singular.first().copied().unwrap_or(0.0);
        let v = svd.V();
        let (mut directions, mut sigma) = (Vec::new(), Vec::new());
        for (k, &s) in singular.iter().enumerate().take(most) {
            if s <= largest * NEGLIGIBLE as f64 || s == 0.0 {
                break;
            }
            directions.push((0..dim).map(|j| v[(j, k)] as f32).collect());
            sigma.push((s / ((n - 1) as f64).sqrt()) as f32);
        }
        Ok(LatentDirections { mean, directions, sigma })
    }

    /// The latent offset `Σ wᵢ·σᵢ·dᵢ` of slider values `weights` (one per direction).
    ///
    /// # Errors
    /// [`Error::Mismatch`] for a count other than one per direction; [`Error::Setting`] for a
    /// value that is not finite.
    pub fn offset(&self, weights: &[f32]) -> Result<Vec<f32>> {
        if weights.len() != self.directions.len() {
            return Err(Error::mismatch("the slider count", weights.len(), self.directions.len()));
        }
        let mut out = vec![0.0f32; self.mean.len()];
        for (k, (&w, d)) in weights.iter().zip(&self.directions).enumerate() {
            if !w.is_finite() {
                return Err(Error::setting(format!("slider {}", k + 1), w, "a finite number"));
            }
            for (o, &dj) in out.iter_mut().zip(d) {
                *o += w * self.sigma[k] * dj;
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Latents spread 3 along `a` and 1 along `b` (orthogonal unit vectors) about `c`.
    fn spread() -> (Vec<Vec<f32>>, [f32; 4], [f32; 4]) {
        let a = [0.6, 0.8, 0.0, 0.0];
        let b = [0.0, 0.0, 1.0, 0.0];
        let c = [1.0, -2.0, 0.5, 3.0];
        let mut rows = Vec::new();
        for (s, t) in [(3.0f32, 1.0f32), (-3.0, 1.0), (3.0, -1.0), (-3.0, -1.0)] {
            rows.push((0..4).map(|j| c[j] + s * a[j] + t * b[j]).collect());
        }
        (rows, a, b)
    }

    #[test]
    fn finds_the_directions_largest_first_with_their_spread() {
        let (rows, a, b) = spread();
        let d = LatentDirections::of(&rows, 8).unwrap();
        assert_eq!(d.directions.len(), 2, "two ways the latents differ");
        assert!((d.mean[3] - 3.0).abs() < 1e-5);
        let dot = |x: &[f32], y: &[f32]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f32>();
        assert!((dot(&d.directions[0], &a).abs() - 1.0).abs() < 1e-5, "{:?}", d.directions[0]);
        assert!((dot(&d.directions[1], &b).abs() - 1.0).abs() < 1e-5, "{:?}", d.directions[1]);
        // Sample standard deviations: sqrt(4·9/3) and sqrt(4/3).
        assert!((d.sigma[0] - 12f32.sqrt()).abs() < 1e-4 && (d.sigma[1] - (4.0f32 / 3.0).sqrt()).abs() < 1e-4);
        let one = d.offset(&[1.0, 0.0]).unwrap();
        assert!((dot(&one, &one).sqrt() - d.sigma[0]).abs() < 1e-4);
        assert_eq!(LatentDirections::of(&rows, 1).unwrap().directions.len(), 1);
    }

    #[test]
    fn one_latent_has_no_directions_and_bad_input_is_refused() {
        let d = LatentDirections::of(&[vec![1.0, 2.0]], 8).unwrap();
        assert!(d.directions.is_empty() && d.offset(&[]).unwrap() == vec![0.0, 0.0]);
        assert!(LatentDirections::of(&[vec![1.0], vec![1.0, 2.0]], 8).is_err());
        assert!(LatentDirections::of(&[vec![f32::NAN], vec![1.0]], 8).is_err());
        let (rows, _, _) = spread();
        let d = LatentDirections::of(&rows, 8).unwrap();
        assert!(d.offset(&[1.0]).is_err() && d.offset(&[f32::INFINITY, 0.0]).is_err());
    }
}
