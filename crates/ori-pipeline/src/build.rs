//! `build-assets` and `assemble`: read the configuration, discover the assets, decide what
//! the searches decide, run the plan, and write what the mode asks for.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use ori_graph::{BlobRef, Cache, Observer, Outcome, RemoteCache, RunOptions, SourceHasher};
use ori_release::{AssetReport, AssetStatus, BuildReport, REPORT_JSON, Release};
use rayon::prelude::*;

use crate::config::{Config, StageParams};
use crate::discover::{Asset, discover};
use crate::gate::GateParams;
use crate::plan::{PlannedAsset, plan};
use crate::release::BuiltPackage;
use crate::report::{Reading, collect};
use crate::runs::Runs;
use crate::shard::{self, Shard};
use crate::stages::Registry;
use crate::summary::{BuildSummary, ExecutionSummary, RemoteSummary, StageLine, WrittenRelease};
use crate::unchanged::{AssetMemo, Looked, Unchanged};
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
    /// Run the jobs on this REAPI farm (`grpc://host:port`) instead of `[execution] remote`.
    pub remote_exec: Option<String>,
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
    // Remote execution runs jobs; a dry run and `assemble` run none.
    let farm = options
        .remote_exec
        .as_ref()
        .or(config.execution.remote.as_ref());
    let execution = match farm {
        Some(url) if !options.dry_run && options.mode != Mode::Assemble => Some(Arc::new(
            config
                .execution
                .open(url, &config.limits)
                .map_err(|message| PipelineError::Config {
                    path: options.config.clone(),
                    message,
                })?,
        )),
        _ => None,
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
        shared_sources: None,
        execution,
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

/// Note in each built asset's report entry what its package misses of its gate.
fn check_gates(report: &mut BuildReport, release: &Release, gates: &HashMap<&str, GateParams>) {
    // Most builds set no gate: no per-asset work then.
    if gates.is_empty() {
        return;
    }
    let texture_bytes: HashMap<&str, u64> = release
        .assets
        .iter()
        .map(|e| (e.name.as_str(), e.texture_bytes))
        .collect();
    for entry in &mut report.assets {
        let gate = gates.get(entry.name.as_str());
        let bytes = texture_bytes.get(entry.name.as_str());
        if let (Some(gate), Some(quality), Some(&bytes)) = (gate, &entry.quality, bytes) {
            entry.gate = gate.missed(quality, bytes);
        }
    }
}

/// Memo files of earlier versions, now memo folders: removed by a build that saves its memos.
const LEGACY_MEMOS: [&str; 2] = ["asset-memo.json", "release-checked.json"];

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
        params,
        limits,
        cache,
        mut run_options,
        remote,
    } = setup(options)?;
    // One stat memo for the memo's look-ups and every run.
    let sources = Arc::new(SourceHasher::new(
        cache.stat_memo_path(),
        run_options.sources.clone(),
    ));
    run_options.shared_sources = Some(sources.clone());
    if let Some(warning) = sources.damage_warning() {
        observer.note(&warning);
    }
    let memo = AssetMemo::open(&cache, &Registry::new(limits), limits, &run_options.sources);
    if let Some(why) = &memo.damaged {
        observer.note(&format!(
            "warning: asset memo: {why}; the assets it held go through the graph"
        ));
    }
    let release_memo = release::ReleaseMemo::open(&cache);
    let write_release = !options.dry_run && !matches!(options.mode, Mode::Shard(_));
    // A package the release will read (to check it or copy it) is read now, so a damaged one
    // is built again instead.
    let usable = |asset: &Asset, blob: &BlobRef| {
        let path = out_dir.join(release::package_path(&asset.name));
        let unread =
            !write_release || (release_memo.knows(blob) && release_memo.holds(&path, blob));
        cache.blob_present(blob) && (unread || cache.read_blob(blob).is_ok())
    };
    // Maps need the bake's outputs, which an unchanged asset does not look up; exploded
    // packages are read whatever the release knows.
    let use_memo = options.dump_maps.is_none() && options.explode.is_none();
    let looked: Vec<Looked> = assets
        .par_iter()
        .zip(&params)
        .map(|(asset, params)| match use_memo {
            true => memo.look_up(asset, params, &sources, usable),
            false => Looked::Build(None),
        })
        .collect();
    let mut runs = Runs {
        cache,
        options: run_options,
        observer,
        stages: Vec::new(),
    };
    // Each asset's gate, checked once its package is in the release.
    let gates: HashMap<&str, GateParams> = assets
        .iter()
        .zip(&params)
        .filter(|(_, p)| p.gate != GateParams::default())
        .map(|(a, p)| (a.name.as_str(), p.gate.clone()))
        .collect();
    let mut entries: Vec<Option<AssetReport>> = vec![None; assets.len()];
    let mut unchanged_packages: Vec<(usize, BuiltPackage<'static>)> = Vec::new();
    let mut changed = Vec::new();
    let mut changed_params = Vec::new();
    for (i, (look, params)) in looked.into_iter().zip(params).enumerate() {
        match look {
            Looked::Unchanged(unchanged) => {
                let Unchanged {
                    report,
                    package,
                    warnings,
                } = *unchanged;
                let stages: Vec<String> = report.jobs.iter().map(|j| j.stage.clone()).collect();
                observer.asset_unchanged(&report.name, &stages);
                for (label, warning) in warnings {
                    observer.note(&format!("warning: {label}: {warning}"));
                }
                StageLine::add_reused(&mut runs.stages, &stages);
                entries[i] = Some(report);
                unchanged_packages.push((i, package));
            }
            Looked::Build(pending) => {
                changed.push((i, pending));
                changed_params.push(params);
            }
        }
    }
    let changed_assets: Vec<Asset> = changed.iter().map(|&(i, _)| assets[i].clone()).collect();
    let mut params = changed_params;

    // `auto` resolutions are measured first, then hierarchies' shapes (a dry run plans the
    // first guess and single ORIs only).
    let (auto, trees) = if options.dry_run {
        (
            vec![None; changed_assets.len()],
            vec![None; changed_assets.len()],
        )
    } else {
        let auto = search::choose_resolutions(&changed_assets, &mut params, limits, &mut runs);
        let trees = search::choose_trees(&changed_assets, &params, limits, &mut runs);
        (auto, trees)
    };
    let resolutions: Vec<u32> = params.iter().map(|p| p.bake.resolution).collect();
    let seeds: Vec<u64> = params.iter().map(|p| p.plt.held_out_seed).collect();
    let planned: Vec<PlannedAsset> = changed_assets
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
    let collected = collect(&graph, &build, &jobs, &resolutions, &seeds, &auto, &reading);
    let failed_jobs = graph
        .jobs()
        .filter(|(id, _)| matches!(build.result(*id).outcome, Outcome::Failed(_)))
        .count()
        + collected.unreadable;
    // Back into asset order, and remembered where they built whole.
    let mut packages: Vec<(usize, BuiltPackage<'_>)> = unchanged_packages;
    let mut built: HashMap<String, BuiltPackage<'_>> = collected
        .packages
        .into_iter()
        .map(|p| (p.name.clone(), p))
        .collect();
    for (((i, pending), entry), j) in changed.iter().zip(collected.report.assets).zip(&jobs) {
        let package = built.remove(entry.name.as_str());
        if let Some(pending) = pending.filter(|_| !options.dry_run) {
            let blob = package.as_ref().map(|p| &p.blob);
            memo.remember(pending, &sources, (&graph, &build), j, &entry, blob);
        }
        packages.extend(package.map(|p| (*i, p)));
        entries[*i] = Some(entry);
    }
    packages.sort_by_key(|&(i, _)| i);
    let packages: Vec<BuiltPackage<'_>> = packages.into_iter().map(|(_, p)| p).collect();
    let mut report = BuildReport {
        assets: entries.into_iter().flatten().collect(),
    };

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
    let mut warnings = Vec::new();
    let mut report_path = None;
    let mut release_written = None;
    if write_release {
        let written = release::write(&out_dir, &packages, &release_memo)
            .map_err(|(path, message)| PipelineError::Output { path, message })?;
        warnings.extend(written.warnings);
        check_gates(&mut report, &written.release, &gates);
        release_written = Some(written.release);
        let path = out_dir.join(REPORT_JSON);
        let json = serde_json::to_vec_pretty(&report).expect("report serialises");
        ori_graph::write_atomic(&path, &json).map_err(|e| PipelineError::Output {
            path: path.clone(),
            message: format!("cannot write: {e}"),
        })?;
        report_path = Some(path);
    }
    if !options.dry_run {
        if options.mode == Mode::Release {
            memo.keep_only(&assets.iter().map(|a| a.name.as_str()).collect());
        }
        for legacy in LEGACY_MEMOS {
            let _ = std::fs::remove_file(runs.cache.root().join(legacy));
        }
        let saved = memo.save().and_then(|()| sources.save());
        if let Err(e) = saved {
            warnings.push(format!(
                "cannot save the memos in {}: {e}",
                runs.cache.root().display()
            ));
        }
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
        sources_hashed: sources.rehashed(),
        dry_run: options.dry_run,
        report: report_path,
        shard: match options.mode {
            Mode::Shard(s) => Some((s, all_assets)),
            Mode::Release | Mode::Assemble => None,
        },
        remote: remote.as_deref().map(RemoteSummary::of),
        execution: runs.options.execution.as_deref().map(ExecutionSummary::of),
        missed_gate: report
            .assets
            .iter()
            .filter(|a| !a.gate.is_empty())
            .map(|a| (a.name.clone(), a.gate.clone()))
            .collect(),
        written: release_written.map(|release| WrittenRelease {
            report,
            release,
            sources,
        }),
    })
}
