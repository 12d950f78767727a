//! Where the pins of each constraint go (accessory-rigs.md §3.3), on the layers' rest masks,
//! before the accessory is meshed: each site becomes a vertex of the accessory's mesh.
//!
//! - **Occlusion**: each stretch of the parent's outline that passes under the child (the child
//!   covers it), pinned at both ends and every `spacing` pixels or less between, so a stretch
//!   shorter than the spacing is pinned too.
//! - **Coincident boundary**: the child's outline where it runs within `coincident_distance`
//!   (paper: 5 px) of the parent's outline.
//! - **Overlap**: the outline of the region the two layers share, when the parent's outline runs
//!   through the child (a child lying wholly inside its parent, a button on a vest, has no region
//!   boundary of the parent's to keep, and falls back to a point as §3.4 says it should); when the
//!   child and the parent hang from two different, jointed body layers, only its stretches within
//!   `attachment_distance` (paper: 20 px) of where those body layers meet.
//! - **Point**: the point of the shared region closest to the child's centroid (the child's pixel
//!   nearest the parent when they do not overlap).
//!
//! A constraint that finds no site falls back to a point (§3.4), and every separate piece of the
//! child (eyes, freckles) gets a point of its own if no other pin lies on it, so no piece of an
//! accessory is left without a handle. Sites are snapped to the centre of a child pixel, which
//! the mesher keeps inside the mesh.

use super::mask::Mask;
use crate::puppet::rig_data::{Constraint, RigEdge, RigOverrides};
use crate::puppet::Puppet;

/// How densely pins are placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinOptions {
    /// Pixels between pins along an outline.
    pub spacing: f32,
    /// Child outline this close to the parent's outline is a coincident boundary (paper: 5 px).
    pub coincident_distance: f32,
    /// Overlap outline kept within this distance of the body layers' attachment (paper: 20 px).
    pub attachment_distance: f32,
    /// A child with several parents: no pin of a later edge's parent within this distance of a
    /// pin of an earlier one (0: no limit), but for the point an edge left with no pin falls back
    /// to (§3.4). Pins of two parents close together that move apart cannot both be met without
    /// folding the child between them.
    pub separation: f32,
}

impl PinOptions {
    /// The paper's distances and a spacing that follows the artwork's scale: one pin every
    /// `max(width, height) / 40` pixels, at least 2 (4.8 px at 192², 16 px at 640²).
    pub fn for_size(width: u32, height: u32) -> Self {
        PinOptions {
            spacing: (width.max(height) as f32 / 40.0).max(2.0),
            coincident_distance: 5.0,
            attachment_distance: 20.0,
            separation: 0.0,
        }
    }
}

/// A pin before meshing: a point of the child and the parent layer it follows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinSite {
    /// Canvas pixels (a child pixel centre).
    pub at: [f32; 2],
    /// The parent layer.
    pub parent: usize,
    /// The constraint that placed it.
    pub constraint: Constraint,
}

/// What the pin placement of one child reads: every layer's mask, each layer's body part (the
/// body layer it hangs from, itself for a body layer), and which body layers are jointed.
pub struct PinContext<'a> {
    /// The puppet (layer kinds and names).
    pub puppet: &'a Puppet,
    /// Every layer's rest mask.
    pub masks: &'a [Mask],
    /// Per layer, the body layer it hangs from.
    pub body_part: &'a [usize],
    /// Jointed body-layer pairs.
    pub adjacent: &'a [[usize; 2]],
}

