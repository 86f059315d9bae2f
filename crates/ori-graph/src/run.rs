//! The scheduler: runs a [`Graph`] against a [`Cache`], in parallel, reusing what it can.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::io;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use crate::action::{ActionJob, ActionOutputs, MAX_ACTION_FILES};
use crate::cache::{ActionEntry, Cache, JobRecord, ReadError};
use crate::execute::RemoteExecution;
use crate::hash::{ContentHash, canonical_json, job_key};
use crate::job::{Graph, Input, JobId, JobSpec};
use crate::outcome::{JobResult, Observer, Outcome, RunReason};
use crate::remote::RemoteCache;
use crate::sources::{SourceHasher, SourceRules};
use crate::stage::{JobContext, JobInputs, StageError, run_catching};
use crate::store::Lookup;
use crate::tiered::Tiered;

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
    /// The source hasher shared by the runs of one build and whatever else it hashes sources
    /// for (its stat memo loaded once; its own rules apply). `None`: the run loads the stat
    /// memo itself, with the rules above.
    pub shared_sources: Option<Arc<SourceHasher>>,
    /// Where jobs that are actions run instead of here (remote execution); shared by the runs
    /// of one build, so an executor that goes away is reported once. The run adds its
    /// `max_in_flight` threads to `threads`, for jobs waiting on it.
    pub execution: Option<Arc<RemoteExecution>>,
}

/// The most worker threads a run starts, whatever it is asked for.
pub const MAX_THREADS: usize = 256;
/// The most times a job is sent to the remote executor for the files its stage discovers
/// (a glTF's files are asked for together, an OBJ's libraries and then each one's textures).
const MAX_ACTION_ROUNDS: usize = 32;

/// Jobs run and reused, and time spent, for one stage.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StageSummary {
    pub stage: &'static str,
    pub ran: usize,
    /// Of those that ran, the ones that ran on the remote executor.
    pub remote: usize,
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
                    Input::Source(_) | Input::Hashed(_) => None,
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
        store: Tiered::new(cache.clone(), options.remote.clone(), !options.dry_run),
        sources: options.shared_sources.clone().unwrap_or_else(|| {
            Arc::new(SourceHasher::new(
                cache.stat_memo_path(),
                options.sources.clone(),
            ))
        }),
        results: (0..graph.len()).map(|_| OnceLock::new()).collect(),
        dry_run: options.dry_run,
        cached_only: options.cached_only,
        fetch_lazily: options.remote.as_ref().map(|_| outputs_read_later(graph)),
        execution: options.execution.clone(),
        observer,
    };
    observer.run_started(graph);
    // A shared hasher's damage is its owner's to report, once.
    if options.shared_sources.is_none()
        && let Some(warning) = exec.sources.damage_warning()
    {
        observer.note(&warning);
    }
    let threads = match &options.execution {
        Some(remote) => {
            let here = match options.threads {
                0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
                n => n,
            };
            here + remote.max_in_flight()
        }
        None => options.threads,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.min(MAX_THREADS))
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
    observer.run_finished();
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
    /// regenerated by re-running the job that made it. The error names the job's asset.
    pub fn read_output(&self, id: JobId, name: &str) -> Result<Vec<u8>, String> {
        let job = self.exec.graph.job(id);
        self.exec
            .read_output(id, name)
            .map_err(|e| e.in_job(&job.asset, source_paths(job)))
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
                Outcome::Ran(_) => {
                    s.ran += 1;
                    s.remote += usize::from(r.ran_remotely);
                }
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
    store: Tiered,
    sources: Arc<SourceHasher>,
    results: Vec<OnceLock<JobResult>>,
    dry_run: bool,
    cached_only: bool,
    /// With a remote tier: per job, the outputs that later jobs of this graph read. A hit
    /// does not fetch them; the job that reads one fetches it (or, failing that, makes it
    /// again) when it runs, so a hit whose dependents are hits too moves no bytes.
    fetch_lazily: Option<Vec<HashSet<String>>>,
    execution: Option<Arc<RemoteExecution>>,
    observer: &'g dyn Observer,
}

/// Per job, the names of its outputs that later jobs of `graph` read.
fn outputs_read_later(graph: &Graph) -> Vec<HashSet<String>> {
    let mut read_later = vec![HashSet::new(); graph.len()];
    for job in &graph.jobs {
        for (_, input) in &job.inputs {
            if let Input::Output { job, name } = input {
                read_later[job.0].insert(name.clone());
            }
        }
    }
    read_later
}

