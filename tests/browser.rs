//! The web editor end to end in a real browser: `puppet serve` on the tiny hatted character,
//! driven in Debian's headless Chromium by `tests/browser/editor.mjs` (Playwright): pin the
//! hand, drag it, check the pin reached its target from the vertices the page shows, remove the
//! pin, undo, redo, reset, click off the character, make and play an eased in-between to a frame uploaded from the page, show the
//! appearance stage's redraws of the pose and the in-between and download them as GIF, hide and
//! show the hat, download the pose as PNG, ask what to draw next and send a drawing back (one of
//! the wrong size first, refused), continue the model on it, play the shipped BVH walk.
//! Screenshots go to `target/browser-editor/`.
//!
//! The model is trained here for a few seconds on three frames of the arm (rest, raised,
//! lowered): an untrained model's decoder ends in a zero layer, so every latent gives the rest
//! pose and no drag can move the pin (measured: it stays 5.0 px from a 5 px drag's target), and
//! the drag uses α1 = 2, α2 = 4 (below). Its appearance stage is trained for three steps: the
//! page is checked for what it shows, not for how well the stage draws.
//!
//! It needs `/usr/bin/chromium`, `node` and `tests/browser/node_modules` (`npm ci` there). When
//! one is missing the test says what and skips, unless `PUPPET_BROWSER_TESTS=1` (CI) makes that
//! a failure.

