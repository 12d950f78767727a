//! The comparison of neural-puppet.md §4.2 / Figure 6 (right): the same pins satisfied directly
//! in vertex space with a hand-crafted energy — as-rigid-as-possible deformation of the template
//! (eq. 2's energy, relative to the rest pose) — instead of on the learned latent manifold.
//!
//! The puppet is one mesh whose layers are connected components; hinge joints (eq. 3) are made
//! exact by welding each joint's two vertices into one, so a dragged hand pulls its arm. Each pin
//! drives the corner of its bound triangle with the largest barycentric weight, keeping the
//! pin's offset from that corner. A drag with a single pin would only translate the whole,
//! connected puppet (ARAP ignores rigid motion), so — as in interactive ARAP editing — parts the
//! user did not pin stay anchored: the root layer (unless pinned) and every welded component
//! without a pin keep one vertex, the one nearest their centroid, where the fit put it.
//!
//! With an accessory rig only the body is solved, and the rig then places the accessories on it;
//! a pin on an accessory drives the body vertex that dominates the pin's affine expression over
//! the body (the rig's map composed with the pin's barycentric weights), so dragging a sleeve
//! moves the arm under it.

use super::bind::Binding;
use crate::error::{Error, Result};
use crate::geom::{component_labels, triangle_edges, ArapSolver};
use crate::puppet::{LayerKind, Puppet};
use crate::rig::deform::RigMap;

/// Local/global iterations of the ARAP solve (libigl's default is 10).
pub const ARAP_ITERATIONS: usize = 20;

