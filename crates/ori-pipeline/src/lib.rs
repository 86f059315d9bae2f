//! The asset pipeline: `pipeline.toml`, the assets it names, and the stages wired into the
//! build graph. `cargo xtask build-assets` is a thin command line over [`build_assets`].
//!
//! A build, in order (each step one module):
//!
//! 1. [`config`]: read `pipeline.toml`; every asset's stage parameters (overrides applied).
//! 2. [`discover`]: the assets under the root; [`shard`]: one part of them (`--shard K/N`).
//! 3. [`search`]: decide what the plan depends on measurements for (`auto` resolutions,
//!    hierarchy shapes), by trial runs through the graph.
//! 4. [`plan`]: the jobs of every asset, each a stage from the registry in [`stages`] (one
//!    file per stage: its parameters, its artifacts, its `run`).
//! 5. [`runs`]: run the graph (`ori_graph`) with the build's cache and observer.
//! 6. [`report`]: `report.json` and the packages from the finished run; [`release`]: the
//!    release folder; [`gate`]: what each asset misses of `[gate]`; [`outputs`]: `--explode`
//!    and `--dump-maps`; [`summary`]: the table printed at the end.
//!
//! [`ori`] is the chain of steps that makes one ORI from a mesh (views, place, bake, select,
//! plt); the stages run it one cached step per job, `eval-table` and the benches whole.
//!
//! [`build`] strings them together for each [`Mode`]. Data flows one way: model file ->
//! ingest (canonical mesh) -> later stages; no module here reads back a later one's output
//! except through the graph.

pub mod action;
pub mod build;
pub mod config;
pub mod discover;
pub mod gate;
pub mod gpu_select;
pub mod hierarchy;
pub mod ori;
pub mod outputs;
pub mod plan;
pub mod release;
pub mod report;
pub mod runs;
pub mod search;
pub mod shard;
pub mod stages;
pub mod summary;
pub mod unchanged;

use std::path::{Path, PathBuf};

pub use build::{BuildOptions, Mode, build_assets};
pub use config::Config;
pub use discover::{Asset, discover};
pub use summary::{BuildSummary, WrittenRelease, format_summary};

/// Errors that stop a build before or after its jobs run. Job failures are not errors here:
/// they are reported per job and counted in [`BuildSummary`].
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("{}: {message}", path.display())]
    Config { path: PathBuf, message: String },
    #[error("{0}")]
    Assets(String),
    #[error("{}: {message}", path.display())]
    Output { path: PathBuf, message: String },
    /// `assemble` found assets whose results are not all in the cache (one line each:
    /// the asset and what is missing).
    #[error(
        "{} asset(s) not fully in the cache (build them first, e.g. with `build-assets --shard K/N`); no release written:\n  {}",
        .0.len(),
        .0.join("\n  ")
    )]
    NotCached(Vec<String>),
}

/// The default configuration file name.
pub fn default_config() -> &'static Path {
    Path::new("pipeline.toml")
}
