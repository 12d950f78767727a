//! The `puppet` command line: parsing and reporting only; every command is a library call.

use std::process::ExitCode;

use clap::Parser;

mod cli;

// Burn allocates and frees a large buffer per tensor operation; glibc's malloc returns big
// blocks to the OS and maps them again each time (page faults, zeroing), mimalloc keeps them.
// Measured in benches/README.md "backend".
#[cfg(feature = "mimalloc")]
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("puppet: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
