//! A character's colours.

use crate::rng::Rng;
use crate::synth::look::Rgb;

pub(super) fn hsv(h: f32, s: f32, v: f32) -> Rgb {
    let h = (h.rem_euclid(1.0)) * 6.0;
    let i = h.floor();
    let f = h - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match i as i32 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

pub(super) fn scale_rgb(c: Rgb, k: f32) -> Rgb {
    c.map(|x| (x * k).clamp(0.0, 1.0))
}

pub(super) fn lighten(c: Rgb, t: f32) -> Rgb {
    c.map(|x| x + (1.0 - x) * t)
}

/// The character's colours.
pub(super) struct Palette {
    pub(super) skin: Rgb,
    pub(super) shirt: Rgb,
    pub(super) pants: Rgb,
    pub(super) shoes: Rgb,
    pub(super) hair: Rgb,
    pub(super) accent: Rgb,
    pub(super) outline: Rgb,
}

impl Palette {
    pub(super) fn random(rng: &mut Rng) -> Self {
        let animal = rng.chance(0.5);
        let skin = if animal {
            hsv(rng.unit(), rng.range(0.25, 0.6), rng.range(0.7, 0.95))
        } else {
            rng.pick(&[
                [1.0, 0.86, 0.72],
                [0.96, 0.76, 0.6],
                [0.78, 0.56, 0.4],
                [0.55, 0.38, 0.26],
                [0.99, 0.9, 0.8],
            ])
        };
        let h = rng.unit();
        let shirt = hsv(h, rng.range(0.45, 0.85), rng.range(0.6, 0.95));
        let pants = hsv(h + rng.range(0.3, 0.7), rng.range(0.3, 0.75), rng.range(0.3, 0.7));
        let shoes = hsv(rng.unit(), rng.range(0.2, 0.8), rng.range(0.15, 0.6));
        let hair = hsv(rng.range(0.0, 0.12), rng.range(0.4, 0.9), rng.range(0.15, 0.7));
        let accent = lighten(hsv(h + 0.5, rng.range(0.5, 0.9), 0.95), rng.range(0.0, 0.5));
        let outline = hsv(h, 0.5, rng.range(0.08, 0.18));
        Palette {
            skin,
            shirt,
            pants,
            shoes,
            hair,
            accent,
            outline,
        }
    }

    /// Metal instead of skin and cloth: greys with a faint tint, a brighter accent.
    pub(super) fn metallic(&mut self, rng: &mut Rng) {
        let tint = rng.unit();
        self.skin = hsv(tint, rng.range(0.03, 0.2), rng.range(0.6, 0.85));
        self.shirt = hsv(tint + rng.range(-0.1, 0.1), rng.range(0.05, 0.35), rng.range(0.45, 0.75));
        self.pants = scale_rgb(self.shirt, 0.8);
        self.shoes = hsv(tint, 0.1, rng.range(0.2, 0.4));
    }
}
