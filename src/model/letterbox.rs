//! Letterboxing: frames of any size go into the network's square S×S input, scaled to fit and
//! centred on transparency. The map between frame pixels and working pixels is one affine map,
//! `work = scale · frame + offset`, so vertices go back to the frame exactly.

use crate::picture::Picture;

/// The affine map between a `width × height` frame and the square working image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Letterbox {
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Working size S (the network input is S×S).
    pub size: u32,
    /// Working pixels per frame pixel.
    pub scale: f32,
    /// Working-pixel position of the frame's top-left corner (whole pixels, so a frame that is
    /// not rescaled is copied, not resampled).
    pub offset: [f32; 2],
}

impl Letterbox {
    /// The letterbox of a `width × height` frame into `size × size`.
    pub fn new(width: u32, height: u32, size: u32) -> Self {
        let scale = size as f32 / width.max(height) as f32;
        let pad = |extent: u32| ((size as f32 - scale * extent as f32) / 2.0).floor().max(0.0);
        Letterbox {
            width,
            height,
            size,
            scale,
            offset: [pad(width), pad(height)],
        }
    }

    /// Frame pixels → working pixels.
    pub fn to_work(&self, p: [f32; 2]) -> [f32; 2] {
        [p[0] * self.scale + self.offset[0], p[1] * self.scale + self.offset[1]]
    }

    /// Working pixels → frame pixels (the exact inverse of [`Letterbox::to_work`]).
    pub fn to_frame(&self, q: [f32; 2]) -> [f32; 2] {
        [(q[0] - self.offset[0]) / self.scale, (q[1] - self.offset[1]) / self.scale]
    }

    /// The frame resampled into the working square, premultiplied RGBA, channel-major
    /// `[4, S, S]` (the network's input layout). Bilinear on premultiplied colour, so
    /// transparent pixels do not bleed dark fringes; exact copy when `scale` is 1.
    pub fn premultiplied_planes(&self, frame: &Picture) -> Vec<f32> {
        let s = self.size as usize;
        let mut planes = vec![0.0f32; 4 * s * s];
        let fetch = |x: i64, y: i64| -> [f32; 4] {
            if x < 0 || y < 0 || x >= frame.width as i64 || y >= frame.height as i64 {
                return [0.0; 4];
            }
            let [r, g, b, a] = frame.pixels[y as usize * frame.width as usize + x as usize];
            [r * a, g * a, b * a, a]
        };
        for wy in 0..s {
            for wx in 0..s {
                // Pixel centre in working space → frame space, then bilinear around it.
                let mut value = [0.0f32; 4];
                for (x, y, w) in bilinear_taps(self.to_frame([wx as f32 + 0.5, wy as f32 + 0.5])) {
                    if w > 0.0 {
                        let p = fetch(x, y);
                        for c in 0..4 {
                            value[c] += w * p[c];
                        }
                    }
                }
                for (c, v) in value.iter().enumerate() {
                    planes[c * s * s + wy * s + wx] = *v;
                }
            }
        }
        planes
    }
}

impl Letterbox {
    /// The working square's premultiplied planes `[4, S, S]` (a network's output) back at the
    /// frame's size as a straight-alpha picture: bilinear at each frame pixel's centre, an exact
    /// crop when `scale` is 1 (the inverse of [`Letterbox::premultiplied_planes`] there).
    pub fn frame_picture(&self, planes: &[f32]) -> Picture {
        let s = self.size as usize;
        let at = |c: usize, x: i64, y: i64| -> f32 {
            if x < 0 || y < 0 || x >= s as i64 || y >= s as i64 {
                0.0
            } else {
                planes[c * s * s + y as usize * s + x as usize]
            }
        };
        let mut pixels = Vec::with_capacity((self.width * self.height) as usize);
        for fy in 0..self.height {
            for fx in 0..self.width {
                let mut value = [0.0f32; 4];
                for (x, y, w) in bilinear_taps(self.to_work([fx as f32 + 0.5, fy as f32 + 0.5])) {
                    if w > 0.0 {
                        for (c, v) in value.iter_mut().enumerate() {
                            *v += w * at(c, x, y);
                        }
                    }
                }
                let a = value[3].clamp(0.0, 1.0);
                pixels.push(if a > 0.0 {
                    let straight = |c: usize| (value[c] / a).clamp(0.0, 1.0);
                    [straight(0), straight(1), straight(2), a]
                } else {
                    [0.0; 4]
                });
            }
        }
        Picture {
            width: self.width,
            height: self.height,
            pixels,
        }
    }
}

