//! `cargo xtask`: the pipeline's command line inside the repository: the user commands of
//! `ori` (crates/ori-cli, which carries their code) under their xtask names, plus the
//! benchmarks and the conformance check, which need the checkout.

mod bench;
mod bench_catalogue;
mod bench_remote;
mod bench_scale;
mod conformance;
mod nginx;

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use ori_cli::{build, compare, compress, eval_table, preview};

#[derive(Parser)]
#[command(
    name = "cargo xtask",
    about = "Omni-directional relief impostor asset pipeline"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The user commands of `ori` (under their xtask names) and the repository's own.
#[derive(Subcommand)]
enum Command {
    /// Build every asset found under the assets folder, reusing cached results.
    BuildAssets(build::BuildArgs),
    /// Write the release from the caches (local, then remote) without running any stage:
    /// after `build-assets --shard K/N` on every shard.
    Assemble(build::AssembleArgs),
    /// Run a benchmark and print its figures.
    Bench {
        #[command(subcommand)]
        which: bench::Bench,
    },
    /// Bake every rival impostor technique and the ORI at one byte budget and compare them at
    /// the held-out directions.
    Compare(compare::Args),
    /// Compress a PNG into a KTX2 texture (BC1 albedo, BC4, BC5 normals).
    CompressTexture(compress::Args),
    /// Check the runtime's conformance data (docs/conformance) against the CPU evaluator.
    Conformance(conformance::Args),
    /// Print the ORI paper's Table 1 for a model (1-4 closest and best:M selection).
    EvalTable(eval_table::Args),
    /// Draw a package with the wgpu runtime renderer beside its mesh and the difference.
    Preview(preview::Args),
    /// Write the HTML build report of an output folder again, without rebuilding.
    Report(build::ReportArgs),
    /// Check a release folder against its release.json: hashes, sizes, package validity.
    Verify(build::VerifyArgs),
}

fn main() -> ExitCode {
    let user = match Cli::parse().command {
        Command::Bench { which } => return bench::run(which),
        Command::Conformance(args) => return conformance::run(args),
        Command::BuildAssets(args) => ori_cli::Command::Build(args),
        Command::Assemble(args) => ori_cli::Command::Assemble(args),
        Command::Compare(args) => ori_cli::Command::Compare(args),
        Command::CompressTexture(args) => ori_cli::Command::CompressTexture(args),
        Command::EvalTable(args) => ori_cli::Command::EvalTable(args),
        Command::Preview(args) => ori_cli::Command::Preview(args),
        Command::Report(args) => ori_cli::Command::Report(args),
        Command::Verify(args) => ori_cli::Command::Verify(args),
    };
    user.run()
}
