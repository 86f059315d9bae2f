//! What a build tells the user at the end: counts and times per stage, the remote cache's
//! traffic, and the table printed from them.

use std::path::PathBuf;
use std::sync::Arc;

use ori_graph::{
    RemoteCache, RemoteDigest, RemoteExecution, RemoteMode, RemoteStats, SourceHasher,
};
use ori_release::{BuildReport, Release};
use serde::Serialize;

use crate::shard;

/// Counts and times of a finished build.
#[derive(Clone, Debug, Serialize)]
pub struct BuildSummary {
    pub assets: usize,
    /// Assets that did not build (their errors were printed with their jobs).
    pub failed_assets: usize,
    /// About the output folder, for the user (e.g. files left alone).
    pub warnings: Vec<String>,
    pub stages: Vec<StageLine>,
    pub failed_jobs: usize,
    pub wall_seconds: f64,
    /// Source files read and hashed (the rest came from the stat memo).
    pub sources_hashed: u64,
    pub dry_run: bool,
    /// Where the report was written (not for dry runs or shards).
    pub report: Option<PathBuf>,
    /// The part built, and how many assets there are in all (`--shard`).
    pub shard: Option<(shard::Shard, usize)>,
    /// What the remote cache did, when one is configured.
    pub remote: Option<RemoteSummary>,
    /// What the remote-execution farm did, when one is configured.
    pub execution: Option<ExecutionSummary>,
    /// The assets whose packages miss their `[gate]`, each with what it misses.
    pub missed_gate: Vec<(String, Vec<String>)>,
    /// What the build wrote into its output folder, for a report made right after it
    /// (`None` when it wrote no release).
    #[serde(skip)]
    pub written: Option<WrittenRelease>,
}

/// A release as a build wrote it, and the build's source hashes: what the report is made
/// from, kept in memory so that a report made right after the build reads none of it again.
#[derive(Clone, Debug)]
pub struct WrittenRelease {
    pub report: BuildReport,
    pub release: Release,
    pub sources: Arc<SourceHasher>,
}

/// The remote cache's part in a build.
#[derive(Clone, Debug, Serialize)]
pub struct RemoteSummary {
    pub url: String,
    pub mode: RemoteMode,
    pub digest: RemoteDigest,
    /// The server failed during the build (the rest was built locally).
    pub unavailable: bool,
    pub stats: RemoteStats,
}

impl RemoteSummary {
    pub(crate) fn of(remote: &RemoteCache) -> RemoteSummary {
        RemoteSummary {
            url: remote.describe(),
            mode: remote.mode(),
            digest: remote.digest(),
            unavailable: remote.is_offline(),
            stats: remote.stats(),
        }
    }
}

/// The remote-execution farm's part in a build.
#[derive(Clone, Debug, Serialize)]
pub struct ExecutionSummary {
    pub url: String,
    /// Jobs it ran.
    pub executed: u64,
    /// Jobs sent to it that ran here after all.
    pub fell_back: u64,
    /// It went away during the build (the rest was built here).
    pub unavailable: bool,
    /// Seconds spent moving blobs, waiting for results, and (of the waiting) running the
    /// jobs' commands on the workers.
    pub transfer_seconds: f64,
    pub waiting_seconds: f64,
    pub running_seconds: f64,
}

impl ExecutionSummary {
    pub(crate) fn of(execution: &RemoteExecution) -> ExecutionSummary {
        let times = execution.times();
        ExecutionSummary {
            url: execution.describe(),
            executed: execution.executed(),
            fell_back: execution.fell_back(),
            unavailable: execution.is_gone(),
            transfer_seconds: times.transfer.as_secs_f64(),
            waiting_seconds: times.waiting.as_secs_f64(),
            running_seconds: times.running.as_secs_f64(),
        }
    }
}

/// One stage's line of the summary.
#[derive(Clone, Debug, Serialize)]
pub struct StageLine {
    pub stage: String,
    pub ran: usize,
    /// Of those that ran, the ones that ran on the remote-execution farm.
    pub remote: usize,
    pub reused: usize,
    pub would_run: usize,
    pub failed: usize,
    pub skipped: usize,
    pub seconds: f64,
}

impl StageLine {
    fn new(stage: &str) -> StageLine {
        StageLine {
            stage: stage.to_string(),
            ran: 0,
            remote: 0,
            reused: 0,
            would_run: 0,
            failed: 0,
            skipped: 0,
            seconds: 0.0,
        }
    }

