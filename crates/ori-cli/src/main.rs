//! `ori`: the pipeline's command, installed with `cargo install --locked --path crates/ori-cli`.

use std::process::ExitCode;

use clap::Parser;

/// The package version and the commit it was built from.
const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (", env!("ORI_GIT_HASH"), ")");

#[derive(Parser)]
#[command(
    name = "ori",
    version = VERSION,
    about = "Omni-directional relief impostor asset pipeline",
    after_help = "Exit status: 0 done; 1 a job or an output failed (or a release check found a mismatch); \
                  2 the configuration or the command line is wrong; 3 built, but an asset missed its [gate]."
)]
struct Cli {
    #[command(subcommand)]
    command: ori_cli::Command,
}

fn main() -> ExitCode {
    Cli::parse().command.run()
}
