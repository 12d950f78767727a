//! `puppet rig`'s picture: the rig at rest — each DAG edge drawn from the parent's centre to the
//! child's, every pin as a dot coloured by its constraint — and one weight map per accessory:
//! its mesh coloured by the blend of its pins' colours under the weights, pins ringed.

use super::mask::Mask;
use crate::error::Result;
use crate::picture::draw::{dot, line, text};
use crate::picture::{contact_sheet, Picture};
use crate::puppet::rig_data::{Constraint, RigData};
use crate::puppet::Puppet;
use crate::render::render_crisp;

/// The colour of pins of each constraint.
pub fn constraint_colour(c: Constraint) -> [f32; 3] {
    match c {
        Constraint::Occlusion => [0.85, 0.1, 0.1],
        Constraint::Point => [0.1, 0.3, 0.9],
        Constraint::Coincident => [0.1, 0.6, 0.2],
        Constraint::Overlap => [0.95, 0.55, 0.0],
    }
}

/// A distinct colour for pin `j` of an accessory (golden-angle hues).
fn pin_colour(j: usize) -> [f32; 3] {
    let h = (j as f32 * 137.508).rem_euclid(360.0) / 60.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [0.15 + 0.8 * r, 0.15 + 0.8 * g, 0.15 + 0.8 * b]
}

/// The preview of `rig` on `puppet` at rest (see the module doc), `scale` times the canvas.
///
/// # Errors
/// Render errors (a rig of another puppet).
pub fn rig_preview(puppet: &Puppet, rig: &RigData, scale: u32) -> Result<Picture> {
    let s = scale.max(1) as f32;
    let rest = render_crisp(puppet, &puppet.rest_vertices(), puppet.width, puppet.height)?.upscaled_on_white(scale);
    let mut overview = faded(&rest);
    let centre = |l: usize| {
        Mask::of_layer(&puppet.layers[l], 0.5)
            .centroid()
            .map_or([0.0, 0.0], |c| [c[0] * s, c[1] * s])
    };
    for e in &rig.edges {
        let (a, b) = (centre(e.parent), centre(e.child));
        line(
            &mut overview,
            [a[0] as i64, a[1] as i64],
            [b[0] as i64, b[1] as i64],
            [0.3, 0.3, 0.3],
        );
        dot(&mut overview, b, 2.5, [0.3, 0.3, 0.3]);
    }
    for acc in &rig.accessories {
        let mesh = &puppet.layers[acc.layer].mesh;
        for pin in &acc.pins {
            let p = mesh.vertices[pin.vertex as usize];
            dot(
                &mut overview,
                [p[0] * s, p[1] * s],
                1.5 + 0.25 * s,
                constraint_colour(pin.constraint),
            );
        }
        let c = centre(acc.layer);
        text(
            &mut overview,
            &puppet.layers[acc.layer].name,
            [c[0] as i64 + 4, c[1] as i64 - 2],
            [0.0; 3],
        );
    }
    let mut x = 2;
    for c in Constraint::ALL {
        dot(&mut overview, [x as f32 + 2.0, 4.5], 2.0, constraint_colour(c));
        text(&mut overview, c.name(), [x + 6, 2], [0.0; 3]);
        x += 10 + 4 * c.name().len() as i64;
    }
    let mut panels = vec![overview];
    for acc in &rig.accessories {
        let mut panel = faded(&rest);
        let mesh = &puppet.layers[acc.layer].mesh;
        let colours: Vec<[f32; 3]> = acc
            .weights
            .iter()
            .map(|row| {
                row.iter().fold([0.0; 3], |c, &(j, w)| {
                    let p = pin_colour(j as usize);
                    [c[0] + w * p[0], c[1] + w * p[1], c[2] + w * p[2]]
                })
            })
            .collect();
        for t in &mesh.triangles {
            let corners = t.map(|i| {
                let v = mesh.vertices[i as usize];
                [v[0] * s, v[1] * s]
            });
            shade(&mut panel, corners, t.map(|i| colours[i as usize]));
        }
        for (j, pin) in acc.pins.iter().enumerate() {
            let p = mesh.vertices[pin.vertex as usize];
            dot(&mut panel, [p[0] * s, p[1] * s], 1.5 + 0.25 * s, [0.0; 3]);
            dot(&mut panel, [p[0] * s, p[1] * s], 0.8 + 0.2 * s, pin_colour(j));
        }
        text(&mut panel, &puppet.layers[acc.layer].name, [2, 2], [0.0; 3]);
        panels.push(panel);
    }
    let refs: Vec<&Picture> = panels.iter().collect();
    Ok(contact_sheet(&refs, 4))
}

/// `p` blended halfway to white, so what is drawn over it stands out.
fn faded(p: &Picture) -> Picture {
    p.mapped(|c| [0.5 + 0.5 * c[0], 0.5 + 0.5 * c[1], 0.5 + 0.5 * c[2], 1.0])
}

/// Fills triangle `t` with its corners' colours interpolated (pixel centres inside).
fn shade(pic: &mut Picture, t: [[f32; 2]; 3], colours: [[f32; 3]; 3]) {
    let xs = t.map(|p| p[0]);
    let ys = t.map(|p| p[1]);
    let lo = |v: [f32; 3]| v.into_iter().fold(f32::INFINITY, f32::min).floor().max(0.0) as u32;
    let hi = |v: [f32; 3], n: u32| (v.into_iter().fold(f32::NEG_INFINITY, f32::max).ceil() as u32).min(n);
    for y in lo(ys)..hi(ys, pic.height) {
        for x in lo(xs)..hi(xs, pic.width) {
            if let Some(w) = crate::geom::triangle::barycentric(t, [x as f32 + 0.5, y as f32 + 0.5]) {
                if w.iter().all(|&b| b >= 0.0) {
                    let c = [0, 1, 2].map(|k| w[0] * colours[0][k] + w[1] * colours[1][k] + w[2] * colours[2][k]);
                    pic.pixels[(y * pic.width + x) as usize] = [c[0], c[1], c[2], 1.0];
                }
            }
        }
    }
}
