//! `build-assets` and `assemble`: read the configuration, discover the assets, decide what
//! the searches decide, run the plan, and write what the mode asks for.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use ori_graph::{Cache, Observer, Outcome, RemoteCache, RunOptions};
use ori_release::{AssetStatus, REPORT_JSON};

use crate::config::{Config, StageParams};
use crate::discover::{Asset, discover};
use crate::plan::{PlannedAsset, plan};
use crate::report::{Collected, Reading, collect};
use crate::runs::Runs;
use crate::shard::{self, Shard};
use crate::summary::{BuildSummary, RemoteSummary};
use crate::{PipelineError, outputs, release, search};

/// What a build is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Run what the caches lack, write the release.
    Release,
    /// Run what the caches lack for one part of the assets; write no release
    /// (`--shard K/N`: `assemble` writes it once every part is built).
    Shard(Shard),
    /// Run no stage: take every result from the caches (local, then remote) and write the
    /// release, or fail naming the assets that are not fully cached (`assemble`).
    Assemble,
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
    pub mode: Mode,
    /// Decide and report what would run, run nothing and write nothing (`--dry-run`).
    pub dry_run: bool,
    /// Write PNG pictures of every relief map into this folder.
    pub dump_maps: Option<PathBuf>,
    /// Write every package as an inspectable folder into this folder.
    pub explode: Option<PathBuf>,
    /// Measure selection with the wgpu renderer on this adapter (`--backend gpu`; the
    /// adapter's summary, from `gpu_select::renderer`), instead of the CPU evaluator.
    pub gpu_select: Option<String>,
}

/// The configuration read and the assets found: what every mode starts from.
struct Setup {
    out_dir: PathBuf,
    /// Every asset found, and those this build is for (a shard's part, or all).
    all_assets: usize,
    assets: Vec<Asset>,
    params: Vec<StageParams>,
    limits: ori_mesh::Limits,
    cache: Cache,
    run_options: RunOptions,
    remote: Option<Arc<RemoteCache>>,
}

fn setup(options: &BuildOptions) -> Result<Setup, PipelineError> {
    let config = Config::load(&options.config)?;
    let chosen = |arg: &Option<PathBuf>, configured: &PathBuf| {
        arg.clone().unwrap_or_else(|| config.resolve(configured))
    };
    let root = chosen(&options.assets, &config.assets.root);
    let out_dir = chosen(&options.out, &config.output.dir);
    let cache_dir = chosen(&options.cache, &config.cache.dir);
    let all_assets = discover(&root, &config.assets)?;
    if all_assets.is_empty() {
        return Err(PipelineError::Assets(format!(
            "no assets under {} match {:?}",
            root.display(),
            config.assets.include
        )));
    }
    let assets = match options.mode {
        Mode::Shard(s) => shard::select(&all_assets, s),
        Mode::Release | Mode::Assemble => all_assets.clone(),
    };
    let remote = match &config.cache.remote {
        Some(r) => Some(Arc::new(r.open().map_err(|message| {
            PipelineError::Config {
                path: options.config.clone(),
                message,
            }
        })?)),
        None => None,
    };
    let mut params = Vec::with_capacity(assets.len());
    for a in &assets {
        params.push(StageParams {
            select_device: options.gpu_select.clone(),
            ..config.params_for(&a.name)?
        });
    }
    let cache = Cache::open(&cache_dir).map_err(|e| PipelineError::Output {
        path: cache_dir.clone(),
        message: format!("cannot create the cache folder: {e}"),
    })?;
    let run_options = RunOptions {
        threads: options.threads,
        dry_run: options.dry_run,
        remote: remote.clone(),
        cached_only: options.mode == Mode::Assemble,
        sources: config.limits.source_rules(&root)?,
    };
    Ok(Setup {
        out_dir,
        all_assets: all_assets.len(),
        assets,
        params,
        limits: config.limits.mesh(),
        cache,
        run_options,
        remote,
    })
}

