//! `puppet demo`: the whole pipeline on the bundled Kenney robot, no arguments — build the
//! puppet, train a short run, fit every frame, make an in-between GIF and a dragged pose, and
//! write out/demo/index.html showing it all (issue 6 item 5; under 5 minutes on 2 cores).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use puppet::edit::arap_drag::arap_drag;
use puppet::edit::inbetween::{inbetween, nearest_frame};
use puppet::edit::pin_overlay::pin_overlay;
use puppet::edit::pose::{Pin, PoseEditor, PoseOptions};
use puppet::model::Model;
use puppet::picture::Picture;
use puppet::progress::Progress;
use puppet::render::animation::{sprite_sheet, write_gif};
use puppet::render::preview::wireframe_preview;
use puppet::render::render_crisp;
use puppet::synth::output::contact_sheet;
use puppet::train::refine::{fit_latents, refined_fit, RefineOptions, DEFAULT_STEPS, DEFAULT_VERTEX_STEPS};
use puppet::train::{self, Frames, TrainConfig, TrainOptions};

use super::Ui;

/// Run the whole pipeline on the bundled Kenney robot and write out/demo/index.html.
///
/// Builds the robot's puppet from its label map, trains the deformation network for a short
/// run (out/demo/train.toml, small enough to finish in a few minutes on two cores), fits every
/// frame, makes in-betweens (GIF) and a dragged pose with the ARAP comparison, and writes an
/// HTML page showing each result. Everything goes to out/demo/ (replaced on each run).
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Output folder.
    #[arg(short, long, default_value = "out/demo", value_name = "DIR")]
    pub output: PathBuf,
    /// Training steps of the short run.
    #[arg(long, default_value_t = 300)]
    pub steps: u64,
}

/// The bundled robot: ./data/kenney/robot, or the copy beside the crate's sources.
fn robot_dir() -> anyhow::Result<PathBuf> {
    let local = PathBuf::from("data/kenney/robot");
    let built_in = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/kenney/robot");
    [local, built_in]
        .into_iter()
        .find(|p| p.join("character.toml").is_file())
        .context("the bundled Kenney robot (data/kenney/robot) is not here; run the demo from the repository root")
}

