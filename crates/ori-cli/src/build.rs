//! `build` (`build-assets`), `assemble`, `report` and `verify`: the build and its release.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ori_graph::Observer;
use ori_pipeline::{BuildOptions, Mode, build_assets, format_summary};

use crate::events;
use crate::progress::{Progress, ProgressMode};

/// The project a build works on: its configuration, the folders it may override, threads.
#[derive(clap::Args)]
pub struct ProjectArgs {
    /// Pipeline configuration.
    #[arg(long, default_value = "pipeline.toml")]
    pub config: PathBuf,
    /// Assets folder (default: `[assets] root` of the configuration).
    #[arg(long)]
    pub assets: Option<PathBuf>,
    /// Output folder (default: `[output] dir`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Cache folder (default: `[cache] dir`).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Worker threads (default: one per core).
    #[arg(short = 'j', long = "jobs", default_value_t = 0)]
    pub jobs: usize,
}

#[derive(clap::Args)]
pub struct BuildArgs {
    #[command(flatten)]
    pub project: ProjectArgs,
    /// Say why each job that ran had to run.
    #[arg(long)]
    pub explain: bool,
    /// Show what would run, and why, without running anything or writing outputs.
    #[arg(long)]
    pub dry_run: bool,
    /// Print only warnings, errors and the summary.
    #[arg(short, long)]
    pub quiet: bool,
    /// Also write PNG pictures of every baked relief map into DIR/<asset>/.
    #[arg(long, value_name = "DIR")]
    pub dump_maps: Option<PathBuf>,
    /// Also write every package as an inspectable folder (manifest.json, KTX2 files, PNG
    /// previews) into DIR/<asset>/.
    #[arg(long, value_name = "DIR")]
    pub explode: Option<PathBuf>,
    /// Do not write the HTML report (report/index.html) after the build.
    #[arg(long)]
    pub no_report: bool,
    /// Build only part K of N of the assets (balanced by source size; see ARCHITECTURE.md)
    /// and write no release; `assemble` writes it once every part is built.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<ori_pipeline::shard::Shard>,
    /// Where selection is measured: the CPU evaluator (default) or the wgpu renderer on the
    /// adapter found. GPU results are device-dependent: they get their own cache keys and are
    /// used only when asked for.
    #[arg(long, value_enum, default_value = "cpu")]
    pub backend: Backend,
    /// `json`: the build as JSON Lines on standard output, one event per line (schema:
    /// docs/EVENTS.md); what a person reads goes to standard error.
    #[arg(long, value_enum, default_value = "human")]
    pub message_format: MessageFormat,
    /// Run the jobs that are not cached on this REAPI build farm (grpc://host:port;
    /// default: `[execution] remote`); a farm that goes away costs one warning and the rest
    /// builds here.
    #[arg(long, value_name = "URL")]
    pub remote_exec: Option<String>,
}

/// `--message-format`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MessageFormat {
    Human,
    Json,
}

/// `--backend`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    Cpu,
    Gpu,
}

#[derive(clap::Args)]
pub struct AssembleArgs {
    #[command(flatten)]
    pub project: ProjectArgs,
    /// Print only warnings, errors and the summary.
    #[arg(short, long)]
    pub quiet: bool,
    /// Also write every package as an inspectable folder into DIR/<asset>/.
    #[arg(long, value_name = "DIR")]
    pub explode: Option<PathBuf>,
    /// Do not write the HTML report (report/index.html).
    #[arg(long)]
    pub no_report: bool,
    /// The backend the shards measured selection with.
    #[arg(long, value_enum, default_value = "cpu")]
    pub backend: Backend,
    /// `json`: JSON Lines events on standard output (docs/EVENTS.md).
    #[arg(long, value_enum, default_value = "human")]
    pub message_format: MessageFormat,
}

#[derive(clap::Args)]
pub struct ReportArgs {
    /// The output folder (default: `[output] dir` of the configuration).
    pub dir: Option<PathBuf>,
    /// Pipeline configuration (gives the assets folder, for the reference pictures).
    #[arg(long, default_value = "pipeline.toml")]
    pub config: PathBuf,
    /// Assets folder (default: `[assets] root` of the configuration).
    #[arg(long)]
    pub assets: Option<PathBuf>,
}

#[derive(clap::Args)]
pub struct VerifyArgs {
    /// The release folder (holding release.json).
    pub dir: PathBuf,
}

