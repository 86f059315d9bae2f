//! `report.json` (`ori_release::BuildReport`) from a finished build: per asset, whether it
//! built, what it measured and what each of its jobs did; and the packages to release.

use std::path::Path;

use ori_graph::{Build, Graph, Outcome};
use ori_release::{
    AssetReport, AssetStatus, AutoReport, BuildReport, HeldOutReport, JobReport, JobStatus,
    MeshSummary, QualityReport,
};
use rayon::prelude::*;

use crate::plan::AssetJobs;
use crate::release::BuiltPackage;
use crate::stages::Artifact;
use crate::stages::bake::MAPS;
use crate::stages::ingest::{MESH, SUMMARY};
use crate::stages::package::PACKAGE;
use crate::stages::plt::{HELD_OUT, PLT};
use crate::stages::select::SELECTION;

/// Bumped when a report entry computed from the same outputs changes (the asset memo keeps
/// entries, and a stage's version covers only its own outputs).
pub const ENTRY_VERSION: u32 = 1;

/// What the final run produced.
pub struct Collected<'a> {
    pub report: BuildReport,
    /// The package of every asset that built.
    pub packages: Vec<BuiltPackage<'a>>,
    /// Outputs that could not be read back (each also fails its asset).
    pub unreadable: usize,
}

/// What to read from the final run.
pub struct Reading<'a> {
    /// Read outputs (false for a dry run: a result found in the remote cache is not
    /// downloaded).
    pub outputs: bool,
    /// Also write pictures of every asset's relief maps here.
    pub dump_maps: Option<&'a Path>,
}

/// The status of a job in `report.json`.
fn job_status(outcome: &Outcome) -> JobStatus {
    match outcome {
        Outcome::Reused => JobStatus::Reused,
        Outcome::Ran(_) => JobStatus::Ran,
        Outcome::WouldRun(_) => JobStatus::WouldRun,
        Outcome::Failed(_) => JobStatus::Failed,
        Outcome::Skipped => JobStatus::Skipped,
        Outcome::NotCached => JobStatus::NotCached,
    }
}

/// Whether an asset built, and the first error among its jobs.
fn asset_status(
    graph: &Graph,
    build: &Build<'_>,
    jobs: &AssetJobs,
) -> (AssetStatus, Option<String>) {
    // Built now or reused: the same bytes either way, so the same status.
    let mut status = AssetStatus::Ok;
    for id in jobs.all() {
        match &build.result(id).outcome {
            Outcome::Reused | Outcome::Ran(_) => {}
            Outcome::WouldRun(_) => status = AssetStatus::NotBuilt,
            Outcome::Failed(m) => return (AssetStatus::Failed, Some(m.clone())),
            Outcome::Skipped => status = AssetStatus::Failed,
            Outcome::NotCached => {
                let stage = graph.job(id).stage.name();
                let error = format!("stage `{stage}` is not in the cache");
                return (AssetStatus::Failed, Some(error));
            }
        }
    }
    (status, None)
}

/// The selection and PLT outputs of an asset as its quality entry.
fn quality(build: &Build<'_>, jobs: &AssetJobs, seed: u64) -> Result<QualityReport, String> {
    let selection = SELECTION.read_from(build, jobs.select)?;
    let plt = PLT.read_from(build, jobs.plt)?;
    let held_out = HELD_OUT.read_from(build, jobs.plt)?;
    let stats = selection.stats();
    Ok(QualityReport {
        held_out: HeldOutReport {
            directions: held_out.views.len(),
            seed,
            coverage_error_max_percent: held_out.max_percent(),
            coverage_error_avg_percent: held_out.avg_percent(),
            impostors_per_view: held_out.avg_impostors(),
        },
        coverage_error_min_percent: stats.min_percent,
        coverage_error_max_percent: stats.max_percent,
        coverage_error_avg_percent: stats.avg_percent,
        impostors_per_view: stats.avg_impostors,
        views_by_impostor_count: stats.views_by_count,
        s0: plt.s0,
        gc: plt.gc,
        plt: plt.pixels(),
        plt_is_lower_bound: matches!(plt.value(), ori_plt::PltValue::AtLeast(_)),
        recommended_resolution: plt.recommended_resolution(),
    })
}

