//! The demo (`puppet demo`): the whole pipeline on a bundled Kenney character (the male
//! adventurer, whose hair is an accessory the rig carries) — build the puppet from its label map,
//! train a short run, fit every frame, make two in-betweens and a dragged pose with the ARAP
//! comparison, and draw the first in-between in the character's other outfit (`outfits/`) —
//! written with an `index.html` ([`page`]) showing it all.
//!
//! Everything goes into one output folder; a rerun replaces what an earlier demo wrote there (its
//! model folder included) and refuses to touch anything else.

pub mod auto;
pub mod page;

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::appearance::{train_appearance, AppearanceConfig, AppearanceOptions, AppearanceStage};
use crate::atomic_file::{record, written_by_puppet, Outputs};
use crate::edit::arap_drag::arap_drag;
use crate::edit::inbetween::{
    comparison_sheet, inbetween, steps_t, write_inbetweens, InbetweenFiles, InbetweenPath, Inbetweens, MAX_STEPS,
};
use crate::edit::manifold_path::Waypoints;
use crate::edit::pin::Pin;
use crate::edit::pin_overlay::pin_overlay;
use crate::edit::pose::{PoseEditor, PoseOptions};
use crate::error::{Error, FolderKind, Result};
use crate::export::spine::{self, OutfitSkin, PoseAnimation};
use crate::fit::{fit, fit_latents, hidden_limbs, FitOptions, DEFAULT_LATENT_STEPS, DEFAULT_VERTEX_STEPS};
use crate::metrics::l2;
use crate::model::Model;
use crate::picture::{contact_sheet, Picture};
use crate::progress::Progress;
use crate::puppet::build::BuildOptions;
use crate::puppet::sequence::Frames;
use crate::puppet::{artwork, LayerKind};
use crate::render::animation::{AnimationFiles, AnimationWriter};
use crate::render::preview::wireframe_preview;
use crate::render::render_crisp;
use crate::rig::outfit::dress;
use crate::rig::RigOptions;
use crate::train::config::{canonical, TrainConfig};
use crate::train::{self, TrainOptions};
use page::{Inbetween, PageData};

/// What the demo runs on and where it writes.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoOptions {
    /// The output folder.
    pub output: PathBuf,
    /// Training steps of the short run.
    pub steps: u64,
    /// The character: artwork with a `frames/` folder of drawn frames.
    pub character: PathBuf,
    /// Replace files in the output folder that puppet did not write.
    pub force: bool,
    /// Also train the appearance stage for this many epochs (batch 1) and show its redraws.
    pub appearance_epochs: Option<u64>,
    /// Where the character's parts came from, when `puppet auto` found them (else the
    /// artwork's own label map).
    pub found_parts: Option<page::FoundParts>,
}

impl DemoOptions {
    /// The demo on the bundled male adventurer into `output`, 300 training steps.
    pub fn new(output: impl Into<PathBuf>) -> Self {
        DemoOptions {
            output: output.into(),
            steps: 300,
            character: bundled_character(),
            force: false,
            appearance_epochs: None,
            found_parts: None,
        }
    }
}

/// The bundled Kenney male adventurer: `data/kenney/male_adventurer` in the working directory,
/// or beside the crate's sources.
pub fn bundled_character() -> PathBuf {
    let local = PathBuf::from(BUNDLED);
    if local.join("character.toml").is_file() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(BUNDLED)
    }
}

const BUNDLED: &str = "data/kenney/male_adventurer";

/// What the demo did.
#[derive(Clone, Debug)]
pub struct DemoSummary {
    /// The page.
    pub index: PathBuf,
    /// Wall time of the whole run, seconds.
    pub seconds: f64,
}

/// The files the demo writes into its output folder (besides `model/`).
const FILES: &[&str] = &[
    "train.toml",
    "fits.png",
    "puppet.png",
    "fit_idle.png",
    "inbetween_walk.gif",
    "inbetween_walk.apng",
    "inbetween_walk_sheet.png",
    "inbetween_walk_sprites.png",
    "inbetween_walk_sprites.json",
    "inbetween_jump.gif",
    "inbetween_jump.apng",
    "inbetween_jump_sheet.png",
    "inbetween_jump_sprites.png",
    "inbetween_jump_sprites.json",
    "inbetween_walk_dressed.gif",
    "inbetween_walk_dressed.apng",
    "inbetween_walk_dressed_sheet.png",
    "pose_sheet.png",
    "drag.gif",
    "drag.apng",
    "spine/puppet.json",
    "spine/puppet.atlas",
    "spine/puppet.png",
    "index.html",
];

