//! `tetbench`: the command line over the `algorithms` library (CONVENTIONS §8).

use std::process::ExitCode;

use clap::Parser;

#[global_allocator]
static ALLOC: algorithms::alloc::CountingAlloc = algorithms::alloc::CountingAlloc;

fn main() -> ExitCode {
    let cli = tetbench::cli::Cli::parse();
    match tetbench::commands::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tetbench: {e}");
            ExitCode::from(if e.is_user_error() { 2 } else { 1 })
        }
    }
}
