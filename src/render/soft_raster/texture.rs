//! Bilinear texture lookup `S(u, v)` and its derivative w.r.t. (u, v) (neural-puppet.md §3.2:
//! the renderer samples the template texture `I^uv`). Texel (i, j) has its centre at
//! `((i + 0.5)/W, (j + 0.5)/H)`; lookups clamp to the edge texels. Values are premultiplied RGBA.

use super::{Real, Texture};

/// The four texels around a lookup and the interpolation weights.
struct Footprint<T> {
    idx: [usize; 4],
    fx: T,
    fy: T,
    /// d(x)/du and d(y)/dv in texels, zeroed on an axis where both texels clamp to one.
    sx: T,
    sy: T,
}

#[inline]
fn footprint<T: Real>(tex: &Texture, uv: [T; 2]) -> Footprint<T> {
    let half = T::from(0.5).expect("0.5 is representable");
    let (w, h) = (tex.width, tex.height);
    let x = uv[0] * T::from(w).expect("texture width fits a float") - half;
    let y = uv[1] * T::from(h).expect("texture height fits a float") - half;
    let (xf, yf) = (x.floor(), y.floor());
    let (fx, fy) = (x - xf, y - yf);
    let clampi = |v: T, n: usize| -> (usize, bool) {
        let i = v.to_i64().unwrap_or(if v > T::zero() { i64::MAX } else { i64::MIN });
        if i < 0 {
            (0, true)
        } else if i as u64 >= n as u64 {
            (n - 1, true)
        } else {
            (i as usize, false)
        }
    };
    let (x0, cx0) = clampi(xf, w);
    let (x1, cx1) = clampi(xf + T::one(), w);
    let (y0, cy0) = clampi(yf, h);
    let (y1, cy1) = clampi(yf + T::one(), h);
    // Both neighbours clamped to the same texel: the lookup is constant along that axis.
    let sx = if (cx0 || cx1) && x0 == x1 { T::zero() } else { T::from(w).expect("fits") };
    let sy = if (cy0 || cy1) && y0 == y1 { T::zero() } else { T::from(h).expect("fits") };
    Footprint { idx: [y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1], fx, fy, sx, sy }
}

/// The bilinear sample at `uv`.
#[inline]
pub(crate) fn sample<T: Real>(tex: &Texture, uv: [T; 2]) -> [T; 4] {
    let f = footprint(tex, uv);
    let t = f.idx.map(|i| tex.texels[i].map(|c| T::from(c).expect("f32 fits")));
    let one = T::one();
    let mut s = [T::zero(); 4];
    for c in 0..4 {
        let top = t[0][c] * (one - f.fx) + t[1][c] * f.fx;
        let bot = t[2][c] * (one - f.fx) + t[3][c] * f.fx;
        s[c] = top * (one - f.fy) + bot * f.fy;
    }
    s
}

/// `Σ_c g[c] · ∂S_c/∂(u, v)` at `uv`: the texture's contribution to the UV gradient.
#[inline]
pub(crate) fn sample_vjp<T: Real>(tex: &Texture, uv: [T; 2], g: [T; 4]) -> [T; 2] {
    let f = footprint(tex, uv);
    let t = f.idx.map(|i| tex.texels[i].map(|c| T::from(c).expect("f32 fits")));
    let one = T::one();
    let (mut gu, mut gv) = (T::zero(), T::zero());
    for c in 0..4 {
        let dx = (t[1][c] - t[0][c]) * (one - f.fy) + (t[3][c] - t[2][c]) * f.fy;
        let dy = (t[2][c] - t[0][c]) * (one - f.fx) + (t[3][c] - t[1][c]) * f.fx;
        gu = gu + g[c] * dx;
        gv = gv + g[c] * dy;
    }
    [gu * f.sx, gv * f.sy]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tex() -> Texture {
        let texels = (0..12).map(|i| [i as f32 / 12.0, (i * i % 7) as f32 / 7.0, 0.5, ((i * 5) % 12) as f32 / 11.0]).collect();
        Texture { width: 4, height: 3, texels }
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
