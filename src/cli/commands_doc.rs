//! docs/commands.md is the CLI's own help, one section per command: this test writes it from
//! clap's definitions and fails while the committed page differs, so the page never drifts from
//! `puppet <command> --help`. `PUPPET_WRITE_DOCS=1 cargo test --release commands_md` rewrites it.

use clap::CommandFactory as _;

use super::Cli;

/// The page's path from the repository root.
const PAGE: &str = "docs/commands.md";

/// Every command a user can run, as its words after `puppet` (`["appearance", "train"]`), with
/// its long help, in the order `puppet --help` lists them.
fn commands() -> Vec<(Vec<String>, String)> {
    fn walk(command: &mut clap::Command, path: &[String], out: &mut Vec<(Vec<String>, String)>) {
        let subcommands: Vec<String> = command
            .get_subcommands()
            .filter(|c| c.get_name() != "help")
            .map(|c| c.get_name().to_string())
            .collect();
        if subcommands.is_empty() || !path.is_empty() {
            out.push((path.to_vec(), command.render_long_help().to_string()));
        }
        for name in subcommands {
            let sub = command.find_subcommand_mut(&name).expect("listed above");
            let mut deeper = path.to_vec();
            deeper.push(name);
            walk(sub, &deeper, out);
        }
    }
    let mut root = Cli::command();
    root.build();
    let mut out = vec![(Vec::new(), root.render_long_help().to_string())];
    walk(&mut root, &[], &mut out);
    out
}

/// The page: the top-level help, then a section per command.
fn page() -> String {
    let mut text = String::from(
        "# Commands\n\n\
         Every command's `--help`, generated from the CLI's definitions by the test \
         `commands_md_is_the_clis_help` (src/cli/commands_doc.rs), which fails when this page \
         is out of date; `PUPPET_WRITE_DOCS=1 cargo test --release commands_md` rewrites it. \
         The guide (docs/guide.md) shows them at work.\n",
    );
    for (path, help) in commands() {
        let title = std::iter::once("puppet")
            .chain(path.iter().map(String::as_str))
            .collect::<Vec<_>>()
            .join(" ");
        text.push_str(&format!("\n## {title}\n\n```text\n{}\n```\n", help.trim_end()));
    }
    text
}

#[test]
fn commands_md_is_the_clis_help() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(PAGE);
    let want = page();
    if std::env::var("PUPPET_WRITE_DOCS").as_deref() == Ok("1") {
        std::fs::write(&path, &want).unwrap();
    }
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    let first_difference = have.lines().zip(want.lines()).position(|(a, b)| a != b);
    assert!(
        have == want,
        "{PAGE} is not the CLI's help (first difference at line {}): run \
         `PUPPET_WRITE_DOCS=1 cargo test --release commands_md` and commit it",
        first_difference.map_or_else(|| "past the shorter's end".to_string(), |k| (k + 1).to_string())
    );
}

#[test]
fn every_command_has_a_line_in_the_readme() {
    let readme = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let missing: Vec<String> = commands()
        .into_iter()
        .filter(|(path, _)| !path.is_empty())
        .map(|(path, _)| format!("puppet {}", path.join(" ")))
        .filter(|command| !readme.contains(&format!("`{command}")))
        .collect();
    assert!(missing.is_empty(), "README.md has no line for {missing:?}");
}