/// The identity of "the same job" across builds: asset and stage.
fn identity(job: &JobSpec) -> ContentHash {
    let mut h = blake3::Hasher::new();
    h.update(job.asset.as_bytes());
    h.update(&[0]);
    h.update(job.stage.name().as_bytes());
    ContentHash(*h.finalize().as_bytes())
}

/// The job's source files (the asset's own files, which name it in messages).
fn source_paths(job: &JobSpec) -> impl Iterator<Item = &Path> {
    job.inputs.iter().filter_map(|(_, input)| match input {
        Input::Source(path) | Input::Hashed(path) => Some(path.as_path()),
        Input::Output { .. } => None,
    })
}

/// The folder discovered files are resolved against: that of the job's first source input.
fn source_dir(job: &JobSpec) -> Option<&Path> {
    job.inputs.iter().find_map(|(_, input)| match input {
        Input::Source(path) => Some(path.parent().unwrap_or(Path::new(""))),
        Input::Hashed(_) | Input::Output { .. } => None,
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
                Input::Source(path) | Input::Hashed(path) => match self.sources.hash(path) {
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
        let reason = match self.store.local_action(&key, self.observer) {
            Lookup::Found(entry) => match self.validate(id, &entry) {
                Ok(()) => {
                    return JobResult {
                        outcome: Outcome::Reused,
                        outputs: entry.outputs,
                        warnings: entry.warnings,
                        discovered: entry.discovered,
                        duration: Duration::ZERO,
                        ran_remotely: false,
                    };
                }
                Err(reason) => reason,
            },
            Lookup::Missing => match self.remote_hit(id, &key, &inputs) {
                Some(entry) => {
                    return JobResult {
                        outcome: Outcome::Reused,
                        outputs: entry.outputs,
                        warnings: entry.warnings,
                        discovered: entry.discovered,
                        duration: Duration::ZERO,
                        ran_remotely: false,
                    };
                }
                None => self.explain_miss(job, &key, &inputs),
            },
            Lookup::Damaged(why) => RunReason::CorruptEntry(why),
        };
        if self.dry_run {
            return JobResult::without_outputs(Outcome::WouldRun(reason));
        }
        if self.cached_only {
            return JobResult::without_outputs(Outcome::NotCached);
        }
        self.observer.job_started(job);
        let start = Instant::now();
        let (entry, ran_remotely) = match self.run_stage(id, &inputs) {
            Ok(ran) => ran,
            Err(e) => {
                let message = e.in_job(&job.asset, source_paths(job));
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
        let local = self.store.local();
        let stored = local
            .write_record(&identity(job), &record)
            .map_err(|e| format!("cannot write to the cache {}: {e}", local.root().display()))
            .and_then(|()| self.store.keep(&key, &entry, self.observer));
        if let Err(message) = stored {
            return JobResult::without_outputs(Outcome::Failed(message));
        }
        JobResult {
            outcome: Outcome::Ran(reason),
            outputs: entry.outputs,
            warnings: entry.warnings,
            discovered: entry.discovered,
            duration: start.elapsed(),
            ran_remotely,
        }
    }

    /// Check that a cached result is still valid: the files the stage discovered are
    /// unchanged and every output blob is present (fetched from the remote tier if need be),
    /// but for the outputs fetched lazily.
    fn validate(&self, id: JobId, entry: &ActionEntry) -> Result<(), RunReason> {
        let job = self.graph.job(id);
        // What a lazily fetched output is called on the server, for the job that reads it.
        self.store.learn_remote_names(entry);
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
        let lazy = self.fetch_lazily.as_ref().map(|outputs| &outputs[id.0]);
        for (name, blob) in &entry.outputs {
            if lazy.is_some_and(|lazy| lazy.contains(name)) {
                continue;
            }
            if !self.store.ensure_blob(blob, self.observer) {
                return Err(RunReason::CorruptEntry(format!(
                    "output `{name}` ({}) is missing or truncated",
                    self.store.local().blob_path(&blob.hash).display()
                )));
            }
        }
        Ok(())
    }

    /// The remote cache's result for a job missing from the local cache: its entry, checked
    /// like a local one (discovered files unchanged, every output blob that is not fetched
    /// lazily downloaded and verified), then stored locally. A dry run only checks the entry
    /// and writes nothing.
    fn remote_hit(
        &self,
        id: JobId,
        key: &ContentHash,
        inputs: &[(String, ContentHash)],
    ) -> Option<ActionEntry> {
        let job = self.graph.job(id);
        let (entry, remote) = self.store.remote_action(key, self.observer)?;
        if entry.stage != job.stage.name() {
            self.observer.note(&format!(
                "warning: remote cache {remote}: action entry {} is for stage `{}`, not `{}`; not used",
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
        self.validate(id, &entry).ok()?;
        let record = JobRecord {
            key: *key,
            stage_version: job.stage.version(),
            params: job.params.clone(),
            inputs: inputs.iter().cloned().collect(),
        };
        let local = self.store.local();
        let stored = self.store.adopt(key, &entry, self.observer).and_then(|()| {
            local
                .write_record(&identity(job), &record)
                .map_err(|e| format!("cannot write to the cache {}: {e}", local.root().display()))
        });
        if let Err(message) = stored {
            self.observer.note(&format!("warning: {message}"));
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
        let Some(last) = self.store.local().read_record(&identity(job)) else {
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

    /// Run a job's stage, on the remote executor when there is one and the job is an action,
    /// else here, and store its outputs; panics in a stage become failures. Also says whether
    /// it ran remotely.
    fn run_stage(
        &self,
        id: JobId,
        inputs: &[(String, ContentHash)],
    ) -> Result<(ActionEntry, bool), StageError> {
        let job = self.graph.job(id);
        let reader = JobReader {
            exec: self,
            job,
            inputs,
        };
        let remote = self
            .execution
            .as_ref()
            .and_then(|remote| self.run_remotely(remote, &reader, inputs));
        let ran_remotely = remote.is_some();
        let (made, discovered, warnings) = match remote {
            Some(done) => (done.outputs, done.left.discovered, done.left.warnings),
            None => {
                let mut ctx = JobContext::new(&job.asset, &job.params, &reader);
                let ran = run_catching(job.stage.as_ref(), &mut ctx);
                let left = ctx.finish();
                ran?;
                (left.outputs, left.discovered, left.warnings)
            }
        };
        let mut outputs = BTreeMap::new();
        for (name, bytes) in made {
            let blob = self.store.put_output(&bytes).map_err(|e| {
                StageError::file(self.store.local().root(), format!("cannot write: {e}"))
            })?;
            outputs.insert(name, blob);
        }
        let entry = ActionEntry {
            stage: job.stage.name().to_string(),
            outputs,
            discovered,
            warnings,
            remote_names: BTreeMap::new(),
        };
        Ok((entry, ran_remotely))
    }

    /// A job's outputs made by the remote executor, which is sent the discovered files its
    /// stage asks for (read here, under the run's source rules) until it has all it needs;
    /// `None` when the job must run here.
    fn run_remotely(
        &self,
        remote: &RemoteExecution,
        reader: &JobReader<'_>,
        inputs: &[(String, ContentHash)],
    ) -> Option<ActionOutputs> {
        if remote.is_gone() {
            return None;
        }
        let mut action = ActionJob::of(reader.job, inputs)?;
        action.settings = remote.settings().clone();
        // Every blob sent, by hash: the inputs, read once for all the rounds, and the
        // discovered files as they are sent.
        let mut blobs: HashMap<ContentHash, Vec<u8>> = HashMap::new();
        for (name, hash) in &action.inputs {
            match reader.input(name) {
                Ok(bytes) => blobs.insert(*hash, bytes),
                Err(e) => {
                    remote.decline(&action, &e.to_string(), self.observer);
                    return None;
                }
            };
        }
        // The files its last run read are likely to be read again: they go with the first
        // round (a rebuild after an edit then takes one).
        let local = self.store.local();
        let last = local
            .read_record(&identity(reader.job))
            .and_then(|record| local.read_action(&record.key).ok());
        for file in last.map(|entry| entry.discovered).unwrap_or_default() {
            if send_discovered(reader, &mut action, &mut blobs, file.path).is_err() {
                break;
            }
        }
        for _ in 0..MAX_ACTION_ROUNDS {
            let read = |hash: &ContentHash| {
                blobs.get(hash).cloned().ok_or_else(|| {
                    StageError::Plan(format!("no blob sent has the hash {}", hash.short()))
                })
            };
            let done = remote.try_execute(&action, &read, self.observer)?;
            if done.left.wanted.is_empty() {
                return Some(done);
            }
            for relative in done.left.wanted {
                let sent = match action.files.contains_key(&relative) {
                    true => Err(format!("it asked again for `{relative}`, which was sent")),
                    false => send_discovered(reader, &mut action, &mut blobs, relative),
                };
                if let Err(why) = sent {
                    remote.decline(&action, &why, self.observer);
                    return None;
                }
            }
            // What the stage said it may read next goes too, under the same rules: a file
            // that cannot be sent makes the job run here, whether or not the stage would
            // read it (so a farm learns nothing from which of them are sent).
            for relative in done.left.will_read {
                if action.files.contains_key(&relative) {
                    continue;
                }
                if let Err(why) = send_discovered(reader, &mut action, &mut blobs, relative) {
                    remote.decline(&action, &why, self.observer);
                    return None;
                }
            }
        }
        let why = format!("it still asked for files after {MAX_ACTION_ROUNDS} rounds");
        remote.decline(&action, &why, self.observer);
        None
    }

    fn read_output(&self, id: JobId, name: &str) -> Result<Vec<u8>, StageError> {
        let job = self.graph.job(id);
        let result = self.result(id);
        let blob = result.outputs.get(name).ok_or_else(|| {
            StageError::Plan(format!(
                "stage `{}` has no output `{name}`",
                job.stage.name()
            ))
        })?;
        match self.store.blob(blob, self.observer) {
            Ok(bytes) => return Ok(bytes),
            Err(ReadError::Io { path, error }) => {
                return Err(StageError::file(path, format!("cannot read: {error}")));
            }
            Err(damage) => {
                if self.cached_only || self.dry_run {
                    return Err(StageError::input(
                        name,
                        format!(
                            "output of stage `{}` is not in the local cache ({damage})",
                            job.stage.name()
                        ),
                    ));
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
            StageError::input(name, format!("cannot regenerate: {outcome:?}"))
        })?;
        let (entry, _) = self.run_stage(id, &inputs)?;
        if entry.outputs != result.outputs {
            return Err(StageError::input(
                name,
                format!(
                    "stage `{}` is not deterministic: re-running it gave different outputs",
                    job.stage.name()
                ),
            ));
        }
        // Kept again in both tiers: a copy the remote one had damaged is replaced.
        let key = job_key(job.stage.name(), job.stage.version(), &job.params, &inputs);
        if let Err(message) = self.store.keep(&key, &entry, self.observer) {
            self.observer.note(&format!("warning: {message}"));
        }
        self.store
            .local()
            .read_blob(blob)
            .map_err(|e| StageError::input(name, e))
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

/// Read the discovered file `relative` here to send it with `action` (its bytes go in
/// `blobs`), or say it is not there; the error says why it cannot be sent.
fn send_discovered(
    reader: &JobReader<'_>,
    action: &mut ActionJob,
    blobs: &mut HashMap<ContentHash, Vec<u8>>,
    relative: String,
) -> Result<(), String> {
    if action.files.len() >= MAX_ACTION_FILES {
        return Err(format!("it asked for more than {MAX_ACTION_FILES} files"));
    }
    match reader.read_discovered(&relative) {
        Ok(bytes) => {
            let hash = ContentHash::of(&bytes);
            action.files.insert(relative, Some(hash));
            blobs.insert(hash, bytes);
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            action.files.insert(relative, None);
        }
        Err(e) => return Err(format!("`{relative}` cannot be sent: {e}")),
    }
    Ok(())
}

/// A running job's view of the scheduler: its inputs by name.
struct JobReader<'a> {
    exec: &'a Exec<'a>,
    job: &'a JobSpec,
    inputs: &'a [(String, ContentHash)],
}

impl JobInputs for JobReader<'_> {
    fn source_path(&self, name: &str) -> Option<&Path> {
        self.job.inputs.iter().find_map(|(n, input)| match input {
            Input::Source(path) | Input::Hashed(path) if n == name => Some(path.as_path()),
            _ => None,
        })
    }

    fn input_hash(&self, name: &str) -> Option<ContentHash> {
        let position = self.job.inputs.iter().position(|(n, _)| n == name)?;
        Some(self.inputs[position].1)
    }

    fn input(&self, name: &str) -> Result<Vec<u8>, StageError> {
        let job = self.job;
        let position = job.inputs.iter().position(|(n, _)| n == name);
        let Some(position) = position else {
            return Err(StageError::Plan(format!(
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
                    .map_err(|e| StageError::file(path, format!("cannot read: {e}")))?;
                if ContentHash::of(&bytes) != expected {
                    // Whether the memo was wrong or the file really changed, the next build
                    // must read it.
                    self.exec.sources.forget(path);
                    return Err(StageError::file(
                        path,
                        "the file changed during the build; run the build again",
                    ));
                }
                Ok(bytes)
            }
            Input::Hashed(path) => Err(StageError::Plan(format!(
                "input `{name}` ({}) is only hashed, never read, by stage `{}`",
                path.display(),
                job.stage.name()
            ))),
            Input::Output { job, name } => self.exec.read_output(*job, name),
        }
    }

    fn read_discovered(&self, relative: &str) -> io::Result<Vec<u8>> {
        let dir = source_dir(self.job).ok_or_else(|| {
            io::Error::new(io::ErrorKind::NotFound, "this job has no source folder")
        })?;
        self.exec.sources.read(&dir.join(relative))
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