/// Read every asset's results from the final run. `resolutions`, `seeds` (of the held-out
/// directions) and `auto` are per asset, in the order of `jobs`. Assets are read in parallel
/// and listed in order.
pub fn collect<'a>(
    graph: &Graph,
    build: &'a Build<'_>,
    jobs: &[AssetJobs],
    resolutions: &[u32],
    seeds: &[u64],
    auto: &[Option<AutoReport>],
    reading: &Reading<'_>,
) -> Collected<'a> {
    let assets: Vec<(AssetReport, Option<BuiltPackage<'a>>, usize)> = jobs
        .par_iter()
        .enumerate()
        .map(|(index, j)| {
            let built = Built {
                resolution: resolutions[index],
                seed: seeds[index],
                auto: auto[index].clone(),
            };
            collect_asset(graph, build, j, built, reading)
        })
        .collect();
    let mut collected = Collected {
        report: BuildReport::default(),
        packages: Vec::new(),
        unreadable: 0,
    };
    for (entry, package, unreadable) in assets {
        collected.report.assets.push(entry);
        collected.packages.extend(package);
        collected.unreadable += unreadable;
    }
    collected
}

/// What the build decided for an asset, beside its jobs.
struct Built {
    resolution: u32,
    seed: u64,
    auto: Option<AutoReport>,
}

/// One asset's report entry, its package if it built, and how many of its outputs could not
/// be read back.
fn collect_asset<'a>(
    graph: &Graph,
    build: &'a Build<'_>,
    j: &AssetJobs,
    built: Built,
    reading: &Reading<'_>,
) -> (AssetReport, Option<BuiltPackage<'a>>, usize) {
    let mut unreadable = 0;
    let mut package = None;
    let (status, error) = asset_status(graph, build, j);
    let ingest = build.result(j.ingest);
    let mut entry = AssetReport {
        name: j.asset.name.clone(),
        status,
        error,
        warnings: j
            .all()
            .iter()
            .flat_map(|&id| build.result(id).warnings.clone())
            .collect(),
        mesh: None,
        mesh_hash: ingest.outputs.get(MESH.name).map(|b| b.hash.to_hex()),
        maps_hash: build
            .result(j.bake)
            .outputs
            .get(MAPS.name)
            .map(|b| b.hash.to_hex()),
        quality: None,
        resolution: built.resolution,
        auto_resolution: built.auto,
        jobs: j
            .all()
            .iter()
            .map(|&id| {
                let r = build.result(id);
                JobReport {
                    stage: graph.job(id).stage.name().to_string(),
                    status: job_status(&r.outcome),
                    seconds: r.duration.as_secs_f64(),
                }
            })
            .collect(),
        gate: Vec::new(),
    };
    let mut fail = |entry: &mut AssetReport, e: String| {
        unreadable += 1;
        entry.status = AssetStatus::Failed;
        entry.error = Some(e);
    };
    let readable = status == AssetStatus::Ok && reading.outputs;
    if readable {
        let job = j.package;
        let blob = build.result(job).outputs.get(PACKAGE.name).cloned();
        let blob = blob.ok_or_else(|| format!("output `{}` is missing", PACKAGE.name));
        match quality(build, j, built.seed).and_then(|q| Ok((q, blob?))) {
            Ok((q, blob)) => {
                entry.quality = Some(q);
                package = Some(BuiltPackage {
                    name: j.asset.name.clone(),
                    blob,
                    read: Box::new(move || PACKAGE.read_from(build, job).map(|p| p.0)),
                });
            }
            Err(e) => fail(&mut entry, e),
        }
    }
    if let Some(dir) = reading.dump_maps.filter(|_| readable)
        && let Err(e) = crate::outputs::dump_maps(build, j, dir)
    {
        fail(&mut entry, e);
    }
    if reading.outputs && matches!(ingest.outcome, Outcome::Reused | Outcome::Ran(_)) {
        match build.read_output(j.ingest, SUMMARY.name) {
            Ok(bytes) => entry.mesh = MeshSummary::decode(&bytes).ok(),
            Err(e) => fail(&mut entry, e.to_string()),
        }
    }
    (entry, package, unreadable)
}
