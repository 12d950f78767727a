//! The integration tests, as one binary so the suite links Burn once: the CLI end to end on
//! `data/`, file formats, bad input, training, editing, the web editor in a browser, and the
//! regressions of closed issues.

// An unwrap here is the test failing and a print is the test reporting, helpers included
// (clippy.toml covers only #[test] bodies).
#![allow(clippy::unwrap_used, clippy::print_stdout, clippy::print_stderr)]

mod appearance;
mod bad_input;
mod browser;
mod cli;
mod edit;
mod formats;
mod parts;
mod prior;
mod regression;
mod render;
mod retarget;
mod suggest;
mod synth;
mod train;
mod util;
