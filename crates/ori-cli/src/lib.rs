//! The pipeline's user commands, shared by the installable `ori` binary and `cargo xtask`
//! (which adds the benchmarks and repository chores). Each command is a thin layer over a
//! library crate, so everything it does is also testable and usable from code.

pub mod action;
pub mod build;
pub mod compare;
pub mod compress;
pub mod eval_table;
mod events;
pub mod init;
pub mod preview;
mod progress;
pub mod worker;

use std::process::ExitCode;

use clap::Subcommand;

/// The commands of `ori`.
#[derive(Subcommand)]
pub enum Command {
    /// Build every asset found under the assets folder, reusing cached results.
    #[command(visible_alias = "build-assets")]
    Build(build::BuildArgs),
    /// Write the release from the caches (local, then remote) without running any stage:
    /// after `build --shard K/N` on every shard.
    Assemble(build::AssembleArgs),
    /// Check a release folder against its release.json: hashes, sizes, package validity.
    Verify(build::VerifyArgs),
    /// Write the HTML build report of an output folder again, without rebuilding.
    Report(build::ReportArgs),
    /// Draw a package with the wgpu runtime renderer beside its mesh and the difference.
    Preview(preview::Args),
    /// Compress a PNG into a KTX2 texture (BC1 albedo, BC4, BC5 normals).
    CompressTexture(compress::Args),
    /// Print the ORI paper's Table 1 for a model (1-4 closest and best:M selection) and the
    /// held-out figures.
    EvalTable(eval_table::Args),
    /// Bake every rival impostor technique and the ORI at one byte budget and compare them at
    /// the held-out directions.
    Compare(compare::Args),
    /// Write a commented pipeline.toml (every key with its default) into the current folder.
    Init(init::Args),
    /// Run a BuildGrid farm's actions on this machine (a bot of its Bots service).
    ReapiWorker(worker::Args),
    /// Run one job from a folder with its description and inputs (a remote worker's command).
    #[command(hide = true)]
    RunAction(action::Args),
}

impl Command {
    pub fn run(self) -> ExitCode {
        match self {
            Command::Build(args) => build::build(args),
            Command::Assemble(args) => build::assemble(args),
            Command::Verify(args) => build::verify(args),
            Command::Report(args) => build::report(args),
            Command::Preview(args) => preview::run(args),
            Command::CompressTexture(args) => compress::run(args),
            Command::EvalTable(args) => eval_table::run(args),
            Command::Compare(args) => compare::run(args),
            Command::Init(args) => init::run(args),
            Command::RunAction(args) => action::run(args),
            Command::ReapiWorker(args) => worker::run(args),
        }
    }
}
