//! `--message-format json`: a build told as JSON Lines on standard output, one event per line,
//! for CI systems and farms. The schema is docs/EVENTS.md (a test holds every event to it);
//! what a person reads (the summary, errors) goes to standard error instead.

use std::collections::HashMap;
use std::io::Write;
use std::sync::Mutex;

use ori_graph::{Graph, JobResult, JobSpec, Observer, Outcome};
use ori_pipeline::{BuildSummary, WrittenRelease};
use serde::Serialize;

/// One line of the stream.
#[derive(Serialize)]
#[serde(tag = "event", rename_all = "kebab-case")]
enum Event<'a> {
    Plan {
        jobs: usize,
    },
    JobStarted {
        stage: &'a str,
        asset: &'a str,
    },
    JobFinished {
        stage: &'a str,
        asset: &'a str,
        outcome: &'static str,
        seconds: f64,
        /// Only for a job that ran on the remote-execution farm.
        #[serde(skip_serializing_if = "std::ops::Not::not")]
        remote: bool,
        #[serde(skip_serializing_if = "Option::is_none")]
        reason: Option<String>,
        #[serde(skip_serializing_if = "Option::is_none")]
        error: Option<&'a str>,
    },
    Warning {
        message: &'a str,
        #[serde(skip_serializing_if = "Option::is_none")]
        asset: Option<&'a str>,
        #[serde(skip_serializing_if = "Option::is_none")]
        stage: Option<&'a str>,
    },
    AssetFinished(AssetFinished<'a>),
    BuildFinished(BuildFinished<'a>),
}

#[derive(Serialize)]
struct AssetFinished<'a> {
    asset: &'a str,
    status: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    package: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    plt: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    plt_at_least: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    held_out_coverage_error_max_percent: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    held_out_coverage_error_avg_percent: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    held_out_impostors_per_view: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    texture_bytes: Option<u64>,
    gate: &'a [String],
}

#[derive(Serialize)]
struct BuildFinished<'a> {
    exit_status: u8,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<&'a str>,
    assets: usize,
    failed_assets: usize,
    missed_gate: usize,
    jobs_ran: usize,
    jobs_reused: usize,
    jobs_failed: usize,
    seconds: f64,
}

/// Writes the events of a build to standard output.
pub struct JsonEvents {
    out: Mutex<std::io::Stdout>,
}

impl Default for JsonEvents {
    fn default() -> Self {
        JsonEvents::new()
    }
}

impl JsonEvents {
    pub fn new() -> JsonEvents {
        JsonEvents {
            out: Mutex::new(std::io::stdout()),
        }
    }

    fn emit(&self, event: &Event<'_>) {
        let line = serde_json::to_string(event).expect("events serialise");
        let mut out = self.out.lock().unwrap();
        // A reader that went away is no reason to stop the build.
        let _ = writeln!(out, "{line}").and_then(|()| out.flush());
    }

    /// One `asset-finished` per asset of the release a build wrote.
    pub fn assets_finished(&self, written: &WrittenRelease) {
        let entries: HashMap<&str, &ori_release::ReleaseEntry> = written
            .release
            .assets
            .iter()
            .map(|e| (e.name.as_str(), e))
            .collect();
        for a in &written.report.assets {
            let entry = entries.get(a.name.as_str());
            let q = a.quality.as_ref();
            self.emit(&Event::AssetFinished(AssetFinished {
                asset: &a.name,
                status: a.status.as_str(),
                error: a.error.as_deref(),
                package: entry.map(|e| e.package.as_str()),
                plt: q.map(|q| q.plt),
                plt_at_least: q.map(|q| q.plt_is_lower_bound),
                held_out_coverage_error_max_percent: q
                    .map(|q| q.held_out.coverage_error_max_percent),
                held_out_coverage_error_avg_percent: q
                    .map(|q| q.held_out.coverage_error_avg_percent),
                held_out_impostors_per_view: q.map(|q| q.held_out.impostors_per_view),
                texture_bytes: entry.map(|e| e.texture_bytes),
                gate: &a.gate,
            }));
        }
    }

    /// The last event: how the build ended (`summary` is `None` when it stopped before
    /// running anything, with `error`).
    pub fn build_finished(&self, summary: Option<&BuildSummary>, status: u8, error: Option<&str>) {
        let stages = summary.map_or(&[][..], |s| &s.stages[..]);
        let total = |f: fn(&ori_pipeline::summary::StageLine) -> usize| -> usize {
            stages.iter().map(f).sum()
        };
        self.emit(&Event::BuildFinished(BuildFinished {
            exit_status: status,
            error,
            assets: summary.map_or(0, |s| s.assets),
            failed_assets: summary.map_or(0, |s| s.failed_assets),
            missed_gate: summary.map_or(0, |s| s.missed_gate.len()),
            jobs_ran: total(|l| l.ran),
            jobs_reused: total(|l| l.reused),
            jobs_failed: total(|l| l.failed),
            seconds: summary.map_or(0.0, |s| s.wall_seconds),
        }));
    }
}

impl Observer for JsonEvents {
    fn run_started(&self, graph: &Graph) {
        self.emit(&Event::Plan { jobs: graph.len() });
    }

    fn job_started(&self, job: &JobSpec) {
        self.emit(&Event::JobStarted {
            stage: job.stage.name(),
            asset: &job.asset,
        });
    }

    fn job_finished(&self, job: &JobSpec, result: &JobResult) {
        let (outcome, reason, error) = match &result.outcome {
            Outcome::Reused => ("reused", None, None),
            Outcome::Ran(reason) => ("ran", Some(reason.to_string()), None),
            Outcome::WouldRun(reason) => ("would-run", Some(reason.to_string()), None),
            Outcome::Failed(message) => ("failed", None, Some(message.as_str())),
            Outcome::Skipped => ("skipped", None, None),
            Outcome::NotCached => ("not-cached", None, None),
        };
        let stage = job.stage.name();
        for message in &result.warnings {
            self.emit(&Event::Warning {
                message,
                asset: Some(&job.asset),
                stage: Some(stage),
            });
        }
        self.emit(&Event::JobFinished {
            stage,
            asset: &job.asset,
            outcome,
            seconds: result.duration.as_secs_f64(),
            remote: result.ran_remotely,
            reason,
            error,
        });
    }

    fn note(&self, message: &str) {
        self.emit(&Event::Warning {
            message: message.strip_prefix("warning: ").unwrap_or(message),
            asset: None,
            stage: None,
        });
    }

    fn asset_unchanged(&self, asset: &str, stages: &[String]) {
        for stage in stages {
            self.emit(&Event::JobFinished {
                stage,
                asset,
                outcome: "reused",
                seconds: 0.0,
                remote: false,
                reason: None,
                error: None,
            });
        }
    }
}
