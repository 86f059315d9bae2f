//! The scheduler: runs a [`Graph`] against a [`Cache`], in parallel, reusing what it can.

use std::collections::BTreeMap;
use std::fmt;
use std::io;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use crate::cache::{ActionEntry, BlobRef, Cache, DiscoveredFile, JobRecord, ReadError};
use crate::hash::{ContentHash, canonical_json, job_key};
use crate::job::{Graph, Input, JobId, JobSpec, StageError};
use crate::remote::RemoteCache;
use crate::sources::{SourceHasher, SourceRules};

/// How to run a graph.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Worker threads; 0 means one per core. Results never depend on it.
    pub threads: usize,
    /// Decide and report what would run, without running anything.
    pub dry_run: bool,
    /// A remote cache consulted after the local one (and filled, in read-write mode). Shared
    /// by the runs of one build, so an unavailable server is reported once.
    pub remote: Option<Arc<RemoteCache>>,
    /// Run no stage: a job whose result is in neither cache is [`Outcome::NotCached`].
    pub cached_only: bool,
    /// What every source file and every file a stage discovers must be to be read.
    pub sources: SourceRules,
}

/// The most worker threads a run starts, whatever it is asked for.
pub const MAX_THREADS: usize = 256;

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
    /// Time spent running the stage (zero when reused).
    pub duration: Duration,
}

impl JobResult {
    fn without_outputs(outcome: Outcome) -> JobResult {
        JobResult {
            outcome,
            outputs: BTreeMap::new(),
            warnings: Vec::new(),
            duration: Duration::ZERO,
        }
    }
}

/// Told about progress; implementations must be cheap and thread-safe.
pub trait Observer: Sync {
    fn job_started(&self, _job: &JobSpec) {}
    fn job_finished(&self, _job: &JobSpec, _result: &JobResult) {}
    /// Something the user should see that belongs to no single job outcome.
    fn note(&self, _message: &str) {}
}

/// An observer that ignores everything.
pub struct Silent;
impl Observer for Silent {}

/// Jobs run and reused, and time spent, for one stage.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StageSummary {
    pub stage: &'static str,
    pub ran: usize,
    pub reused: usize,
    pub would_run: usize,
    pub failed: usize,
    pub skipped: usize,
    /// Sum of the run times of its jobs (CPU-side, across threads).
    pub time: Duration,
}

/// A finished run: every job's result, and verified access to outputs.
pub struct Build<'g> {
    exec: Exec<'g>,
}

/// Run every job of `graph`, in parallel where the dependencies allow.
pub fn run<'g>(
    graph: &'g Graph,
    cache: &Cache,
    options: &RunOptions,
    observer: &'g dyn Observer,
) -> Build<'g> {
    let mut dependents = vec![Vec::new(); graph.len()];
    let pending: Vec<AtomicUsize> = graph
        .jobs
        .iter()
        .enumerate()
        .map(|(id, job)| {
            let deps: Vec<JobId> = job
                .inputs
                .iter()
                .filter_map(|(_, input)| match input {
                    Input::Output { job, .. } => Some(*job),
                    Input::Source(_) => None,
                })
                .collect();
            for dep in &deps {
                dependents[dep.0].push(JobId(id));
            }
            AtomicUsize::new(deps.len())
        })
        .collect();
    let exec = Exec {
        graph,
        cache: cache.clone(),
        sources: SourceHasher::new(cache.stat_memo_path(), options.sources.clone()),
        results: (0..graph.len()).map(|_| OnceLock::new()).collect(),
        dry_run: options.dry_run,
        cached_only: options.cached_only,
        remote: options.remote.clone(),
        observer,
    };
    if exec.sources.dropped() > 0 {
        observer.note(&format!(
            "warning: stat memo {}: {} damaged or mismatched entries dropped; those files are read again",
            cache.stat_memo_path().display(),
            exec.sources.dropped()
        ));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.min(MAX_THREADS))
        .build()
        .expect("cannot start worker threads");
    pool.scope(|scope| {
        for (id, count) in pending.iter().enumerate() {
            if count.load(Ordering::Relaxed) == 0 {
                let (exec, pending, dependents) = (&exec, &pending, &dependents);
                scope.spawn(move |s| exec.run_and_release(JobId(id), pending, dependents, s));
            }
        }
    });
    if !options.dry_run
        && let Err(e) = exec.sources.save()
    {
        observer.note(&format!(
            "warning: cannot save the stat memo {}: {e}",
            cache.stat_memo_path().display()
        ));
    }
    Build { exec }
}