use std::io::{BufRead as _, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Instant;

use crate::util::{puppet, repo, write_hatted_character};

/// Debian's Chromium, the browser the script launches.
const CHROMIUM: &str = "/usr/bin/chromium";

/// What the browser test needs and is not there, each with how to install it.
fn missing_tools() -> Vec<String> {
    let mut missing = Vec::new();
    if !Path::new(CHROMIUM).is_file() {
        missing.push(format!("{CHROMIUM} (apt-get install chromium)"));
    }
    if Command::new("node").arg("--version").output().map_or(true, |o| !o.status.success()) {
        missing.push("node (apt-get install nodejs npm)".to_string());
    }
    if !repo().join("tests/browser/node_modules/playwright-core").is_dir() {
        missing.push("tests/browser/node_modules/playwright-core (cd tests/browser && npm ci)".to_string());
    }
    missing
}

/// Kills the server when the test ends, however it ends.
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `puppet serve` on any free port; returns it and the page's address.
fn serve(cwd: &Path, model: &Path, frames: &Path) -> (Server, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_puppet"))
        .args(["serve", "--appearance", "--model"])
        .arg(model)
        .arg("--frames")
        .arg(frames)
        .args(["--port", "0", "--latent-steps", "0"])
        .current_dir(cwd)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let server = Server(child);
    let address = line
        .split("http://")
        .nth(1)
        .and_then(|rest| rest.split('/').next())
        .unwrap_or_else(|| panic!("no address in the server's first line {line:?}"));
    (server, format!("http://{address}/"))
}

/// The arm rotated about its joint with the torso by these angles (degrees; negative raises it,
/// y being down), one training frame each: `a_rest.png` first, the frame the page opens.
const ARM_FRAMES: [(&str, f32); 3] = [("a_rest.png", 0.0), ("b_raised.png", -40.0), ("c_lowered.png", 40.0)];

/// Writes the frames of [`ARM_FRAMES`] for the puppet built in `built` into `dir`.
fn arm_frames(built: &Path, dir: &Path) {
    let p = puppet::puppet::format::load(built).unwrap();
    let arm = p.layer_index("arm").unwrap();
    let rest = p.rest_vertices();
    let hinge = p
        .joints
        .iter()
        .flat_map(|j| [j.a, j.b])
        .find(|v| v.layer == arm)
        .expect("the arm is jointed to the torso");
    let pivot = rest[p.global_index(hinge)];
    let offsets = p.vertex_offsets();
    std::fs::create_dir_all(dir).unwrap();
    for (name, degrees) in ARM_FRAMES {
        let (sin, cos) = degrees.to_radians().sin_cos();
        let mut v = rest.clone();
        for q in &mut v[offsets[arm]..offsets[arm + 1]] {
            let [dx, dy] = [q[0] - pivot[0], q[1] - pivot[1]];
            *q = [pivot[0] + cos * dx - sin * dy, pivot[1] + sin * dx + cos * dy];
        }
        puppet::render::render_crisp(&p, &v, p.width, p.height)
            .unwrap()
            .save_png(&dir.join(name))
            .unwrap();
    }
}

/// Trains a model on the frames in `frames` into `out` with a tiny config (15–20 s on two
/// cores). At 64², the frames' own size, 220 steps learn enough of the arm's swing for a drag to
/// follow; at 48² or 32² the arm is a few pixels wide and the loss plateaus before it moves.
fn train(tmp: &Path, built: &Path, frames: &Path, out: &Path) {
    let config = tmp.join("train.toml");
    std::fs::write(
        &config,
        format!(
            "puppet = {built:?}\nframes = {frames:?}\noutput = {out:?}\ntest_fraction = 0.0\n\
             [model]\ninput_size = 64\nlatent = 16\n\
             [train]\nsteps = 220\nbatch = 3\nlearning_rate = 1e-3\nsigma = [1.0, 1.0]\n"
        ),
    )
    .unwrap();
    puppet(tmp, &["train", config.to_str().unwrap(), "-q"]).assert_ok();
}

/// Trains the model's appearance stage for 3 steps (seconds): the page shows what it draws, not
/// how well.
fn train_appearance(tmp: &Path, model: &Path) {
    let config = tmp.join("appearance.toml");
    std::fs::write(&config, "epochs = 1\nbatch = 1\nfit = \"one-pass\"\n").unwrap();
    let (model, config) = (model.to_str().unwrap(), config.to_str().unwrap());
    puppet(tmp, &["appearance", "train", "--model", model, config, "-q"]).assert_ok();
}

#[test]
fn browser_editor_poses_plays_inbetweens_toggles_an_accessory_and_downloads() {
    let missing = missing_tools();
    if !missing.is_empty() {
        let what = missing.join("; ");
        if std::env::var("PUPPET_BROWSER_TESTS").as_deref() == Ok("1") {
            panic!("PUPPET_BROWSER_TESTS=1 but the browser test cannot run: missing {what}");
        }
        // Past the harness's capture (which takes print! and eprint!), so `cargo test` shows it.
        let _ = writeln!(
            std::io::stderr(),
            "browser_editor_poses_plays_inbetweens_toggles_an_accessory_and_downloads: SKIPPED, the browser test needs {what} \
             (set PUPPET_BROWSER_TESTS=1 to make this a failure)"
        );
        return;
    }
    let started = Instant::now();
    let tmp = tempfile::tempdir().unwrap();
    let art = write_hatted_character(&tmp.path().join("art"));
    let built = tmp.path().join("built");
    puppet(tmp.path(), &["build", art.to_str().unwrap(), "-o", built.to_str().unwrap()]).assert_ok();
    let frames = tmp.path().join("frames");
    arm_frames(&built, &frames);
    let model = tmp.path().join("model");
    train(tmp.path(), &built, &frames, &model);
    train_appearance(tmp.path(), &model);
    let trained = started.elapsed();
    let small = tmp.path().join("small.png");
    puppet::picture::Picture::filled(16, 16, [0.2, 0.4, 0.8, 1.0])
        .save_png(&small)
        .unwrap();
    let served = files(&model);
    let (server, url) = serve(tmp.path(), &model, &frames);
    let out: PathBuf = repo().join("target/browser-editor");
    std::fs::create_dir_all(&out).unwrap();
    let run = Command::new("node")
        .arg(repo().join("tests/browser/editor.mjs"))
        .arg(&url)
        .arg(&out)
        .env("HAND_LAYER", "arm")
        .env("UPLOAD_FRAME", frames.join("c_lowered.png"))
        // The artist's drawing of the first suggestion: any frame of the character will do.
        .env("DRAWING", frames.join("b_raised.png"))
        .env("BAD_DRAWING", &small)
        .env("CONTINUE_STEPS", "3")
        .env("MOTION", repo().join("data/motion/walk.bvh"))
        .env("MOTION_FRAMES", "36")
        // Set on the page's α sliders: with the paper's 25 and 50 the ARAP and joint terms
        // hold this briefly trained arm back, and even after the page's settling request on
        // release the pin ends 2.6 px from the target of a 5 px drag; with 2 and 4, 0.4 px
        // (measured) — the minimum of L_deform moves, not the optimiser's progress.
        .env("ALPHA_REG", "2")
        .env("ALPHA_JOINTS", "4")
        .output()
        .unwrap();
    drop(server);
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    println!("{stdout}");
    eprint!("{stderr}");
    println!(
        "browser test: {:.1} s in all ({:.1} s building and training the model)",
        started.elapsed().as_secs_f64(),
        trained.as_secs_f64()
    );
    assert!(
        run.status.success(),
        "tests/browser/editor.mjs failed ({}):\n{stdout}\n{stderr}",
        run.status
    );
    // What the page's drawing and continuation left on disk: a copy of the frames with the
    // drawing beside the model, the continued model there, the model itself as it was.
    let next = tmp.path().join("model-next");
    let mut copied: Vec<String> = std::fs::read_dir(next.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    copied.sort();
    assert_eq!(copied, ["a_rest.png", "b_raised.png", "c_lowered.png", "drawn_next_1.png"]);
    let split: serde_json::Value = serde_json::from_slice(&std::fs::read(next.join("model/split.json")).unwrap()).unwrap();
    assert!(
        split["train"].as_array().unwrap().contains(&serde_json::json!("drawn_next_1.png")),
        "{split}"
    );
    assert_eq!(files(&model), served, "the model being served is only read");
}

/// The files of `dir` (not its folders) with their bytes, by name.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect();
    files.sort();
    files
}
