//! The content-hashed build graph.
//!
//! A job is (stage, stage version, canonical parameters, input content hashes); its key is the
//! blake3 of those ([`job_key`]). Outputs are stored by content hash in a [`Cache`]; an action
//! entry maps a key to the output hashes. A downstream job's key is made from upstream
//! *output* hashes, so an upstream job that re-runs and produces the same bytes stops the
//! cascade (early cutoff). [`run`] executes a [`Graph`] on a rayon pool; results never depend
//! on the thread count because every job is a pure function of its key. Results are kept in
//! tiers ([`ResultStore`]): the local [`Cache`] and an optional [`RemoteCache`] (filled by
//! builders in read-write mode), which a run reads and writes through [`Tiered`].

mod action;
mod cache;
mod execute;
mod hash;
mod job;
mod memo;
mod outcome;
mod remote;
mod run;
mod sources;
mod stage;
mod store;
mod tiered;

pub use action::{
    ActionJob, ActionLeft, ActionOutputs, INPUTS_DIR, JOB_FILE, LEFT_FILE, OUTPUTS_DIR, run_action,
};
pub use cache::{
    ActionEntry, BlobRef, Cache, DiscoveredFile, JobRecord, ReadError, STAT_MEMO, write_atomic,
};
pub use execute::{ExecuteError, Executor, ExecutorTimes, RemoteExecution};
pub use hash::{ContentHash, canonical_json, job_key};
pub use job::{Graph, Input, JobId, JobSpec};
pub use memo::{MEMO_SHARDS, MemoKey, MemoMap};
pub use outcome::{JobResult, Observer, Outcome, RunReason, Silent};
pub use remote::{
    Namespace, RemoteCache, RemoteDigest, RemoteError, RemoteMode, RemoteStats, RemoteStore,
};
pub use run::{Build, MAX_THREADS, RunOptions, StageSummary, run};
pub use sources::{DEFAULT_MAX_FILE_BYTES, FileVersion, RACY_WINDOW, SourceHasher, SourceRules};
pub use stage::{JobContext, Stage, StageError};
pub use store::{Lookup, ResultStore};
pub use tiered::Tiered;