/// Runs `puppet demo`.
pub fn run(args: DemoArgs, ui: &Ui) -> anyhow::Result<()> {
    let started = Instant::now();
    let robot = robot_dir()?;
    let out = args.output.clone();
    let model_dir = out.join("model");
    if model_dir.exists() {
        // Only our own earlier demo output: training refuses to overwrite a checkpointed run.
        std::fs::remove_dir_all(&model_dir).with_context(|| format!("removing the previous {}", model_dir.display()))?;
    }
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let config_text = format!(
        "# Written by `puppet demo`: a short run on the Kenney robot at 64×64 working pixels.\n\
         puppet = {:?}\nframes = {:?}\noutput = {:?}\nseed = 1\ntest_fraction = 0.3\n\n\
         [model]\ninput_size = 64\n\n[train]\nsteps = {}\nbatch = 8\nlearning_rate = 1e-4\nlearning_rate_end = 1e-5\nsigma = [2.0, 0.25]\ncheckpoint_every = {}\n\n\
         [loss]\narap = 2500.0\njoints = 1e4\n",
        abs(&robot).display().to_string(),
        abs(&robot.join("frames")).display().to_string(),
        abs(&out).join("model").display().to_string(),
        args.steps,
        args.steps.max(1)
    );
    let config_path = out.join("train.toml");
    puppet::atomic_file::write_atomic(&config_path, config_text.as_bytes())?;
    let config = TrainConfig::load(&config_path)?;
    let mut timings: Vec<(String, f64)> = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |what: &str, timings: &mut Vec<(String, f64)>| {
        timings.push((what.to_string(), clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };

    // 1–2. Build (inside train: the config names the artwork) and train.
    let summary = train::train(&config, &TrainOptions::default(), ui)?;
    lap("build the puppet + train", &mut timings);

    // 3. Fit every frame.
    let device = puppet::backend::device();
    let model = Model::load(&model_dir, &device)?;
    let frames = Frames::load(&robot.join("frames"))?;
    let names = frames.names();
    let split = puppet::train::trainer::SplitRecord::load(&model_dir)?;
    let held_out: Vec<String> = split.map(|s| s.test).unwrap_or_default();
    ui.stage("fit", frames.frames.len() as u64);
    let (w, h) = (model.puppet.width, model.puppet.height);
    let refs: Vec<&Picture> = frames.frames.iter().collect();
    let refine = RefineOptions::for_model(&model_dir, DEFAULT_STEPS, DEFAULT_VERTEX_STEPS)?;
    let fits = refined_fit(&model, &refs, &refine, &device)?;
    let mut fit_cells = Vec::new();
    let mut l2_rows = Vec::new();
    for ((name, frame), fit) in names.iter().zip(&frames.frames).zip(&fits) {
        let render = render_crisp(&model.puppet, fit, w, h)?;
        l2_rows.push((name.clone(), puppet::eval::l2(&render, frame), held_out.contains(name)));
        fit_cells.push(frame.clone());
        fit_cells.push(render);
        ui.advance(1);
    }
    let fit_refs: Vec<&Picture> = fit_cells.iter().collect();
    contact_sheet(&fit_refs, 8).save_png(&out.join("fits.png"))?;
    let idle_index = names.iter().position(|n| n.contains("idle")).unwrap_or(0);
    let idle = &frames.frames[idle_index];
    wireframe_preview(&model.puppet, &model.puppet.rest_vertices(), idle, 3).save_png(&out.join("puppet.png"))?;
    wireframe_preview(&model.puppet, &fits[idle_index], idle, 3).save_png(&out.join("fit_idle.png"))?;
    lap("fit every frame", &mut timings);

    // 4. In-betweens: walk0 → walk4 (half a cycle apart) and idle → jump.
    let pick = |needle: &str, fallback: usize| {
        names
            .iter()
            .position(|n| n.contains(needle))
            .unwrap_or(fallback.min(names.len() - 1))
    };
    let mut gifs = Vec::new();
    for (a, b, stem) in [
        (pick("walk0", 0), pick("walk4", 1), "inbetween_walk"),
        (idle_index, pick("jump", 2), "inbetween_jump"),
    ] {
        ui.stage(stem, 0);
        let steps = 8;
        let ib = inbetween(&model, &frames.frames[a], &frames.frames[b], steps, &refine, &device)?;
        let latent: Vec<Picture> = ib
            .latent
            .iter()
            .map(|v| render_crisp(&model.puppet, v, w, h))
            .collect::<Result<_, _>>()?;
        let vertex: Vec<Picture> = ib
            .vertex
            .iter()
            .map(|v| render_crisp(&model.puppet, v, w, h))
            .collect::<Result<_, _>>()?;
        let nearest: Vec<Picture> = latent
            .iter()
            .filter_map(|p| nearest_frame(p, &frames.frames).map(|(k, _)| frames.frames[k].clone()))
            .collect();
        let there_and_back: Vec<Picture> = latent
            .iter()
            .chain(latent.iter().rev().skip(1).take(latent.len() - 2))
            .cloned()
            .collect();
        write_gif(&out.join(format!("{stem}.gif")), &there_and_back, 90, [1.0; 3])?;
        let rows: Vec<&Picture> = latent.iter().chain(&vertex).chain(&nearest).collect();
        contact_sheet(&rows, latent.len()).save_png(&out.join(format!("{stem}_sheet.png")))?;
        sprite_sheet(&latent, latent.len())?.save_png(&out.join(format!("{stem}_sprites.png")))?;
        gifs.push((stem, names[a].clone(), names[b].clone()));
    }
    lap("in-betweens (2 × 10 frames)", &mut timings);

    // 5. A dragged pose: lift the robot's front hand on the idle frame.
    ui.stage("pose", 0);
    let mut editor = PoseEditor::new(&model, idle, &refine, &device)?;
    let hand = ["hand_r", "hand_l", "arm_r", "arm_l"]
        .iter()
        .find_map(|n| model.puppet.layer_index(n))
        .unwrap_or(model.puppet.layers.len() - 1);
    let offsets = model.puppet.vertex_offsets();
    let fitted = editor.fitted().to_vec();
    let centre = |pose: &[[f32; 2]]| {
        let part = &pose[offsets[hand]..offsets[hand + 1]];
        part.iter().fold([0.0, 0.0], |s, p| {
            [s[0] + p[0] / part.len() as f32, s[1] + p[1] / part.len() as f32]
        })
    };
    // The hand goes where the decoder puts it for the jump frame (its latent fit: the fits above
    // leave the manifold, a drag does not): a pose the nine training frames show, so the decoder
    // knows how the rest of the body goes with it (far drags to poses it never saw distort the
    // whole robot). Without a jump frame: a lift by a tenth of the frame.
    let from = centre(&fitted);
    let to = match names.iter().position(|n| n.contains("jump")) {
        Some(j) => {
            let z = fit_latents(&model, &[&frames.frames[j]], &refine, &device)?;
            centre(&model.to_frame_vertices(model.decode(z, &device))[0])
        }
        None => [from[0] + 0.06 * w as f32, from[1] - 0.1 * h as f32],
    };
    let pin = Pin { from, to };
    editor.set_pins(&[pin.from])?;
    let options = PoseOptions::default();
    let drag_started = Instant::now();
    let dragged = editor.drag(&[pin.to], &options)?;
    let drag_ms = drag_started.elapsed().as_secs_f64() * 1e3;
    let arap = arap_drag(&model.puppet, editor.fitted(), &[(editor.bindings()[0], pin.to)])?;
    let ours = render_crisp(&model.puppet, &dragged.vertices, w, h)?;
    let arap_pic = render_crisp(&model.puppet, &arap, w, h)?;
    let fit_pic = render_crisp(&model.puppet, editor.fitted(), w, h)?;
    let drawn: Vec<Picture> = [idle, &fit_pic, &ours, &arap_pic].iter().map(|p| pin_overlay(p, &[pin])).collect();
    let drawn_refs: Vec<&Picture> = drawn.iter().collect();
    contact_sheet(&drawn_refs, 4).save_png(&out.join("pose_sheet.png"))?;
    editor.reset();
    let mut drag_frames = Vec::new();
    for k in 1..=12 {
        let s = k as f32 / 12.0;
        let to = [
            pin.from[0] + s * (pin.to[0] - pin.from[0]),
            pin.from[1] + s * (pin.to[1] - pin.from[1]),
        ];
        let step = editor.drag(&[to], &options)?;
        drag_frames.push(pin_overlay(
            &render_crisp(&model.puppet, &step.vertices, w, h)?,
            &[Pin { from: pin.from, to }],
        ));
    }
    write_gif(&out.join("drag.gif"), &drag_frames, 90, [1.0; 3])?;
    lap("dragged pose + ARAP comparison", &mut timings);

    // 6. The page.
    let total = started.elapsed().as_secs_f64();
    let html = page(&PageData {
        layer_names: model.puppet.layers.iter().map(|l| l.name.clone()).collect(),
        vertices: model.puppet.vertex_count(),
        joints: model.puppet.joints.len(),
        steps: summary.steps,
        images_per_second: summary.images_per_second,
        split: summary.split,
        l2_rows,
        fit_rounds: refine.vertex_rounds,
        gifs,
        pin,
        pin_error: dragged.pin_error[0],
        drag_ms,
        pose_steps: options.steps,
        layer: model.puppet.layers[hand].name.clone(),
        timings,
        total,
    });
    let index = out.join("index.html");
    puppet::atomic_file::write_atomic(&index, html.as_bytes())?;
    ui.say(format!("demo done in {total:.0} s → {}", index.display()));
    Ok(())
}

struct PageData {
    layer_names: Vec<String>,
    vertices: usize,
    joints: usize,
    steps: u64,
    images_per_second: f64,
    split: (usize, usize),
    l2_rows: Vec<(String, f64, bool)>,
    fit_rounds: usize,
    gifs: Vec<(&'static str, String, String)>,
    pin: Pin,
    pin_error: f32,
    drag_ms: f64,
    pose_steps: usize,
    layer: String,
    timings: Vec<(String, f64)>,
    total: f64,
}

fn page(d: &PageData) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>puppet demo — Kenney robot</title>\n<style>\
         body{{font-family:sans-serif;max-width:1100px;margin:1em auto;color:#222}} img{{image-rendering:pixelated;border:1px solid #ccc;margin:4px}}\
         table{{border-collapse:collapse}} td,th{{padding:2px 10px;border-bottom:1px solid #eee;text-align:right}} th{{text-align:left}}\
         .row{{display:flex;flex-wrap:wrap;align-items:flex-start;gap:8px}} figcaption{{font-size:90%;color:#555}}</style></head><body>\n\
         <h1>puppet demo: the Kenney robot</h1>\n<p>Neural Puppet (§3–4) end to end on the bundled CC0 robot: a layered puppet built from one labelled frame, \
         a deformation network trained for {} steps ({:.1} images/s) on {} frames with {} held out, then fits, in-betweens and a dragged pose. \
         Whole run: <b>{:.0} s</b>.</p>",
        d.steps, d.images_per_second, d.split.0, d.split.1, d.total
    );
    let _ = writeln!(
        s,
        "<h2>1. The puppet</h2><div class=\"row\"><figure><img src=\"puppet.png\" width=\"288\"><figcaption>{} layers ({}), {} vertices, {} joints (rings), rest pose</figcaption></figure>\
         <figure><img src=\"fit_idle.png\" width=\"288\"><figcaption>the mesh fitted to the idle frame by the trained network</figcaption></figure></div>",
        d.layer_names.len(),
        d.layer_names.join(", "),
        d.vertices,
        d.joints
    );
    let _ = write!(
        s,
        "<h2>2. Fits</h2><p>Each frame beside the puppet rendered at its fit — the network's prediction refined by {DEFAULT_STEPS} latent steps, then {} rounds of a limb search and {DEFAULT_VERTEX_STEPS} steps on the vertices (pairs: frame, render). \
         L2 as in DESIGN.md (RGB on white, 0–255).</p><img src=\"fits.png\" width=\"1000\"><table><tr><th>frame</th><th>L2</th><th></th></tr>",
        d.fit_rounds
    );
    for (name, l2, test) in &d.l2_rows {
        let _ = write!(
            s,
            "<tr><th>{name}</th><td>{l2:.0}</td><td>{}</td></tr>",
            if *test { "held out" } else { "" }
        );
    }
    s.push_str("</table>\n<h2>3. In-betweens (§4.1)</h2>");
    for (stem, a, b) in &d.gifs {
        let _ = writeln!(
            s,
            "<h3>{a} → {b}</h3><div class=\"row\"><figure><img src=\"{stem}.gif\" width=\"192\"><figcaption>latent interpolation, there and back</figcaption></figure>\
             <figure><img src=\"{stem}_sheet.png\" width=\"800\"><figcaption>rows: latent interpolation (ours), vertex-space interpolation, nearest frame of the sequence</figcaption></figure></div>"
        );
    }
    let _ = writeln!(
        s,
        "<h2>4. A dragged pose (§4.2)</h2><p>The point ({:.0}, {:.0}) on layer “{}” is pinned and dragged to ({:.0}, {:.0}); \
         {} gradient steps on the latent (eq. 7–9, α1 = 25, α2 = 50) took {:.1} ms and leave the pin {:.1} px from its target.</p>\
         <div class=\"row\"><figure><img src=\"pose_sheet.png\" width=\"800\"><figcaption>input | fit | ours (latent) | direct vertex-space ARAP</figcaption></figure>\
         <figure><img src=\"drag.gif\" width=\"192\"><figcaption>the drag as an editor would run it: 12 updates, each continuing from the last</figcaption></figure></div>",
        d.pin.from[0], d.pin.from[1], d.layer, d.pin.to[0], d.pin.to[1], d.pose_steps, d.drag_ms, d.pin_error
    );
    s.push_str("<h2>Time</h2><table>");
    for (what, secs) in &d.timings {
        let _ = write!(s, "<tr><th>{what}</th><td>{secs:.1} s</td></tr>");
    }
    let _ = writeln!(s, "<tr><th>total</th><td>{:.1} s</td></tr></table>\n</body></html>", d.total);
    s
}
