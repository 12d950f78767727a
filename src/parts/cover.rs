//! Part selection by set cover (apes-part-extraction.md §3.3, eq. 3): candidate parts from every
//! ordered pair of poses — the parts [`segment`] finds on the pair alone, cut from its first
//! pose — each covering the superpixels of every pose that its motion carries there; the fewest
//! candidates covering every superpixel of every pose, by LP relaxation (clarabel's interior
//! point method) and randomised rounding (Raghavan & Thompson 1987); each rounded selection
//! turned into parts of the reference pose, settled as [`segment`] settles its own, and scored
//! by how well those parts rebuild every pose (moved rigidly, or bent by ARAP as the paper
//! does, [`CoverOptions::score`]); the best kept.
//!
//! Where the paper is silent, ours: a candidate covers a superpixel of another pose when at
//! least [`CoverOptions::coverage`] of its pixels correspond to the candidate's pixels and sit
//! within [`CoverOptions::tolerance`] of where the candidate's similarity puts them; the
//! rebuild is rigid per part (the paper deforms each part by ARAP).

use std::collections::BTreeSet;

use rayon::prelude::*;

use super::deform::Rebuild;
use super::flow::Correspondences;
use super::pose::SheetPose;
use super::reconstruct::redraw;
use super::segment::{reference_pose, segment, settle, SegmentOptions, Segmentation};
use super::skeleton::skeleton;
use super::superpixels::{Superpixels, NONE};
use crate::error::{Error, Result};
use crate::geom::similarity::{Moments, Similarity};
use crate::rng::Rng;

/// How the set cover selects parts.
#[derive(Clone, Debug, PartialEq)]
pub struct CoverOptions {
    /// Randomised roundings of the LP's solution tried (distinct selections are scored).
    pub rounds: usize,
    /// Seeds the roundings.
    pub seed: u64,
    /// Share of a superpixel's pixels a candidate must carry there to cover it.
    pub coverage: f32,
    /// How far, in pixels, a pixel may sit from where the candidate's similarity puts it and
    /// still be carried by it.
    pub tolerance: f32,
    /// How the poses are rebuilt to score a selection. Rigid by default, not the paper's ARAP:
    /// bent parts rebuild a pose well even when a selection merges parts that move apart, so
    /// ARAP tells selections apart less well (docs/results.md "Scoring the cover by ARAP").
    pub score: Rebuild,
}

impl Default for CoverOptions {
    fn default() -> Self {
        CoverOptions {
            rounds: 24,
            seed: 0,
            coverage: 0.5,
            tolerance: 3.0,
            score: Rebuild::Rigid,
        }
    }
}

/// A candidate part: the superpixels it covers (numbered across all poses, pose by pose), and
/// the share of each reference superpixel it carries there.
#[derive(Clone, Debug)]
struct Candidate {
    covers: Vec<usize>,
    reference_shares: Vec<f32>,
}

/// What the selection did, for reports.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CoverReport {
    /// Candidates pooled from all pairs.
    pub candidates: usize,
    /// Superpixels of all poses.
    pub superpixels: usize,
    /// Superpixels no candidate covers (left out of the cover).
    pub uncovered: usize,
    /// The LP relaxation's optimum (a lower bound of the fewest candidates).
    pub lp_bound: f64,
    /// Distinct selections scored.
    pub selections: usize,
    /// Candidates in the selection kept.
    pub selected: usize,
}