    /// Add a run's per-stage counts and times to `lines` (by stage name, first-seen order).
    pub fn add_run(lines: &mut Vec<StageLine>, build: &ori_graph::Build<'_>) {
        for s in build.summary() {
            let i = match lines.iter().position(|l| l.stage == s.stage) {
                Some(i) => i,
                None => {
                    lines.push(StageLine::new(s.stage));
                    lines.len() - 1
                }
            };
            let l = &mut lines[i];
            l.ran += s.ran;
            l.remote += s.remote;
            l.reused += s.reused;
            l.would_run += s.would_run;
            l.failed += s.failed;
            l.skipped += s.skipped;
            l.seconds += s.time.as_secs_f64();
        }
    }

    /// Count jobs of these stages as reused (an asset known unchanged, whose jobs are in no
    /// run).
    pub fn add_reused(lines: &mut Vec<StageLine>, stages: &[String]) {
        for stage in stages {
            let i = match lines.iter().position(|l| &l.stage == stage) {
                Some(i) => i,
                None => {
                    lines.push(StageLine::new(stage));
                    lines.len() - 1
                }
            };
            lines[i].reused += 1;
        }
    }
}

/// The summary as the table printed at the end of a build.
pub fn format_summary(s: &BuildSummary) -> String {
    let mut out = String::new();
    // The `remote` column only where a farm could have run jobs.
    let remote = |text: String| {
        if s.execution.is_some() {
            text
        } else {
            String::new()
        }
    };
    out.push_str(&format!(
        "{:<10} {:>6}{} {:>7} {:>7} {:>9}\n",
        "stage",
        "ran",
        remote(format!(" {:>6}", "remote")),
        "reused",
        "failed",
        "time (s)"
    ));
    for l in &s.stages {
        let ran = if s.dry_run { l.would_run } else { l.ran };
        out.push_str(&format!(
            "{:<10} {:>6}{} {:>7} {:>7} {:>9.2}\n",
            l.stage,
            ran,
            remote(format!(" {:>6}", l.remote)),
            l.reused,
            l.failed + l.skipped,
            l.seconds
        ));
    }
    if s.dry_run {
        let jobs: usize = s.stages.iter().map(|l| l.would_run).sum();
        out.push_str(&format!(
            "dry run of {} assets: {jobs} job(s) would run",
            s.assets
        ));
    } else if s.failed_assets > 0 {
        out.push_str(&format!(
            "{} assets built, {} failed",
            s.assets - s.failed_assets,
            s.failed_assets
        ));
    } else {
        out.push_str(&format!("{} assets built", s.assets));
    }
    out.push_str(&format!(
        " in {:.2} s ({} source files hashed)",
        s.wall_seconds, s.sources_hashed
    ));
    if let Some(r) = &s.report {
        out.push_str(&format!("; report: {}", r.display()));
    }
    if let Some((shard, total)) = s.shard {
        out.push_str(&format!(
            "\nshard {shard}: {} of {total} assets; no release written (`assemble` writes it once every shard is built)",
            s.assets
        ));
    }
    if let Some(r) = &s.remote {
        let mb = |b: u64| b as f64 / 1e6;
        let st = &r.stats;
        let access = match r.mode {
            RemoteMode::ReadOnly => "read-only",
            RemoteMode::ReadWrite => "read-write",
        };
        let names = match r.digest {
            RemoteDigest::Blake3 => "",
            RemoteDigest::Sha256 => ", sha256 names",
        };
        let mode = format!("{access}{names}");
        out.push_str(&format!(
            "\nremote cache {} ({mode}): downloaded {} entries, {} blobs, {:.2} MB; uploaded {} entries, {} blobs, {:.2} MB",
            r.url,
            st.entries_downloaded,
            st.blobs_downloaded,
            mb(st.bytes_downloaded),
            st.entries_uploaded,
            st.blobs_uploaded,
            mb(st.bytes_uploaded)
        ));
        if st.corrupt > 0 {
            out.push_str(&format!("; {} damaged download(s) rebuilt", st.corrupt));
        }
        if r.unavailable {
            out.push_str("; unavailable during the build, the rest was built locally");
        }
    }
    if let Some(e) = &s.execution {
        out.push_str(&format!(
            "\nremote execution {}: {} job(s) ran there",
            e.url, e.executed
        ));
        if e.executed > 0 {
            out.push_str(&format!(
                " (job seconds: {:.2} moving blobs, {:.2} waiting for results, of which {:.2} running)",
                e.transfer_seconds, e.waiting_seconds, e.running_seconds
            ));
        }
        if e.fell_back > 0 {
            out.push_str(&format!(", {} sent there ran here", e.fell_back));
        }
        if e.unavailable {
            out.push_str("; unavailable during the build, the rest was built here");
        }
    }
    out
}