/// `build` (`build-assets` in xtask).
pub fn build(args: BuildArgs) -> ExitCode {
    run(args, false)
}

/// `assemble`: the release from the caches, no stage run.
pub fn assemble(a: AssembleArgs) -> ExitCode {
    run(
        BuildArgs {
            project: a.project,
            explain: false,
            dry_run: false,
            quiet: a.quiet,
            dump_maps: None,
            explode: a.explode,
            no_report: a.no_report,
            shard: None,
            backend: a.backend,
            message_format: a.message_format,
            remote_exec: None,
        },
        true,
    )
}

/// Exit status 0: every package matches; 1: mismatches, each printed.
pub fn verify(args: VerifyArgs) -> ExitCode {
    let dir = args.dir.as_path();
    match ori_pipeline::release::verify(dir) {
        Ok(n) => {
            println!("{n} package(s) verified in {}", dir.display());
            ExitCode::SUCCESS
        }
        Err(problems) => {
            for p in &problems {
                eprintln!("mismatch: {p}");
            }
            eprintln!(
                "error: {} mismatch(es) in {}",
                problems.len(),
                dir.display()
            );
            ExitCode::from(1)
        }
    }
}

/// The output and assets folders a configuration names, unless given, and how the report
/// may read the source models (the build's rules).
fn folders(
    config: &Path,
    out: Option<PathBuf>,
    assets: Option<PathBuf>,
    cache: Option<PathBuf>,
) -> Result<
    (
        PathBuf,
        PathBuf,
        ori_report::SourceAccess,
        ori_report::ReportOptions,
    ),
    String,
> {
    let c = ori_pipeline::Config::load(config).map_err(|e| e.to_string())?;
    let assets = assets.unwrap_or_else(|| c.resolve(&c.assets.root));
    let access = ori_report::SourceAccess {
        rules: c.limits.source_rules(&assets).map_err(|e| e.to_string())?,
        limits: c.limits.mesh(),
        loaded_stat_memo: None,
        stat_memo: Some(
            cache
                .unwrap_or_else(|| c.resolve(&c.cache.dir))
                .join(ori_graph::STAT_MEMO),
        ),
    };
    let options = ori_report::ReportOptions {
        compare_directions: c.compare.directions(),
    };
    Ok((
        out.unwrap_or_else(|| c.resolve(&c.output.dir)),
        assets,
        access,
        options,
    ))
}

/// Write the HTML report (from the release a build just wrote, when given; from the output
/// folder otherwise); print its path and every package that failed its check. `Err` when it
/// could not be written or a package is invalid.
fn write_report(
    config: &Path,
    out: Option<PathBuf>,
    assets: Option<PathBuf>,
    cache: Option<PathBuf>,
    built: Option<ori_pipeline::WrittenRelease>,
) -> Result<PathBuf, String> {
    let (out, assets, mut access, options) = folders(config, out, assets, cache)?;
    let written = match built {
        Some(built) => {
            access.loaded_stat_memo = Some(built.sources);
            let (report, release) = (&built.report, &built.release);
            ori_report::write_report_of(report, release, &out, &assets, &access, &options)?
        }
        None => ori_report::write_report(&out, &assets, &access, &options)?,
    };
    if written.invalid_packages.is_empty() {
        return Ok(written.index);
    }
    for p in &written.invalid_packages {
        eprintln!("invalid package: {p}");
    }
    Err(format!(
        "{} package(s) in {} failed their check (report written without their pictures: {})",
        written.invalid_packages.len(),
        out.display(),
        written.index.display()
    ))
}