/// The demo's animation `<stem>.gif` and `<stem>.apng` in `out`, on a transparent background.
fn animation(out: &Path, stem: &str, there_and_back: bool) -> AnimationFiles {
    AnimationFiles {
        gif: Some(out.join(format!("{stem}.gif"))),
        apng: Some(out.join(format!("{stem}.apng"))),
        delay_ms: 90,
        there_and_back,
        ..AnimationFiles::default()
    }
}

/// In-between steps between the two end frames of each demo in-between.
const INBETWEEN_STEPS: usize = 8;
/// Updates of the dragged pose shown in `drag.gif`.
const DRAG_FRAMES: usize = 12;

/// Runs the demo.
///
/// # Errors
/// [`Error::WouldOverwrite`] (before anything is written) if the output holds files the demo did
/// not write; [`Error::WrongFolder`] if the character has no frames; whatever training, fitting
/// and writing report.
pub fn run(options: &DemoOptions, progress: &dyn Progress) -> Result<DemoSummary> {
    let started = Instant::now();
    let out = &options.output;
    let outputs = Outputs::new(options.force);
    // One demo at a time in a folder (a second would delete the first's model under it).
    outputs.lock_folder(out)?;
    // Everything is looked at before anything is written; each writer claims its own files.
    check_outputs(options)?;
    let model_dir = out.join("model");
    if model_dir.exists() {
        // The demo trains from scratch: an earlier demo's model goes.
        std::fs::remove_dir_all(&model_dir).map_err(|e| Error::io(&model_dir, e))?;
    }
    let frames_dir = options.character.join("frames");
    if !frames_dir.is_dir() {
        return Err(Error::WrongFolder {
            path: options.character.clone(),
            expected: FolderKind::Artwork,
            problem: "no frames/ folder of drawn frames beside the artwork".into(),
        });
    }
    let config = short_run(options, &model_dir);
    let config_text = toml::to_string_pretty(&config).map_err(|e| Error::format(out.join("train.toml"), e.to_string()))?;
    outputs.write(
        &out.join("train.toml"),
        format!("# Written by the demo: a short run at 64×64 working pixels.\n{config_text}").as_bytes(),
    )?;
    let mut timings: Vec<(String, f64)> = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |what: &str, timings: &mut Vec<(String, f64)>| {
        timings.push((what.to_string(), clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };

    // 1–2. Build (the config names the artwork) and train.
    let summary = train::train(&config, &TrainOptions::default(), progress)?;
    // The run is finished and never resumed: its checkpoints (three quarters of the demo's
    // bytes) are not what the page, `serve` or `fit` read.
    let checkpoints = model_dir.join(crate::train::checkpoint::CHECKPOINT_DIR);
    std::fs::remove_dir_all(&checkpoints).map_err(|e| Error::io(&checkpoints, e))?;
    record(&model_dir)?;
    lap("build the puppet + train", &mut timings);

    // 3. Fit every frame.
    let device = crate::backend::device();
    let model = Model::load(&model_dir, &device)?;
    let frames = Frames::load(&frames_dir, &crate::fit::frame::frame_check(&model))?;
    let names = frames.names();
    let held_out = train::trainer::SplitRecord::load(&model_dir)?.map(|s| s.test).unwrap_or_default();
    let refs: Vec<&Picture> = frames.frames.iter().collect();
    let fit_options = FitOptions::for_model(&model_dir, DEFAULT_LATENT_STEPS, DEFAULT_VERTEX_STEPS)?.with_hidden_limbs(
        &model_dir,
        &model,
        hidden_limbs::DEFAULT_SLACK,
        &device,
        progress,
    )?;
    progress.stage("fit", refs.len() as u64);
    let fits = fit(&model, &refs, &fit_options, &device, progress)?;
    let (w, h) = (model.puppet.width, model.puppet.height);
    let mut cells = Vec::new();
    let mut l2_rows = Vec::new();
    for ((name, frame), pose) in names.iter().zip(&frames.frames).zip(&fits) {
        let render = render_crisp(&model.puppet, pose, w, h)?;
        l2_rows.push((name.clone(), l2(&render, frame), held_out.contains(name)));
        cells.push(frame.clone());
        cells.push(render);
    }
    let save = |name: &str, picture: &Picture| -> Result<()> {
        let path = out.join(name);
        picture.save_png(&path)?;
        record(&path)
    };
    save("fits.png", &contact_sheet(&cells.iter().collect::<Vec<_>>(), 8))?;
    let pick = |needle: &str, fallback: usize| {
        names
            .iter()
            .position(|n| n.contains(needle))
            .unwrap_or(fallback.min(names.len() - 1))
    };
    let idle = pick("idle", 0);
    save(
        "puppet.png",
        &wireframe_preview(&model.puppet, &model.puppet.rest_vertices(), &frames.frames[idle], 3),
    )?;
    save(
        "fit_idle.png",
        &wireframe_preview(&model.puppet, &fits[idle], &frames.frames[idle], 3),
    )?;
    lap("fit every frame", &mut timings);

    // 4. In-betweens: walk0 → walk4 (half a cycle apart) and idle → jump; the first also in the
    // character's other outfit, if it has one.
    let trained: Vec<&Picture> = names
        .iter()
        .zip(&frames.frames)
        .filter(|(name, _)| !held_out.contains(name))
        .map(|(_, frame)| frame)
        .collect();
    let waypoints = Waypoints::of_frames(&model, &trained, &device)?;
    let mut inbetweens = Vec::new();
    let mut exported = Vec::new();
    let mut outfit = None;
    let mut first_path = None;
    for (a, b, stem) in [
        (pick("walk0", 0), pick("walk4", 1), "inbetween_walk"),
        (idle, pick("jump", 2), "inbetween_jump"),
    ] {
        let t = steps_t(INBETWEEN_STEPS, MAX_STEPS)?;
        let ib = inbetween(
            &model,
            &frames.frames[a],
            &frames.frames[b],
            &t,
            &fit_options,
            &waypoints,
            InbetweenPath::default(),
            &device,
        )?;
        let files = InbetweenFiles {
            path: AnimationFiles {
                sprites: Some((out.join(format!("{stem}_sprites.png")), t.len())),
                ..animation(out, stem, true)
            },
            ..InbetweenFiles::default()
        };
        write_inbetweens(&model, &ib, &[], &files, &outputs, progress)?;
        save(&format!("{stem}_sheet.png"), &comparison_sheet(&model, &ib, &frames.frames)?)?;
        exported.push(PoseAnimation {
            name: stem.to_string(),
            poses: ib.path.clone(),
        });
        if first_path.is_none() {
            first_path = Some((stem, ib.path.clone()));
        }
        inbetweens.push(Inbetween {
            stem: stem.to_string(),
            from: names[a].clone(),
            to: names[b].clone(),
        });
        if outfit.is_none() {
            if let Some(dir) = crate::rig::outfit::outfits_in(&options.character)?.into_iter().next() {
                outfit = Some(redress(&model, &dir, &ib, &frames.frames, (out, stem), &outputs, progress)?);
            }
        }
    }
    lap("in-betweens (2 × 10 frames)", &mut timings);

    // 5. A dragged pose: the robot's front hand on the idle frame.
    progress.stage("pose", DRAG_FRAMES as u64);
    let mut editor = PoseEditor::new(&model, &frames.frames[idle], &fit_options, &device)?;
    let (pin, layer) = drag_pin(&model, &names, &frames.frames, editor.fitted(), &fit_options, &device)?;
    editor.set_pins(&[pin.from])?;
    let pose_options = PoseOptions::default();
    let drag_started = Instant::now();
    let dragged = editor.drag(&[pin.to], &pose_options)?;
    let drag_ms = drag_started.elapsed().as_secs_f64() * 1e3;
    let arap = arap_drag(&model.puppet, editor.fitted(), &[(editor.bindings()[0], pin.to)])?;
    let shown: Vec<Picture> = [
        frames.frames[idle].clone(),
        render_crisp(&model.puppet, editor.fitted(), w, h)?,
        render_crisp(&model.puppet, &dragged.vertices, w, h)?,
        render_crisp(&model.puppet, &arap, w, h)?,
    ]
    .iter()
    .map(|p| pin_overlay(p, &[pin]))
    .collect();
    save("pose_sheet.png", &contact_sheet(&shown.iter().collect::<Vec<_>>(), 4))?;
    let mut writer = AnimationWriter::new(&animation(out, "drag", false), DRAG_FRAMES, w, h, &outputs)?;
    editor.write_drag(&model, &[pin], DRAG_FRAMES, &pose_options, &mut writer, progress)?;
    writer.finish()?;
    lap("dragged pose + ARAP comparison", &mut timings);

    // The appearance stage (§3.3), if asked: its sheet and the first in-between redrawn.
    let appearance = match (options.appearance_epochs, &first_path) {
        (Some(epochs), Some((stem, poses))) => {
            let config = AppearanceConfig {
                epochs,
                ..AppearanceConfig::default()
            };
            let trained = train_appearance(&model_dir, &config, &fit_options, &AppearanceOptions::default(), progress)?;
            let stage = AppearanceStage::load(&model_dir, &model, &device)?;
            let generated_stem = format!("{stem}_generated");
            let mut writer = AnimationWriter::new(&animation(out, &generated_stem, true), poses.len(), w, h, &outputs)?;
            let generated: Vec<Picture> = stage
                .render_and_redraw(&model.puppet, poses, &device)?
                .into_iter()
                .map(|(_, g)| g)
                .collect();
            for frame in &generated {
                writer.push(frame)?;
            }
            for k in writer.return_frames() {
                writer.push_return(&generated[k])?;
            }
            writer.finish()?;
            lap("appearance stage (train + redraw)", &mut timings);
            Some(page::Appearance {
                epochs,
                summary: trained,
                stem: stem.to_string(),
            })
        }
        _ => None,
    };

    // 6. For game engines: the in-betweens and the drag (fit → dragged) as a Spine skeleton.
    exported.push(PoseAnimation {
        name: "drag".into(),
        poses: vec![editor.fitted().to_vec(), dragged.vertices.clone()],
    });
    // The other outfit, if any, as a skin: the same keys in its accessories.
    let skins: Vec<OutfitSkin> = outfit
        .iter()
        .map(|(o, worn)| OutfitSkin {
            name: o.name.clone(),
            puppet: worn.puppet.clone(),
            poses: exported
                .iter()
                .map(|a| a.poses.iter().map(|p| worn.pose_from(&model, p)).collect())
                .collect(),
        })
        .collect();
    let skeleton = spine::skeleton(&model.puppet, &exported, &skins, "puppet", 0.09)?;
    let mut engine_files = Vec::new();
    for path in spine::write(&skeleton, &out.join("spine"), "puppet", &outputs)? {
        let bytes = std::fs::metadata(&path).map_err(|e| Error::io(&path, e))?.len();
        let name = path.strip_prefix(out).unwrap_or(&path).to_string_lossy().into_owned();
        engine_files.push((name, bytes));
    }
    lap("Spine export", &mut timings);

    // 7. The page.
    let seconds = started.elapsed().as_secs_f64();
    let html = page::render(&PageData {
        character: match &options.found_parts {
            Some(found) => found.name.clone(),
            None => options
                .character
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        },
        outfit: outfit.map(|(o, _)| o),
        accessories: accessory_names(&model.puppet),
        layer_names: model.puppet.layers.iter().map(|l| l.name.clone()).collect(),
        vertices: model.puppet.vertex_count(),
        joints: model.puppet.joints.len(),
        steps: summary.steps,
        images_per_second: summary.images_per_second,
        split: summary.split,
        l2_rows,
        fit: fit_options,
        inbetweens,
        appearance,
        pin,
        pin_error: dragged.pin_error[0],
        drag_ms,
        pose_steps: pose_options.steps,
        layer,
        engine_files,
        spine_animations: exported.iter().map(|a| a.name.clone()).collect(),
        timings,
        found_parts: options.found_parts.clone(),
        total: seconds,
    });
    let index = out.join("index.html");
    outputs.write(&index, html.as_bytes())?;
    Ok(DemoSummary { index, seconds })
}

/// The names of `puppet`'s accessory layers.
fn accessory_names(puppet: &crate::puppet::Puppet) -> Vec<String> {
    puppet
        .layers
        .iter()
        .filter(|l| l.kind == LayerKind::Accessory)
        .map(|l| l.name.clone())
        .collect()
}

/// The in-between `ib` of `model` (its files in `out` named after `stem`) drawn in the outfit in
/// `dir`: `<stem>_dressed.gif` and `<stem>_dressed_sheet.png`.
fn redress(
    model: &Model,
    dir: &Path,
    ib: &Inbetweens,
    frames: &[Picture],
    (out, stem): (&Path, &str),
    outputs: &Outputs,
    progress: &dyn Progress,
) -> Result<(page::PageOutfit, Model)> {
    let started = Instant::now();
    let art = artwork::load(dir, &artwork::ImportOptions::default())?;
    let puppet = dress(&model.puppet, &art, &BuildOptions::default(), &RigOptions::default(), progress)?;
    let worn = model.wearing(puppet)?;
    let rig_ms = started.elapsed().as_secs_f64() * 1e3;
    let dressed = ib.dressed(model, &worn);
    let files = InbetweenFiles {
        path: animation(out, &format!("{stem}_dressed"), true),
        ..InbetweenFiles::default()
    };
    write_inbetweens(&worn, &dressed, &[], &files, outputs, progress)?;
    let sheet = out.join(format!("{stem}_dressed_sheet.png"));
    comparison_sheet(&worn, &dressed, frames)?.save_png(&sheet)?;
    record(&sheet)?;
    let outfit = page::PageOutfit {
        name: dir.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        accessories: accessory_names(&worn.puppet),
        stem: stem.to_string(),
        rig_ms,
    };
    Ok((outfit, worn))
}

/// Checks that the demo may write everything it writes into its output folder.
///
/// # Errors
/// [`Error::WouldOverwrite`] naming a file or model folder puppet did not write (unless forced).
pub fn check_outputs(options: &DemoOptions) -> Result<()> {
    let outputs = Outputs::new(options.force);
    for file in FILES {
        outputs.check(&options.output.join(file))?;
    }
    let model_dir = options.output.join("model");
    if model_dir.exists() && !(options.force || written_by_puppet(&model_dir)?) {
        return Err(Error::WouldOverwrite {
            path: model_dir,
            reason: "is not a model folder an earlier demo wrote".into(),
        });
    }
    Ok(())
}

/// The short training run: the robot at 64×64 working pixels, batch 8, cosine decay.
fn short_run(options: &DemoOptions, model_dir: &Path) -> TrainConfig {
    let mut config = TrainConfig {
        puppet: canonical(&options.character),
        frames: canonical(&options.character.join("frames")),
        output: canonical(model_dir),
        start: None,
        seed: 1,
        split_seed: None,
        test_fraction: 0.3,
        model: Default::default(),
        train: Default::default(),
        loss: Default::default(),
        limits: Default::default(),
    };
    config.model.input_size = 64;
    config.train.steps = options.steps.max(1);
    config.train.batch = 8;
    config.train.learning_rate = 1e-4;
    config.train.learning_rate_end = Some(1e-5);
    config.train.sigma = [2.0, 0.25];
    config.train.checkpoint_every = options.steps.max(1);
    config.train.eval_every = (options.steps / 10).max(1);
    config
}

/// The drag of the demo: the centre of the robot's front hand (or the front-most layer) in the
/// `idle` frame's latent fit (where the editor binds pins), to where
/// the decoder puts it for the jump frame — a pose the nine training frames show, so the decoder
/// knows how the rest of the body goes with it (far drags to poses it never saw distort the
/// whole robot). The target comes from the jump frame's latent fit: the full fits leave the
/// manifold, a drag does not. Without a jump frame: a lift by a tenth of the frame.
fn drag_pin(
    model: &Model,
    names: &[String],
    frames: &[Picture],
    idle: &[[f32; 2]],
    options: &FitOptions,
    device: &burn::tensor::Device,
) -> Result<(Pin, String)> {
    let puppet = &model.puppet;
    let hand = ["hand_r", "hand_l", "arm_r", "arm_l"]
        .iter()
        .find_map(|n| puppet.layer_index(n))
        .unwrap_or(puppet.layers.len() - 1);
    let offsets = puppet.vertex_offsets();
    let centre = |pose: &[[f32; 2]]| {
        let part = &pose[offsets[hand]..offsets[hand + 1]];
        let n = part.len() as f32;
        part.iter().fold([0.0, 0.0], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n])
    };
    let from = centre(idle);
    let to = match names.iter().position(|n| n.contains("jump")) {
        Some(j) => {
            let z = fit_latents(model, &[&frames[j]], options, device)?;
            centre(&model.to_frame_vertices(model.decode(z, device))[0])
        }
        None => [from[0] + 0.06 * puppet.width as f32, from[1] - 0.1 * puppet.height as f32],
    };
    Ok((Pin { from, to }, puppet.layers[hand].name.clone()))
}