/// Parts of `poses` by set cover over candidates from every pair (see the module doc).
///
/// # Errors
/// As [`segment`]; [`Error::Setting`] for options out of range; [`Error::Geometry`] if the LP
/// solver fails.
pub fn cover(
    poses: &[SheetPose],
    superpixels: &[Superpixels],
    flows: &Correspondences,
    options: &SegmentOptions,
    cover: &CoverOptions,
) -> Result<(Segmentation, CoverReport)> {
    if !(cover.coverage > 0.0 && cover.coverage <= 1.0) {
        return Err(Error::setting("cover coverage", cover.coverage, "a share in (0, 1]"));
    }
    if !(cover.tolerance > 0.0 && cover.tolerance.is_finite()) {
        return Err(Error::setting("cover tolerance", cover.tolerance, "a positive number of pixels"));
    }
    if cover.rounds == 0 {
        return Err(Error::setting("cover rounds", 0, "at least 1"));
    }
    flows.check_complete()?;
    let reference = reference_pose(poses, options)?;
    if poses.len() < 2 {
        return Ok((segment(poses, superpixels, flows, options)?, CoverReport::default()));
    }
    let offsets: Vec<usize> = std::iter::once(0)
        .chain(superpixels.iter().scan(0, |n, sp| {
            *n += sp.count;
            Some(*n)
        }))
        .collect();
    let pairs: Vec<(usize, usize)> = (0..poses.len())
        .flat_map(|s| (0..poses.len()).filter(move |&t| t != s).map(move |t| (s, t)))
        .collect();
    let masks = pairs
        .par_iter()
        .map(|&(s, t)| pair_candidates(poses, superpixels, flows, options, s, t))
        .collect::<Result<Vec<_>>>()?;
    let candidates: Vec<Candidate> = masks
        .into_iter()
        .zip(&pairs)
        .flat_map(|(masks, &(s, _))| masks.into_iter().map(move |mask| (s, mask)))
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|(s, mask)| {
            let mut covers = Vec::new();
            let mut reference_shares = Vec::new();
            for (u, &offset) in offsets.iter().take(poses.len()).enumerate() {
                let shares = carried_shares(poses, superpixels, flows, s, &mask, u, cover.tolerance);
                covers.extend((0..shares.len()).filter(|&k| shares[k] >= cover.coverage).map(|k| offset + k));
                if u == reference {
                    reference_shares = shares;
                }
            }
            Candidate { covers, reference_shares }
        })
        .collect();
    let elements = offsets[poses.len()];
    let mut covered_by = vec![Vec::new(); elements];
    for (c, candidate) in candidates.iter().enumerate() {
        for &e in &candidate.covers {
            covered_by[e].push(c);
        }
    }
    let universe: Vec<usize> = (0..elements).filter(|&e| !covered_by[e].is_empty()).collect();
    let z = lp_relaxation(candidates.len(), &universe, &covered_by)?;
    let selections = round(&z, &candidates, &universe, &covered_by, cover);
    let scored = selections
        .par_iter()
        .map(|selection| {
            let seg = selected_parts(poses, superpixels, flows, options, reference, &candidates, selection);
            let error = rebuild_error(poses, &seg, flows, &cover.score)?;
            Ok((error, seg, selection.len()))
        })
        .collect::<Result<Vec<_>>>()?;
    let (_, best, selected) = scored
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .expect("rounding yields at least one selection");
    let report = CoverReport {
        candidates: candidates.len(),
        superpixels: elements,
        uncovered: elements - universe.len(),
        lp_bound: z.iter().sum(),
        selections: selections.len(),
        selected,
    };
    Ok((best, report))
}

/// The parts [`segment`] finds on poses `s` and `t` alone, as masks of pose `s`.
fn pair_candidates(
    poses: &[SheetPose],
    superpixels: &[Superpixels],
    flows: &Correspondences,
    options: &SegmentOptions,
    s: usize,
    t: usize,
) -> Result<Vec<Vec<bool>>> {
    let pixels = poses[s].mask.len();
    let mut pair = Correspondences::new(2, pixels);
    for (from, to, a, b) in [(s, t, 0, 1), (t, s, 1, 0)] {
        let flow = flows.get(from, to).expect("checked complete");
        pair.set(a, b, flow.clone())?;
    }
    let options = SegmentOptions {
        reference: Some(0),
        ..options.clone()
    };
    let seg = segment(
        &[poses[s].clone(), poses[t].clone()],
        &[superpixels[s].clone(), superpixels[t].clone()],
        &pair,
        &options,
    )?;
    Ok((0..seg.parts as u32)
        .map(|p| seg.labels[0].iter().map(|&l| l == p).collect())
        .collect())
}

