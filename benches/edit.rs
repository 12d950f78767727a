//! Latency of what an interactive editor does per mouse move (issue 6, neural-puppet.md §4.1–4.2):
//! one drag update (5 gradient steps of eq. 9 through the decoder + a crisp render of the
//! 96×128 frame) and one in-between frame (one decode + a crisp render), on the Kenney robot's
//! puppet with the paper-size network at 128² input. Weights are random (the decoder's last
//! layer too, so the latent moves the pose as in a trained model); time does not depend on them.
//! Ids: `edit/drag/steps=5/pins=1`, `edit/inbetween/frame`; beside it the as-rigid-as-possible
//! in-between: `edit/inbetween/arap_setup` (the system factorised for two keyframes) and
//! `edit/inbetween/arap_frame` (one solve + the crisp render). And the default fit's limb search
//! over one frame (`edit/fit/limb_search`: every limb of the robot turned through its fan, a
//! turned arm to find), and one round of the default fit's vertex steps on that frame, all at
//! full size or the first share at half size (`edit/fit/vertex_round/coarse_share=<S>`). On
//! the male adventurer, his hair rigged, one frame with the hair drawn off the rig: one round of
//! vertex steps, then none or the default number of steps on the accessories' moves
//! (`edit/fit/accessory_steps=<N>`). And the default fit of four frames of the robot, limbs
//! turned (`edit/fit/default/frames=4`).

// Benchmarks print their figures, read their own committed data, and criterion's macros write
// undocumented functions.
#![allow(missing_docs, clippy::print_stdout, clippy::unwrap_used)]

use std::hint::black_box;

use burn::module::{Module, ModuleMapper, Param};
use burn::tensor::{Distribution, Tensor};
use criterion::{criterion_group, criterion_main, Criterion};
use puppet::edit::inbetween::{rigid_interpolation, Interpolator};
use puppet::edit::pose::{PoseEditor, PoseOptions};
use puppet::fit::limb_search::LimbSearch;
use puppet::fit::{fit, FitOptions, DEFAULT_ACCESSORY_STEPS, DEFAULT_VERTEX_COARSE_SHARE};
use puppet::model::deformation::DeformationNetConfig;
use puppet::model::Model;
use puppet::progress::Silent;
use puppet::puppet::limbs::limbs;
use puppet::render::{render_crisp, SoftRasterizer};

/// Gives all-zero weight tensors (the decoder's zero-initialised last layer) small random values.
struct Noise;
impl ModuleMapper for Noise {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        param.map(|t| {
            if t.clone().abs().max().into_scalar::<f32>() == 0.0 {
                Tensor::random(t.shape(), Distribution::Uniform(-0.02, 0.02), &t.device())
            } else {
                t
            }
        })
    }
}

/// An untrained model of a bundled Kenney character (with its accessory rig, if `rigged`), its
/// decoder's last layer given small random weights.
fn kenney_model(name: &str, rigged: bool) -> Model {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/kenney").join(name);
    let art = puppet::puppet::artwork::load(&dir, &Default::default()).expect("the bundled character loads");
    let p = if rigged {
        puppet::rig::build_rigged(&art, &Default::default(), &Default::default(), &Silent).expect("the character rigs")
    } else {
        puppet::puppet::build::build(&art, &Default::default(), &Silent)
            .expect("the character builds")
            .0
    };
    let device = puppet::backend::device();
    let outputs = p.free_vertices().len();
    let mut model = Model::new(DeformationNetConfig::new(outputs), p, &device).expect("a model for the character");
    model.net = model.net.map(&mut Noise);
    model
}

