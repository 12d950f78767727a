//! Shared helpers for integration tests: a temporary folder, tiny characters written as each
//! artwork form, and a runner for the `puppet` binary.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The outcome of one `puppet` run.
pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

impl Run {
    /// Asserts the run failed with exit code 1 and an error message (after any progress lines)
    /// naming every `needle`, without a panic.
    pub fn assert_error(&self, needles: &[&str]) {
        assert_eq!(self.code, 1, "expected exit 1\nstdout: {}\nstderr: {}", self.stdout, self.stderr);
        assert!(!self.stderr.contains("panicked"), "panic instead of an error:\n{}", self.stderr);
        let at = self
            .stderr
            .find("puppet: error: ")
            .unwrap_or_else(|| panic!("no error message on stderr:\n{}", self.stderr));
        let error = &self.stderr[at..];
        for n in needles {
            assert!(error.contains(n), "the error lacks {n:?}:\n{}", self.stderr);
        }
    }

    /// Asserts the run succeeded.
    pub fn assert_ok(&self) {
        assert_eq!(self.code, 0, "expected success\nstdout: {}\nstderr: {}", self.stdout, self.stderr);
    }

    /// Asserts the run succeeded and warned `warning` (the text after `warning: `) on stderr.
    pub fn assert_ok_warning(&self, warning: &str) {
        self.assert_ok();
        let line = format!("warning: {warning}");
        assert!(self.stderr.contains(&line), "no {line:?} on stderr:\n{}", self.stderr);
    }
}

/// Runs the `puppet` binary with `args` in `cwd`.
pub fn puppet(cwd: &Path, args: &[&str]) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_puppet"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the puppet binary runs");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// The repository root (for `data/`).
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// An RGBA image of `w`×`h` where `inside(x, y)` pixels get `colour`, others are transparent.
pub fn shape(w: u32, h: u32, colour: [u8; 4], inside: impl Fn(f32, f32) -> bool) -> image::RgbaImage {
    image::RgbaImage::from_fn(w, h, |x, y| {
        let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
        image::Rgba(if inside(cx, cy) { colour } else { [0, 0, 0, 0] })
    })
}

/// The tiny test character: a torso box, a head disc overlapping its top, an arm box overlapping
/// its side, 64×64, as (name, image) back → front.
pub fn tiny_layers() -> Vec<(&'static str, image::RgbaImage)> {
    let torso = shape(64, 64, [60, 120, 200, 255], |x, y| {
        (20.0..44.0).contains(&x) && (24.0..52.0).contains(&y)
    });
    let head = shape(64, 64, [240, 200, 150, 255], |x, y| (x - 32.0).powi(2) + (y - 16.0).powi(2) < 100.0);
    let arm = shape(64, 64, [200, 60, 60, 255], |x, y| {
        (40.0..52.0).contains(&x) && (26.0..34.0).contains(&y)
    });
    vec![("torso", torso), ("head", head), ("arm", arm)]
}

/// Writes the tiny character in the layer-PNG form into `dir` (with `extra` appended to
/// character.toml's top-level keys) and returns `dir`.
pub fn write_layer_character(dir: &Path, extra: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let mut toml = format!("name = \"tiny\"\nroot = \"torso\"\n{extra}\n");
    for (name, img) in tiny_layers() {
        img.save(dir.join(format!("{name}.png"))).unwrap();
        toml.push_str(&format!("[[layer]]\nname = \"{name}\"\nfile = \"{name}.png\"\n"));
    }
    std::fs::write(dir.join("character.toml"), toml).unwrap();
    dir.to_path_buf()
}

/// Writes the tiny character in the label-map form into `dir` and returns `dir`.
pub fn write_label_character(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let layers = tiny_layers();
    let legend = [[255u8, 0, 0], [0, 255, 0], [0, 0, 255]];
    let mut map = image::RgbaImage::new(64, 64);
    let mut reference = image::RgbaImage::new(64, 64);
    for (k, (_, img)) in layers.iter().enumerate() {
        for (x, y, p) in img.enumerate_pixels() {
            if p[3] > 0 {
                let c = legend[k];
                map.put_pixel(x, y, image::Rgba([c[0], c[1], c[2], 255]));
                reference.put_pixel(x, y, *p);
            }
        }
    }
    map.save(dir.join("labels.png")).unwrap();
    reference.save(dir.join("reference.png")).unwrap();
    let mut toml = String::from("root = \"torso\"\n[labels]\nmap = \"labels.png\"\nimage = \"reference.png\"\n");
    for (k, (name, _)) in layers.iter().enumerate() {
        let c = legend[k];
        toml.push_str(&format!(
            "[[layer]]\nname = \"{name}\"\ncolor = \"#{:02x}{:02x}{:02x}\"\n",
            c[0], c[1], c[2]
        ));
    }
    std::fs::write(dir.join("character.toml"), toml).unwrap();
    dir.to_path_buf()
}

/// The tiny character wearing a hat (an accessory layer over the top of the head), in the
/// layer-PNG form in `dir`; returns `dir`.
pub fn write_hatted_character(dir: &std::path::Path) -> std::path::PathBuf {
    let art = write_layer_character(dir, "");
    let hat = shape(64, 64, [30, 30, 30, 255], |x, y| {
        (22.0..42.0).contains(&x) && (4.0..12.0).contains(&y)
    });
    hat.save(art.join("hat.png")).unwrap();
    let toml = std::fs::read_to_string(art.join("character.toml")).unwrap();
    std::fs::write(
        art.join("character.toml"),
        format!("{toml}[[layer]]\nname = \"hat\"\nfile = \"hat.png\"\nkind = \"accessory\"\n"),
    )
    .unwrap();
    art
}