/// The pin sites of accessory `child` for its `edges` (module doc), with `overrides`' extra pins
/// added and unpinned regions cleared.
pub fn pin_sites(cx: &PinContext, child: usize, edges: &[&RigEdge], overrides: &RigOverrides, options: &PinOptions) -> Vec<PinSite> {
    let masks = cx.masks;
    let c = &masks[child];
    let mut sites = Vec::new();
    for edge in edges {
        let p = edge.parent;
        let before = sites.len();
        for &constraint in &edge.constraints {
            let points = match constraint {
                Constraint::Occlusion => occlusion_points(&masks[p], c, options.spacing),
                Constraint::Coincident => {
                    let edge_distance = outline_mask(&masks[p]).distance();
                    c.outline(options.spacing)
                        .into_iter()
                        .filter(|q| pixel_value(&edge_distance, c, *q).is_some_and(|d| d <= options.coincident_distance))
                        .collect()
                }
                Constraint::Overlap => overlap_outline(cx, child, p, options),
                Constraint::Point => point_site(c, &masks[p], c).into_iter().collect(),
            };
            let points = apart_from_other_parents(points, &sites, p, options.separation);
            push_snapped(&mut sites, c, &points, p, constraint);
        }
        if sites.len() == before {
            // §3.4: no occluded outline, coincident boundary or overlap near the attachment.
            if let Some(q) = point_site(c, &masks[p], c) {
                push_snapped(&mut sites, c, &[q], p, Constraint::Point);
            }
        }
    }
    for pin in overrides.pins.iter().filter(|o| cx.puppet.layer_index(&o.child) == Some(child)) {
        if let Some(parent) = cx.puppet.layer_index(&pin.parent) {
            push_snapped(&mut sites, c, &[pin.at], parent, Constraint::Point);
        }
    }
    for unpin in overrides.unpins.iter().filter(|o| cx.puppet.layer_index(&o.child) == Some(child)) {
        sites.retain(|s| (s.at[0] - unpin.at[0]).hypot(s.at[1] - unpin.at[1]) > unpin.radius);
    }
    // Every piece of the child gets a handle: one with no site follows the first parent at a point.
    if let Some(first) = edges.first() {
        for piece in c.pieces() {
            let on_piece = |s: &PinSite| {
                let i = (s.at[1] as usize) * c.width as usize + s.at[0] as usize;
                piece.binary_search(&i).is_ok()
            };
            if !sites.iter().any(on_piece) {
                let part = Mask {
                    width: c.width,
                    height: c.height,
                    inside: {
                        let mut inside = vec![false; c.inside.len()];
                        piece.iter().for_each(|&i| inside[i] = true);
                        inside
                    },
                };
                if let Some(q) = point_site(&part, &masks[first.parent], c) {
                    push_snapped(&mut sites, c, &[q], first.parent, Constraint::Point);
                }
            }
        }
    }
    sites
}

/// Arc length between the outline samples the occlusion constraint looks at, pixels.
const OUTLINE_STEP: f32 = 0.5;

/// The occlusion constraint's sites: each stretch of `parent`'s outline under `child`, pinned at
/// both ends and at most `spacing` apart between (a stretch shorter than half the spacing, at
/// its middle). Samples every `spacing` along the whole outline would miss a stretch shorter
/// than the spacing (the temple of a pair of glasses crossing a head's outline) and leave the
/// ends of longer ones, where the child's rim crosses the outline and covers it least, up to a
/// spacing from the nearest pin.
fn occlusion_points(parent: &Mask, child: &Mask, spacing: f32) -> Vec<[f32; 2]> {
    let mut points = Vec::new();
    for ring in parent.outline_rings(OUTLINE_STEP) {
        let covered: Vec<bool> = ring.iter().map(|&q| child.covers(q)).collect();
        let Some(start) = covered.iter().position(|&c| !c) else {
            // The whole ring under the child: no ends, evenly spaced samples.
            let k = ((ring.len() as f32 * OUTLINE_STEP / spacing).round() as usize)
                .max(1)
                .min(ring.len());
            points.extend((0..k).map(|j| ring[j * ring.len() / k]));
            continue;
        };
        let mut run = Vec::new();
        // From just after an uncovered sample round to it, so a stretch across the ring's
        // first point is one stretch and the last one ends.
        for j in 1..=ring.len() {
            let i = (start + j) % ring.len();
            if covered[i] {
                run.push(ring[i]);
            } else if !run.is_empty() {
                points.extend(spread_over(&run, spacing));
                run.clear();
            }
        }
    }
    points
}

/// Points of a stretch of outline samples (`OUTLINE_STEP` apart): its two ends and as few
/// between as keep neighbours at most `spacing` apart, or its middle sample if it is shorter
/// than half the spacing.
fn spread_over(run: &[[f32; 2]], spacing: f32) -> Vec<[f32; 2]> {
    let last = run.len() - 1;
    let length = last as f32 * OUTLINE_STEP;
    if length < spacing / 2.0 {
        return vec![run[last / 2]];
    }
    let intervals = (length / spacing).ceil() as usize;
    (0..=intervals).map(|j| run[j * last / intervals]).collect()
}