fn bench(c: &mut Criterion) {
    let device = puppet::backend::device();
    let model = kenney_model("robot", false);
    let (w, h) = (model.puppet.width, model.puppet.height);
    let frame = render_crisp(&model.puppet, &model.puppet.rest_vertices(), w, h).expect("rest render");
    let mut group = c.benchmark_group("edit");

    let mut editor = PoseEditor::new(&model, &frame, &FitOptions::one_pass(), &device).expect("fit");
    // The front hand's centre, dragged up and out by a few pixels per update.
    let hand = model.puppet.layer_index("hand_r").unwrap_or(model.puppet.layers.len() - 1);
    let offsets = model.puppet.vertex_offsets();
    let part = &editor.fitted()[offsets[hand]..offsets[hand + 1]];
    let from = part.iter().fold([0.0f32; 2], |s, p| {
        [s[0] + p[0] / part.len() as f32, s[1] + p[1] / part.len() as f32]
    });
    editor.set_pins(&[from]).expect("the hand is on the character");
    let options = PoseOptions::default();
    let mut k = 0u32;
    group.bench_function("drag/steps=5/pins=1", |b| {
        b.iter(|| {
            k += 1;
            let d = (k % 20) as f32;
            let out = editor.drag(&[[from[0] + 0.5 * d, from[1] - d]], &options).expect("drag");
            black_box(render_crisp(&model.puppet, &out.vertices, w, h).expect("render"))
        })
    });

    let mut other = model.puppet.rest_vertices();
    other.iter_mut().for_each(|p| p[0] += 3.0);
    let b_frame = render_crisp(&model.puppet, &other, w, h).expect("render");
    let interp = Interpolator::new(&model, &frame, &b_frame, &FitOptions::one_pass(), &device).expect("encode");
    let mut t = 0.0f32;
    group.bench_function("inbetween/frame", |b| {
        b.iter(|| {
            t = (t + 0.137) % 1.0;
            let pose = interp.latent_poses(&model, &[t], &device).pop().expect("one pose");
            black_box(render_crisp(&model.puppet, &pose, w, h).expect("render"))
        })
    });
    group.bench_function("inbetween/arap_setup", |b| {
        b.iter(|| {
            let [key_a, key_b] = interp.keys();
            black_box(rigid_interpolation(&model.puppet, key_a, key_b).expect("interpolation"))
        })
    });
    let [key_a, key_b] = interp.keys();
    let mut rigid = rigid_interpolation(&model.puppet, key_a, key_b).expect("interpolation");
    group.bench_function("inbetween/arap_frame", |b| {
        b.iter(|| {
            t = (t + 0.137) % 1.0;
            black_box(render_crisp(&model.puppet, &rigid.at(f64::from(t)), w, h).expect("render"))
        })
    });

    let raster = SoftRasterizer::new(&model.puppet).expect("rasterizer");
    let mut turned = model.puppet.rest_vertices();
    limbs(&model.puppet)[1].turn(&mut turned, 50f32.to_radians());
    group.bench_function("fit/limb_search", |b| {
        b.iter(|| {
            let mut pose = turned.clone();
            let search = LimbSearch::default();
            black_box(
                search
                    .improve(&raster, &model.puppet, None, None, &frame, &mut pose)
                    .expect("search"),
            )
        })
    });

    let drawn = render_crisp(&model.puppet, &turned, w, h).expect("render");
    group.sample_size(10);
    for share in [0.0, DEFAULT_VERTEX_COARSE_SHARE] {
        let options = FitOptions {
            latent_steps: 0,
            vertex_rounds: 1,
            limb_search: None,
            vertex_coarse_share: share,
            ..FitOptions::default()
        };
        group.bench_function(format!("fit/vertex_round/coarse_share={share}"), |b| {
            b.iter(|| black_box(fit(&model, &[&drawn], &options, &device, &Silent).expect("fit")))
        });
    }

    // The default fit of four frames (the robot's held-out split has four), in two batches side
    // by side.
    let poses: Vec<Vec<[f32; 2]>> = (1..=4)
        .map(|k| {
            let mut pose = model.puppet.rest_vertices();
            limbs(&model.puppet)[k].turn(&mut pose, (20.0 * k as f32).to_radians());
            pose
        })
        .collect();
    let frames: Vec<_> = poses
        .iter()
        .map(|p| render_crisp(&model.puppet, p, w, h).expect("render"))
        .collect();
    let frames: Vec<_> = frames.iter().collect();
    group.bench_function("fit/default/frames=4", |b| {
        b.iter(|| black_box(fit(&model, &frames, &FitOptions::default(), &device, &Silent).expect("fit")))
    });

    let dressed = kenney_model("male_adventurer", true);
    let (w, h) = (dressed.puppet.width, dressed.puppet.height);
    // The hair drawn 2 px lower and 1 px to the right of where the rig puts it at rest.
    let mut off_rig = dressed.puppet.rest_vertices();
    let offsets = dressed.puppet.vertex_offsets();
    for (l, layer) in dressed.puppet.layers.iter().enumerate() {
        if layer.kind == puppet::puppet::LayerKind::Accessory {
            off_rig[offsets[l]..offsets[l + 1]]
                .iter_mut()
                .for_each(|p| *p = [p[0] + 1.0, p[1] + 2.0]);
        }
    }
    let drawn = render_crisp(&dressed.puppet, &off_rig, w, h).expect("render");
    for accessory_steps in [0, DEFAULT_ACCESSORY_STEPS] {
        let options = FitOptions {
            latent_steps: 0,
            vertex_rounds: 1,
            limb_search: None,
            accessory_steps,
            ..FitOptions::default()
        };
        group.bench_function(format!("fit/accessory_steps={accessory_steps}"), |b| {
            b.iter(|| black_box(fit(&dressed, &[&drawn], &options, &device, &Silent).expect("fit")))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