/// Run the pipeline: read the configuration, discover assets, run the graph, and write the
/// release and `report.json` into the output folder (as `options.mode` says). `observer`
/// is told about every job of every run.
pub fn build_assets(
    options: &BuildOptions,
    observer: &dyn Observer,
) -> Result<BuildSummary, PipelineError> {
    let start = Instant::now();
    let Setup {
        out_dir,
        all_assets,
        assets,
        mut params,
        limits,
        cache,
        run_options,
        remote,
    } = setup(options)?;
    let mut runs = Runs {
        cache,
        options: run_options,
        observer,
        stages: Vec::new(),
        sources_hashed: 0,
    };
    // `auto` resolutions are measured first, then hierarchies' shapes (a dry run plans the
    // first guess and single ORIs only).
    let (auto, trees) = if options.dry_run {
        (vec![None; assets.len()], vec![None; assets.len()])
    } else {
        let auto = search::choose_resolutions(&assets, &mut params, limits, &mut runs);
        let trees = search::choose_trees(&assets, &params, limits, &mut runs);
        (auto, trees)
    };
    let resolutions: Vec<u32> = params.iter().map(|p| p.bake.resolution).collect();
    let seeds: Vec<u64> = params.iter().map(|p| p.plt.held_out_seed).collect();
    let planned: Vec<PlannedAsset> = assets
        .iter()
        .zip(params)
        .zip(trees)
        .map(|((asset, params), tree)| PlannedAsset {
            asset: asset.clone(),
            params,
            measure_only: false,
            tree,
        })
        .collect();
    let (graph, jobs) = plan(&planned, limits);
    let build = runs.run(&graph);
    let reading = Reading {
        outputs: !options.dry_run,
        dump_maps: options.dump_maps.as_deref(),
    };
    let Collected {
        report,
        packages,
        unreadable,
    } = collect(&graph, &build, &jobs, &resolutions, &seeds, &auto, &reading);
    let failed_jobs = graph
        .jobs()
        .filter(|(id, _)| matches!(build.result(*id).outcome, Outcome::Failed(_)))
        .count()
        + unreadable;

    if options.mode == Mode::Assemble && !options.dry_run {
        let missing: Vec<String> = report
            .assets
            .iter()
            .filter(|a| a.status != AssetStatus::Ok)
            .map(|a| match &a.error {
                Some(e) => format!("{}: {e}", a.name),
                None => format!("{}: {}", a.name, a.status.as_str()),
            })
            .collect();
        if !missing.is_empty() {
            return Err(PipelineError::NotCached(missing));
        }
    }
    if !options.dry_run
        && let Some(dir) = &options.explode
    {
        outputs::explode(dir, &packages)?;
    }
    let write_release = !options.dry_run && !matches!(options.mode, Mode::Shard(_));
    let mut warnings = Vec::new();
    let mut report_path = None;
    if write_release {
        let memo = release::ReleaseMemo::open(runs.cache.root());
        let written = release::write(&out_dir, &packages, &memo)
            .map_err(|(path, message)| PipelineError::Output { path, message })?;
        warnings.extend(written.warnings);
        let path = out_dir.join(REPORT_JSON);
        let json = serde_json::to_vec_pretty(&report).expect("report serialises");
        ori_graph::write_atomic(&path, &json).map_err(|e| PipelineError::Output {
            path: path.clone(),
            message: format!("cannot write: {e}"),
        })?;
        report_path = Some(path);
    }
    Ok(BuildSummary {
        assets: assets.len(),
        failed_assets: report
            .assets
            .iter()
            .filter(|a| a.status == AssetStatus::Failed)
            .count(),
        warnings,
        stages: runs.stages,
        failed_jobs,
        wall_seconds: start.elapsed().as_secs_f64(),
        sources_hashed: runs.sources_hashed,
        dry_run: options.dry_run,
        report: report_path,
        shard: match options.mode {
            Mode::Shard(s) => Some((s, all_assets)),
            Mode::Release | Mode::Assemble => None,
        },
        remote: remote.as_deref().map(RemoteSummary::of),
    })
}