/// The share of each superpixel of pose `u` that the candidate `mask` of pose `s` carries
/// there: its pixels whose correspondence in `s` falls on the candidate and lies within
/// `tolerance` of where the candidate's similarity puts it (in `s` itself, the candidate's own
/// pixels).
fn carried_shares(
    poses: &[SheetPose],
    superpixels: &[Superpixels],
    flows: &Correspondences,
    s: usize,
    mask: &[bool],
    u: usize,
    tolerance: f32,
) -> Vec<f32> {
    let sp = &superpixels[u];
    let w = poses[s].width();
    let h = mask.len() / w;
    let mut shares = vec![0.0; sp.count];
    let motion = if u == s {
        Some(Similarity::IDENTITY)
    } else {
        similarity(flows, s, u, mask, w)
    };
    let Some(motion) = motion else { return shares };
    let back = (u != s).then(|| flows.get(u, s).expect("checked complete"));
    for (i, &l) in sp.labels.iter().enumerate() {
        let here = [(i % w) as f32, (i / w) as f32];
        let q = match back {
            _ if l == NONE => continue,
            Some(flow) => match flow.at(i) {
                Some(q) => q,
                None => continue,
            },
            None => here,
        };
        let (x, y) = (q[0].round(), q[1].round());
        if x < 0.0 || y < 0.0 || x as usize >= w || y as usize >= h || !mask[y as usize * w + x as usize] {
            continue;
        }
        let there = motion.apply(q);
        if (there[0] - here[0]).hypot(there[1] - here[1]) <= tolerance {
            shares[l as usize] += 1.0;
        }
    }
    for (share, &size) in shares.iter_mut().zip(&sp.sizes) {
        *share /= size.max(1) as f32;
    }
    shares
}

/// The similarity carrying the pixels of `mask` (pose `s`) to pose `u` by their
/// correspondences, if they have enough for one.
fn similarity(flows: &Correspondences, s: usize, u: usize, mask: &[bool], w: usize) -> Option<Similarity> {
    let flow = flows.get(s, u)?;
    let mut moments = Moments::default();
    for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
        if let Some(q) = flow.at(i) {
            moments.add([(i % w) as f32, (i / w) as f32], q);
        }
    }
    moments.fit()
}

