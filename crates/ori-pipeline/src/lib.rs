//! The asset pipeline: configuration, asset discovery, and the stages wired into the build
//! graph. `cargo xtask build-assets` is a thin command line over [`build_assets`].
//!
//! Data flows one way: model file -> ingest (canonical mesh) -> later stages. Each stage is a
//! [`ori_graph::Stage`]; adding one means adding its job to [`plan`] and its parameters to
//! [`config::StageParams`], without touching the graph crate.

pub mod config;
pub mod discover;
pub mod ingest;
pub mod stages;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use ori_graph::{Cache, Graph, Input, JobId, JobSpec, Outcome, Progress, ProgressMode, RunOptions};
use serde::Serialize;

pub use config::Config;
pub use discover::{Asset, discover};

/// Errors that stop a build before or after its jobs run. Job failures are not errors here:
/// they are reported per job and counted in [`BuildSummary`].
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("{}: {message}", path.display())]
    Config { path: PathBuf, message: String },
    #[error("{0}")]
    Assets(String),
    #[error("{}: {message}", path.display())]
    Output { path: PathBuf, message: String },
}

/// What `build-assets` was asked to do.
#[derive(Clone, Debug)]
pub struct BuildOptions {
    pub config: PathBuf,
    /// Overrides `[assets] root`.
    pub assets: Option<PathBuf>,
    /// Overrides `[output] dir`.
    pub out: Option<PathBuf>,
    /// Overrides `[cache] dir`.
    pub cache: Option<PathBuf>,
    /// Worker threads (0: one per core).
    pub threads: usize,
    pub explain: bool,
    pub dry_run: bool,
    pub progress: ProgressMode,
    /// Write PNG pictures of every relief map into this folder.
    pub dump_maps: Option<PathBuf>,
}

/// The jobs of one asset.
#[derive(Clone, Debug)]
pub struct AssetJobs {
    pub asset: Asset,
    pub ingest: JobId,
    pub views: JobId,
    pub bake: JobId,
}

impl AssetJobs {
    /// Every job of the asset, upstream first.
    pub fn all(&self) -> [JobId; 3] {
        [self.ingest, self.views, self.bake]
    }
}

/// Build the job graph for `assets` under `config`.
pub fn plan(config: &Config, assets: &[Asset]) -> (Graph, Vec<AssetJobs>) {
    let ingest_stage: Arc<dyn ori_graph::Stage> = Arc::new(ingest::IngestStage);
    let views_stage: Arc<dyn ori_graph::Stage> = Arc::new(stages::ViewsStage);
    let bake_stage: Arc<dyn ori_graph::Stage> = Arc::new(stages::BakeStage);
    let output = |job: JobId, name: &str| Input::Output {
        job,
        name: name.to_string(),
    };
    let mut graph = Graph::new();
    let mut jobs = Vec::new();
    for asset in assets {
        let params = config.params_for(&asset.name);
        let format = ori_mesh::Format::from_path(&asset.path);
        let ingest = graph.add(JobSpec {
            asset: asset.name.clone(),
            stage: ingest_stage.clone(),
            params: match format {
                Some(f) => ingest::params(f, &params.ingest),
                None => serde_json::json!({ "format": null }),
            },
            inputs: vec![("source".into(), Input::Source(asset.path.clone()))],
        });
        let views = graph.add(JobSpec {
            asset: asset.name.clone(),
            stage: views_stage.clone(),
            params: to_json(&params.views),
            inputs: vec![(ingest::MESH.into(), output(ingest, ingest::MESH))],
        });
        let bake = graph.add(JobSpec {
            asset: asset.name.clone(),
            stage: bake_stage.clone(),
            params: to_json(&params.bake),
            inputs: vec![
                (ingest::MESH.into(), output(ingest, ingest::MESH)),
                (stages::VIEWS.into(), output(views, stages::VIEWS)),
            ],
        });
        jobs.push(AssetJobs {
            asset: asset.clone(),
            ingest,
            views,
            bake,
        });
    }
    (graph, jobs)
}

fn to_json<T: Serialize>(value: &T) -> serde_json::Value {
    serde_json::to_value(value).expect("parameters serialise to JSON")
}

/// Counts and times of a finished build.
#[derive(Clone, Debug, Serialize)]
pub struct BuildSummary {
    pub assets: usize,
    pub stages: Vec<StageLine>,
    pub failed_jobs: usize,
    pub wall_seconds: f64,
    /// Source files read and hashed (the rest came from the stat memo).
    pub sources_hashed: u64,
    pub dry_run: bool,
    /// Where the report was written (not for dry runs).
    pub report: Option<PathBuf>,
}

/// One stage's line of the summary.
#[derive(Clone, Debug, Serialize)]
pub struct StageLine {
    pub stage: String,
    pub ran: usize,
    pub reused: usize,
    pub would_run: usize,
    pub failed: usize,
    pub skipped: usize,
    pub seconds: f64,
}

/// One asset in `report.json`.
#[derive(Serialize)]
struct AssetReport {
    name: String,
    status: &'static str,
    error: Option<String>,
    warnings: Vec<String>,
    mesh: Option<ingest::MeshSummary>,
    mesh_hash: Option<String>,
    /// Content hash of the baked relief maps.
    maps_hash: Option<String>,
}

/// `report.json`: what was built. Timings live in the summary, which is printed, so the
/// report bytes depend only on the inputs.
#[derive(Serialize)]
struct Report {
    assets: Vec<AssetReport>,
}