/// Deforms the fitted pose `fitted` (global numbering, pixels) so that each pin's bound point
/// moves to its target, as-rigid-as-possible w.r.t. the rest template. `pins` pairs a binding
/// (made on `fitted`) with its target in the same pixel space.
///
/// # Errors
/// [`Error::Mismatch`] if `fitted` is not one position per vertex; [`Error::Setting`] if there is
/// no pin; [`Error::Geometry`] if a target is not finite or the ARAP system cannot be set up (a
/// degenerate template layer).
pub fn arap_drag(puppet: &Puppet, fitted: &[[f32; 2]], pins: &[(Binding, [f32; 2])]) -> Result<Vec<[f32; 2]>> {
    let n = puppet.vertex_count();
    if fitted.len() != n {
        return Err(Error::mismatch("arap drag: the fitted pose's vertex count", fitted.len(), n));
    }
    if pins.is_empty() {
        return Err(Error::setting("arap drag pins", 0, "at least one"));
    }
    if pins.iter().any(|(_, t)| !t[0].is_finite() || !t[1].is_finite()) {
        return Err(Error::geometry("arap drag: a pin target", "is not finite"));
    }
    // Weld joint vertices (components of the joints over the global numbering).
    let (welded_id, count) = component_labels(
        n,
        puppet.joints.iter().map(|j| (puppet.global_index(j.a), puppet.global_index(j.b))),
    );
    let average = |pos: &[[f32; 2]]| {
        let mut sum = vec![[0.0f64; 3]; count];
        for (i, p) in pos.iter().enumerate() {
            let s = &mut sum[welded_id[i]];
            s[0] += p[0] as f64;
            s[1] += p[1] as f64;
            s[2] += 1.0;
        }
        sum.into_iter().map(|[x, y, k]| [x / k, y / k]).collect::<Vec<[f64; 2]>>()
    };
    let rest = average(&puppet.rest_vertices());
    let initial = average(fitted);
    let offsets = puppet.vertex_offsets();
    let map = puppet.rig.as_ref().map(|rig| RigMap::new(puppet, rig));
    let solved_layer = |l: usize| map.is_none() || puppet.layers[l].kind == LayerKind::Body;
    let triangles: Vec<[u32; 3]> = puppet
        .layers
        .iter()
        .enumerate()
        .filter(|&(l, _)| solved_layer(l))
        .flat_map(|(l, layer)| layer.mesh.triangles.iter().map(move |t| (l, t)))
        .map(|(l, t)| t.map(|i| welded_id[offsets[l] + i as usize] as u32))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();

    // Handles: the dominant corner of each pin (targets averaged if pins share one) …
    let mut handles: Vec<u32> = Vec::new();
    let mut targets: Vec<[f64; 3]> = Vec::new();
    for (b, target) in pins {
        let v = dominant_vertex(b, map.as_ref());
        let p = b.position(fitted);
        let goal = [(target[0] + fitted[v][0] - p[0]) as f64, (target[1] + fitted[v][1] - p[1]) as f64];
        let h = welded_id[v] as u32;
        match handles.iter().position(|&x| x == h) {
            Some(i) => targets[i] = [targets[i][0] + goal[0], targets[i][1] + goal[1], targets[i][2] + 1.0],
            None => {
                handles.push(h);
                targets.push([goal[0], goal[1], 1.0]);
            }
        }
    }
    // … then anchors: the root layer unless pinned, and every component without a handle.
    let (component, _) = component_labels(count, triangle_edges(&triangles));
    let layer_of = |v: usize| offsets.partition_point(|&o| o <= v) - 1;
    let pinned_layers: Vec<usize> = pins.iter().map(|(b, _)| layer_of(dominant_vertex(b, map.as_ref()))).collect();
    let anchor = |members: &mut dyn Iterator<Item = usize>, handles: &mut Vec<u32>, targets: &mut Vec<[f64; 3]>| {
        let members: Vec<usize> = members.collect();
        if members.is_empty() {
            return;
        }
        let c = members
            .iter()
            .fold([0.0, 0.0], |s, &i| [s[0] + initial[i][0], s[1] + initial[i][1]]);
        let c = [c[0] / members.len() as f64, c[1] / members.len() as f64];
        let d = |i: usize| (initial[i][0] - c[0]).powi(2) + (initial[i][1] - c[1]).powi(2);
        let best = members.iter().copied().min_by(|&a, &b| d(a).total_cmp(&d(b))).unwrap_or(members[0]);
        if !handles.contains(&(best as u32)) {
            handles.push(best as u32);
            targets.push([initial[best][0], initial[best][1], 1.0]);
        }
    };
    if !pinned_layers.contains(&puppet.root) {
        let root: Vec<usize> = (offsets[puppet.root]..offsets[puppet.root + 1]).map(|i| welded_id[i]).collect();
        anchor(&mut root.into_iter(), &mut handles, &mut targets);
    }
    let ncomp = component.iter().copied().max().map_or(0, |m| m + 1);
    for c in 0..ncomp {
        if !handles.iter().any(|&h| component[h as usize] == c) {
            anchor(&mut (0..count).filter(|&i| component[i] == c), &mut handles, &mut targets);
        }
    }
    let targets: Vec<[f64; 2]> = targets.iter().map(|t| [t[0] / t[2], t[1] / t[2]]).collect();
    let mut solver = ArapSolver::new(&rest, &triangles, &handles)?;
    let solved = solver.solve(&targets, ARAP_ITERATIONS, &initial);
    let mut out: Vec<[f32; 2]> = (0..n).map(|i| solved[welded_id[i]].map(|c| c as f32)).collect();
    if let Some(map) = &map {
        map.apply(&mut out);
    }
    Ok(out)
}