impl<'g> Build<'g> {
    /// The result of a job.
    pub fn result(&self, id: JobId) -> &JobResult {
        self.exec.result(id)
    }

    /// Whether every job was reused or ran successfully.
    pub fn succeeded(&self) -> bool {
        self.exec
            .graph
            .jobs()
            .all(|(id, _)| matches!(self.result(id).outcome, Outcome::Reused | Outcome::Ran(_)))
    }

    /// Bytes of a job's output, verified against its hash. A corrupt or missing blob is
    /// regenerated by re-running the job that made it.
    pub fn read_output(&self, id: JobId, name: &str) -> Result<Vec<u8>, StageError> {
        self.exec.read_output(id, name)
    }

    /// Source files read and hashed during this build (memo misses).
    pub fn sources_rehashed(&self) -> u64 {
        self.exec.sources.rehashed()
    }

    /// Per-stage counts and times, stages in first-appearance order.
    pub fn summary(&self) -> Vec<StageSummary> {
        let graph = self.exec.graph;
        let mut summaries: Vec<StageSummary> = graph
            .stage_names()
            .into_iter()
            .map(|stage| StageSummary {
                stage,
                ..StageSummary::default()
            })
            .collect();
        for (id, job) in graph.jobs() {
            let s = summaries
                .iter_mut()
                .find(|s| s.stage == job.stage.name())
                .expect("stage listed");
            let r = self.result(id);
            s.time += r.duration;
            match r.outcome {
                Outcome::Reused => s.reused += 1,
                Outcome::Ran(_) => s.ran += 1,
                Outcome::WouldRun(_) => s.would_run += 1,
                Outcome::Failed(_) | Outcome::NotCached => s.failed += 1,
                Outcome::Skipped => s.skipped += 1,
            }
        }
        summaries
    }
}

struct Exec<'g> {
    graph: &'g Graph,
    cache: Cache,
    sources: SourceHasher,
    results: Vec<OnceLock<JobResult>>,
    dry_run: bool,
    cached_only: bool,
    remote: Option<Arc<RemoteCache>>,
    observer: &'g dyn Observer,
}

/// The identity of "the same job" across builds: asset and stage.
fn identity(job: &JobSpec) -> ContentHash {
    let mut h = blake3::Hasher::new();
    h.update(job.asset.as_bytes());
    h.update(&[0]);
    h.update(job.stage.name().as_bytes());
    ContentHash(*h.finalize().as_bytes())
}

/// The folder discovered files are resolved against: that of the job's first source input.
fn source_dir(job: &JobSpec) -> Option<&Path> {
    job.inputs.iter().find_map(|(_, input)| match input {
        Input::Source(path) => Some(path.parent().unwrap_or(Path::new(""))),
        Input::Output { .. } => None,
    })
}

impl<'g> Exec<'g> {
    fn result(&self, id: JobId) -> &JobResult {
        self.results[id.0]
            .get()
            .expect("job finished before its dependents")
    }

