//! A stage, what it sees while it runs ([`JobContext`]) and how it fails.

use std::collections::BTreeMap;
use std::fmt;
use std::io;
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

/// A stage failed; the message is shown to the user as is, so it should name the file and
/// the problem.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StageError(pub String);

impl StageError {
    pub fn new(message: impl fmt::Display) -> StageError {
        StageError(message.to_string())
    }
}

impl fmt::Display for StageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for StageError {}

/// Where a running job's inputs come from (the scheduler): reads verified against the hashes
/// its key was computed from, and reads of discovered files under the run's source rules.
pub(crate) trait JobInputs {
    fn source_path(&self, name: &str) -> Option<&Path>;
    fn input_hash(&self, name: &str) -> Option<ContentHash>;
    fn input(&self, name: &str) -> Result<Vec<u8>, StageError>;
    fn read_file(&self, path: &Path) -> io::Result<Vec<u8>>;
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
    source_dir: Option<PathBuf>,
    left: JobLeft,
}

impl<'a> JobContext<'a> {
    pub(crate) fn new(
        asset: &'a str,
        params: &'a serde_json::Value,
        inputs: &'a dyn JobInputs,
        source_dir: Option<PathBuf>,
    ) -> JobContext<'a> {
        JobContext {
            asset,
            params,
            inputs,
            source_dir,
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
        let dir = self.source_dir.as_ref().ok_or_else(|| {
            io::Error::new(io::ErrorKind::NotFound, "this job has no source folder")
        })?;
        let result = self.inputs.read_file(&dir.join(relative));
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

    /// Store a named output.
    pub fn output(&mut self, name: &str, bytes: Vec<u8>) {
        self.left.outputs.insert(name.to_string(), bytes);
    }

    /// Record a warning for the user; it is replayed whenever the result is reused.
    pub fn warn(&mut self, message: impl Into<String>) {
        self.left.warnings.push(message.into());
    }
}