/// The vertex a pin drives: its bound triangle's corner of largest weight, or — for a pin on a
/// rigged accessory — the body vertex of largest coefficient in the pin's expression over the
/// body.
fn dominant_vertex(b: &Binding, map: Option<&RigMap>) -> usize {
    let corner = |k: usize| b.vertices[k] as usize;
    let k = (0..3).max_by(|&x, &y| b.weights[x].total_cmp(&b.weights[y])).unwrap_or(0);
    let Some(map) = map else { return corner(k) };
    let mut over_body: Vec<(usize, f32)> = Vec::new();
    for (c, &w) in b.vertices.iter().zip(&b.weights) {
        match map.rows.iter().position(|&r| r == *c as usize) {
            Some(row) => over_body.extend(map.coefficients[row].iter().map(|&(j, m)| (j, w * m))),
            None => over_body.push((*c as usize, w)),
        }
    }
    over_body.sort_unstable_by_key(|&(j, _)| j);
    over_body.dedup_by(|later, earlier| {
        let same = later.0 == earlier.0;
        if same {
            earlier.1 += later.1;
        }
        same
    });
    over_body.iter().max_by(|x, y| x.1.total_cmp(&y.1)).map_or(corner(k), |&(j, _)| j)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edit::bind::bind;
    use crate::test_util::{dressed_puppet, hinged_puppet};

    #[test]
    fn the_pin_is_met_and_unpinned_parts_stay_put() {
        let puppet = hinged_puppet();
        let rest = puppet.rest_vertices();
        // Grab the front arm's tip and lift it by 8 px.
        let b = bind(&puppet, &rest, [42.0, 22.5]).unwrap();
        let target = [42.0, 14.5];
        let out = arap_drag(&puppet, &rest, &[(b, target)]).unwrap();
        let got = b.position(&out);
        // The handle is the dominant corner; the pin point itself lands within a pixel.
        assert!((got[0] - target[0]).abs() < 1.0 && (got[1] - target[1]).abs() < 1.0, "{got:?}");
        // The torso (root, anchored, not pinned) barely moves; the other arm and head stay.
        let offsets = puppet.vertex_offsets();
        for name in ["torso", "head", "arm_back"] {
            let l = puppet.layer_index(name).unwrap();
            let moved = (offsets[l]..offsets[l + 1])
                .map(|i| ((out[i][0] - rest[i][0]).powi(2) + (out[i][1] - rest[i][1]).powi(2)).sqrt())
                .fold(0.0f32, f32::max);
            assert!(moved < 1.5, "{name} moved {moved} px");
        }
        // The hinge holds: the welded pair still coincides.
        let j = puppet.joints[0];
        assert_eq!(out[puppet.global_index(j.a)], out[puppet.global_index(j.b)]);
        assert!(arap_drag(&puppet, &rest, &[]).is_err());
        assert!(arap_drag(&puppet, &rest, &[(b, [f32::NAN, 0.0])]).is_err());
    }

    #[test]
    fn a_pin_on_a_rigged_accessory_moves_the_body_under_it() {
        let puppet = dressed_puppet();
        let rest = puppet.rest_vertices();
        // The sleeve's free end, off the torso it hangs from, pulled 4 px down.
        let b = bind(&puppet, &rest, [40.0, 22.5]).unwrap();
        assert_eq!(puppet.layers[b.layer].name, "arm_front");
        let from = b.position(&rest);
        let target = [from[0], from[1] + 4.0];
        let out = arap_drag(&puppet, &rest, &[(b, target)]).unwrap();
        let got = b.position(&out);
        assert!(
            (got[0] - target[0]).abs() < 1.0 && (got[1] - target[1]).abs() < 1.0,
            "{got:?} vs {target:?}"
        );
        // The body moved (the torso carries the sleeve), and the sleeve is where the rig puts it.
        let torso = puppet.layer_index("torso").unwrap();
        let offsets = puppet.vertex_offsets();
        let shift = (offsets[torso]..offsets[torso + 1]).map(|i| out[i][1] - rest[i][1]).sum::<f32>()
            / (offsets[torso + 1] - offsets[torso]) as f32;
        assert!(shift > 2.0, "the torso moved {shift} px");
        let mut placed = out.clone();
        RigMap::new(&puppet, puppet.rig.as_ref().unwrap()).apply(&mut placed);
        assert_eq!(placed, out);
    }
}
