//! What APES leaves out and a puppet needs (issue 16 item 1): hinges between parts, the joint
//! tree from its root, and the back-to-front order.
//!
//! - **Hinges.** Two parts hinge at the reference point `c` that both their motions carry to the
//!   same place in every pose: `c` minimises `Σ_t |S_a^t(c) − S_b^t(c)|²`, a 2 × 2 linear least
//!   squares problem; its RMS residual says how well a hinge explains the two motions.
//! - **Tree.** The root is the part touching the most others (a torso; the largest on ties);
//!   the tree is the minimum spanning tree of parts that touch in the reference (Prim's
//!   algorithm from the root), weighted by the hinge residual plus how far the pivot lies from
//!   where the two parts touch (a true hinge sits at the contact).
//! - **Order.** Wherever a part's pixels in one pose, carried into another pose by its motions,
//!   land on pixels that pose shows as another part, that part is in front: a vote (over every
//!   ordered pair of poses, so a part hidden in the reference still gets votes). Parts are ordered by repeatedly
//!   taking, as the next from the back, the part with the fewest votes for being in front of the
//!   remaining ones (ties: larger parts further back).

use super::segment::Segmentation;
use super::superpixels::NONE;
use crate::geom::similarity::Similarity;

/// A hinge between two parts.
#[derive(Clone, Debug, PartialEq)]
pub struct Hinge {
    /// The parent part (nearer the root).
    pub parent: usize,
    /// The child part.
    pub child: usize,
    /// The pivot in the reference pose, pixels.
    pub pivot: [f32; 2],
    /// RMS over poses of how far the two motions carry the pivot apart, pixels.
    pub residual: f32,
}

/// The skeleton and order of a segmentation.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    /// The root part.
    pub root: usize,
    /// One hinge per non-root part that touches another, parents before children.
    pub hinges: Vec<Hinge>,
    /// Parts back to front.
    pub order: Vec<usize>,
}