    fn run_and_release<'s>(
        &'s self,
        id: JobId,
        pending: &'s [AtomicUsize],
        dependents: &'s [Vec<JobId>],
        scope: &rayon::Scope<'s>,
    ) {
        let job = self.graph.job(id);
        let result = self.execute(id);
        self.observer.job_finished(job, &result);
        let _ = self.results[id.0].set(result);
        for &next in &dependents[id.0] {
            if pending[next.0].fetch_sub(1, Ordering::AcqRel) == 1 {
                scope.spawn(move |s| self.run_and_release(next, pending, dependents, s));
            }
        }
    }

    /// The content hashes of a job's inputs, or the outcome that stops it.
    fn input_hashes(&self, id: JobId) -> Result<Vec<(String, ContentHash)>, Outcome> {
        let job = self.graph.job(id);
        let mut hashes = Vec::with_capacity(job.inputs.len());
        for (name, input) in &job.inputs {
            let hash = match input {
                Input::Source(path) => match self.sources.hash(path) {
                    Ok(Some(h)) => h,
                    Ok(None) => {
                        return Err(Outcome::Failed(format!(
                            "{}: file not found",
                            path.display()
                        )));
                    }
                    Err(e) => {
                        return Err(Outcome::Failed(format!(
                            "{}: cannot read: {e}",
                            path.display()
                        )));
                    }
                },
                Input::Output {
                    job: dep,
                    name: output,
                } => {
                    let upstream = self.result(*dep);
                    match &upstream.outcome {
                        Outcome::Failed(_) | Outcome::Skipped | Outcome::NotCached => {
                            return Err(Outcome::Skipped);
                        }
                        Outcome::WouldRun(_) => {
                            return Err(Outcome::WouldRun(RunReason::UpstreamWouldRun));
                        }
                        Outcome::Reused | Outcome::Ran(_) => {}
                    }
                    match upstream.outputs.get(output) {
                        Some(blob) => blob.hash,
                        None => {
                            return Err(Outcome::Failed(format!(
                                "stage `{}` produced no output `{output}`",
                                self.graph.job(*dep).stage.name()
                            )));
                        }
                    }
                }
            };
            hashes.push((name.clone(), hash));
        }
        Ok(hashes)
    }

    fn execute(&self, id: JobId) -> JobResult {
        let job = self.graph.job(id);
        let inputs = match self.input_hashes(id) {
            Ok(h) => h,
            Err(outcome) => return JobResult::without_outputs(outcome),
        };
        let key = job_key(job.stage.name(), job.stage.version(), &job.params, &inputs);
        let reason = match self.cache.read_action(&key) {
            Ok(entry) => match self.validate(job, &entry) {
                Ok(()) => {
                    return JobResult {
                        outcome: Outcome::Reused,
                        outputs: entry.outputs,
                        warnings: entry.warnings,
                        duration: Duration::ZERO,
                    };
                }
                Err(reason) => reason,
            },
            Err(ReadError::Missing) => match self.remote_hit(job, &key, &inputs) {
                Some(entry) => {
                    return JobResult {
                        outcome: Outcome::Reused,
                        outputs: entry.outputs,
                        warnings: entry.warnings,
                        duration: Duration::ZERO,
                    };
                }
                None => self.explain_miss(job, &key, &inputs),
            },
            Err(e) => RunReason::CorruptEntry(e.to_string()),
        };
        if self.dry_run {
            return JobResult::without_outputs(Outcome::WouldRun(reason));
        }
        if self.cached_only {
            return JobResult::without_outputs(Outcome::NotCached);
        }
        self.observer.job_started(job);
        let start = Instant::now();
        let entry = match self.run_stage(id, &inputs) {
            Ok(entry) => entry,
            Err(message) => {
                let mut result = JobResult::without_outputs(Outcome::Failed(message));
                result.duration = start.elapsed();
                return result;
            }
        };
        let record = JobRecord {
            key,
            stage_version: job.stage.version(),
            params: job.params.clone(),
            inputs: inputs.iter().cloned().collect(),
        };
        let stored = self
            .cache
            .write_action(&key, &entry)
            .and_then(|()| self.cache.write_record(&identity(job), &record));
        if let Err(e) = stored {
            let message = format!(
                "cannot write to the cache {}: {e}",
                self.cache.root().display()
            );
            return JobResult::without_outputs(Outcome::Failed(message));
        }
        if let Some(remote) = &self.remote {
            remote.upload(&self.cache, &key, &entry, self.observer);
        }
        JobResult {
            outcome: Outcome::Ran(reason),
            outputs: entry.outputs,
            warnings: entry.warnings,
            duration: start.elapsed(),
        }
    }

    /// Check that a cached result is still valid: the files the stage discovered are
    /// unchanged and every output blob is present.
    fn validate(&self, job: &JobSpec, entry: &ActionEntry) -> Result<(), RunReason> {
        let dir = source_dir(job);
        for file in &entry.discovered {
            let current = match dir {
                Some(dir) => self.sources.hash(&dir.join(&file.path)).unwrap_or(None),
                None => None,
            };
            if current != file.hash {
                let what = match (file.hash, current) {
                    (None, _) => "appeared",
                    (_, None) => "disappeared",
                    _ => "changed",
                };
                return Err(RunReason::Discovered(format!(
                    "new input: referenced file `{}` {what}",
                    file.path
                )));
            }
        }
        for (name, blob) in &entry.outputs {
            if !self.cache.blob_present(blob) && !self.fetch_blob(blob) {
                self.cache.discard_blob(&blob.hash);
                return Err(RunReason::CorruptEntry(format!(
                    "output `{name}` ({}) is missing or truncated",
                    self.cache.blob_path(&blob.hash).display()
                )));
            }
        }
        Ok(())
    }

    /// Download a blob missing from the local cache from the remote one, verified.
    fn fetch_blob(&self, blob: &BlobRef) -> bool {
        !self.dry_run
            && self
                .remote
                .as_ref()
                .is_some_and(|r| r.fetch_blob(&self.cache, blob, self.observer))
    }

    /// The remote cache's result for a job missing from the local cache: its entry, checked
    /// like a local one (discovered files unchanged, every output blob downloaded and
    /// verified), then stored locally. A dry run only checks the entry and writes nothing.
    fn remote_hit(
        &self,
        job: &JobSpec,
        key: &ContentHash,
        inputs: &[(String, ContentHash)],
    ) -> Option<ActionEntry> {
        let remote = self.remote.as_ref()?;
        let entry = remote.fetch_action(key, self.observer)?;
        if entry.stage != job.stage.name() {
            self.observer.note(&format!(
                "warning: remote cache {}: action entry {} is for stage `{}`, not `{}`; not used",
                remote.describe(),
                key.short(),
                entry.stage,
                job.stage.name()
            ));
            return None;
        }
        if self.dry_run {
            let dir = source_dir(job);
            let unchanged = entry.discovered.iter().all(|file| {
                dir.and_then(|d| self.sources.hash(&d.join(&file.path)).unwrap_or(None))
                    == file.hash
            });
            return unchanged.then_some(entry);
        }
        self.validate(job, &entry).ok()?;
        let record = JobRecord {
            key: *key,
            stage_version: job.stage.version(),
            params: job.params.clone(),
            inputs: inputs.iter().cloned().collect(),
        };
        let stored = self
            .cache
            .write_action(key, &entry)
            .and_then(|()| self.cache.write_record(&identity(job), &record));
        if let Err(e) = stored {
            self.observer.note(&format!(
                "warning: cannot write to the cache {}: {e}",
                self.cache.root().display()
            ));
        }
        Some(entry)
    }

    /// Why a job whose key is not in the cache must run, by comparison with its last run.
    fn explain_miss(
        &self,
        job: &JobSpec,
        key: &ContentHash,
        inputs: &[(String, ContentHash)],
    ) -> RunReason {
        let Some(last) = self.cache.read_record(&identity(job)) else {
            return RunReason::NewJob;
        };
        if last.key == *key {
            return RunReason::EntryMissing;
        }
        if last.stage_version != job.stage.version() {
            return RunReason::StageVersion {
                from: last.stage_version,
                to: job.stage.version(),
            };
        }
        let changes = param_changes(&last.params, &job.params);
        if !changes.is_empty() {
            return RunReason::Params(changes);
        }
        let changed: Vec<String> = inputs
            .iter()
            .filter(|(name, hash)| last.inputs.get(name) != Some(hash))
            .map(|(name, _)| name.clone())
            .collect();
        RunReason::Inputs(changed)
    }

    /// Run a job's stage and store its outputs; panics in a stage become failures.
    fn run_stage(
        &self,
        id: JobId,
        inputs: &[(String, ContentHash)],
    ) -> Result<ActionEntry, String> {
        let job = self.graph.job(id);
        let mut ctx = JobContext {
            exec: self,
            id,
            inputs,
            source_dir: source_dir(job).map(Path::to_path_buf),
            outputs: BTreeMap::new(),
            discovered: Vec::new(),
            warnings: Vec::new(),
        };
        let ran = catch_unwind(AssertUnwindSafe(|| job.stage.run(&mut ctx)));
        match ran {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(e.0),
            Err(panic) => {
                let what = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                return Err(format!(
                    "internal error in stage `{}` for {}: {what} (please report this)",
                    job.stage.name(),
                    job.asset
                ));
            }
        }
        let mut outputs = BTreeMap::new();
        for (name, bytes) in ctx.outputs {
            let blob = self.cache.put_blob(&bytes).map_err(|e| {
                format!(
                    "cannot write to the cache {}: {e}",
                    self.cache.root().display()
                )
            })?;
            outputs.insert(name, blob);
        }
        Ok(ActionEntry {
            stage: job.stage.name().to_string(),
            outputs,
            discovered: ctx.discovered,
            warnings: ctx.warnings,
        })
    }

    fn read_output(&self, id: JobId, name: &str) -> Result<Vec<u8>, StageError> {
        let job = self.graph.job(id);
        let result = self.result(id);
        let blob = result.outputs.get(name).ok_or_else(|| {
            StageError(format!(
                "{}: stage `{}` has no output `{name}`",
                job.asset,
                job.stage.name()
            ))
        })?;
        match self.cache.read_blob(blob) {
            Ok(bytes) => return Ok(bytes),
            Err(ReadError::Io { path, error }) => {
                return Err(StageError(format!(
                    "cannot read {}: {error}",
                    path.display()
                )));
            }
            Err(damage) => {
                if self.fetch_blob(blob)
                    && let Ok(bytes) = self.cache.read_blob(blob)
                {
                    return Ok(bytes);
                }
                if self.cached_only || self.dry_run {
                    return Err(StageError(format!(
                        "{}: output `{name}` of stage `{}` is not in the local cache ({damage})",
                        job.asset,
                        job.stage.name()
                    )));
                }
                self.observer.note(&format!(
                    "warning: {}: {damage}; re-running stage `{}` to regenerate it",
                    job.asset,
                    job.stage.name()
                ));
            }
        }
        // Regenerate: the same inputs must give the same bytes, which keeps every
        // downstream key valid.
        let inputs = self.input_hashes(id).map_err(|outcome| {
            StageError(format!("{}: cannot regenerate: {outcome:?}", job.asset))
        })?;
        let entry = self.run_stage(id, &inputs).map_err(StageError)?;
        if entry.outputs != result.outputs {
            return Err(StageError(format!(
                "{}: stage `{}` is not deterministic: re-running it gave different outputs",
                job.asset,
                job.stage.name()
            )));
        }
        self.cache
            .read_blob(blob)
            .map_err(|e| StageError(e.to_string()))
    }
}

