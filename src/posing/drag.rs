//! ARAP drags: a layer's end pulled a few per cent of the figure's size while its joints stay
//! where the limb turns put them, the rest of the layer following as rigidly as it can
//! (`geom::arap`, Sorkine & Alexa 2007). Limb turns alone give rigid parts; the drags bend them,
//! as a drawn frame bends a sleeve or a tail (prior-design.md §3, "ARAP drags").

use std::sync::Mutex;

use crate::geom::ArapSolver;
use crate::puppet::{LayerKind, Puppet};
use crate::rng::Rng;

/// Local/global iterations of a drag's ARAP solve.
const ITERATIONS: usize = 20;

/// The most a pin moves, as a share of its distance from the nearest held vertex: a longer pull
/// folds the layer over its joint.
const MAX_REACH_SHARE: f32 = 0.3;

/// One layer that can be dragged: its held vertices, its pin, and the factored ARAP system.
pub struct DragLayer {
    /// Index of the layer.
    pub layer: usize,
    /// The layer's vertices that stay: its joint vertices, or without a joint the vertex nearest
    /// its centroid (local numbering).
    held: Vec<u32>,
    /// The vertex pulled: the one farthest from every held vertex at rest (local numbering).
    pin: u32,
    /// The pin's rest distance from the nearest held vertex (pixels).
    reach: f32,
    /// The solver over the layer's rest mesh with handles `held` then `pin`. A solve is a
    /// function of its inputs alone (the scratch is overwritten), so a shared lock is enough.
    solver: Mutex<ArapSolver>,
}

/// The layers of `puppet` a drag may bend: body layers (every layer without a rig, whose
/// accessories are posed like the body), with triangles and a pin away from the held vertices.
/// A layer the ARAP system cannot be set up for (one of several pieces, say) is posed rigidly.
pub fn drag_layers(puppet: &Puppet) -> Vec<DragLayer> {
    let mut out = Vec::new();
    for (l, layer) in puppet.layers.iter().enumerate() {
        let mesh = &layer.mesh;
        if (puppet.rig.is_some() && layer.kind != LayerKind::Body) || mesh.triangles.is_empty() {
            continue;
        }
        let mut held: Vec<u32> = puppet
            .joints
            .iter()
            .flat_map(|j| [j.a, j.b])
            .filter(|v| v.layer == l)
            .map(|v| v.vertex)
            .collect();
        held.sort_unstable();
        held.dedup();
        let dist = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        if held.is_empty() {
            let n = mesh.vertices.len() as f32;
            let c = mesh.vertices.iter().fold([0.0, 0.0], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n]);
            let nearest = (0..mesh.vertices.len()).min_by(|&a, &b| dist(mesh.vertices[a], c).total_cmp(&dist(mesh.vertices[b], c)));
            held.extend(nearest.map(|v| v as u32));
        }
        let gap = |v: usize| {
            held.iter()
                .map(|&h| dist(mesh.vertices[v], mesh.vertices[h as usize]))
                .fold(f32::INFINITY, f32::min)
        };
        let Some(pin) = (0..mesh.vertices.len()).max_by(|&a, &b| gap(a).total_cmp(&gap(b))) else {
            continue;
        };
        let reach = gap(pin);
        if reach.is_nan() || reach < 1.0 {
            continue;
        }
        let rest: Vec<[f64; 2]> = mesh.vertices.iter().map(|p| p.map(f64::from)).collect();
        let handles: Vec<u32> = held.iter().copied().chain([pin as u32]).collect();
        let Ok(solver) = ArapSolver::new(&rest, &mesh.triangles, &handles) else {
            continue;
        };
        out.push(DragLayer {
            layer: l,
            held,
            pin: pin as u32,
            reach,
            solver: Mutex::new(solver),
        });
    }
    out
}

impl DragLayer {
    /// Pulls this layer's pin in `pose` (global numbering, pixels; `offset` is where the layer
    /// starts) in a direction drawn from `rng`, by a distance drawn between half and all of
    /// `strength` (pixels, capped near the joint), holding the held vertices where they are.
    /// A solve that would turn a triangle over leaves the layer as it was.
    pub fn drag(&self, puppet: &Puppet, pose: &mut [[f32; 2]], offset: usize, strength: f32, rng: &mut Rng) {
        let angle = rng.range(0.0, std::f32::consts::TAU);
        let length = (rng.range(0.5, 1.0) * strength).min(MAX_REACH_SHARE * self.reach);
        let mesh = &puppet.layers[self.layer].mesh;
        let part = &mut pose[offset..offset + mesh.vertices.len()];
        let initial: Vec<[f64; 2]> = part.iter().map(|p| p.map(f64::from)).collect();
        let mut targets: Vec<[f64; 2]> = self.held.iter().map(|&h| initial[h as usize]).collect();
        let p = initial[self.pin as usize];
        let (s, c) = angle.sin_cos();
        targets.push([p[0] + f64::from(length * c), p[1] + f64::from(length * s)]);
        let solved = self
            .solver
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .solve(&targets, ITERATIONS, &initial);
        let posed: Vec<[f32; 2]> = solved.iter().map(|p| p.map(|c| c as f32)).collect();
        let area = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| posed[i as usize]);
            (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        };
        let sound = posed.iter().flatten().all(|x| x.is_finite()) && mesh.triangles.iter().all(|t| area(t) > 0.0);
        if sound {
            part.copy_from_slice(&posed);
        }
    }
}
