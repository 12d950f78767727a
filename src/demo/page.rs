//! The demo's `index.html`: every picture the demo wrote, with the numbers behind it. Names that
//! come from the artwork (layers, frames) are HTML-escaped.

use std::fmt::Write as _;

use crate::appearance::AppearanceSummary;
use crate::edit::pin::Pin;
use crate::fit::FitOptions;

/// One in-between of the demo: its files' stem and its two end frames.
#[derive(Clone, Debug)]
pub struct Inbetween {
    /// The stem of its files (`<stem>.apng`, `<stem>.gif`, `<stem>_sheet.png`, `<stem>_sprites.png` and `.json`).
    pub stem: String,
    /// The first frame's name.
    pub from: String,
    /// The last frame's name.
    pub to: String,
}

/// The demo's in-between drawn in another outfit (issue 14: mix and match).
#[derive(Clone, Debug)]
pub struct PageOutfit {
    /// The outfit's name (its folder).
    pub name: String,
    /// Its accessories, back to front.
    pub accessories: Vec<String>,
    /// The stem of the in-between it re-draws.
    pub stem: String,
    /// Time to rig it on the model's body, milliseconds.
    pub rig_ms: f64,
}

/// Parts found by `puppet auto` from the user's poses (APES), in place of a painted label map.
#[derive(Clone, Debug, PartialEq)]
pub struct FoundParts {
    /// The character's name (the poses' file or folder).
    pub name: String,
    /// Poses they were found from.
    pub poses: usize,
    /// Parts found.
    pub parts: usize,
    /// Seconds finding them took.
    pub seconds: f64,
    /// `parts.png`, relative to the page.
    pub preview: String,
}

/// Everything the page shows.
#[derive(Clone, Debug)]
pub struct PageData {
    /// The character's name.
    pub character: String,
    /// The puppet's layers, back to front.
    pub layer_names: Vec<String>,
    /// Its vertex count.
    pub vertices: usize,
    /// Its joint count.
    pub joints: usize,
    /// Training steps done.
    pub steps: u64,
    /// Training speed.
    pub images_per_second: f64,
    /// Frames trained on and held out.
    pub split: (usize, usize),
    /// Per frame: name, L2 of its fit, whether it was held out.
    pub l2_rows: Vec<(String, f64, bool)>,
    /// How the frames were fitted.
    pub fit: FitOptions,
    /// The in-betweens.
    pub inbetweens: Vec<Inbetween>,
    /// The appearance stage, when the demo trained one.
    pub appearance: Option<Appearance>,
    /// The first in-between in another outfit, if the character has one (`outfits/`).
    pub outfit: Option<PageOutfit>,
    /// The puppet's accessory layers (placed by the rig).
    pub accessories: Vec<String>,
    /// The dragged pin.
    pub pin: Pin,
    /// Its distance to its target after the drag, pixels.
    pub pin_error: f32,
    /// The drag's time, milliseconds.
    pub drag_ms: f64,
    /// Gradient steps of the drag.
    pub pose_steps: usize,
    /// The layer the pin is on.
    pub layer: String,
    /// Wall time of each stage, seconds.
    pub timings: Vec<(String, f64)>,
    /// The Spine export's files (relative to the page) and their sizes in bytes.
    pub engine_files: Vec<(String, u64)>,
    /// The animations in the Spine export.
    pub spine_animations: Vec<String>,
    /// The parts `puppet auto` found, if it ran the demo.
    pub found_parts: Option<FoundParts>,
    /// Wall time of the whole run, seconds.
    pub total: f64,
}

/// The demo's appearance stage.
#[derive(Clone, Debug)]
pub struct Appearance {
    /// Epochs it trained.
    pub epochs: u64,
    /// What training measured.
    pub summary: AppearanceSummary,
    /// The in-between it redrew (`<stem>_generated.apng`).
    pub stem: String,
}

