//! The layers of ../shared/DESIGN.md, checked: every module imports only from layers below its
//! own, or from the modules of its own layer listed in [`SAME_LAYER`]. The test reads the
//! sources, so a new `use crate::…` that points upwards fails it with the file and line.

use std::collections::BTreeMap;
use std::path::Path;

/// Each top-level module's layer (DESIGN.md "Layers of the code"). `cli` and `main.rs` are the
/// binary's (layer 7) and not part of the library.
const LAYERS: &[(&str, u8)] = &[
    ("error", 0),
    ("picture", 0),
    ("atomic_file", 0),
    ("folder_lock", 0),
    ("progress", 0),
    ("rng", 0),
    ("backend", 0),
    ("user_file", 0),
    ("geom", 1),
    ("metrics", 1),
    ("puppet", 2),
    ("rig", 3),
    ("posing", 3),
    ("render", 3),
    ("model", 4),
    ("objective", 4),
    ("train", 4),
    ("fit", 5),
    ("edit", 5),
    ("appearance", 5),
    ("parts", 5),
    ("prior", 5),
    ("synth", 6),
    ("eval", 6),
    ("export", 6),
    ("serve", 6),
    ("demo", 6),
];

/// Imports allowed between modules of one layer (importer, imported): one-way, so no cycle.
const SAME_LAYER: &[(&str, &str)] = &[
    ("atomic_file", "error"),
    ("folder_lock", "error"),
    ("atomic_file", "user_file"),
    ("atomic_file", "folder_lock"),
    ("user_file", "error"),
    ("picture", "error"),
    ("picture", "atomic_file"),
    ("picture", "user_file"),
    ("rig", "render"),
    ("posing", "rig"),
    ("posing", "render"),
    ("objective", "model"),
    ("train", "model"),
    ("train", "objective"),
    ("edit", "fit"),
    ("appearance", "fit"),
    ("parts", "fit"),
    ("prior", "parts"),
    ("prior", "fit"),
    ("edit", "prior"),
    ("eval", "synth"),
    ("demo", "eval"),
    ("demo", "synth"),
    ("demo", "export"),
    ("serve", "export"),
];

/// Modules outside the layers: test helpers and this check.
const EXEMPT: &[&str] = &["test_util", "layering", "lib"];

/// The code of a file before its `#[cfg(test)] mod tests` (tests may use anything).
fn non_test_code(text: &str) -> &str {
    let mut offset = 0;
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    for (k, line) in lines.iter().enumerate() {
        if line.trim() == "#[cfg(test)]" && lines.get(k + 1).is_some_and(|next| next.trim_start().starts_with("mod tests")) {
            return &text[..offset];
        }
        offset += line.len();
    }
    text
}

/// Every `crate::<module>` a file's non-test code names, with its line, skipping comments.
fn imports(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in non_test_code(text).lines().enumerate() {
        let code = line.split("//").next().unwrap_or_default();
        let mut rest = code;
        while let Some(at) = rest.find("crate::") {
            let name: String = rest[at + 7..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                out.push((n + 1, name));
            }
            rest = &rest[at + 7..];
        }
        // `use crate::{a, b::c}` names several modules at once.
        if let Some(at) = code.find("crate::{") {
            let inner = &code[at + 8..];
            for part in inner.split([',', '}']) {
                let name: String = part.trim().chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                if !name.is_empty() && name != "self" {
                    out.push((n + 1, name));
                }
            }
        }
    }
    out
}

/// The top-level module a source file belongs to (`src/fit/frame.rs` → `fit`).
fn module_of(path: &Path, src: &Path) -> Option<String> {
    let relative = path.strip_prefix(src).ok()?;
    let first = relative.components().next()?.as_os_str().to_string_lossy().into_owned();
    Some(first.trim_end_matches(".rs").to_string())
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ is readable").flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Every import of `src` that breaks the layering, as "file:line: a (layer) → b (layer)".
fn violations(src: &Path) -> Vec<String> {
    let layer: BTreeMap<&str, u8> = LAYERS.iter().copied().collect();
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut out = Vec::new();
    for file in files {
        let Some(module) = module_of(&file, src) else { continue };
        if EXEMPT.contains(&module.as_str()) || matches!(module.as_str(), "cli" | "main" | "allocator") {
            continue;
        }
        let text = std::fs::read_to_string(&file).expect("a source file is readable");
        let Some(&own) = layer.get(module.as_str()) else {
            out.push(format!("{}: module {module:?} is in no layer of DESIGN.md", file.display()));
            continue;
        };
        for (line, imported) in imports(&text) {
            if imported == module || EXEMPT.contains(&imported.as_str()) || imported == "Error" || imported == "Result" {
                continue;
            }
            let Some(&theirs) = layer.get(imported.as_str()) else {
                out.push(format!(
                    "{}:{line}: {module} names crate::{imported}, which is in no layer",
                    file.display()
                ));
                continue;
            };
            let allowed = theirs < own || (theirs == own && SAME_LAYER.contains(&(module.as_str(), imported.as_str())));
            if !allowed {
                out.push(format!(
                    "{}:{line}: {module} (layer {own}) imports {imported} (layer {theirs})",
                    file.display()
                ));
            }
        }
    }
    out
}

#[test]
fn every_module_imports_only_from_layers_below_its_own() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let bad = violations(&src);
    assert!(
        bad.is_empty(),
        "{} imports break DESIGN.md's layers:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn the_check_finds_an_upward_import_and_ignores_tests_and_comments() {
    let text = "use crate::geom::arap;\n// crate::cli in a comment\nfn f() { crate::train::x(); }\n#[cfg(test)]\nmod tests {\n    use crate::synth;\n}\n";
    let found: Vec<String> = imports(text).into_iter().map(|(_, m)| m).collect();
    assert_eq!(found, ["geom", "train"]);
    let grouped: Vec<String> = imports("use crate::{fit::FitOptions, metrics::l2};")
        .into_iter()
        .map(|(_, m)| m)
        .collect();
    assert_eq!(grouped, ["fit", "metrics"]);
    let same: Vec<(u8, u8)> = SAME_LAYER
        .iter()
        .map(|(a, b)| {
            let l = |m: &str| LAYERS.iter().find(|(n, _)| *n == m).map(|(_, l)| *l).expect("listed");
            (l(a), l(b))
        })
        .collect();
    assert!(same.iter().all(|(a, b)| a == b), "SAME_LAYER pairs are within one layer");
    assert!(
        SAME_LAYER.iter().all(|(a, b)| !SAME_LAYER.contains(&(b, a))),
        "same-layer imports are one-way"
    );
}