/// The LP relaxation of eq. 3: minimise Σ z over 0 ≤ z ≤ 1 with every element of `universe`
/// covered at least once.
fn lp_relaxation(n: usize, universe: &[usize], covered_by: &[Vec<usize>]) -> Result<Vec<f64>> {
    use clarabel::algebra::CscMatrix;
    use clarabel::solver::{DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
    // Rows: −Σ z ≤ −1 per element, then −z ≤ 0 and z ≤ 1 per candidate (A z + s = b, s ≥ 0).
    let m = universe.len();
    let mut columns: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for (row, &e) in universe.iter().enumerate() {
        for &c in &covered_by[e] {
            columns[c].push((row, -1.0));
        }
    }
    for (c, column) in columns.iter_mut().enumerate() {
        column.push((m + c, -1.0));
        column.push((m + n + c, 1.0));
    }
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for column in &columns {
        for &(r, v) in column {
            rowval.push(r);
            nzval.push(v);
        }
        colptr.push(rowval.len());
    }
    let rows = m + 2 * n;
    let a = CscMatrix::new(rows, n, colptr, rowval, nzval);
    let b: Vec<f64> = (0..rows)
        .map(|r| {
            if r < m {
                -1.0
            } else if r < m + n {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    let p = CscMatrix::zeros((n, n));
    let q = vec![1.0; n];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .build()
        .map_err(|e| Error::geometry("the set cover's LP", format!("bad settings: {e}")))?;
    let mut solver = DefaultSolver::new(&p, &q, &a, &b, &[NonnegativeConeT(rows)], settings)
        .map_err(|e| Error::geometry("the set cover's LP", format!("{e:?}")))?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => Ok(solver.solution.x.iter().map(|z| z.clamp(0.0, 1.0)).collect()),
        status => Err(Error::geometry("the set cover's LP", format!("not solved ({status:?})"))),
    }
}

/// Distinct covers rounded from the LP's `z`: the largest z first until all is covered, then
/// `rounds` randomised roundings (each candidate drawn with probability z, ⌈ln m⌉ + 1 times,
/// the rest covered greedily); each pruned of candidates the others make redundant.
fn round(z: &[f64], candidates: &[Candidate], universe: &[usize], covered_by: &[Vec<usize>], options: &CoverOptions) -> Vec<Vec<usize>> {
    let mut by_z: Vec<usize> = (0..z.len()).collect();
    by_z.sort_by(|&a, &b| z[b].total_cmp(&z[a]).then(a.cmp(&b)));
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    let mut keep = |selection: Vec<usize>| {
        let pruned = prune(selection, z, candidates, covered_by.len());
        if seen.insert(pruned.clone()) {
            out.push(pruned);
        }
    };
    keep(complete(Vec::new(), &by_z, candidates, universe, covered_by));
    let draws = (universe.len().max(2) as f64).ln().ceil() as usize + 1;
    let mut rng = Rng::new(options.seed);
    for _ in 0..options.rounds {
        let mut picked = vec![false; z.len()];
        for _ in 0..draws {
            for (c, chosen) in picked.iter_mut().enumerate() {
                if !*chosen && rng.unit() < z[c] as f32 {
                    *chosen = true;
                }
            }
        }
        let selection = (0..z.len()).filter(|&c| picked[c]).collect();
        keep(complete(selection, &by_z, candidates, universe, covered_by));
    }
    out
}

/// `selection` with candidates added until every element of `universe` is covered: each time
/// the one covering the most uncovered elements (ties: the larger z, in `by_z`'s order).
fn complete(
    mut selection: Vec<usize>,
    by_z: &[usize],
    candidates: &[Candidate],
    universe: &[usize],
    covered_by: &[Vec<usize>],
) -> Vec<usize> {
    let mut count = vec![0usize; covered_by.len()];
    for &c in &selection {
        for &e in &candidates[c].covers {
            count[e] += 1;
        }
    }
    while universe.iter().any(|&e| count[e] == 0) {
        let gain = |c: usize| candidates[c].covers.iter().filter(|&&e| count[e] == 0).count();
        let Some((_, best)) = by_z
            .iter()
            .copied()
            .enumerate()
            .max_by_key(|&(rank, c)| (gain(c), std::cmp::Reverse(rank)))
            .filter(|&(_, c)| gain(c) > 0)
        else {
            break;
        };
        for &e in &candidates[best].covers {
            count[e] += 1;
        }
        selection.push(best);
    }
    selection
}

/// `selection` without the candidates every element of which another selected one covers,
/// the smallest z tried first; sorted.
fn prune(mut selection: Vec<usize>, z: &[f64], candidates: &[Candidate], elements: usize) -> Vec<usize> {
    let mut count = vec![0usize; elements];
    for &c in &selection {
        for &e in &candidates[c].covers {
            count[e] += 1;
        }
    }
    selection.sort_by(|&a, &b| z[a].total_cmp(&z[b]).then(a.cmp(&b)));
    let mut kept = Vec::with_capacity(selection.len());
    for c in selection {
        if candidates[c].covers.iter().all(|&e| count[e] > 1) {
            for &e in &candidates[c].covers {
                count[e] -= 1;
            }
        } else {
            kept.push(c);
        }
    }
    kept.sort_unstable();
    kept
}

/// The parts of a selection, settled: each reference superpixel given to the selected
/// candidate carrying most of it there, then [`settle`].
fn selected_parts(
    poses: &[SheetPose],
    superpixels: &[Superpixels],
    flows: &Correspondences,
    options: &SegmentOptions,
    reference: usize,
    candidates: &[Candidate],
    selection: &[usize],
) -> Segmentation {
    let sp = &superpixels[reference];
    // Per reference superpixel: (share carried, candidate rank in the selection).
    let mut best: Vec<Option<(f32, usize)>> = vec![None; sp.count];
    for (rank, &c) in selection.iter().enumerate() {
        for (k, &share) in candidates[c].reference_shares.iter().enumerate() {
            if share > 0.0 && best[k].is_none_or(|(s, _)| share > s) {
                best[k] = Some((share, rank));
            }
        }
    }
    let mut part_of_rank = vec![None; selection.len()];
    let mut parts = 0;
    for &(_, rank) in best.iter().flatten() {
        if part_of_rank[rank].is_none() {
            part_of_rank[rank] = Some(parts);
            parts += 1;
        }
    }
    let initial: Vec<u32> = sp
        .labels
        .iter()
        .map(|&l| match (l != NONE).then(|| best[l as usize]).flatten() {
            Some((_, rank)) => part_of_rank[rank].expect("numbered above") as u32,
            None => NONE,
        })
        .collect();
    settle(poses, superpixels, flows, options, reference, initial, parts.max(1))
}

/// Mean squared error, over the poses' pixels and premultiplied channels, of every pose
/// rebuilt from the parts.
fn rebuild_error(poses: &[SheetPose], seg: &Segmentation, flows: &Correspondences, how: &Rebuild) -> Result<f64> {
    let order = skeleton(seg, poses[seg.reference].width()).order;
    let meshes = how.meshes(poses, seg, flows)?;
    let mut total = 0.0;
    let mut count = 0usize;
    for (t, pose) in poses.iter().enumerate() {
        let rebuilt = redraw(poses, seg, meshes.as_deref(), &order, t);
        for (a, b) in rebuilt.pixels.iter().zip(&pose.image.pixels) {
            for ch in 0..4 {
                let (x, y) = if ch < 3 { (a[ch] * a[3], b[ch] * b[3]) } else { (a[3], b[3]) };
                total += f64::from(x - y).powi(2);
            }
        }
        count += pose.image.pixels.len();
    }
    Ok(total / count.max(1) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Candidates covering `sets` (no pixels: only the cover is exercised).
    fn candidates(sets: &[Vec<usize>]) -> Vec<Candidate> {
        sets.iter()
            .map(|covers| Candidate {
                covers: covers.clone(),
                reference_shares: Vec::new(),
            })
            .collect()
    }

    /// The fewest sets covering `0..elements`, by trying every subset.
    fn brute_force(sets: &[Vec<usize>], elements: usize) -> usize {
        (0u32..1 << sets.len())
            .filter(|subset| {
                let mut hit = vec![false; elements];
                for (c, set) in sets.iter().enumerate() {
                    if subset & (1 << c) != 0 {
                        set.iter().for_each(|&e| hit[e] = true);
                    }
                }
                hit.iter().all(|&h| h)
            })
            .map(u32::count_ones)
            .min()
            .expect("the sets cover the universe") as usize
    }

    /// LP bound, every rounded selection, and the smallest of them, for `sets` over `0..elements`.
    fn solve(sets: &[Vec<usize>], elements: usize) -> (f64, Vec<Vec<usize>>) {
        let candidates = candidates(sets);
        let mut covered_by = vec![Vec::new(); elements];
        for (c, set) in sets.iter().enumerate() {
            set.iter().for_each(|&e| covered_by[e].push(c));
        }
        let universe: Vec<usize> = (0..elements).collect();
        let z = lp_relaxation(sets.len(), &universe, &covered_by).unwrap();
        let selections = round(&z, &candidates, &universe, &covered_by, &CoverOptions::default());
        (z.iter().sum(), selections)
    }

    fn covers_all(sets: &[Vec<usize>], selection: &[usize], elements: usize) -> bool {
        let mut hit = vec![false; elements];
        selection.iter().for_each(|&c| sets[c].iter().for_each(|&e| hit[e] = true));
        hit.iter().all(|&h| h)
    }

    #[test]
    fn the_lp_sees_past_the_largest_set_that_greedy_would_take() {
        // Greedy takes C (4 elements) first and then needs A and B anyway: 3 sets; the cover is
        // A and B, and the LP knows it (2 and 5 have one set each).
        let sets = vec![vec![0, 1, 2], vec![3, 4, 5], vec![0, 1, 3, 4]];
        let (bound, selections) = solve(&sets, 6);
        assert!((bound - 2.0).abs() < 1e-6, "LP optimum {bound}");
        assert!(selections.iter().all(|s| covers_all(&sets, s, 6)));
        assert!(selections.contains(&vec![0, 1]), "{selections:?}");
        assert!(
            selections.iter().all(|s| s.len() == 2),
            "pruning drops C from every selection: {selections:?}"
        );
    }

    #[test]
    fn rounded_covers_cover_everything_reach_the_brute_force_optimum_and_stay_above_the_lp_bound() {
        let mut rng = Rng::new(11);
        for instance in 0..20 {
            let elements = 6 + rng.below(6);
            let count = 5 + rng.below(6);
            let mut sets: Vec<Vec<usize>> = (0..count)
                .map(|_| {
                    let mut set: Vec<usize> = (0..elements).filter(|_| rng.chance(0.3)).collect();
                    set.dedup();
                    set
                })
                .collect();
            // Every element in some set.
            for e in 0..elements {
                if !sets.iter().any(|s| s.contains(&e)) {
                    let k = rng.below(count);
                    sets[k].push(e);
                }
            }
            let optimum = brute_force(&sets, elements);
            let (bound, selections) = solve(&sets, elements);
            assert!(
                bound <= optimum as f64 + 1e-6,
                "instance {instance}: LP {bound} above the optimum {optimum}"
            );
            assert!(selections.iter().all(|s| covers_all(&sets, s, elements)), "instance {instance}");
            let best = selections.iter().map(Vec::len).min().unwrap();
            assert!(best == optimum, "instance {instance}: best rounding {best}, optimum {optimum}");
        }
    }
}