/// Every leaf value that differs between two parameter sets, as `path: old -> new`.
fn param_changes(old: &serde_json::Value, new: &serde_json::Value) -> Vec<String> {
    fn flatten(prefix: &str, v: &serde_json::Value, out: &mut BTreeMap<String, String>) {
        match v {
            serde_json::Value::Object(map) => {
                for (k, v) in map {
                    let path = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    flatten(&path, v, out);
                }
            }
            leaf => {
                out.insert(prefix.to_string(), canonical_json(leaf));
            }
        }
    }
    let (mut a, mut b) = (BTreeMap::new(), BTreeMap::new());
    flatten("", old, &mut a);
    flatten("", new, &mut b);
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            let show = |v: Option<&String>| v.cloned().unwrap_or_else(|| "(unset)".into());
            format!("{k}: {} -> {}", show(a.get(k)), show(b.get(k)))
        })
        .collect()
}

/// What a running stage sees: its parameters, its inputs, and where to put its outputs.
pub struct JobContext<'a> {
    exec: &'a Exec<'a>,
    id: JobId,
    inputs: &'a [(String, ContentHash)],
    source_dir: Option<PathBuf>,
    outputs: BTreeMap<String, Vec<u8>>,
    discovered: Vec<DiscoveredFile>,
    warnings: Vec<String>,
}

