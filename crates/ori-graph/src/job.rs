//! Jobs and the graph that connects them.

use std::path::PathBuf;
use std::sync::Arc;

use crate::stage::Stage;

/// Index of a job in its [`Graph`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct JobId(pub usize);

/// Where one input of a job comes from.
#[derive(Clone, Debug)]
pub enum Input {
    /// A file on disk, identified by its content hash. Files the stage discovers while running
    /// (`JobContext::read_discovered`) are resolved relative to this file's folder.
    Source(PathBuf),
    /// A file on disk the stage identifies by its content hash only
    /// (`JobContext::input_hash`) and never reads: a job with no other file input can run
    /// where the file is not.
    Hashed(PathBuf),
    /// A named output of an earlier job.
    Output { job: JobId, name: String },
}

/// A job: a stage applied to named inputs with canonical parameters, for one asset.
#[derive(Clone)]
pub struct JobSpec {
    /// The asset the job belongs to (its path relative to the assets folder); with the stage
    /// name it identifies "the same job" across builds, for `--explain`.
    pub asset: String,
    pub stage: Arc<dyn Stage>,
    /// Parameters; hashed in canonical form (sorted keys), so field order does not matter.
    pub params: serde_json::Value,
    /// Named inputs, in a fixed order (the order is part of the key).
    pub inputs: Vec<(String, Input)>,
}

/// A directed acyclic graph of jobs. Acyclic by construction: a job may only take outputs of
/// jobs added before it.
#[derive(Default)]
pub struct Graph {
    pub(crate) jobs: Vec<JobSpec>,
}

impl Graph {
    pub fn new() -> Graph {
        Graph::default()
    }

    /// Add a job and return its id.
    ///
    /// # Panics
    /// If an input names a job that is not yet in the graph (a programming error in the
    /// caller, not a user error).
    pub fn add(&mut self, job: JobSpec) -> JobId {
        let id = JobId(self.jobs.len());
        for (_, input) in &job.inputs {
            if let Input::Output { job: dep, .. } = input {
                assert!(dep.0 < id.0, "job input refers to a later job");
            }
        }
        self.jobs.push(job);
        id
    }

    /// The job with this id.
    pub fn job(&self, id: JobId) -> &JobSpec {
        &self.jobs[id.0]
    }

    /// All jobs, in insertion order.
    pub fn jobs(&self) -> impl Iterator<Item = (JobId, &JobSpec)> {
        self.jobs.iter().enumerate().map(|(i, j)| (JobId(i), j))
    }

    pub fn len(&self) -> usize {
        self.jobs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.jobs.is_empty()
    }

    /// Stage names in first-appearance order.
    pub fn stage_names(&self) -> Vec<&'static str> {
        let mut names: Vec<&'static str> = Vec::new();
        for job in &self.jobs {
            if !names.contains(&job.stage.name()) {
                names.push(job.stage.name());
            }
        }
        names
    }
}