/// `points` (of parent `parent`) without those within `separation` of a site of another parent.
fn apart_from_other_parents(points: Vec<[f32; 2]>, sites: &[PinSite], parent: usize, separation: f32) -> Vec<[f32; 2]> {
    let near_other = |q: &[f32; 2]| {
        sites
            .iter()
            .any(|s| s.parent != parent && (s.at[0] - q[0]).hypot(s.at[1] - q[1]) < separation)
    };
    points.into_iter().filter(|q| !near_other(q)).collect()
}

/// Adds `points` snapped to the nearest child pixel centre (within 1.5 px), each once.
fn push_snapped(sites: &mut Vec<PinSite>, child: &Mask, points: &[[f32; 2]], parent: usize, constraint: Constraint) {
    for &q in points {
        if let Some(at) = child.nearest_inside(q, 1.5) {
            if !sites.iter().any(|s| s.at == at) {
                sites.push(PinSite { at, parent, constraint });
            }
        }
    }
}

/// The value of a per-pixel field at the pixel holding `q` (or the nearest one of `mask`'s
/// canvas), `None` off the canvas.
fn pixel_value(field: &[f32], mask: &Mask, q: [f32; 2]) -> Option<f32> {
    let (x, y) = (q[0].floor() as i64, q[1].floor() as i64);
    let inside = x >= 0 && y >= 0 && x < i64::from(mask.width) && y < i64::from(mask.height);
    inside.then(|| field[(y as usize) * mask.width as usize + x as usize])
}

/// The pixels of `mask` on its outline (covered, with an uncovered 4-neighbour or the canvas
/// edge beside them).
fn outline_mask(mask: &Mask) -> Mask {
    let w = mask.width as i64;
    let inside = (0..mask.inside.len())
        .map(|i| {
            let (x, y) = ((i as i64) % w, (i as i64) / w);
            mask.inside[i] && [(-1, 0), (1, 0), (0, -1), (0, 1)].iter().any(|(dx, dy)| !mask.at(x + dx, y + dy))
        })
        .collect();
    Mask {
        width: mask.width,
        height: mask.height,
        inside,
    }
}

/// The overlap constraint's outline samples (module doc).
fn overlap_outline(cx: &PinContext, child: usize, parent: usize, options: &PinOptions) -> Vec<[f32; 2]> {
    // Sampled as finely as the occlusion pins walk it, so a crossing shorter than the spacing
    // counts.
    let crosses = cx.masks[parent]
        .outline(OUTLINE_STEP)
        .into_iter()
        .any(|q| cx.masks[child].covers(q));
    if !crosses {
        return Vec::new();
    }
    let shared = cx.masks[child].and(&cx.masks[parent]);
    let outline = shared.outline(options.spacing);
    let (a, b) = (cx.body_part[child], cx.body_part[parent]);
    let jointed = a != b && cx.adjacent.iter().any(|&[x, y]| (x, y) == (a, b) || (x, y) == (b, a));
    if !jointed {
        return outline;
    }
    let near_attachment = cx.masks[a].and(&cx.masks[b]).distance();
    outline
        .into_iter()
        .filter(|&q| pixel_value(&near_attachment, &shared, q).is_some_and(|d| d <= options.attachment_distance))
        .collect()
}

/// The single-point site of `part` (a child or one piece of it) on `parent`: the shared pixel
/// closest to the part's centroid, or, if they share none, the part's pixel nearest the parent.
fn point_site(part: &Mask, parent: &Mask, child: &Mask) -> Option<[f32; 2]> {
    let centroid = part.centroid()?;
    let shared = part.and(parent);
    let nearest = |m: &Mask, to: [f32; 2]| {
        (0..m.inside.len())
            .filter(|&i| m.inside[i])
            .map(|i| m.centre(i))
            .min_by(|p, q| dist(*p, to).total_cmp(&dist(*q, to)))
    };
    if shared.count() > 0 {
        return nearest(&shared, centroid);
    }
    let d = parent.distance();
    let best = (0..part.inside.len())
        .filter(|&i| part.inside[i])
        .min_by(|&i, &j| d[i].total_cmp(&d[j]))?;
    child.nearest_inside(part.centre(best), 0.5)
}