/// `text` safe inside HTML text and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// The page.
pub fn render(d: &PageData) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>puppet demo — {}</title>\n<style>\
         body{{font-family:sans-serif;max-width:1100px;margin:1em auto;color:#222}} img{{image-rendering:pixelated;border:1px solid #ccc;margin:4px}}\
         table{{border-collapse:collapse}} td,th{{padding:2px 10px;border-bottom:1px solid #eee;text-align:right}} th{{text-align:left}}\
         .row{{display:flex;flex-wrap:wrap;align-items:flex-start;gap:8px}} figcaption{{font-size:90%;color:#555}}</style></head><body>\n\
         <h1>puppet demo: {}</h1>\n<p>Neural Puppet (§3–4) end to end {}, \
         a deformation network trained for {} steps ({:.1} images/s) on {} frames with {} held out, then fits, in-betweens and a dragged pose. {} \
         Whole run: <b>{:.0} s</b>.</p>",
        escape(&d.character),
        escape(&d.character),
        match &d.found_parts {
            None => "on a bundled CC0 Kenney character: a layered puppet built from one labelled frame".to_string(),
            Some(f) => format!(
                "from nothing but drawn poses: {} parts found in {:.1} s from {} poses by the correspondence network and \
                 part finder (APES, apes-part-extraction.md; <a href=\"{}\">the poses and their parts</a>), a layered puppet built from them",
                f.parts,
                f.seconds,
                f.poses,
                escape(&f.preview)
            ),
        },
        d.steps,
        d.images_per_second,
        d.split.0,
        d.split.1,
        if d.accessories.is_empty() {
            String::new()
        } else {
            format!(
                "The network poses the body; the accessory rig (accessory-rigs.md) carries the accessories ({}) along, inside training and every edit.",
                d.accessories.iter().map(|a| escape(a)).collect::<Vec<_>>().join(", ")
            )
        },
        d.total
    );
    let layers: Vec<String> = d.layer_names.iter().map(|n| escape(n)).collect();
    let _ = writeln!(
        s,
        "<h2>1. The puppet</h2><div class=\"row\"><figure><img src=\"puppet.png\" width=\"288\"><figcaption>{} layers ({}), {} vertices, {} joints (rings), rest pose</figcaption></figure>\
         <figure><img src=\"fit_idle.png\" width=\"288\"><figcaption>the mesh fitted to the idle frame by the trained network</figcaption></figure></div>",
        layers.len(),
        layers.join(", "),
        d.vertices,
        d.joints
    );
    let _ = write!(
        s,
        "<h2>2. Fits</h2><p>Each frame beside the puppet rendered at its fit — the network's prediction, then {} latent steps, then {} rounds of a limb search and {} steps on the vertices (pairs: frame, render). \
         L2 as in DESIGN.md (RGB on white, 0–255).</p><img src=\"fits.png\" width=\"1000\"><table><tr><th>frame</th><th>L2</th><th></th></tr>",
        d.fit.latent_steps, d.fit.vertex_rounds, d.fit.vertex_steps
    );
    for (name, l2, held_out) in &d.l2_rows {
        let _ = write!(
            s,
            "<tr><th>{}</th><td>{l2:.0}</td><td>{}</td></tr>",
            escape(name),
            if *held_out { "held out" } else { "" }
        );
    }
    s.push_str("</table>\n<h2>3. In-betweens (§4.1)</h2>");
    for ib in &d.inbetweens {
        let stem = escape(&ib.stem);
        let _ = writeln!(
            s,
            "<h3>{} → {}</h3><div class=\"row\"><figure><img src=\"{stem}.apng\" width=\"192\"><figcaption>in-betweens along the training frames' poses, there and back (APNG; also <a href=\"{stem}.gif\">GIF</a>, \
             <a href=\"{stem}_sprites.png\">sprite sheet</a> + <a href=\"{stem}_sprites.json\">atlas</a>)</figcaption></figure>\
             <figure><img src=\"{stem}_sheet.png\" width=\"800\"><figcaption>rows: ours (through the training frames' poses between the keys), vertex-space and as-rigid-as-possible interpolation, nearest frame of the sequence</figcaption></figure></div>",
            escape(&ib.from),
            escape(&ib.to)
        );
    }
    if let Some(o) = &d.outfit {
        let stem = escape(&o.stem);
        let _ = writeln!(
            s,
            "<h3>The same in-between in another outfit</h3><p>PageOutfit “{}” ({}), drawn for the same rest body, rigged against the trained model's body in {:.0} ms and \
             put on the poses above — no retraining (accessory-rigs.md Fig. 1 F–H).</p><div class=\"row\"><figure><img src=\"{stem}_dressed.apng\" width=\"192\">\
             <figcaption>the in-between re-dressed (<a href=\"{stem}_dressed.gif\">GIF</a>)</figcaption></figure><figure><img src=\"{stem}_dressed_sheet.png\" width=\"800\"><figcaption>rows: ours, vertex-space, as-rigid-as-possible, nearest frame</figcaption></figure></div>",
            escape(&o.name),
            o.accessories.iter().map(|a| escape(a)).collect::<Vec<_>>().join(", "),
            o.rig_ms
        );
    }
    let _ = writeln!(
        s,
        "<h2>4. A dragged pose (§4.2)</h2><p>The point ({:.0}, {:.0}) on layer “{}” is pinned and dragged to ({:.0}, {:.0}); \
         {} gradient steps on the latent (eq. 7–9, α1 = 25, α2 = 50) took {:.1} ms and leave the pin {:.1} px from its target.</p>\
         <div class=\"row\"><figure><img src=\"pose_sheet.png\" width=\"800\"><figcaption>input | fit | ours (latent) | direct vertex-space ARAP</figcaption></figure>\
         <figure><img src=\"drag.apng\" width=\"192\"><figcaption>the drag as an editor would run it: 12 updates, each continuing from the last (<a href=\"drag.gif\">GIF</a>)</figcaption></figure></div>\
         <p>To drag it yourself, the web editor serves this model to the browser: <code>puppet serve</code> (run where <code>out/demo</code> is, \
         or name this folder's <code>model</code>), then open <a href=\"http://127.0.0.1:8080/\">http://127.0.0.1:8080/</a>.</p>",
        d.pin.from[0],
        d.pin.from[1],
        escape(&d.layer),
        d.pin.to[0],
        d.pin.to[1],
        d.pose_steps,
        d.drag_ms,
        d.pin_error
    );
    if let Some(a) = &d.appearance {
        let _ = writeln!(
            s,
            "<h2>Appearance (§3.3)</h2><p>A generator trained {} epochs to redraw each render as the frame was drawn (render | generated | drawn; \
             training frames, then held-out ones). Mean L2 on the training frames: rendered {:.0}, generated {:.0}; held out: rendered {:.0}, generated {:.0}.</p>\
             <div class=\"row\"><figure><img src=\"model/appearance/sheet.png\" width=\"576\"><figcaption>render | generated | drawn</figcaption></figure>\
             <figure><img src=\"{stem}.apng\" width=\"192\"><figcaption>the in-between, rendered</figcaption></figure>\
             <figure><img src=\"{stem}_generated.apng\" width=\"192\"><figcaption>the same, redrawn</figcaption></figure></div>\
             <p>In the web editor, <code>puppet serve --appearance</code> shows each pose and in-between redrawn beside the render.</p>",
            a.epochs,
            a.summary.train.rendered,
            a.summary.train.generated,
            a.summary.held_out.rendered,
            a.summary.held_out.generated,
            stem = escape(&a.stem),
        );
    }
    let files: Vec<String> = d
        .engine_files
        .iter()
        .map(|(name, bytes)| format!("<a href=\"{0}\">{0}</a> ({1:.1} KB)", escape(name), *bytes as f64 / 1024.0))
        .collect();
    let _ = writeln!(
        s,
        "<h2>5. For game engines</h2><p>Each in-between is also a sprite sheet with a TexturePacker-style atlas (<code>*_sprites.png</code> + <code>*_sprites.json</code>: \
         frame rectangles, pivot, durations, the animation — read by Phaser, PixiJS and Godot importers) and an APNG with full alpha. \
         The puppet itself, with the animations {}, is a Spine 4.2 skeleton: one bone per layer at its joint, each layer a weighted mesh, \
         keys of bone rotations and translations plus per-vertex deform offsets that reproduce our poses; another outfit, if the character has one, is a skin: {}.</p>",
        d.spine_animations.iter().map(|a| escape(a)).collect::<Vec<_>>().join(", "),
        files.join(", ")
    );
    s.push_str("<h2>Time</h2><table>");
    for (what, secs) in &d.timings {
        let _ = write!(s, "<tr><th>{}</th><td>{secs:.1} s</td></tr>", escape(what));
    }
    let _ = writeln!(s, "<tr><th>total</th><td>{:.1} s</td></tr></table>\n</body></html>", d.total);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_from_the_artwork_are_escaped() {
        assert_eq!(
            escape("<b>\"arm\" & 'leg'</b>"),
            "&lt;b&gt;&quot;arm&quot; &amp; &#39;leg&#39;&lt;/b&gt;"
        );
        let page = render(&PageData {
            character: "robot & co".into(),
            layer_names: vec!["<script>".into()],
            vertices: 10,
            joints: 1,
            steps: 5,
            images_per_second: 1.0,
            split: (3, 1),
            l2_rows: vec![("a<b.png".into(), 12.0, true)],
            fit: FitOptions::default(),
            inbetweens: vec![Inbetween {
                stem: "inbetween_walk".into(),
                from: "walk0".into(),
                to: "walk4".into(),
            }],
            appearance: None,
            outfit: Some(PageOutfit {
                name: "cap".into(),
                accessories: vec!["<hat>".into()],
                stem: "inbetween_walk".into(),
                rig_ms: 12.0,
            }),
            accessories: vec!["hair".into()],
            pin: Pin {
                from: [1.0, 2.0],
                to: [3.0, 4.0],
            },
            pin_error: 0.5,
            drag_ms: 14.0,
            pose_steps: 5,
            layer: "hand".into(),
            timings: vec![("train".into(), 1.0)],
            engine_files: vec![("spine/puppet.json".into(), 2048)],
            spine_animations: vec!["inbetween_walk".into()],
            found_parts: None,
            total: 2.0,
        });
        assert!(!page.contains("<script>") && page.contains("&lt;script&gt;") && page.contains("a&lt;b.png"));
        assert!(page.contains("inbetween_walk_sheet.png") && page.contains("held out"));
        assert!(page.contains("inbetween_walk_dressed.apng") && page.contains("&lt;hat&gt;") && page.contains("robot &amp; co"));
    }
}
