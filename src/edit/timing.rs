//! The timing of in-betweens, as animators set it: how the `N` in-betweens between two keys are
//! spaced. Uniform steps move at one speed; slow-in/slow-out bunches the in-betweens near the
//! keys so the motion eases out of one and into the other; a spacing list places each one by
//! hand (the spacing chart drawn beside a key).
//!
//! Every timing gives `N + 2` parameters from 0 to 1, the keys included, as [`steps_t`] does.

use std::fmt;
use std::str::FromStr;

use super::inbetween::steps_t;
use crate::error::{Error, Result};

/// How uniform steps are eased.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Easing {
    /// One speed throughout.
    #[default]
    Linear,
    /// Slow out of the first key, fast into the second (`t²`).
    EaseIn,
    /// Fast out of the first key, slow into the second (`1 − (1 − t)²`).
    EaseOut,
    /// Slow out of the first key and slow into the second (`3t² − 2t³`).
    EaseInOut,
}

impl Easing {
    /// Every easing, with its name.
    pub const ALL: [(Easing, &'static str); 4] = [
        (Easing::Linear, "linear"),
        (Easing::EaseIn, "ease-in"),
        (Easing::EaseOut, "ease-out"),
        (Easing::EaseInOut, "ease-in-out"),
    ];

    /// Eases a uniform parameter `t` in [0, 1]; 0 and 1 stay put.
    pub fn apply(self, t: f32) -> f32 {
        match self {
            Easing::Linear => t,
            Easing::EaseIn => t * t,
            Easing::EaseOut => 1.0 - (1.0 - t) * (1.0 - t),
            Easing::EaseInOut => t * t * (3.0 - 2.0 * t),
        }
    }
}

impl fmt::Display for Easing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = Easing::ALL.iter().find(|(e, _)| e == self).map_or("linear", |(_, n)| n);
        f.write_str(name)
    }
}

impl FromStr for Easing {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Easing::ALL.iter().find(|(_, n)| *n == s).map(|(e, _)| *e).ok_or_else(|| {
            let names: Vec<&str> = Easing::ALL.iter().map(|(_, n)| *n).collect();
            format!("{s:?} is not an easing (give one of {})", names.join(", "))
        })
    }
}

/// The `N + 2` parameters of `steps = N` in-betweens, eased.
///
/// # Errors
/// As [`steps_t`].
pub fn eased_t(steps: usize, easing: Easing, max_steps: usize) -> Result<Vec<f32>> {
    Ok(steps_t(steps, max_steps)?.into_iter().map(|t| easing.apply(t)).collect())
}

/// The parameters of in-betweens placed by hand: `spacing` (each strictly between 0 and 1, in
/// increasing order) framed by the keys, 0 and 1.
///
/// # Errors
/// [`Error::Setting`] for an empty list or a value out of order, not finite or not strictly
/// inside (0, 1); [`Error::Limit`] for more than `max_steps` values.
pub fn spacing_t(spacing: &[f32], max_steps: usize) -> Result<Vec<f32>> {
    if spacing.is_empty() {
        return Err(Error::setting("in-between spacing", "an empty list", "at least one value"));
    }
    if spacing.len() > max_steps {
        return Err(Error::limit(
            "the in-between count",
            spacing.len() as u64,
            max_steps as u64,
            "frames",
        ));
    }
    let mut last = 0.0f32;
    for (k, &t) in spacing.iter().enumerate() {
        if !(t.is_finite() && t > last && t < 1.0) {
            return Err(Error::setting(
                format!("in-between spacing value {}", k + 1),
                t,
                format!("a number above {last} and below 1 (values increase from key 0 to key 1)"),
            ));
        }
        last = t;
    }
    Ok(std::iter::once(0.0)
        .chain(spacing.iter().copied())
        .chain(std::iter::once(1.0))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn easings_keep_the_keys_and_increase() {
        for (easing, name) in Easing::ALL {
            assert_eq!(name.parse::<Easing>(), Ok(easing));
            assert_eq!(easing.to_string(), name);
            let t = eased_t(9, easing, 100).unwrap();
            assert_eq!((t[0], t[10]), (0.0, 1.0), "{name}");
            assert!(t.windows(2).all(|w| w[1] > w[0]), "{name}: {t:?}");
        }
        assert!("bounce".parse::<Easing>().unwrap_err().contains("ease-in-out"));
    }

    #[test]
    fn slow_in_slow_out_bunches_the_inbetweens_near_both_keys() {
        let linear = eased_t(5, Easing::Linear, 10).unwrap();
        let eased = eased_t(5, Easing::EaseInOut, 10).unwrap();
        // Near each key the eased steps are shorter than the uniform ones, in the middle longer.
        let gap = |t: &[f32], k: usize| t[k + 1] - t[k];
        assert!(gap(&eased, 0) < gap(&linear, 0) && gap(&eased, 5) < gap(&linear, 5));
        assert!(gap(&eased, 3) > gap(&linear, 3));
        assert!((eased[3] - 0.5).abs() < 1e-6, "symmetric about the middle: {eased:?}");
        let ease_in = eased_t(5, Easing::EaseIn, 10).unwrap();
        assert!(gap(&ease_in, 0) < gap(&ease_in, 5));
    }

    #[test]
    fn a_spacing_list_is_framed_by_the_keys_and_checked() {
        assert_eq!(spacing_t(&[0.1, 0.5, 0.9], 10).unwrap(), vec![0.0, 0.1, 0.5, 0.9, 1.0]);
        for bad in [
            vec![],
            vec![0.5, 0.4],
            vec![0.0, 0.5],
            vec![0.5, 1.0],
            vec![f32::NAN],
            vec![0.3, 0.3],
        ] {
            assert!(spacing_t(&bad, 10).is_err(), "{bad:?}");
        }
        assert!(matches!(spacing_t(&[0.1, 0.2, 0.3], 2), Err(Error::Limit { .. })));
    }
}
