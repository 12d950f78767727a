//! The assignment problem (Kuhn 1955; the O(n²m) shortest-augmenting-path form with row and
//! column potentials): which column each row takes so the total cost is least. Part IoU
//! matches predicted to true parts with it (apes-part-extraction.md §5.1, cost 1 − IoU).
//!
//! Written here rather than taken from a crate: the well-kept ones (`pathfinding`'s
//! Kuhn–Munkres) need integer costs, and ours are IoUs.

/// The least-cost assignment of the rows of `cost` (`rows × columns`, row-major) to distinct
/// columns, or of the columns to distinct rows when there are fewer columns: `assignment[r]` is
/// the column of row `r`, `None` for rows left over. Ties go to the lower index.
///
/// # Panics
/// If `cost.len() != rows * columns` or a cost is not finite (caller bugs).
pub fn assign(cost: &[f64], rows: usize, columns: usize) -> Vec<Option<usize>> {
    assert_eq!(cost.len(), rows * columns, "cost matrix size");
    assert!(cost.iter().all(|c| c.is_finite()), "costs must be finite");
    if rows == 0 || columns == 0 {
        return vec![None; rows];
    }
    if rows > columns {
        // Transpose, solve, invert.
        let transposed: Vec<f64> = (0..columns * rows).map(|k| cost[(k % rows) * columns + k / rows]).collect();
        let column_to_row = assign(&transposed, columns, rows);
        let mut out = vec![None; rows];
        for (c, r) in column_to_row.into_iter().enumerate() {
            if let Some(r) = r {
                out[r] = Some(c);
            }
        }
        return out;
    }
    // 1-based arrays, index 0 a virtual row/column (the classical formulation).
    let (n, m) = (rows, columns);
    let at = |i: usize, j: usize| cost[(i - 1) * m + (j - 1)];
    let mut u = vec![0.0f64; n + 1];
    let mut v = vec![0.0f64; m + 1];
    let mut row_of = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        row_of[0] = i;
        let mut j0 = 0;
        let mut min_to = vec![f64::INFINITY; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = row_of[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0;
            for j in 1..=m {
                if !used[j] {
                    let reduced = at(i0, j) - u[i0] - v[j];
                    if reduced < min_to[j] {
                        min_to[j] = reduced;
                        way[j] = j0;
                    }
                    if min_to[j] < delta {
                        delta = min_to[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[row_of[j]] += delta;
                    v[j] -= delta;
                } else {
                    min_to[j] -= delta;
                }
            }
            j0 = j1;
            if row_of[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            row_of[j0] = row_of[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut out = vec![None; n];
    for j in 1..=m {
        if row_of[j] != 0 {
            out[row_of[j] - 1] = Some(j - 1);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn total(cost: &[f64], columns: usize, a: &[Option<usize>]) -> f64 {
        a.iter().enumerate().filter_map(|(r, c)| c.map(|c| cost[r * columns + c])).sum()
    }

    /// The least total over every injective assignment of the smaller side, by enumeration.
    fn brute_force(cost: &[f64], rows: usize, columns: usize) -> f64 {
        fn go(cost: &[f64], rows: usize, columns: usize, r: usize, used: &mut Vec<bool>, left: usize) -> f64 {
            if r == rows {
                return if left == 0 { 0.0 } else { f64::INFINITY };
            }
            // Row r may stay unassigned only while enough rows remain for the columns.
            let mut best = if rows - r > left {
                go(cost, rows, columns, r + 1, used, left)
            } else {
                f64::INFINITY
            };
            for c in 0..columns {
                if !used[c] && left > 0 {
                    used[c] = true;
                    best = best.min(cost[r * columns + c] + go(cost, rows, columns, r + 1, used, left - 1));
                    used[c] = false;
                }
            }
            best
        }
        go(cost, rows, columns, 0, &mut vec![false; columns], rows.min(columns))
    }

    #[test]
    fn assignment_matches_brute_force_on_random_rectangular_matrices() {
        let mut rng = Rng::new(11);
        for trial in 0..300 {
            let rows = 1 + trial % 6;
            let columns = 1 + (trial / 6) % 6;
            let cost: Vec<f64> = (0..rows * columns)
                .map(|_| (f64::from(rng.range(-3.0, 7.0))).round() / 2.0)
                .collect();
            let a = assign(&cost, rows, columns);
            let assigned: Vec<usize> = a.iter().flatten().copied().collect();
            assert_eq!(assigned.len(), rows.min(columns), "trial {trial}: {a:?}");
            let mut distinct = assigned.clone();
            distinct.sort_unstable();
            distinct.dedup();
            assert_eq!(distinct.len(), assigned.len(), "trial {trial}: a column used twice");
            let want = brute_force(&cost, rows, columns);
            assert!(
                (total(&cost, columns, &a) - want).abs() < 1e-9,
                "trial {trial}: {} vs {want}",
                total(&cost, columns, &a)
            );
        }
    }
}
