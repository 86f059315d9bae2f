//! A stage, what it sees while it runs ([`JobContext`]) and how it fails.

use std::collections::BTreeMap;
use std::fmt;
use std::io;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use crate::cache::DiscoveredFile;
use crate::hash::ContentHash;

/// One step of the pipeline, a pure function of its inputs and parameters.
///
/// Implementations live in the crates that own the step; the graph only needs this trait, so
/// a new stage plugs in without touching this crate.
pub trait Stage: Send + Sync {
    /// Stable name; part of every job key and shown in progress and summaries.
    fn name(&self) -> &'static str;
    /// Bump whenever the stage's outputs for the same inputs change (a fixed bug, a new field):
    /// every job of the stage then re-runs.
    fn version(&self) -> u32;
    /// Read inputs from `ctx`, compute, and store named outputs with [`JobContext::output`].
    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError>;
}

/// Why a job failed, by whose fix it needs. Messages name the problem only: the runner adds
/// the asset once ([`StageError::in_job`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StageError {
    /// The asset cannot make this step's output (a degenerate mesh, a limit, a table that
    /// cannot be written): the user changes the asset or its parameters.
    Asset(String),
    /// A file the job read is unreadable, malformed or changed under it; `path` names it.
    File { path: PathBuf, problem: String },
    /// The job's parameters are not valid for its stage.
    Params(String),
    /// An input from an earlier job could not be read, regenerated or decoded.
    Input { name: String, problem: String },
    /// The job was wired wrongly (an input or output it needs does not exist): a bug.
    Plan(String),
    /// The stage panicked (caught by the runner): a bug.
    Panic { stage: &'static str, what: String },
}

impl StageError {
    pub fn asset(problem: impl fmt::Display) -> StageError {
        StageError::Asset(problem.to_string())
    }

    pub fn file(path: impl Into<PathBuf>, problem: impl fmt::Display) -> StageError {
        StageError::File {
            path: path.into(),
            problem: problem.to_string(),
        }
    }

    pub fn input(name: impl Into<String>, problem: impl fmt::Display) -> StageError {
        StageError::Input {
            name: name.into(),
            problem: problem.to_string(),
        }
    }

    /// The message for the user about a job of `asset` whose own files are `sources`: the
    /// error, after the asset's name unless it already names one of the asset's own files.
    pub fn in_job<'a>(&self, asset: &str, mut sources: impl Iterator<Item = &'a Path>) -> String {
        match self {
            StageError::File { path, .. } if sources.any(|s| s == path) => self.to_string(),
            StageError::Panic { stage, what } => {
                format!(
                    "internal error in stage `{stage}` for {asset}: {what} (please report this)"
                )
            }
            _ => format!("{asset}: {self}"),
        }
    }
}

impl fmt::Display for StageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StageError::Asset(problem) => f.write_str(problem),
            StageError::File { path, problem } => write!(f, "{}: {problem}", path.display()),
            StageError::Params(problem) => write!(f, "bad parameters: {problem}"),
            StageError::Input { name, problem } => write!(f, "input `{name}`: {problem}"),
            StageError::Plan(problem) => {
                write!(f, "{problem} (a bug in the plan; please report it)")
            }
            StageError::Panic { stage, what } => {
                write!(
                    f,
                    "internal error in stage `{stage}`: {what} (please report this)"
                )
            }
        }
    }
}

impl std::error::Error for StageError {}

/// Run `stage` in `ctx`; a panic in the stage becomes [`StageError::Panic`].
pub(crate) fn run_catching(stage: &dyn Stage, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
    match catch_unwind(AssertUnwindSafe(|| stage.run(ctx))) {
        Ok(ran) => ran,
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(StageError::Panic {
                stage: stage.name(),
                what,
            })
        }
    }
}