/// The best hinge between two motions over the poses (`None` if no pose moves them apart in a
/// determinate way, e.g. the two motions are the same in every pose).
pub fn hinge_pivot(a: &[Similarity], b: &[Similarity]) -> Option<([f32; 2], f32)> {
    // S_a(c) − S_b(c) = D c + e with D = [[da, −db], [db, da]], e = t_a − t_b.
    let (mut dd, mut rhs) = (0.0f64, [0.0f64; 2]);
    for (sa, sb) in a.iter().zip(b) {
        let (da, db) = (f64::from(sa.a - sb.a), f64::from(sa.b - sb.b));
        let e = [f64::from(sa.tx - sb.tx), f64::from(sa.ty - sb.ty)];
        // Dᵀ D = (da² + db²) I; Dᵀ e:
        dd += da * da + db * db;
        rhs[0] += da * e[0] + db * e[1];
        rhs[1] += -db * e[0] + da * e[1];
    }
    if dd < 1e-10 {
        return None;
    }
    let c = [-rhs[0] / dd, -rhs[1] / dd];
    let pivot = [c[0] as f32, c[1] as f32];
    let squared: f32 = a
        .iter()
        .zip(b)
        .map(|(sa, sb)| {
            let (p, q) = (sa.apply(pivot), sb.apply(pivot));
            (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
        })
        .sum();
    Some((pivot, (squared / a.len().max(1) as f32).sqrt()))
}

/// Hinges, tree and order of `seg` over poses of `width` pixels per row.
pub fn skeleton(seg: &Segmentation, width: usize) -> Skeleton {
    let parts = seg.parts;
    let reference = &seg.labels[seg.reference];
    let mut area = vec![0usize; parts];
    let mut touching = vec![false; parts * parts];
    // Pixels where each pair touches, for the pivot's distance to the contact.
    let mut contact: std::collections::HashMap<(usize, usize), Vec<[f32; 2]>> = std::collections::HashMap::new();
    for (i, &l) in reference.iter().enumerate() {
        if l == NONE {
            continue;
        }
        area[l as usize] += 1;
        for j in [
            (i % width + 1 < width).then(|| i + 1),
            (i + width < reference.len()).then(|| i + width),
        ]
        .into_iter()
        .flatten()
        {
            let m = reference[j];
            if m != NONE && m != l {
                touching[l as usize * parts + m as usize] = true;
                touching[m as usize * parts + l as usize] = true;
                let key = (l.min(m) as usize, l.max(m) as usize);
                contact.entry(key).or_default().push([(i % width) as f32, (i / width) as f32]);
            }
        }
    }
    let neighbours = |p: usize| (0..parts).filter(|&q| touching[p * parts + q]).count();
    let root = (0..parts)
        .max_by_key(|&p| (neighbours(p), area[p], std::cmp::Reverse(p)))
        .unwrap_or(0);
    let cost = |parent: usize, child: usize| -> ([f32; 2], f32, f32) {
        let Some((pivot, residual)) = hinge_pivot(&seg.motions[parent], &seg.motions[child]) else {
            return ([0.0; 2], f32::INFINITY, f32::INFINITY);
        };
        let gap = contact
            .get(&(parent.min(child), parent.max(child)))
            .into_iter()
            .flatten()
            .map(|c| (c[0] - pivot[0]).hypot(c[1] - pivot[1]))
            .fold(f32::INFINITY, f32::min);
        (pivot, residual, residual + gap)
    };
    // Prim's algorithm over touching parts, cheapest hinge first.
    let mut in_tree = vec![false; parts];
    in_tree[root] = true;
    let mut hinges = Vec::new();
    loop {
        let mut best: Option<(f32, Hinge)> = None;
        for parent in (0..parts).filter(|&p| in_tree[p]) {
            for child in (0..parts).filter(|&c| !in_tree[c] && touching[parent * parts + c]) {
                let (pivot, residual, weight) = cost(parent, child);
                if best.as_ref().is_none_or(|(w, _)| weight < *w) {
                    best = Some((
                        weight,
                        Hinge {
                            parent,
                            child,
                            pivot,
                            residual,
                        },
                    ));
                }
            }
        }
        match best {
            Some((_, h)) => {
                in_tree[h.child] = true;
                hinges.push(h);
            }
            None => break,
        }
    }
    Skeleton {
        root,
        hinges,
        order: order(seg, width, &area),
    }
}

/// How far inside its part, in pixels, a pixel must lie to vote on the order.
const MARGIN: usize = 1;

fn order(seg: &Segmentation, width: usize, area: &[usize]) -> Vec<usize> {
    let parts = seg.parts;
    let height = seg.labels[0].len() / width.max(1);
    // in_front[a * parts + b]: pixels where a is seen over b's carried region.
    let mut in_front = vec![0u64; parts * parts];
    let inverse: Vec<Vec<Similarity>> = seg
        .motions
        .iter()
        .map(|m| {
            m.iter()
                .map(|s| if s.scale() > 1e-6 { s.inverse() } else { Similarity::IDENTITY })
                .collect()
        })
        .collect();
    for (s, from) in seg.labels.iter().enumerate() {
        // Only pixels inside their part vote: an outline pixel carried by a motion that is a
        // little off lands on the neighbour it touches, whichever is in front.
        let inner = |labels: &[u32], i: usize, l: u32| {
            let (x, y) = (i % width, i / width);
            x >= MARGIN
                && y >= MARGIN
                && x + MARGIN < width
                && y + MARGIN < height
                && (y - MARGIN..=y + MARGIN).all(|yy| (x - MARGIN..=x + MARGIN).all(|xx| labels[yy * width + xx] == l))
        };
        for (t, to) in seg.labels.iter().enumerate().filter(|&(t, _)| t != s) {
            for (i, &l) in from.iter().enumerate() {
                if l == NONE || !inner(from, i, l) {
                    continue;
                }
                let p = l as usize;
                // Pose s → reference → pose t along the part's motions.
                let q = seg.motions[p][t].apply(inverse[p][s].apply([(i % width) as f32, (i / width) as f32]));
                let (x, y) = (q[0].round(), q[1].round());
                if x < 0.0 || y < 0.0 || x as usize >= width || y as usize >= height {
                    continue;
                }
                let j = y as usize * width + x as usize;
                let seen = to[j];
                // ... and only where it lands well inside the part seen there.
                if seen != NONE && seen as usize != p && inner(to, j, seen) {
                    in_front[seen as usize * parts + p] += 1;
                }
            }
        }
    }
    let mut remaining: Vec<usize> = (0..parts).collect();
    let mut back_to_front = Vec::new();
    while !remaining.is_empty() {
        // The part least in front of the others goes next from the back.
        let score = |a: usize, remaining: &[usize]| -> i64 {
            remaining
                .iter()
                .filter(|&&b| b != a)
                .map(|&b| in_front[a * parts + b] as i64 - in_front[b * parts + a] as i64)
                .sum()
        };
        let (k, _) = remaining
            .iter()
            .enumerate()
            .min_by_key(|&(_, &a)| (score(a, &remaining), std::cmp::Reverse(area[a]), a))
            .expect("remaining is not empty");
        back_to_front.push(remaining.remove(k));
    }
    improve_order(back_to_front, &in_front, parts)
}

/// Local search from the greedy order: move single parts to the place that most raises the
/// votes the order agrees with minus those it contradicts, until no move helps (the minimum
/// feedback arc set is NP-hard; sheets have a few dozen parts at most).
fn improve_order(mut order: Vec<usize>, in_front: &[u64], parts: usize) -> Vec<usize> {
    // Agreement of `order`: for each pair, +votes for "later is in front", −votes against.
    let agreement = |order: &[usize]| -> i64 {
        let mut total = 0i64;
        for (k, &a) in order.iter().enumerate() {
            for &b in &order[k + 1..] {
                total += in_front[b * parts + a] as i64 - in_front[a * parts + b] as i64;
            }
        }
        total
    };
    let mut best = agreement(&order);
    // Each pass moves at least one part or stops; the agreement is bounded, so this ends.
    loop {
        let mut improved = false;
        for from in 0..order.len() {
            for to in 0..order.len() {
                if to == from {
                    continue;
                }
                let mut trial = order.clone();
                let part = trial.remove(from);
                trial.insert(to, part);
                let score = agreement(&trial);
                if score > best {
                    (best, order, improved) = (score, trial, true);
                }
            }
        }
        if !improved {
            return order;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hinge_fit_recovers_the_pivot_two_motions_share() {
        let pivot = [30.0f32, 12.0];
        // Part a moves freely; part b turns about the pivot relative to a, in each pose.
        let poses = [
            (0.0f32, 1.0f32, [0.0f32, 0.0f32], 0.0f32),
            (0.3, 1.1, [5.0, -3.0], 0.7),
            (-0.5, 0.9, [-8.0, 2.0], -0.4),
            (1.2, 1.0, [2.0, 9.0], 0.2),
        ];
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for &(angle, scale, t, bend) in &poses {
            let sa = Similarity::new(angle, scale, t);
            // b = sa ∘ (rotation by `bend` about the pivot).
            let about = Similarity::new(0.0, 1.0, pivot)
                .compose(&Similarity::new(bend, 1.0, [0.0, 0.0]))
                .compose(&Similarity::new(0.0, 1.0, [-pivot[0], -pivot[1]]));
            a.push(sa);
            b.push(sa.compose(&about));
        }
        let (found, residual) = hinge_pivot(&a, &b).expect("the motions differ");
        assert!(
            (found[0] - pivot[0]).abs() < 1e-3 && (found[1] - pivot[1]).abs() < 1e-3,
            "{found:?}"
        );
        assert!(residual < 1e-3, "{residual}");
        assert_eq!(hinge_pivot(&a, &a), None);
    }
}
