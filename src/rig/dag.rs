//! The layer DAG (accessory-rigs.md §3.2): which layer each accessory follows.
//!
//! Body layers are the roots. For each accessory, the paper measures its overlap (shared opaque
//! pixels) with every other layer, keeps the layers within ε = 15 % of the largest overlap, and
//! takes the one closest in z-order. It claims z-order avoids cycles, which is false as stated:
//! two overlapping accessories adjacent in z-order can each be the other's closest candidate. Here
//! an accessory's candidates are the body layers and the accessories drawn *behind* it, so every
//! accessory-to-accessory edge points from back to front and z-order itself is a topological
//! order: no cycle can form. What is under an accessory is what it rests on (a collar on a
//! bodice, buttons on a vest); a layer drawn in front of it cannot carry it. Ties go to the larger
//! overlap, then to the lower layer index. No rule reads a layer's name.
//!
//! An accessory that overlaps no candidate follows the nearest one if it lies within
//! [`DagOptions::attach_distance`] (with a warning naming both), else it is an error naming it:
//! it is never dropped. User overrides (`[[rig.edge]]`) replace a child's automatic edge; a
//! cycle they create is an error naming its layers.

use super::mask::Mask;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::puppet::rig_data::{Constraint, Origin, RigEdge, RigOverrides};
use crate::puppet::{LayerKind, Puppet};

/// How the DAG is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DagOptions {
    /// Candidates within this fraction of the largest overlap tie (paper: 0.15).
    pub epsilon: f32,
    /// An accessory that overlaps nothing follows the nearest candidate within this many pixels.
    pub attach_distance: f32,
}

impl Default for DagOptions {
    fn default() -> Self {
        DagOptions {
            epsilon: 0.15,
            attach_distance: 12.0,
        }
    }
}

/// One accessory's parent as the automatic rule chose it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Choice {
    parent: usize,
    /// Shared pixels (0 for a parent chosen by distance).
    overlap: usize,
}

/// The DAG of `puppet` from its layers' `masks`, with `overrides` applied; each edge carries
/// the constraints the automatic rules (§3.4) give its pair, or the user's.
///
/// # Errors
/// [`Error::Layer`]-style errors naming the accessory that overlaps nothing near, an override
/// naming a missing layer or a body layer as child, or the layers of a cycle an override made.
pub fn layer_dag(
    puppet: &Puppet,
    masks: &[Mask],
    overrides: &RigOverrides,
    options: &DagOptions,
    progress: &dyn Progress,
) -> Result<Vec<RigEdge>> {
    let index = |name: &str, role: &str| {
        puppet
            .layer_index(name)
            .ok_or_else(|| Error::setting(format!("rig {role}"), format!("{name:?}"), "the name of a layer of the character"))
    };
    let mut overridden = vec![Vec::new(); puppet.layers.len()];
    for e in &overrides.edges {
        let (child, parent) = (index(&e.child, "edge child")?, index(&e.parent, "edge parent")?);
        if puppet.layers[child].kind == LayerKind::Body {
            return Err(Error::setting(
                "rig edge child",
                format!("{:?}", e.child),
                "an accessory (body layers are the DAG's roots)",
            ));
        }
        if child == parent {
            return Err(Error::setting(
                "rig edge",
                format!("{:?} → itself", e.child),
                "two different layers",
            ));
        }
        overridden[child].push((parent, e.constraint));
    }
    let mut edges = Vec::new();
    for (child, by_hand) in overridden.iter().enumerate() {
        if puppet.layers[child].kind == LayerKind::Body {
            continue;
        }
        if !by_hand.is_empty() {
            for &(parent, constraint) in by_hand {
                edges.push(RigEdge {
                    parent,
                    child,
                    constraints: constraint.map_or_else(|| automatic_constraints(puppet, parent), |c| vec![c]),
                    origin: Origin::User,
                });
            }
            continue;
        }
        let choice = choose_parent(puppet, masks, child, options)?;
        if choice.overlap == 0 {
            progress.warn(&format!(
                "rig: layer {:?} overlaps no layer under it; it follows the nearest, {:?}",
                puppet.layers[child].name, puppet.layers[choice.parent].name
            ));
        }
        edges.push(RigEdge {
            parent: choice.parent,
            child,
            constraints: automatic_constraints(puppet, choice.parent),
            origin: Origin::Auto,
        });
    }
    topological_order(puppet, &edges)?;
    Ok(edges)
}

/// §3.4's rules: a body parent gives occlusion, an accessory parent coincident boundary and
/// overlap (either falls back to a single point when it yields no pin; see `pins`).
fn automatic_constraints(puppet: &Puppet, parent: usize) -> Vec<Constraint> {
    match puppet.layers[parent].kind {
        LayerKind::Body => vec![Constraint::Occlusion],
        LayerKind::Accessory => vec![Constraint::Coincident, Constraint::Overlap],
    }
}