/// Where a running job's inputs come from (the scheduler, or an action's folder): reads
/// verified against the hashes its key was computed from, and reads of discovered files
/// (relative to the folder of the job's source file) under the run's source rules.
pub(crate) trait JobInputs {
    fn source_path(&self, name: &str) -> Option<&Path>;
    fn input_hash(&self, name: &str) -> Option<ContentHash>;
    fn input(&self, name: &str) -> Result<Vec<u8>, StageError>;
    fn read_discovered(&self, relative: &str) -> io::Result<Vec<u8>>;
    /// Discovered files the stage may read next ([`JobContext::will_read`]).
    fn will_read(&self, relatives: &[String]) {
        let _ = relatives;
    }
}

/// What a stage left when it finished: its outputs, the files it discovered, its warnings.
pub(crate) struct JobLeft {
    pub outputs: BTreeMap<String, Vec<u8>>,
    pub discovered: Vec<DiscoveredFile>,
    pub warnings: Vec<String>,
}

/// What a running stage sees: its parameters, its inputs, and where to put its outputs.
pub struct JobContext<'a> {
    asset: &'a str,
    params: &'a serde_json::Value,
    inputs: &'a dyn JobInputs,
    left: JobLeft,
}

impl<'a> JobContext<'a> {
    pub(crate) fn new(
        asset: &'a str,
        params: &'a serde_json::Value,
        inputs: &'a dyn JobInputs,
    ) -> JobContext<'a> {
        JobContext {
            asset,
            params,
            inputs,
            left: JobLeft {
                outputs: BTreeMap::new(),
                discovered: Vec::new(),
                warnings: Vec::new(),
            },
        }
    }

    pub(crate) fn finish(self) -> JobLeft {
        self.left
    }

    /// The asset this job belongs to.
    pub fn asset(&self) -> &str {
        self.asset
    }

    /// The job's parameters.
    pub fn params(&self) -> &serde_json::Value {
        self.params
    }

    /// The path of a source input, for messages and format detection.
    pub fn source_path(&self, name: &str) -> Option<&Path> {
        self.inputs.source_path(name)
    }

    /// The content hash of the named input (the one its key was computed from), without
    /// reading it: for stages that record where their inputs came from.
    pub fn input_hash(&self, name: &str) -> Option<ContentHash> {
        self.inputs.input_hash(name)
    }

    /// The bytes of the named input, verified against the hash its key was computed from.
    pub fn input(&mut self, name: &str) -> Result<Vec<u8>, StageError> {
        self.inputs.input(name)
    }

    /// Read a file the stage discovered it needs (a glTF buffer, a texture), relative to the
    /// folder of the job's source file, under the run's source rules (inside the root, a
    /// regular file, within the size limit; the error names the rule broken). The read is
    /// recorded: if the file later changes, appears or disappears, the job runs again.
    pub fn read_discovered(&mut self, relative: &str) -> io::Result<Vec<u8>> {
        let result = self.inputs.read_discovered(relative);
        let hash = match &result {
            Ok(bytes) => Some(ContentHash::of(bytes)),
            Err(e) if e.kind() == io::ErrorKind::NotFound => None,
            Err(_) => return result,
        };
        let record = DiscoveredFile {
            path: relative.to_string(),
            hash,
        };
        if !self.left.discovered.contains(&record) {
            self.left.discovered.push(record);
        }
        result
    }

    /// Say which discovered files the stage may read next, before it reads any of them (a
    /// glTF's buffers and images, once its JSON is parsed). Here it changes nothing; on a
    /// remote-execution farm, a job that stops for a file that was not sent is sent these
    /// with it, so a model's files take one round instead of one each. Nothing is recorded:
    /// only what is read is.
    pub fn will_read(&mut self, relatives: &[String]) {
        self.inputs.will_read(relatives);
    }

    /// Store a named output.
    pub fn output(&mut self, name: &str, bytes: Vec<u8>) {
        self.left.outputs.insert(name.to_string(), bytes);
    }

    /// Record a warning for the user; it is replayed whenever the result is reused.
    pub fn warn(&mut self, message: impl Into<String>) {
        self.left.warnings.push(message.into());
    }
}