/// Exit status 0: report written; 1: it could not be, or a package in the folder is invalid.
pub fn report(args: ReportArgs) -> ExitCode {
    match write_report(&args.config, args.dir, args.assets, None, None) {
        Ok(index) => {
            println!("report: {}", index.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// `-j N` clamped to the cores this machine has: more threads than cores never speed up the
/// stages (they are CPU-bound) and thousands of them cost memory and time.
fn worker_threads(asked: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if asked > cores {
        eprintln!("warning: -j {asked} is more than this machine's {cores} core(s); using {cores}");
        return cores;
    }
    asked
}

/// `build`, or `assemble` (no stage runs). Exit status 0: built; 1: some job failed,
/// an output could not be written or (assemble) some asset is not cached; 2: the
/// configuration or command line is wrong; 3: every job ran but some package misses its
/// `[gate]`.
fn run(args: BuildArgs, assemble: bool) -> ExitCode {
    let events = (args.message_format == MessageFormat::Json).then(events::JsonEvents::new);
    let (status, summary, error) = run_build(args, assemble, events.as_ref());
    if let Some(events) = &events {
        events.build_finished(summary.as_ref(), status, error.as_deref());
    }
    ExitCode::from(status)
}

/// [`run`]'s work: its exit status, the build's summary when it ran, and the error that
/// stopped it, if one did (printed already).
fn run_build(
    args: BuildArgs,
    assemble: bool,
    events: Option<&events::JsonEvents>,
) -> (u8, Option<ori_pipeline::BuildSummary>, Option<String>) {
    // With JSON events, standard output carries only them.
    let say = |line: &str| match events {
        Some(_) => eprintln!("{line}"),
        None => println!("{line}"),
    };
    let progress = if args.quiet || events.is_some() {
        ProgressMode::Quiet
    } else {
        ProgressMode::detect()
    };
    let want_report = !(args.no_report || args.dry_run || args.shard.is_some());
    let (config_path, out_arg, assets_arg, cache_arg) = (
        args.project.config.clone(),
        args.project.out.clone(),
        args.project.assets.clone(),
        args.project.cache.clone(),
    );
    let gpu_select = match args.backend {
        Backend::Cpu => None,
        Backend::Gpu => match ori_pipeline::gpu_select::renderer() {
            Ok(r) => {
                say(&format!(
                    "selection backend: gpu on {}",
                    r.adapter_summary()
                ));
                Some(r.adapter_summary())
            }
            Err(e) => {
                let e = format!("--backend gpu: {e}");
                eprintln!("error: {e}");
                return (2, None, Some(e));
            }
        },
    };
    let options = BuildOptions {
        gpu_select,
        config: args.project.config,
        assets: args.project.assets,
        out: args.project.out,
        cache: args.project.cache,
        threads: worker_threads(args.project.jobs),
        mode: match (assemble, args.shard) {
            (true, _) => Mode::Assemble,
            (false, Some(shard)) => Mode::Shard(shard),
            (false, None) => Mode::Release,
        },
        dry_run: args.dry_run,
        dump_maps: args.dump_maps,
        explode: args.explode,
        remote_exec: args.remote_exec,
    };
    let progress = Progress::new(progress, args.explain || args.dry_run);
    let observer: &dyn ori_graph::Observer = match events {
        Some(events) => events,
        None => &progress,
    };
    match build_assets(&options, observer) {
        Ok(mut summary) => {
            for w in &summary.warnings {
                eprintln!("warning: {w}");
                if let Some(events) = events {
                    events.note(w);
                }
            }
            say(&format_summary(&summary));
            if let (Some(events), Some(written)) = (events, &summary.written) {
                events.assets_finished(written);
            }
            for (asset, missed) in &summary.missed_gate {
                for what in missed {
                    eprintln!("error: quality gate: {asset}: {what}");
                }
            }
            if want_report {
                let started = std::time::Instant::now();
                let built = summary.written.take();
                match write_report(&config_path, out_arg, assets_arg, cache_arg, built) {
                    Ok(index) => say(&format!(
                        "html report: {} ({:.2} s)",
                        index.display(),
                        started.elapsed().as_secs_f64()
                    )),
                    Err(e) => {
                        let e = format!("cannot write the html report: {e}");
                        eprintln!("error: {e}");
                        return (1, Some(summary), Some(e));
                    }
                }
            }
            let (status, error) = if summary.failed_jobs > 0 {
                (
                    1,
                    format!("{} job(s) failed (see above)", summary.failed_jobs),
                )
            } else if !summary.missed_gate.is_empty() {
                let config = config_path.display();
                let n = summary.missed_gate.len();
                (
                    3,
                    format!("{n} asset(s) missed the quality gate ([gate] in {config})"),
                )
            } else {
                return (0, Some(summary), None);
            };
            eprintln!("error: {error}");
            (status, Some(summary), Some(error))
        }
        Err(e) => {
            let status = match e {
                ori_pipeline::PipelineError::NotCached(_)
                | ori_pipeline::PipelineError::Output { .. } => 1,
                _ => 2,
            };
            eprintln!("error: {e}");
            (status, None, Some(e.to_string()))
        }
    }
}
