//! Progress display: indicatif bars (overall and per stage) on a terminal, or one plain line
//! per event when stdout is not a terminal or `CI` is set (logs stay readable).

use std::io::IsTerminal;
use std::sync::Mutex;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use ori_graph::{Graph, JobResult, JobSpec, Observer, Outcome};

/// How progress is shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// Live bars on the terminal.
    Bars,
    /// One line per finished job.
    Lines,
    /// Only warnings and errors.
    Quiet,
}

impl ProgressMode {
    /// Bars on an interactive terminal, lines otherwise (and whenever `CI` is set).
    pub fn detect() -> ProgressMode {
        if std::env::var_os("CI").is_some() || !std::io::stdout().is_terminal() {
            ProgressMode::Lines
        } else {
            ProgressMode::Bars
        }
    }
}

/// An [`Observer`] that shows progress, warnings, errors and (with `explain`) why jobs ran.
/// A build runs several graphs (trial runs, then the final one): each gets fresh bars.
pub struct Progress {
    mode: ProgressMode,
    explain: bool,
    multi: MultiProgress,
    bars: Mutex<Option<Bars>>,
}

/// The bars of the graph being run.
struct Bars {
    overall: ProgressBar,
    stages: Vec<(&'static str, ProgressBar)>,
}

impl Progress {
    pub fn new(mode: ProgressMode, explain: bool) -> Progress {
        let target = if mode == ProgressMode::Bars {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        };
        Progress {
            mode,
            explain,
            multi: MultiProgress::with_draw_target(target),
            bars: Mutex::new(None),
        }
    }

    fn bars(&self) -> std::sync::MutexGuard<'_, Option<Bars>> {
        self.bars.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn print(&self, line: &str) {
        match self.mode {
            ProgressMode::Bars => {
                let _ = self.multi.println(line);
            }
            ProgressMode::Lines | ProgressMode::Quiet => println!("{line}"),
        }
    }

    /// Errors and warnings go to standard error, where scripts and people look for them.
    fn print_problem(&self, line: &str) {
        match self.mode {
            ProgressMode::Bars => self.multi.suspend(|| eprintln!("{line}")),
            ProgressMode::Lines | ProgressMode::Quiet => eprintln!("{line}"),
        }
    }
}

impl Bars {
    fn new(multi: &MultiProgress, graph: &Graph) -> Bars {
        let style = |template: &str| {
            ProgressStyle::with_template(template)
                .expect("valid progress template")
                .progress_chars("=> ")
        };
        let overall = multi.add(ProgressBar::new(graph.len() as u64));
        overall.set_style(style("{prefix:>10} [{bar:30}] {pos}/{len} jobs, {elapsed}"));
        overall.set_prefix("all");
        let stages = graph
            .stage_names()
            .into_iter()
            .map(|name| {
                let total = graph.jobs().filter(|(_, j)| j.stage.name() == name).count();
                let bar = multi.add(ProgressBar::new(total as u64));
                bar.set_style(style("{prefix:>10} [{bar:30}] {pos}/{len} {wide_msg}"));
                bar.set_prefix(name);
                (name, bar)
            })
            .collect();
        Bars { overall, stages }
    }

    fn stage(&self, stage: &str) -> Option<&ProgressBar> {
        self.stages
            .iter()
            .find(|(n, _)| *n == stage)
            .map(|(_, b)| b)
    }

    fn clear(&self, multi: &MultiProgress) {
        for (_, bar) in &self.stages {
            bar.finish_and_clear();
        }
        self.overall.finish_and_clear();
        let _ = multi.clear();
    }
}

impl Observer for Progress {
    fn run_started(&self, graph: &Graph) {
        let mut bars = self.bars();
        if let Some(old) = bars.take() {
            old.clear(&self.multi);
        }
        *bars = Some(Bars::new(&self.multi, graph));
    }

    /// Remove the bars (the summary is printed after the last run).
    fn run_finished(&self) {
        if let Some(old) = self.bars().take() {
            old.clear(&self.multi);
        }
    }

    fn job_started(&self, job: &JobSpec) {
        if let Some(bar) = self.bars().as_ref().and_then(|b| b.stage(job.stage.name())) {
            bar.set_message(job.asset.clone());
        }
    }

    fn job_finished(&self, job: &JobSpec, result: &JobResult) {
        if let Some(bars) = self.bars().as_ref() {
            bars.overall.inc(1);
            if let Some(bar) = bars.stage(job.stage.name()) {
                bar.inc(1);
            }
        }
        let what = format!("[{}] {}", job.stage.name(), job.asset);
        let lines = self.mode == ProgressMode::Lines;
        let line = match &result.outcome {
            Outcome::Reused if lines => Some(format!("{what}: reused")),
            Outcome::Ran(reason) if self.explain => Some(format!(
                "{what}: ran{} in {:.2} s because {reason}",
                where_ran(result),
                result.duration.as_secs_f64()
            )),
            Outcome::Ran(_) if lines => Some(format!(
                "{what}: ran{} in {:.2} s",
                where_ran(result),
                result.duration.as_secs_f64()
            )),
            Outcome::WouldRun(reason) => Some(format!("{what}: would run because {reason}")),
            Outcome::Failed(message) => {
                self.print_problem(&format!("error: {what}: {message}"));
                None
            }
            Outcome::Skipped if lines => Some(format!("{what}: skipped (an upstream job failed)")),
            Outcome::NotCached if lines => Some(format!("{what}: not in the cache")),
            _ => None,
        };
        if let Some(line) = line {
            self.print(&line);
        }
        for warning in &result.warnings {
            self.print_problem(&format!("warning: {}: {warning}", job.asset));
        }
    }

    fn note(&self, message: &str) {
        self.print_problem(message);
    }

    fn asset_unchanged(&self, asset: &str, stages: &[String]) {
        if self.mode == ProgressMode::Lines {
            for stage in stages {
                self.print(&format!("[{stage}] {asset}: reused"));
            }
        }
    }
}

/// Where a job that ran did (nothing when here).
fn where_ran(result: &JobResult) -> &'static str {
    if result.ran_remotely { " remotely" } else { "" }
}
