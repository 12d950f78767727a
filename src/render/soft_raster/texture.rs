//! Bilinear texture lookup `S(u, v)` and its derivative w.r.t. (u, v) (neural-puppet.md §3.2:
//! the renderer samples the template texture `I^uv`). Texel (i, j) has its centre at
//! `((i + 0.5)/W, (j + 0.5)/H)`; lookups clamp to the edge texels. Values are premultiplied RGBA.

use num_traits::NumCast;

use super::{Real, Texture};

/// One lookup: the four texels around it and the interpolation weights, so the sample and its
/// UV gradient share the work.
pub(crate) struct Lookup<T> {
    /// Texels (x0, y0), (x1, y0), (x0, y1), (x1, y1).
    t: [[T; 4]; 4],
    fx: T,
    fy: T,
    /// d(x)/du and d(y)/dv in texels, zeroed on an axis where both texels clamp to one.
    sx: T,
    sy: T,
}

/// `floor(v)` clamped to [−1, n] as an integer, and whether the lower and upper neighbour
/// (`floor`, `floor + 1`) clamp onto the same texel. The cast truncates toward zero, so 1 is
/// added before it (non-negative after the clamp) and taken off after: no libm `floor` call.
#[inline]
fn cell<T: Real>(v: T, n: usize) -> (usize, usize, T, bool) {
    let one = T::one();
    let lo = -one;
    let hi = <T as NumCast>::from(n).expect("texture size fits a float");
    let vc = v.max(lo).min(hi);
    let i = (vc + one).to_usize().expect("clamped to [0, n + 1]") as i64 - 1;
    let i = if <T as NumCast>::from(i).expect("small integer") > vc {
        i - 1
    } else {
        i
    };
    let f = v - <T as NumCast>::from(i).expect("small integer");
    let clamp = |k: i64| k.clamp(0, n as i64 - 1) as usize;
    let (a, b) = (clamp(i), clamp(i + 1));
    (a, b, f, a == b)
}

impl<T: Real> Lookup<T> {
    /// Prepares the lookup of `tex` at `uv`.
    #[inline]
    pub fn new(tex: &Texture, uv: [T; 2]) -> Self {
        let half = <T as From<f32>>::from(0.5);
        let (w, h) = (tex.width, tex.height);
        let x = uv[0] * <T as NumCast>::from(w).expect("texture width fits a float") - half;
        let y = uv[1] * <T as NumCast>::from(h).expect("texture height fits a float") - half;
        let (x0, x1, fx, flat_x) = cell(x, w);
        let (y0, y1, fy, flat_y) = cell(y, h);
        let texel = |i: usize| tex.texels[i].map(<T as From<f32>>::from);
        Lookup {
            t: [texel(y0 * w + x0), texel(y0 * w + x1), texel(y1 * w + x0), texel(y1 * w + x1)],
            // Where both neighbours are one texel the weight does not matter; keep it in [0, 1].
            fx: if flat_x { T::zero() } else { fx },
            fy: if flat_y { T::zero() } else { fy },
            sx: if flat_x {
                T::zero()
            } else {
                <T as NumCast>::from(w).expect("fits")
            },
            sy: if flat_y {
                T::zero()
            } else {
                <T as NumCast>::from(h).expect("fits")
            },
        }
    }

    /// The bilinear sample.
    #[inline]
    pub fn sample(&self) -> [T; 4] {
        let (t, one) = (&self.t, T::one());
        let mut s = [T::zero(); 4];
        for c in 0..4 {
            let top = t[0][c] * (one - self.fx) + t[1][c] * self.fx;
            let bot = t[2][c] * (one - self.fx) + t[3][c] * self.fx;
            s[c] = top * (one - self.fy) + bot * self.fy;
        }
        s
    }

    /// `Σ_c g[c] · ∂S_c/∂(u, v)`: the texture's contribution to the UV gradient.
    #[inline]
    pub fn vjp(&self, g: [T; 4]) -> [T; 2] {
        let (t, one) = (&self.t, T::one());
        let (mut gu, mut gv) = (T::zero(), T::zero());
        for c in 0..4 {
            let dx = (t[1][c] - t[0][c]) * (one - self.fy) + (t[3][c] - t[2][c]) * self.fy;
            let dy = (t[2][c] - t[0][c]) * (one - self.fx) + (t[3][c] - t[1][c]) * self.fx;
            gu = gu + g[c] * dx;
            gv = gv + g[c] * dy;
        }
        [gu * self.sx, gv * self.sy]
    }
}

/// The bilinear sample at `uv`.
#[cfg(test)]
pub(crate) fn sample<T: Real>(tex: &Texture, uv: [T; 2]) -> [T; 4] {
    Lookup::new(tex, uv).sample()
}

/// `Σ_c g[c] · ∂S_c/∂(u, v)` at `uv`: the texture's contribution to the UV gradient.
#[cfg(test)]
pub(crate) fn sample_vjp<T: Real>(tex: &Texture, uv: [T; 2], g: [T; 4]) -> [T; 2] {
    Lookup::new(tex, uv).vjp(g)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tex() -> Texture {
        let texels = (0..12)
            .map(|i| [i as f32 / 12.0, (i * i % 7) as f32 / 7.0, 0.5, ((i * 5) % 12) as f32 / 11.0])
            .collect();
        Texture {
            width: 4,
            height: 3,
            texels,
        }
    }

    #[test]
    fn texel_centres_return_texels() {
        let t = tex();
        for j in 0..3 {
            for i in 0..4 {
                let s = sample(&t, [(i as f64 + 0.5) / 4.0, (j as f64 + 0.5) / 3.0]);
                let want = t.texels[j * 4 + i];
                assert!((0..4).all(|c| (s[c] - want[c] as f64).abs() < 1e-7), "{i},{j}: {s:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn uv_gradient_matches_central_differences_inside_and_at_clamped_borders() {
        let t = tex();
        let g = [0.4, -0.9, 0.2, 1.3];
        let f = |uv: [f64; 2]| (0..4).map(|c| g[c] * sample(&t, uv)[c]).sum::<f64>();
        for uv in [[0.41, 0.52], [0.03, 0.47], [0.7, 0.97], [1.3, -0.2], [0.26, 0.61]] {
            let a = sample_vjp(&t, uv, g);
            let h = 1e-7;
            let du = (f([uv[0] + h, uv[1]]) - f([uv[0] - h, uv[1]])) / (2.0 * h);
            let dv = (f([uv[0], uv[1] + h]) - f([uv[0], uv[1] - h])) / (2.0 * h);
            assert!((a[0] - du).abs() < 1e-6 && (a[1] - dv).abs() < 1e-6, "{uv:?}: {a:?} vs {du}, {dv}");
        }
    }
}