impl JobContext<'_> {
    fn job(&self) -> &JobSpec {
        self.exec.graph.job(self.id)
    }

    /// The asset this job belongs to.
    pub fn asset(&self) -> &str {
        &self.job().asset
    }

    /// The job's parameters.
    pub fn params(&self) -> &serde_json::Value {
        &self.job().params
    }

    /// The path of a source input, for messages and format detection.
    pub fn source_path(&self, name: &str) -> Option<&Path> {
        self.job().inputs.iter().find_map(|(n, input)| match input {
            Input::Source(path) if n == name => Some(path.as_path()),
            _ => None,
        })
    }

    /// The content hash of the named input (the one its key was computed from), without
    /// reading it: for stages that record where their inputs came from.
    pub fn input_hash(&self, name: &str) -> Option<ContentHash> {
        let job = self.exec.graph.job(self.id);
        let position = job.inputs.iter().position(|(n, _)| n == name)?;
        Some(self.inputs[position].1)
    }

    /// The bytes of the named input, verified against the hash its key was computed from.
    pub fn input(&mut self, name: &str) -> Result<Vec<u8>, StageError> {
        let job = self.exec.graph.job(self.id);
        let position = job.inputs.iter().position(|(n, _)| n == name);
        let Some(position) = position else {
            return Err(StageError(format!(
                "stage `{}` has no input `{name}`",
                job.stage.name()
            )));
        };
        let expected = self.inputs[position].1;
        match &job.inputs[position].1 {
            Input::Source(path) => {
                let bytes = self
                    .exec
                    .sources
                    .read(path)
                    .map_err(|e| StageError(format!("{}: cannot read: {e}", path.display())))?;
                if ContentHash::of(&bytes) != expected {
                    // Whether the memo was wrong or the file really changed, the next build
                    // must read it.
                    self.exec.sources.forget(path);
                    return Err(StageError(format!(
                        "{}: the file changed during the build; run the build again",
                        path.display()
                    )));
                }
                Ok(bytes)
            }
            Input::Output { job, name } => self.exec.read_output(*job, name),
        }
    }

    /// Read a file the stage discovered it needs (a glTF buffer, a texture), relative to the
    /// folder of the job's source file, under the run's [`SourceRules`] (inside the root, a
    /// regular file, within the size limit; the error names the rule broken). The read is
    /// recorded: if the file later changes, appears or disappears, the job runs again.
    pub fn read_discovered(&mut self, relative: &str) -> io::Result<Vec<u8>> {
        let dir = self.source_dir.as_ref().ok_or_else(|| {
            io::Error::new(io::ErrorKind::NotFound, "this job has no source folder")
        })?;
        let result = self.exec.sources.read(&dir.join(relative));
        let hash = match &result {
            Ok(bytes) => Some(ContentHash::of(bytes)),
            Err(e) if e.kind() == io::ErrorKind::NotFound => None,
            Err(_) => return result,
        };
        let record = DiscoveredFile {
            path: relative.to_string(),
            hash,
        };
        if !self.discovered.contains(&record) {
            self.discovered.push(record);
        }
        result
    }

    /// Store a named output.
    pub fn output(&mut self, name: &str, bytes: Vec<u8>) {
        self.outputs.insert(name.to_string(), bytes);
    }

    /// Record a warning for the user; it is replayed whenever the result is reused.
    pub fn warn(&mut self, message: impl Into<String>) {
        self.warnings.push(message.into());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn param_changes_name_each_leaf() {
        let old = json!({"ingest": {"recompute_normals": false}, "bake": {"n": 20}});
        let new = json!({"ingest": {"recompute_normals": true}, "bake": {"n": 20, "m": 1}});
        assert_eq!(
            param_changes(&old, &new),
            vec![
                "bake.m: (unset) -> 1",
                "ingest.recompute_normals: false -> true"
            ]
        );
    }
}
