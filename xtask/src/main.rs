//! `cargo xtask`: the pipeline's command line inside the repository: the user commands of
//! `ori` (crates/ori-cli, which carries their code; `build` is also `build-assets`), plus the
//! benchmarks and the conformance check, which need the checkout.

mod bench;
mod bench_catalogue;
mod bench_remote;
mod bench_remote_exec;
mod bench_scale;
mod buildgrid;
mod conformance;
mod moto;
mod nginx;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "cargo xtask",
    about = "Omni-directional relief impostor asset pipeline"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The user commands of `ori` (`build` is also `build-assets`) and the repository's own.
#[derive(Subcommand)]
enum Command {
    #[command(flatten)]
    User(ori_cli::Command),
    /// Run a benchmark and print its figures.
    Bench {
        #[command(subcommand)]
        which: bench::Bench,
    },
    /// Check the runtime's conformance data (docs/conformance) against the CPU evaluator.
    Conformance(conformance::Args),
}

fn main() -> ExitCode {
    match Cli::parse().command {
        Command::User(command) => command.run(),
        Command::Bench { which } => bench::run(which),
        Command::Conformance(args) => conformance::run(args),
    }
}
