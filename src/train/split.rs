//! The seeded train/test split of a sequence (neural-puppet.md §4: 70/30) and the seeded
//! shuffles of the batch order.

use crate::error::{Error, Result};
use crate::rng::Rng;

/// A seeded split of `n` frames into (train, test) indices, each sorted. `round(n · fraction)`
/// frames are held out, at least one when `fraction > 0`.
///
/// # Errors
/// [`Error::Setting`] (`test_fraction`) if the split would leave no training frame.
pub fn split(n: usize, test_fraction: f64, seed: u64) -> Result<(Vec<usize>, Vec<usize>)> {
    let tests = if test_fraction > 0.0 {
        ((n as f64 * test_fraction).round() as usize).max(1)
    } else {
        0
    };
    if n == 0 || tests >= n {
        return Err(Error::setting(
            "test_fraction",
            test_fraction,
            format!("{n} frames leave no frame for training"),
        ));
    }
    let order = shuffled(n, &mut Rng::new(seed));
    let (mut test, mut train) = (order[..tests].to_vec(), order[tests..].to_vec());
    test.sort_unstable();
    train.sort_unstable();
    Ok((train, test))
}

/// `0..n` in a seeded random order (Fisher–Yates on the platform-independent SplitMix stream).
pub fn shuffled(n: usize, rng: &mut Rng) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        order.swap(i, rng.below(i + 1));
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_is_seeded_disjoint_and_rejects_empty_sides() {
        let (train, test) = split(10, 0.3, 7).unwrap();
        assert_eq!((train.len(), test.len()), (7, 3));
        assert!(test.iter().all(|t| !train.contains(t)));
        assert_eq!(split(10, 0.3, 7).unwrap(), (train.clone(), test.clone()));
        assert_ne!(split(10, 0.3, 8).unwrap().1, test, "another seed, another split");
        assert_eq!(split(3, 0.1, 1).unwrap().1.len(), 1, "at least one test frame");
        assert!(split(1, 0.3, 1).is_err());
        assert!(split(0, 0.0, 1).is_err());
        assert_eq!(split(4, 0.0, 1).unwrap(), (vec![0, 1, 2, 3], vec![]));
    }
}