fn dist(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::puppet::rig_data::Origin;

    fn rect(w: u32, h: u32, r: [u32; 4]) -> Mask {
        Mask {
            width: w,
            height: h,
            inside: (0..w * h)
                .map(|i| (r[0]..r[2]).contains(&(i % w)) && (r[1]..r[3]).contains(&(i / w)))
                .collect(),
        }
    }

    fn edge(parent: usize, constraints: &[Constraint]) -> RigEdge {
        RigEdge {
            parent,
            child: 1,
            constraints: constraints.to_vec(),
            origin: Origin::Auto,
        }
    }

    /// The sites `constraint` gives a child rectangle over a parent rectangle on a 40² canvas.
    fn rect_sites(parent: [u32; 4], child: [u32; 4], constraint: Constraint, spacing: f32) -> Vec<PinSite> {
        sites(vec![rect(40, 40, parent), rect(40, 40, child)], &edge(0, &[constraint]), spacing)
    }

    fn sites(masks: Vec<Mask>, e: &RigEdge, spacing: f32) -> Vec<PinSite> {
        let options = PinOptions {
            spacing,
            ..PinOptions::for_size(40, 40)
        };
        sites_of(masks, &[e], &options)
    }

    fn sites_of(masks: Vec<Mask>, edges: &[&RigEdge], options: &PinOptions) -> Vec<PinSite> {
        let layers = (0..masks.len())
            .map(|k| crate::test_util::rect_layer(&format!("l{k}"), (40, 40), [0.0, 0.0, 1.0, 1.0], (1, 1), |_, _| [0.0; 3]));
        let puppet = Puppet {
            width: 40,
            height: 40,
            layers: layers.collect(),
            root: 0,
            joints: Vec::new(),
            rig: None,
        };
        let body_part: Vec<usize> = (0..masks.len()).map(|_| 0).collect();
        let cx = PinContext {
            puppet: &puppet,
            masks: &masks,
            body_part: &body_part,
            adjacent: &[],
        };
        pin_sites(&cx, 1, edges, &RigOverrides::default(), options)
    }

    #[test]
    fn a_later_parent_keeps_its_distance_from_an_earlier_one() {
        // Hair [8, 32) × [3, 30) over a head [16, 24) × [5, 20) and a torso from y = 22: the
        // torso's top edge under the hair runs 3 px below the head's bottom edge in the middle
        // and farther from it at the sides.
        let masks = || {
            vec![
                rect(40, 40, [16, 5, 24, 20]),
                rect(40, 40, [8, 3, 32, 30]),
                rect(40, 40, [5, 22, 35, 40]),
            ]
        };
        let (head, torso) = (edge(0, &[Constraint::Occlusion]), edge(2, &[Constraint::Occlusion]));
        let with = |separation| {
            let options = PinOptions {
                spacing: 2.0,
                separation,
                ..PinOptions::for_size(40, 40)
            };
            sites_of(masks(), &[&head, &torso], &options)
        };
        let closest = |s: &[PinSite]| {
            let of = |parent| s.iter().filter(move |p| p.parent == parent);
            of(2)
                .flat_map(|t| of(0).map(move |h| (t.at[0] - h.at[0]).hypot(t.at[1] - h.at[1])))
                .fold(f32::INFINITY, f32::min)
        };
        let (all, apart) = (with(0.0), with(5.0));
        assert!(closest(&all) < 5.0, "{all:?}");
        assert!(closest(&apart) >= 5.0, "{apart:?}");
        // The head keeps every pin, the torso those away from it (occlusion pins, not a fallback).
        let count = |s: &[PinSite], parent| {
            s.iter()
                .filter(|p| p.parent == parent && p.constraint == Constraint::Occlusion)
                .count()
        };
        assert_eq!(count(&apart, 0), count(&all, 0));
        assert!(
            (1..count(&all, 2)).contains(&count(&apart, 2)),
            "{} of {}",
            count(&apart, 2),
            count(&all, 2)
        );
    }

    #[test]
    fn occlusion_pins_the_parent_outline_under_the_child() {
        // An arm [10, 30) × [10, 20) under a sleeve covering its left half [8, 20) × [8, 22).
        let s = rect_sites([10, 10, 30, 20], [8, 8, 20, 22], Constraint::Occlusion, 2.0);
        assert!(s.len() >= 8, "{s:?}");
        for p in &s {
            assert!(p.at[0] < 20.0 && p.constraint == Constraint::Occlusion, "{p:?}");
            let on_outline = (p.at[0] - 10.0).abs() < 1.0 || (p.at[1] - 10.0).abs() < 1.0 || (p.at[1] - 20.0).abs() < 1.0;
            assert!(on_outline, "{p:?} is not on the arm's outline");
        }
    }

    #[test]
    fn every_stretch_of_outline_under_the_child_is_pinned_at_its_ends() {
        // A head [10, 30) × [10, 30) under a temple 2 px thick, [26, 36) × [19, 21), which
        // crosses its right edge: a stretch of 2 px, far shorter than the 16 px spacing.
        let s = rect_sites([10, 10, 30, 30], [26, 19, 36, 21], Constraint::Occlusion, 16.0);
        // An occlusion pin, not the point a child without any falls back to.
        assert_eq!(s.len(), 1, "{s:?}");
        assert_eq!(s[0].constraint, Constraint::Occlusion);
        assert!((s[0].at[0] - 29.5).abs() <= 1.0 && (19.0..21.0).contains(&s[0].at[1]), "{s:?}");
        // A cap [5, 35) × [5, 18) over the head: the stretch runs down both sides and along the
        // top, and its two ends, where the cap's rim crosses the sides at y = 18, are pins.
        let s = rect_sites([10, 10, 30, 30], [5, 5, 35, 18], Constraint::Occlusion, 5.0);
        for x in [10.5, 29.5] {
            assert!(
                s.iter().any(|p| (p.at[0] - x).abs() <= 1.0 && p.at[1] >= 16.5),
                "no end at x = {x}: {s:?}"
            );
        }
        // Both sides (8 px each) and the top (20 px) at most 5 px apart: at least 2 + 4 + 2.
        assert!(s.len() >= 8, "{s:?}");
    }

    #[test]
    fn a_crossing_shorter_than_the_spacing_gives_overlap_pins() {
        // A strap 2 px thick, [26, 36) × [19, 21), over a patch [10, 30) × [10, 30): the patch's
        // outline runs through it for 2 px, far less than the 16 px spacing, so the strap keeps
        // the outline of their shared region instead of falling back to a point.
        let s = rect_sites([10, 10, 30, 30], [26, 19, 36, 21], Constraint::Overlap, 16.0);
        assert!(!s.is_empty() && s.iter().all(|p| p.constraint == Constraint::Overlap), "{s:?}");
    }

    #[test]
    fn coincident_pins_where_the_outlines_meet_and_a_button_falls_back_to_a_point() {
        // Two rectangles sharing the edge x = 20.
        let s = rect_sites([5, 5, 20, 30], [20, 5, 35, 30], Constraint::Coincident, 2.0);
        assert!(!s.is_empty() && s.iter().all(|p| p.at[0] < 26.0), "{s:?}");
        // A button on a square: no shared outline, so one point at the button's centre.
        let s = rect_sites([5, 5, 35, 35], [18, 18, 22, 22], Constraint::Coincident, 2.0);
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].at, s[0].constraint), ([19.5, 19.5], Constraint::Point));
    }

    #[test]
    fn every_piece_of_a_speckled_layer_gets_a_pin() {
        let mut specks = rect(40, 40, [0, 0, 0, 0]);
        for k in 0..5 {
            specks.inside[(5 + 6 * k) * 40 + 7] = true;
        }
        let s = sites(vec![rect(40, 40, [2, 2, 38, 38]), specks], &edge(0, &[Constraint::Occlusion]), 3.0);
        assert_eq!(s.len(), 5, "{s:?}");
        assert!(s.iter().all(|p| p.constraint == Constraint::Point));
    }
}
