//! The stages, one file each, and the registry that the plan takes them from.
//!
//! A stage is a [`PipelineStage`]: a name, a version, a parameter type and a `run` over typed
//! inputs. [`Registered`] adapts it to the graph's untyped [`ori_graph::Stage`] (parameters
//! as canonical JSON, outputs as named blobs); the parameters are deserialised in one place
//! and each artifact is decoded by its own type ([`Artifact`]).
//!
//! Data flow of one ORI (`plan.rs` wires it):
//! ```text
//! source ─ ingest ─ mesh ┬─ views ─ plan ─ place ─ plan ─ bake ─ maps ┬─ select ─ selection ─ plt
//!                        ├──────────────────────────────────────────┘ │
//!                        │                              maps ─ compress ─ textures
//!                        │      maps, selection, plt, textures ─ package ─ package
//!                        └─ clip (a hierarchy node's mesh) ─ ... ─ hierarchy ─ package
//! ```

pub mod bake;
pub mod clip;
pub mod compress;
pub mod hierarchy;
pub mod ingest;
pub mod package;
pub mod place;
pub mod plt;
pub mod select;
pub mod views;

use std::marker::PhantomData;
use std::sync::Arc;

use ori_artifact::DecodeError;
use ori_graph::{Input, JobContext, JobId, StageError};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// One stage of the pipeline, typed.
pub trait PipelineStage: Send + Sync + 'static {
    /// Stable name; part of every job key.
    const NAME: &'static str;
    /// Bump whenever the outputs for the same inputs change: every job of the stage re-runs.
    const VERSION: u32;
    /// The job's parameters, hashed into its key as canonical JSON.
    type Params: Serialize + DeserializeOwned;
    fn run(&self, params: Self::Params, job: &mut JobContext<'_>) -> Result<(), StageError>;
}

/// A [`PipelineStage`] as the graph sees it.
pub struct Registered<S>(pub S);

impl<S: PipelineStage> ori_graph::Stage for Registered<S> {
    fn name(&self) -> &'static str {
        S::NAME
    }

    fn version(&self) -> u32 {
        S::VERSION
    }

    fn run(&self, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let params = serde_json::from_value(job.params().clone())
            .map_err(|e| StageError::Params(e.to_string()))?;
        self.0.run(params, job)
    }
}

/// A job's parameters in the form the graph hashes.
pub(crate) fn params_json<S: PipelineStage>(params: &S::Params) -> serde_json::Value {
    serde_json::to_value(params).expect("stage parameters serialise to JSON")
}

/// What flows between stages: a value with its own checked encoding.
pub trait Artifact: Sized {
    fn encode(&self) -> Vec<u8>;
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError>;
}

/// A named output (or input) of jobs, holding a `T`.
pub struct Slot<T> {
    pub name: &'static str,
    of: PhantomData<fn() -> T>,
}

impl<T> Clone for Slot<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Slot<T> {}

impl<T> Slot<T> {
    pub const fn new(name: &'static str) -> Slot<T> {
        Slot {
            name,
            of: PhantomData,
        }
    }

    /// This output of `job`, as another job's input: only from a stage that makes a `T`.
    pub fn of<S: Makes<T>>(self, job: Job<S>) -> Input {
        Input::Output {
            job: job.id,
            name: self.name.to_string(),
        }
    }

    /// This output of `job` as the input of the same name (the usual wiring).
    pub fn from<S: Makes<T>>(self, job: Job<S>) -> (&'static str, Input) {
        (self.name, self.of(job))
    }
}

/// A stage whose jobs make an output of type `T`.
pub trait Makes<T>: PipelineStage {}

/// A planned job of stage `S`. Inputs are wired from it only through the artifacts `S`
/// makes ([`Slot::of`]), so a plan that feeds a stage the wrong artifact does not compile.
pub struct Job<S> {
    pub id: JobId,
    stage: PhantomData<fn() -> S>,
}

impl<S> Job<S> {
    pub(crate) fn new(id: JobId) -> Job<S> {
        Job {
            id,
            stage: PhantomData,
        }
    }
}

impl<S> Clone for Job<S> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<S> Copy for Job<S> {}

impl<T: Artifact> Slot<T> {
    /// Read and decode this input of a running job.
    pub fn read(self, job: &mut JobContext<'_>) -> Result<T, StageError> {
        let bytes = job.input(self.name)?;
        T::decode(&bytes).map_err(|e| StageError::input(self.name, e))
    }

    /// Store this output of a running job.
    pub fn write(self, job: &mut JobContext<'_>, value: &T) {
        job.output(self.name, value.encode());
    }

    /// This output of a finished job, decoded.
    pub fn read_from(self, build: &ori_graph::Build<'_>, job: JobId) -> Result<T, String> {
        let bytes = build.read_output(job, self.name)?;
        T::decode(&bytes).map_err(|e| e.to_string())
    }
}

/// Every stage, in data-flow order: the one list of what the pipeline runs. The plan takes
/// each job's stage from here by type.
pub struct Registry {
    stages: Vec<Arc<dyn ori_graph::Stage>>,
}

impl Registry {
    /// The stages of a build whose models load within `limits`.
    pub fn new(limits: ori_mesh::Limits) -> Registry {
        Registry {
            stages: vec![
                Arc::new(Registered(ingest::Ingest { limits })),
                Arc::new(Registered(views::Views)),
                Arc::new(Registered(place::Place)),
                Arc::new(Registered(bake::Bake)),
                Arc::new(Registered(select::Select)),
                Arc::new(Registered(plt::PltStage)),
                Arc::new(Registered(compress::Compress)),
                Arc::new(Registered(package::Package)),
                Arc::new(Registered(clip::Clip)),
                Arc::new(Registered(hierarchy::Hierarchy)),
            ],
        }
    }

    /// The registered instance of stage `S`.
    ///
    /// # Panics
    /// If `S` is not in the list above (a programming error).
    pub fn get<S: PipelineStage>(&self) -> Arc<dyn ori_graph::Stage> {
        self.stages
            .iter()
            .find(|s| s.name() == S::NAME)
            .unwrap_or_else(|| panic!("stage `{}` is not registered", S::NAME))
            .clone()
    }

    /// The registered stage named `name`.
    pub fn by_name(&self, name: &str) -> Option<Arc<dyn ori_graph::Stage>> {
        self.stages.iter().find(|s| s.name() == name).cloned()
    }

    /// Every stage's name, in data-flow order.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.stages.iter().map(|s| s.name())
    }

    /// Every stage's name and version, in data-flow order.
    pub fn versions(&self) -> Vec<(&'static str, u32)> {
        self.stages
            .iter()
            .map(|s| (s.name(), s.version()))
            .collect()
    }
}