/// The automatic parent of accessory `child` (module doc).
fn choose_parent(puppet: &Puppet, masks: &[Mask], child: usize, options: &DagOptions) -> Result<Choice> {
    let candidates: Vec<usize> = (0..puppet.layers.len())
        .filter(|&l| l != child && (puppet.layers[l].kind == LayerKind::Body || l < child))
        .collect();
    let overlaps: Vec<(usize, usize)> = candidates.iter().map(|&l| (l, masks[child].and(&masks[l]).count())).collect();
    let largest = overlaps.iter().map(|&(_, o)| o).max().unwrap_or(0);
    if largest > 0 {
        let floor = (1.0 - options.epsilon) * largest as f32;
        let best = overlaps
            .iter()
            .filter(|&&(_, o)| o as f32 >= floor)
            .min_by_key(|&&(l, o)| (l.abs_diff(child), std::cmp::Reverse(o), l))
            .expect("the largest overlap is a candidate");
        return Ok(Choice {
            parent: best.0,
            overlap: best.1,
        });
    }
    // Nothing overlaps: the nearest candidate, by the distance from the child's pixels to its.
    let child_pixels: Vec<usize> = (0..masks[child].inside.len()).filter(|&i| masks[child].inside[i]).collect();
    let nearest = candidates
        .iter()
        .map(|&l| {
            let d = masks[l].distance();
            (l, child_pixels.iter().map(|&i| d[i]).fold(f32::INFINITY, f32::min))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    match nearest {
        Some((parent, d)) if d <= options.attach_distance => Ok(Choice { parent, overlap: 0 }),
        found => Err(Error::setting(
            format!("rig: layer {:?}", puppet.layers[child].name),
            found.map_or_else(
                || "no layer to follow".to_string(),
                |(l, d)| format!("{d:.0} px from the nearest layer, {:?}", puppet.layers[l].name),
            ),
            format!(
                "an accessory overlapping a layer under it, or within {} px of one; add a [[rig.edge]] for it in character.toml",
                options.attach_distance
            ),
        )),
    }
}

/// The accessories in an order where every parent comes first (Kahn's algorithm, lowest index
/// first among the ready ones).
///
/// # Errors
/// [`Error::Setting`] naming the layers on a cycle.
pub fn topological_order(puppet: &Puppet, edges: &[RigEdge]) -> Result<Vec<usize>> {
    let n = puppet.layers.len();
    let mut waiting = vec![0usize; n];
    for e in edges {
        if puppet.layers[e.parent].kind == LayerKind::Accessory {
            waiting[e.child] += 1;
        }
    }
    let accessories: Vec<usize> = (0..n).filter(|&l| puppet.layers[l].kind == LayerKind::Accessory).collect();
    let mut ready: std::collections::BTreeSet<usize> = accessories.iter().copied().filter(|&l| waiting[l] == 0).collect();
    let mut order = Vec::with_capacity(accessories.len());
    while let Some(l) = ready.pop_first() {
        order.push(l);
        for e in edges.iter().filter(|e| e.parent == l) {
            waiting[e.child] -= 1;
            if waiting[e.child] == 0 {
                ready.insert(e.child);
            }
        }
    }
    if order.len() < accessories.len() {
        let stuck: Vec<String> = accessories
            .iter()
            .filter(|l| !order.contains(l))
            .map(|&l| format!("{:?}", puppet.layers[l].name))
            .collect();
        return Err(Error::setting(
            "rig edges",
            format!("a cycle through {}", stuck.join(", ")),
            "a DAG: no accessory may (indirectly) follow itself",
        ));
    }
    Ok(order)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::{Recorder, Silent};
    use crate::test_util::rect_layer;

    fn mask_of(puppet: &Puppet) -> Vec<Mask> {
        puppet.layers.iter().map(|l| Mask::of_layer(l, 0.5)).collect()
    }

    /// Layers back to front as (name, kind, rectangle [x0, y0, x1, y1]) on a 40×40 canvas.
    fn puppet(layers: &[(&str, LayerKind, [f32; 4])]) -> Puppet {
        Puppet {
            width: 40,
            height: 40,
            layers: layers
                .iter()
                .map(|&(name, kind, r)| {
                    let mut l = rect_layer(name, (40, 40), r, (4, 4), |_, _| [0.5; 3]);
                    l.kind = kind;
                    l
                })
                .collect(),
            root: 0,
            joints: Vec::new(),
            rig: None,
        }
    }

    const B: LayerKind = LayerKind::Body;
    const A: LayerKind = LayerKind::Accessory;

    #[test]
    fn the_closest_layer_in_z_within_epsilon_wins_and_accessories_rest_on_what_is_under_them() {
        // A shirt over the torso and the arm; a sleeve over the arm and the shirt; a collar on the
        // shirt only; two accessories that would pick each other (badges) both rest on the shirt.
        let p = puppet(&[
            ("torso", B, [10.0, 10.0, 30.0, 35.0]),
            ("arm", B, [28.0, 12.0, 38.0, 30.0]),
            ("shirt", A, [9.0, 9.0, 31.0, 30.0]),
            ("sleeve", A, [27.0, 11.0, 39.0, 22.0]),
            ("badge_a", A, [12.0, 14.0, 18.0, 20.0]),
            ("badge_b", A, [12.0, 14.0, 18.0, 20.0]),
        ]);
        let edges = layer_dag(&p, &mask_of(&p), &RigOverrides::default(), &DagOptions::default(), &Silent).unwrap();
        let parent = |child: &str| {
            let c = p.layer_index(child).unwrap();
            let e = edges.iter().find(|e| e.child == c).unwrap();
            p.layers[e.parent].name.clone()
        };
        assert_eq!(parent("shirt"), "torso", "largest overlap");
        assert_eq!(parent("sleeve"), "arm", "the shirt overlaps it less than 85 % of the arm's overlap");
        assert_eq!(parent("badge_a"), "shirt");
        assert_eq!(parent("badge_b"), "badge_a", "closest in z within ε; never badge_b ↔ badge_a");
        assert_eq!(topological_order(&p, &edges).unwrap(), [2, 3, 4, 5]);
        let kinds: Vec<&[Constraint]> = edges.iter().map(|e| e.constraints.as_slice()).collect();
        assert_eq!(kinds[0], [Constraint::Occlusion]);
        assert_eq!(kinds[3], [Constraint::Coincident, Constraint::Overlap]);
    }

    #[test]
    fn an_accessory_overlapping_nothing_follows_the_nearest_layer_or_is_an_error_naming_it() {
        let near = puppet(&[("torso", B, [10.0, 10.0, 20.0, 20.0]), ("tag", A, [22.0, 10.0, 25.0, 13.0])]);
        let warnings = Recorder::default();
        let edges = layer_dag(&near, &mask_of(&near), &RigOverrides::default(), &DagOptions::default(), &warnings).unwrap();
        assert_eq!((edges[0].parent, edges[0].child), (0, 1));
        assert!(
            warnings.warnings()[0].contains("\"tag\" overlaps no layer"),
            "{:?}",
            warnings.warnings()
        );
        let far = puppet(&[("torso", B, [2.0, 2.0, 8.0, 8.0]), ("tag", A, [30.0, 30.0, 35.0, 35.0])]);
        let err = layer_dag(&far, &mask_of(&far), &RigOverrides::default(), &DagOptions::default(), &Silent).unwrap_err();
        assert!(
            err.to_string().contains("\"tag\"") && err.to_string().contains("[[rig.edge]]"),
            "{err}"
        );
    }

    #[test]
    fn overrides_replace_edges_and_a_cycle_or_a_missing_layer_is_an_error_naming_them() {
        use crate::puppet::rig_data::EdgeOverride;
        let p = puppet(&[
            ("torso", B, [10.0, 10.0, 30.0, 35.0]),
            ("a", A, [9.0, 9.0, 31.0, 30.0]),
            ("b", A, [12.0, 14.0, 18.0, 20.0]),
        ]);
        let edge = |child: &str, parent: &str, constraint| EdgeOverride {
            child: child.into(),
            parent: parent.into(),
            constraint,
        };
        let overrides = RigOverrides {
            edges: vec![
                edge("b", "torso", Some(Constraint::Point)),
                edge("a", "torso", None),
                edge("a", "b", None),
            ],
            ..RigOverrides::default()
        };
        let edges = layer_dag(&p, &mask_of(&p), &overrides, &DagOptions::default(), &Silent).unwrap();
        let of = |c: usize| {
            edges
                .iter()
                .filter(|e| e.child == c)
                .map(|e| (e.parent, e.origin))
                .collect::<Vec<_>>()
        };
        assert_eq!(of(1), [(0, Origin::User), (2, Origin::User)], "two parents by hand");
        assert_eq!(edges.iter().find(|e| e.child == 2).unwrap().constraints, [Constraint::Point]);
        let cycle = RigOverrides {
            edges: vec![edge("a", "b", None), edge("b", "a", None)],
            ..RigOverrides::default()
        };
        let err = layer_dag(&p, &mask_of(&p), &cycle, &DagOptions::default(), &Silent)
            .unwrap_err()
            .to_string();
        assert!(err.contains("cycle") && err.contains("\"a\"") && err.contains("\"b\""), "{err}");
        let missing = RigOverrides {
            edges: vec![edge("hat", "torso", None)],
            ..RigOverrides::default()
        };
        let err = layer_dag(&p, &mask_of(&p), &missing, &DagOptions::default(), &Silent)
            .unwrap_err()
            .to_string();
        assert!(err.contains("\"hat\""), "{err}");
    }
}
