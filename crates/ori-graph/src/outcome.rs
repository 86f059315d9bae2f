//! What happened to each job of a run, and the observer told about it as it happens.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

use crate::cache::{BlobRef, DiscoveredFile};
use crate::job::{Graph, JobSpec};

/// Why a job had to run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RunReason {
    /// No earlier run of this (asset, stage) is known to this cache.
    NewJob,
    /// The stage's version changed since the last run.
    StageVersion { from: u32, to: u32 },
    /// Parameters changed: one `path: old -> new` line each.
    Params(Vec<String>),
    /// The content of these inputs changed.
    Inputs(Vec<String>),
    /// A file the stage read last time changed, appeared or disappeared.
    Discovered(String),
    /// The cached result failed verification.
    CorruptEntry(String),
    /// Same key as the last run, but the cache no longer holds its result.
    EntryMissing,
    /// Dry run only: an upstream job would run, so this one's inputs are not known yet.
    UpstreamWouldRun,
}

impl fmt::Display for RunReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunReason::NewJob => f.write_str("new job (never built with this cache)"),
            RunReason::StageVersion { from, to } => {
                write!(f, "stage version bumped from {from} to {to}")
            }
            RunReason::Params(changes) => write!(f, "parameters changed: {}", changes.join(", ")),
            RunReason::Inputs(names) => write!(f, "new input: {} changed", names.join(", ")),
            RunReason::Discovered(what) => f.write_str(what),
            RunReason::CorruptEntry(what) => write!(f, "corrupt cache entry: {what}"),
            RunReason::EntryMissing => f.write_str("result no longer in the cache"),
            RunReason::UpstreamWouldRun => f.write_str("an upstream job would run"),
        }
    }
}

/// What happened to a job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Its result was already in the cache.
    Reused,
    /// It ran, for this reason.
    Ran(RunReason),
    /// Dry run: it would run, for this reason.
    WouldRun(RunReason),
    /// It failed with this message.
    Failed(String),
    /// Not attempted because an upstream job failed.
    Skipped,
    /// A cached-only run found no result for it, locally or remotely.
    NotCached,
}

/// The result of one job.
#[derive(Clone, Debug)]
pub struct JobResult {
    pub outcome: Outcome,
    /// Named outputs (empty unless reused or ran).
    pub outputs: BTreeMap<String, BlobRef>,
    /// Warnings the stage printed (replayed from the cache when reused).
    pub warnings: Vec<String>,
    /// Files the stage read besides its inputs (empty unless reused or ran).
    pub discovered: Vec<DiscoveredFile>,
    /// Time spent running the stage (zero when reused).
    pub duration: Duration,
    /// Whether it ran on the remote executor.
    pub ran_remotely: bool,
}

impl JobResult {
    pub(crate) fn without_outputs(outcome: Outcome) -> JobResult {
        JobResult {
            outcome,
            outputs: BTreeMap::new(),
            warnings: Vec::new(),
            discovered: Vec::new(),
            duration: Duration::ZERO,
            ran_remotely: false,
        }
    }
}

/// Told about progress; implementations must be cheap and thread-safe.
pub trait Observer: Sync {
    /// A run of `graph` starts (a build may run several graphs, one after the other).
    fn run_started(&self, _graph: &Graph) {}
    /// The run started last has finished every job.
    fn run_finished(&self) {}
    fn job_started(&self, _job: &JobSpec) {}
    fn job_finished(&self, _job: &JobSpec, _result: &JobResult) {}
    /// A warning the user should see that belongs to no single job outcome (the message
    /// starts with `warning: `).
    fn note(&self, _message: &str) {}
    /// The caller knew, without looking its jobs up, that `asset`'s results are those of an
    /// earlier build: its jobs (of these stages) count as reused and are in no graph.
    fn asset_unchanged(&self, _asset: &str, _stages: &[String]) {}
}

/// An observer that ignores everything.
pub struct Silent;
impl Observer for Silent {}