/// The four pixels around the point `p` (pixel units, centres at +0.5) and their bilinear weights.
fn bilinear_taps(p: [f32; 2]) -> [(i64, i64, f32); 4] {
    let (gx, gy) = (p[0] - 0.5, p[1] - 0.5);
    let (x0, y0) = (gx.floor(), gy.floor());
    let (tx, ty) = (gx - x0, gy - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    [
        (x0, y0, (1.0 - tx) * (1.0 - ty)),
        (x0 + 1, y0, tx * (1.0 - ty)),
        (x0, y0 + 1, (1.0 - tx) * ty),
        (x0 + 1, y0 + 1, tx * ty),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_round_trips_and_centres_the_frame() {
        let lb = Letterbox::new(96, 128, 128);
        assert_eq!((lb.scale, lb.offset), (1.0, [16.0, 0.0]));
        let half = Letterbox::new(200, 100, 100);
        assert_eq!((half.scale, half.offset), (0.5, [0.0, 25.0]));
        for p in [[0.0, 0.0], [12.25, 99.5], [199.0, 3.0]] {
            let back = half.to_frame(half.to_work(p));
            assert!((back[0] - p[0]).abs() < 1e-4 && (back[1] - p[1]).abs() < 1e-4, "{p:?} → {back:?}");
        }
    }

    #[test]
    fn unscaled_frames_are_copied_exactly_into_the_box() {
        let mut frame = Picture::filled(4, 8, [0.0; 4]);
        frame.pixels[8 + 3] = [1.0, 0.5, 0.25, 0.5]; // (3, 2)
        let lb = Letterbox::new(4, 8, 8);
        let planes = lb.premultiplied_planes(&frame);
        let at = |c: usize, x: usize, y: usize| planes[c * 64 + y * 8 + x];
        // The frame sits at x offset 2, so (3, 2) → (5, 2), premultiplied.
        assert_eq!([at(0, 5, 2), at(1, 5, 2), at(2, 5, 2), at(3, 5, 2)], [0.5, 0.25, 0.125, 0.5]);
        assert_eq!(planes.iter().filter(|v| **v != 0.0).count(), 4);
    }

    #[test]
    fn frame_picture_inverts_the_planes_of_an_unscaled_frame() {
        let mut frame = Picture::filled(4, 8, [0.0; 4]);
        frame.pixels[8 + 3] = [1.0, 0.5, 0.25, 0.5];
        frame.pixels[30] = [0.2, 0.4, 0.6, 1.0];
        let lb = Letterbox::new(4, 8, 8);
        let back = lb.frame_picture(&lb.premultiplied_planes(&frame));
        for (a, b) in back.pixels.iter().zip(&frame.pixels) {
            assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6), "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn downscaling_averages_premultiplied_colour() {
        let frame = Picture::filled(4, 4, [1.0, 0.0, 0.0, 1.0]);
        let lb = Letterbox::new(4, 4, 2);
        let planes = lb.premultiplied_planes(&frame);
        assert!(planes[..4].iter().all(|v| (*v - 1.0).abs() < 1e-6), "{planes:?}");
        assert!(planes[12..].iter().all(|v| (*v - 1.0).abs() < 1e-6));
    }
}
