//! Running jobs elsewhere: an [`Executor`] takes a job that is an action ([`ActionJob`]) and
//! gives back its outputs; [`RemoteExecution`] is one shared by the runs of a build, which
//! stops asking it, with one warning, once it is unavailable, so the build finishes here.
//! The graph knows no protocol: the executors live in other crates.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::action::{ActionJob, ActionOutputs};
use crate::hash::ContentHash;
use crate::outcome::Observer;
use crate::stage::StageError;

/// Why an executor gave no outputs for a job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ExecuteError {
    /// The executor cannot be used (down, refusing us): stop asking it.
    Unavailable(String),
    /// This job did not finish there (its stage failed, its worker was lost for good, its
    /// outputs were wrong): it runs here, which also gives the stage's own error.
    Failed(String),
}

/// Where the time of the jobs an executor ran went, summed over them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExecutorTimes {
    /// Moving blobs: uploading what it lacked, downloading the outputs.
    pub transfer: std::time::Duration,
    /// Waiting for results: queued, laid out, run, stored.
    pub waiting: std::time::Duration,
    /// Of the waiting, the time the jobs' commands ran (as the workers report it).
    pub running: std::time::Duration,
}

/// Where jobs that are actions run instead of in this process.
pub trait Executor: Send + Sync {
    /// Where it is, for messages (no credentials).
    fn describe(&self) -> String;
    /// How many jobs may wait on it at once.
    fn max_in_flight(&self) -> usize;
    /// Run `job`, whose input blobs `read` gives by content hash (checked), and return the
    /// outputs it made.
    fn execute(
        &self,
        job: &ActionJob,
        read: &dyn Fn(&ContentHash) -> Result<Vec<u8>, StageError>,
    ) -> Result<ActionOutputs, ExecuteError>;
    /// Where the time of the jobs it ran so far went.
    fn times(&self) -> ExecutorTimes {
        ExecutorTimes::default()
    }
}

/// An executor shared by the runs of a build.
pub struct RemoteExecution {
    executor: Box<dyn Executor>,
    /// Sent with every action ([`ActionJob::settings`]).
    settings: serde_json::Value,
    /// Why it stopped being asked, once it did.
    gone: OnceLock<String>,
    executed: AtomicU64,
    fell_back: AtomicU64,
}

impl std::fmt::Debug for RemoteExecution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemoteExecution")
            .field("executor", &self.describe())
            .field("gone", &self.gone.get())
            .finish()
    }
}

/// Why the outputs an executor gave for `job` cannot be its result, if they cannot: an output
/// name that is not a plain name, or a file the stage read that is not the one sent.
fn unbelievable(job: &ActionJob, done: &ActionOutputs) -> Option<String> {
    if let Some(name) = done.outputs.keys().find(|n| !ActionJob::is_output_name(n)) {
        return Some(format!("it returned an output named `{name}`"));
    }
    done.left.discovered.iter().find_map(|f| {
        let why = match job.files.get(&f.path) {
            Some(sent) if *sent == f.hash => return None,
            None => "which was not sent",
            Some(None) => "which was sent as absent",
            Some(Some(_)) => "with other bytes than were sent",
        };
        Some(format!("it read `{}`, {why}", f.path))
    })
}

impl RemoteExecution {
    /// An executor whose actions carry `settings` (see [`ActionJob::settings`]).
    pub fn new(executor: Box<dyn Executor>, settings: serde_json::Value) -> RemoteExecution {
        RemoteExecution {
            executor,
            settings,
            gone: OnceLock::new(),
            executed: AtomicU64::new(0),
            fell_back: AtomicU64::new(0),
        }
    }

    pub fn describe(&self) -> String {
        self.executor.describe()
    }

    pub fn max_in_flight(&self) -> usize {
        self.executor.max_in_flight().max(1)
    }

    /// Where the time of the jobs it ran went.
    pub fn times(&self) -> ExecutorTimes {
        self.executor.times()
    }

    /// Jobs it ran.
    pub fn executed(&self) -> u64 {
        self.executed.load(Ordering::Relaxed)
    }

    /// Jobs given to it that ran here after all.
    pub fn fell_back(&self) -> u64 {
        self.fell_back.load(Ordering::Relaxed)
    }

    /// Whether it stopped being asked.
    pub fn is_gone(&self) -> bool {
        self.gone.get().is_some()
    }

    pub(crate) fn settings(&self) -> &serde_json::Value {
        &self.settings
    }

    /// The outputs of `job` run by the executor, or `None` when it must run here. Outputs
    /// whose [`ActionLeft::wanted`](crate::ActionLeft) names files are not a result: the
    /// caller sends the job again with them.
    pub(crate) fn try_execute(
        &self,
        job: &ActionJob,
        read: &dyn Fn(&ContentHash) -> Result<Vec<u8>, StageError>,
        observer: &dyn Observer,
    ) -> Option<ActionOutputs> {
        if self.is_gone() {
            return None;
        }
        let failed = match self.executor.execute(job, read) {
            Ok(done) if !done.left.wanted.is_empty() => return Some(done),
            Ok(done) => match unbelievable(job, &done) {
                Some(why) => why,
                None => {
                    self.executed.fetch_add(1, Ordering::Relaxed);
                    return Some(done);
                }
            },
            Err(ExecuteError::Failed(why)) => why,
            Err(ExecuteError::Unavailable(why)) => {
                self.fell_back.fetch_add(1, Ordering::Relaxed);
                if self.gone.set(why.clone()).is_ok() {
                    observer.note(&format!(
                        "warning: remote execution {}: {why}; the remaining jobs run here",
                        self.describe()
                    ));
                }
                return None;
            }
        };
        self.decline(job, &failed, observer);
        None
    }

    /// Count `job` as sent but run here, with a warning saying why.
    pub(crate) fn decline(&self, job: &ActionJob, why: &str, observer: &dyn Observer) {
        self.fell_back.fetch_add(1, Ordering::Relaxed);
        observer.note(&format!(
            "warning: {}: job `{}` did not run on {}: {why}; it runs here",
            job.asset,
            job.stage,
            self.describe()
        ));
    }
}
