//! The `puppet` command line: parsing and reporting only; every command is a library call.

use std::process::ExitCode;

use clap::Parser;

mod cli;

#[path = "allocator.rs"]
mod allocator;

fn main() -> ExitCode {
    allocator::keep_freed_memory();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("puppet: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