/// Run the pipeline: read the configuration, discover assets, run the graph, write
/// `report.json` into the output folder.
pub fn build_assets(options: &BuildOptions) -> Result<BuildSummary, PipelineError> {
    let start = Instant::now();
    let config = Config::load(&options.config)?;
    let root = options
        .assets
        .clone()
        .unwrap_or_else(|| config.resolve(&config.assets.root));
    let out_dir = options
        .out
        .clone()
        .unwrap_or_else(|| config.resolve(&config.output.dir));
    let cache_dir = options
        .cache
        .clone()
        .unwrap_or_else(|| config.resolve(&config.cache.dir));
    let assets = discover(&root, &config.assets)?;
    if assets.is_empty() {
        return Err(PipelineError::Assets(format!(
            "no assets under {} match {:?}",
            root.display(),
            config.assets.include
        )));
    }
    let cache = Cache::open(&cache_dir).map_err(|e| PipelineError::Output {
        path: cache_dir.clone(),
        message: format!("cannot create the cache folder: {e}"),
    })?;
    let (graph, jobs) = plan(&config, &assets);
    let progress = Progress::new(&graph, options.progress, options.explain || options.dry_run);
    let run_options = RunOptions {
        threads: options.threads,
        dry_run: options.dry_run,
    };
    let build = ori_graph::run(&graph, &cache, &run_options, &progress);
    progress.finish();

    let mut report = Report { assets: Vec::new() };
    let mut unreadable_outputs = 0;
    for j in &jobs {
        // Built now or reused: the same bytes either way, so the same status.
        let mut status = "ok";
        let mut error = None;
        for id in j.all() {
            match &build.result(id).outcome {
                Outcome::Reused | Outcome::Ran(_) => {}
                Outcome::WouldRun(_) => status = "not built (dry run)",
                Outcome::Failed(m) => {
                    status = "failed";
                    error = Some(m.clone());
                    break;
                }
                Outcome::Skipped => status = "failed",
            }
        }
        let result = build.result(j.ingest);
        let warnings = j
            .all()
            .iter()
            .flat_map(|&id| build.result(id).warnings.clone())
            .collect();
        let mut entry = AssetReport {
            name: j.asset.name.clone(),
            status,
            error,
            warnings,
            mesh: None,
            mesh_hash: result.outputs.get(ingest::MESH).map(|b| b.hash.to_hex()),
            maps_hash: build
                .result(j.bake)
                .outputs
                .get(stages::MAPS)
                .map(|b| b.hash.to_hex()),
        };
        if let Some(dir) = options.dump_maps.as_ref().filter(|_| status == "ok")
            && let Err(e) = dump_maps(&build, j, dir)
        {
            unreadable_outputs += 1;
            entry.status = "failed";
            entry.error = Some(e);
        }
        if matches!(result.outcome, Outcome::Reused | Outcome::Ran(_)) {
            match build.read_output(j.ingest, ingest::SUMMARY) {
                Ok(bytes) => entry.mesh = serde_json::from_slice(&bytes).ok(),
                Err(e) => {
                    unreadable_outputs += 1;
                    entry.status = "failed";
                    entry.error = Some(e.to_string());
                }
            }
        }
        report.assets.push(entry);
    }
    let failed_jobs = graph
        .jobs()
        .filter(|(id, _)| matches!(build.result(*id).outcome, Outcome::Failed(_)))
        .count()
        + unreadable_outputs;

    let report_path = if options.dry_run {
        None
    } else {
        let path = out_dir.join("report.json");
        let json = serde_json::to_vec_pretty(&report).expect("report serialises");
        ori_graph::write_atomic(&path, &json).map_err(|e| PipelineError::Output {
            path: path.clone(),
            message: format!("cannot write: {e}"),
        })?;
        Some(path)
    };

    let stages = build
        .summary()
        .into_iter()
        .map(|s| StageLine {
            stage: s.stage.to_string(),
            ran: s.ran,
            reused: s.reused,
            would_run: s.would_run,
            failed: s.failed,
            skipped: s.skipped,
            seconds: secs(s.time),
        })
        .collect();
    Ok(BuildSummary {
        assets: assets.len(),
        stages,
        failed_jobs,
        wall_seconds: secs(start.elapsed()),
        sources_hashed: build.sources_rehashed(),
        dry_run: options.dry_run,
        report: report_path,
    })
}

/// Write `<dir>/<asset>/map-NN-{depth,normal,albedo}.png` for every relief map of an asset.
fn dump_maps(build: &ori_graph::Build<'_>, jobs: &AssetJobs, dir: &Path) -> Result<(), String> {
    let bytes = build
        .read_output(jobs.bake, stages::MAPS)
        .map_err(|e| e.to_string())?;
    let set = stages::decode_maps(&bytes)?;
    let folder = dir.join(&jobs.asset.name);
    for (i, map) in set.maps.iter().enumerate() {
        ori_bake::write_pngs(map, &folder, &format!("map-{i:02}"))?;
    }
    Ok(())
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

/// The summary as the table printed at the end of a build.
pub fn format_summary(s: &BuildSummary) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "{:<10} {:>6} {:>7} {:>7} {:>9}\n",
        "stage", "ran", "reused", "failed", "time (s)"
    ));
    for l in &s.stages {
        let ran = if s.dry_run { l.would_run } else { l.ran };
        out.push_str(&format!(
            "{:<10} {:>6} {:>7} {:>7} {:>9.2}\n",
            l.stage,
            ran,
            l.reused,
            l.failed + l.skipped,
            l.seconds
        ));
    }
    let verb = if s.dry_run { "would run" } else { "built" };
    out.push_str(&format!(
        "{} assets {verb} in {:.2} s ({} source files hashed)",
        s.assets, s.wall_seconds, s.sources_hashed
    ));
    if let Some(r) = &s.report {
        out.push_str(&format!("; report: {}", r.display()));
    }
    out
}

/// The default configuration file name.
pub fn default_config() -> &'static Path {
    Path::new("pipeline.toml")
}
