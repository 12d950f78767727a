//! Pins drawn over a picture — what a person checks after `puppet pose`: a line from each grabbed
//! point (white ring) to its target (red dot).

use super::pin::Pin;
use crate::geom::triangle::closest_on_segment;
use crate::picture::Picture;

/// `picture` composited on white with the pins drawn over it (see [`draw_pins`]): what a sheet
/// shows.
pub fn pin_overlay(picture: &Picture, pins: &[Pin]) -> Picture {
    draw_pins(
        &picture.mapped(|[r, g, b, a]| [r * a + 1.0 - a, g * a + 1.0 - a, b * a + 1.0 - a, 1.0]),
        pins,
    )
}

/// `picture` (straight alpha, kept: an animation chooses its own background) with each pin drawn
/// over it as a grey line from `from` to `to`, a ring at `from` and a red dot at `to` (frame
/// pixels; anti-aliased by distance).
pub fn draw_pins(picture: &Picture, pins: &[Pin]) -> Picture {
    let mut out = picture.clone();
    let radius = (picture.width.max(picture.height) as f32 / 64.0).max(1.5);
    for pin in pins {
        paint(
            &mut out,
            |p| segment_distance(p, pin.from, pin.to) - 0.5 * radius * 0.5,
            [0.35, 0.35, 0.35],
        );
        paint(&mut out, |p| (dist(p, pin.from) - radius).abs() - 0.35 * radius, [0.1, 0.1, 0.1]);
        paint(&mut out, |p| dist(p, pin.to) - radius, [0.9, 0.1, 0.1]);
    }
    out
}

/// Draws `colour` over the straight-alpha picture wherever the signed distance `sdf` (pixels)
/// is below 0.5, with one pixel of anti-aliasing.
fn paint(out: &mut Picture, sdf: impl Fn([f32; 2]) -> f32, colour: [f32; 3]) {
    let w = out.width as usize;
    for (i, px) in out.pixels.iter_mut().enumerate() {
        let p = [(i % w) as f32 + 0.5, (i / w) as f32 + 0.5];
        let a = (0.5 - sdf(p)).clamp(0.0, 1.0);
        if a > 0.0 {
            let below = px[3] * (1.0 - a);
            let alpha = a + below;
            for c in 0..3 {
                px[c] = (colour[c] * a + px[c] * below) / alpha;
            }
            px[3] = alpha;
        }
    }
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn segment_distance(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    dist(p, closest_on_segment(a, b, p))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_is_red_source_ringed_and_far_pixels_untouched() {
        let pic = Picture::filled(64, 64, [0.0; 4]);
        let out = pin_overlay(
            &pic,
            &[Pin {
                from: [10.5, 10.5],
                to: [50.5, 40.5],
            }],
        );
        let at = |x: u32, y: u32| out.get(x, y);
        assert!(at(50, 40)[0] > 0.8 && at(50, 40)[1] < 0.2, "{:?}", at(50, 40));
        assert!(at(12, 10)[0] < 0.7, "the ring passes (12, 10): {:?}", at(12, 10));
        assert!(at(30, 25)[0] < 0.9, "the line passes (30, 25): {:?}", at(30, 25));
        assert_eq!(at(60, 2), [1.0; 4]);
        // Over a transparent frame the pins keep the transparency around them.
        let pins = draw_pins(
            &pic,
            &[Pin {
                from: [10.5, 10.5],
                to: [50.5, 40.5],
            }],
        );
        assert_eq!(pins.get(60, 2), [0.0; 4]);
        assert_eq!(pins.get(50, 40), [0.9, 0.1, 0.1, 1.0]);
        let edge = pins.get(30, 25);
        assert!(
            edge[3] > 0.0 && (edge[0] - 0.35).abs() < 1e-5,
            "the line in its own colour: {edge:?}"
        );
    }
}
