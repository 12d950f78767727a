//! The `puppet` command line: parsing and reporting only; every command is a library call.

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;

mod cli;

#[path = "allocator.rs"]
mod allocator;

fn main() -> ExitCode {
    allocator::keep_freed_memory();
    let args = match cli::Cli::try_parse() {
        Ok(args) => args,
        Err(e) => {
            // Help and version go to stdout and exit 0; usage errors to stderr with exit 2.
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of stdout went away (`puppet eval … | head`): nothing left to say.
        Err(err) if cli::is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            let _ = writeln!(std::io::stderr().lock(), "puppet: error: {}", cli::describe(&err));
            ExitCode::FAILURE
        }
    }
}
