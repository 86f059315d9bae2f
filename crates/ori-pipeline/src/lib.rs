//! The asset pipeline: configuration, asset discovery, and the stages wired into the build
//! graph. `cargo xtask build-assets` is a thin command line over [`build_assets`].
//!
//! Data flows one way: model file -> ingest (canonical mesh) -> later stages. Each stage is a
//! [`ori_graph::Stage`]; adding one means adding its job to [`plan`] and its parameters to
//! [`config::StageParams`], without touching the graph crate.

pub mod config;
pub mod discover;
pub mod gpu_select;
pub mod hierarchy;
pub mod ingest;
pub mod package;
pub mod release;
pub mod shard;
pub mod stages;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use ori_graph::{RemoteCache, RemoteMode, RemoteStats};
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
    /// `assemble` found assets whose results are not all in the cache (one line each:
    /// the asset and what is missing).
    #[error(
        "{} asset(s) not fully in the cache (build them first, e.g. with `build-assets --shard K/N`); no release written:\n  {}",
        .0.len(),
        .0.join("\n  ")
    )]
    NotCached(Vec<String>),
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
    /// Write every package as an inspectable folder into this folder.
    pub explode: Option<PathBuf>,
    /// Build only this part of the assets, and write no release (`--shard K/N`).
    pub shard: Option<shard::Shard>,
    /// Run no stage: take every result from the caches (local, then remote) and write the
    /// release, or fail naming the assets that are not fully cached (`assemble`).
    pub assemble: bool,
    /// Measure selection with the wgpu renderer on this adapter (`--backend gpu`; the
    /// adapter's summary, from `gpu_select::renderer`), instead of the CPU evaluator.
    pub gpu_select: Option<String>,
}

/// The jobs of one asset. For a hierarchy, the chain fields are the root node's and
/// `package` is the hierarchy job.
#[derive(Clone, Debug)]
pub struct AssetJobs {
    pub asset: Asset,
    pub ingest: JobId,
    pub views: JobId,
    pub place: JobId,
    pub bake: JobId,
    pub select: JobId,
    pub plt: JobId,
    pub compress: JobId,
    pub package: JobId,
    /// The other nodes' jobs of a hierarchy (clip and chain), upstream first.
    pub nodes: Vec<JobId>,
    /// Per hierarchy node, root first: the job whose `mesh` output is its mesh (ingest for
    /// the root, else its clip) and its PLT job. Just the root's for a single ORI.
    pub measured: Vec<(JobId, JobId)>,
}

impl AssetJobs {
    /// Every job of the asset, upstream first.
    pub fn all(&self) -> Vec<JobId> {
        let mut all = vec![
            self.ingest,
            self.views,
            self.place,
            self.bake,
            self.select,
            self.plt,
            self.compress,
        ];
        all.extend(&self.nodes);
        all.push(self.package);
        all.dedup();
        all
    }
}

/// One asset to plan: its parameters (overrides applied, resolution decided), whether it
/// gets the whole chain or, while `auto` resolution or a hierarchy's shape is measured, only
/// the jobs up to its PLT, and its hierarchy's shape once decided.
#[derive(Clone, Debug)]
pub struct PlannedAsset {
    pub asset: Asset,
    pub params: config::StageParams,
    pub measure_only: bool,
    pub tree: Option<hierarchy::PlannedTree>,
}

/// Every stage, shared by the jobs of one plan.
struct Stages {
    ingest: Arc<dyn ori_graph::Stage>,
    views: Arc<dyn ori_graph::Stage>,
    place: Arc<dyn ori_graph::Stage>,
    bake: Arc<dyn ori_graph::Stage>,
    select: Arc<dyn ori_graph::Stage>,
    plt: Arc<dyn ori_graph::Stage>,
    compress: Arc<dyn ori_graph::Stage>,
    package: Arc<dyn ori_graph::Stage>,
    clip: Arc<dyn ori_graph::Stage>,
    hierarchy: Arc<dyn ori_graph::Stage>,
}

impl Stages {
    fn new(limits: ori_mesh::Limits) -> Stages {
        Stages {
            ingest: Arc::new(ingest::IngestStage { limits }),
            views: Arc::new(stages::ViewsStage),
            place: Arc::new(stages::PlaceStage),
            bake: Arc::new(stages::BakeStage),
            select: Arc::new(stages::SelectStage),
            plt: Arc::new(stages::PltStage),
            compress: Arc::new(package::CompressStage),
            package: Arc::new(package::PackageStage),
            clip: Arc::new(hierarchy::ClipStage),
            hierarchy: Arc::new(hierarchy::HierarchyStage),
        }
    }
}

fn output(job: JobId, name: &str) -> Input {
    Input::Output {
        job,
        name: name.to_string(),
    }
}

/// The jobs from a mesh to a package (`compress` and `package` are `None` when measuring).
struct Chain {
    views: JobId,
    place: JobId,
    bake: JobId,
    select: JobId,
    plt: JobId,
    compress: Option<JobId>,
    package: Option<JobId>,
}

impl Chain {
    fn jobs(&self) -> Vec<JobId> {
        let mut jobs = vec![self.views, self.place, self.bake, self.select, self.plt];
        jobs.extend(self.compress);
        jobs.extend(self.package);
        jobs
    }
}

/// Add the chain of one ORI of `asset` (labelled `label` in progress and messages) over the
/// mesh output `mesh` = (job, output name): the asset's own mesh, or a hierarchy node's part
/// of it. (Through a node's cuts one sees back faces, culled unless double-sided.)
fn plan_chain(
    graph: &mut Graph,
    stages: &Stages,
    label: &str,
    planned: &PlannedAsset,
    mesh: (JobId, &str),
) -> Chain {
    let (asset, params) = (&planned.asset, &planned.params);
    let job = |stage: &Arc<dyn ori_graph::Stage>, params, inputs| JobSpec {
        asset: label.to_string(),
        stage: stage.clone(),
        params,
        inputs,
    };
    let mesh_input = || (ingest::MESH.to_string(), output(mesh.0, mesh.1));
    let views = graph.add(job(
        &stages.views,
        to_json(&params.views),
        vec![mesh_input()],
    ));
    let place = graph.add(job(
        &stages.place,
        place_params(params),
        vec![
            mesh_input(),
            (stages::VIEWS.into(), output(views, stages::VIEWS)),
        ],
    ));
    let bake = graph.add(job(
        &stages.bake,
        to_json(&params.bake),
        vec![
            mesh_input(),
            (stages::VIEWS.into(), output(place, stages::VIEWS)),
        ],
    ));
    let select = graph.add(job(
        &stages.select,
        select_params(params),
        vec![
            mesh_input(),
            (stages::MAPS.into(), output(bake, stages::MAPS)),
        ],
    ));
    let plt = graph.add(job(
        &stages.plt,
        serde_json::json!({}),
        vec![(stages::SELECTION.into(), output(select, stages::SELECTION))],
    ));
    if planned.measure_only {
        return Chain {
            views,
            place,
            bake,
            select,
            plt,
            compress: None,
            package: None,
        };
    }
    let compress = graph.add(job(
        &stages.compress,
        to_json(&params.compress),
        vec![(stages::MAPS.into(), output(bake, stages::MAPS))],
    ));
    let package_params = package::PackageParams {
        name: asset.name.clone(),
        tool: package::tool(),
        depth: params.compress.depth,
        pipeline: recorded_params(params),
        measured_on: params.select_device.clone(),
    };
    let package = graph.add(job(
        &stages.package,
        to_json(&package_params),
        vec![
            // Hashed, never read: the manifest records the source's content hash.
            ("source".into(), Input::Source(asset.path.clone())),
            (stages::MAPS.into(), output(bake, stages::MAPS)),
            (stages::SELECTION.into(), output(select, stages::SELECTION)),
            (stages::PLT.into(), output(plt, stages::PLT)),
            (
                package::TEXTURES.into(),
                output(compress, package::TEXTURES),
            ),
        ],
    ));
    Chain {
        views,
        place,
        bake,
        select,
        plt,
        compress: Some(compress),
        package: Some(package),
    }
}

/// The ingest job of an asset.
fn plan_ingest(graph: &mut Graph, stages: &Stages, planned: &PlannedAsset) -> JobId {
    let (asset, params) = (&planned.asset, &planned.params);
    graph.add(JobSpec {
        asset: asset.name.clone(),
        stage: stages.ingest.clone(),
        params: match ori_mesh::Format::from_path(&asset.path) {
            Some(f) => ingest::params(f, &params.ingest),
            None => serde_json::json!({ "format": null }),
        },
        inputs: vec![("source".into(), Input::Source(asset.path.clone()))],
    })
}

/// The clip job of a hierarchy node: the asset's mesh clipped to `clip`.
fn plan_clip(
    graph: &mut Graph,
    stages: &Stages,
    label: String,
    ingest: JobId,
    clip: &ori_hierarchy::Cell,
) -> JobId {
    graph.add(JobSpec {
        asset: label,
        stage: stages.clip.clone(),
        params: to_json(&hierarchy::ClipParams {
            min: clip.min,
            max: clip.max,
        }),
        inputs: vec![(ingest::MESH.into(), output(ingest, ingest::MESH))],
    })
}

/// How a hierarchy node's jobs are labelled in progress lines and messages.
fn node_label(asset: &str, node: usize) -> String {
    format!("{asset} [node {node}]")
}

/// Build the job graph for `assets`; models are loaded within `limits`.
pub fn plan(assets: &[PlannedAsset], limits: ori_mesh::Limits) -> (Graph, Vec<AssetJobs>) {
    let stages = Stages::new(limits);
    let mut graph = Graph::new();
    let mut jobs = Vec::new();
    for planned in assets {
        let asset = &planned.asset;
        let ingest = plan_ingest(&mut graph, &stages, planned);
        let root = plan_chain(
            &mut graph,
            &stages,
            &asset.name,
            planned,
            (ingest, ingest::MESH),
        );
        let mut nodes = Vec::new();
        let mut measured = vec![(ingest, root.plt)];
        let mut package = root.package;
        if let Some(tree) = &planned.tree {
            let mut node_packages = vec![root.package];
            for (i, node) in tree.nodes.iter().enumerate().skip(1) {
                let label = node_label(&asset.name, i);
                let cell = node.clip.as_ref().unwrap_or(&node.cell);
                let clip = plan_clip(&mut graph, &stages, label.clone(), ingest, cell);
                let chain = plan_chain(&mut graph, &stages, &label, planned, (clip, ingest::MESH));
                nodes.push(clip);
                nodes.extend(chain.jobs());
                measured.push((clip, chain.plt));
                node_packages.push(chain.package);
            }
            if !planned.measure_only {
                let params =
                    hierarchy::TreeParams::new(&asset.name, &planned.params.hierarchy, tree);
                let mut inputs = vec![("source".into(), Input::Source(asset.path.clone()))];
                for (i, p) in node_packages.iter().enumerate() {
                    let p = p.expect("a full chain has a package job");
                    inputs.push((hierarchy::node_input(i), output(p, package::PACKAGE)));
                }
                package = Some(graph.add(JobSpec {
                    asset: asset.name.clone(),
                    stage: stages.hierarchy.clone(),
                    params: to_json(&params),
                    inputs,
                }));
            }
        }
        jobs.push(AssetJobs {
            asset: asset.clone(),
            ingest,
            views: root.views,
            place: root.place,
            bake: root.bake,
            select: root.select,
            plt: root.plt,
            compress: root.compress.unwrap_or(root.plt),
            package: package.unwrap_or(root.plt),
            nodes,
            measured,
        });
    }
    (graph, jobs)
}

/// The select job's parameters: `[select]`, plus the backend and device when the GPU measures.
fn select_params(params: &config::StageParams) -> serde_json::Value {
    let mut json = to_json(&params.select);
    if let Some(device) = &params.select_device {
        json["backend"] = stages::GPU_BACKEND.into();
        json["device"] = device.as_str().into();
    }
    json
}

/// The place job's parameters: its own, and those of the bake and selection it measures
/// with (its result depends on them).
fn place_params(params: &config::StageParams) -> serde_json::Value {
    serde_json::json!({
        "place": to_json(&params.place),
        "bake": to_json(&params.bake),
        "select": to_json(&params.select),
        "item_buffer_size": params.views.item_buffer_size,
    })
}

/// The parameters a package records: every stage's, and whether the resolution was chosen
/// by `auto`.
fn recorded_params(params: &config::StageParams) -> serde_json::Value {
    let mut json = to_json(params);
    json["bake"]["resolution_auto"] = serde_json::Value::Bool(params.auto_resolution);
    let object = json.as_object_mut().expect("an object");
    if !params.auto_resolution {
        object.remove("plt");
    }
    if !params.hierarchy.enabled {
        object.remove("hierarchy");
    }
    json
}

fn to_json<T: Serialize>(value: &T) -> serde_json::Value {
    serde_json::to_value(value).expect("parameters serialise to JSON")
}

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
}

/// The remote cache's part in a build.
#[derive(Clone, Debug, Serialize)]
pub struct RemoteSummary {
    pub url: String,
    pub mode: RemoteMode,
    /// The server failed during the build (the rest was built locally).
    pub unavailable: bool,
    pub stats: RemoteStats,
}

impl RemoteSummary {
    fn of(remote: &RemoteCache) -> RemoteSummary {
        RemoteSummary {
            url: remote.describe(),
            mode: remote.mode(),
            unavailable: remote.is_offline(),
            stats: remote.stats(),
        }
    }
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
    /// Selection statistics and the projected length threshold.
    quality: Option<QualityReport>,
    /// Relief-map resolution the package was built at.
    resolution: u32,
    /// How `bake.resolution = "auto"` chose it.
    auto_resolution: Option<AutoReport>,
    /// This build's jobs of the asset, upstream first: what happened and how long it took.
    jobs: Vec<JobReport>,
}

/// One job of an asset in this build.
#[derive(Serialize)]
struct JobReport {
    stage: &'static str,
    /// "ran", "reused", "would run", "failed" or "skipped".
    status: &'static str,
    seconds: f64,
}

/// The `auto` resolution search of one asset.
#[derive(Clone, Debug, Serialize)]
struct AutoReport {
    target_px: u32,
    /// Whether the chosen resolution's PLT reaches the target (false: the largest allowed).
    reached: bool,
    /// Every resolution measured, with its PLT in pixels, in the order tried.
    tried: Vec<(u32, f64)>,
}

/// The measured quality of an asset's ORI (the rows of the paper's Table 1).
#[derive(Serialize)]
struct QualityReport {
    /// Coverage error over the 320 evaluation directions, percent of s0 x s0.
    coverage_error_min_percent: f64,
    coverage_error_max_percent: f64,
    coverage_error_avg_percent: f64,
    impostors_per_view: f64,
    /// Directions drawing 0, 1, 2, ... impostors.
    views_by_impostor_count: Vec<u32>,
    s0: u32,
    /// GC(s0): the largest coverage error, in pixels.
    gc: u32,
    /// s0^2 / GC(s0); when GC is 0 this is the lower bound s0^2 and `plt_is_lower_bound` is set.
    plt: f64,
    plt_is_lower_bound: bool,
    /// Power of two nearest to 2 x PLT (the paper's advice).
    recommended_resolution: u32,
}

/// Read the selection and PLT outputs of an asset into its report entry.
fn quality(build: &ori_graph::Build<'_>, jobs: &AssetJobs) -> Result<QualityReport, String> {
    let selection = ori_select::Selection::decode(
        &build
            .read_output(jobs.select, stages::SELECTION)
            .map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    let plt = ori_plt::Plt::decode(
        &build
            .read_output(jobs.plt, stages::PLT)
            .map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    let stats = selection.stats();
    Ok(QualityReport {
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

/// `report.json`: what this build did and measured, per asset. It records which jobs ran and
/// their times, so unlike the packages and `release.json` it is a log of one build, not part
/// of the reproducible release.
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
    let all_assets = discover(&root, &config.assets)?;
    if all_assets.is_empty() {
        return Err(PipelineError::Assets(format!(
            "no assets under {} match {:?}",
            root.display(),
            config.assets.include
        )));
    }
    let assets = match options.shard {
        Some(s) => shard::select(&all_assets, s),
        None => all_assets.clone(),
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
        params.push(config::StageParams {
            select_device: options.gpu_select.clone(),
            ..config.params_for(&a.name)?
        });
    }
    let limits = config.limits.mesh();
    let sources = config.limits.source_rules(&root)?;
    let cache = Cache::open(&cache_dir).map_err(|e| PipelineError::Output {
        path: cache_dir.clone(),
        message: format!("cannot create the cache folder: {e}"),
    })?;
    let run_options = RunOptions {
        threads: options.threads,
        dry_run: options.dry_run,
        remote: remote.clone(),
        cached_only: options.assemble,
        sources,
    };
    let mut stages = Vec::new();
    let mut sources_hashed = 0;
    // `auto` resolutions are measured first, then hierarchies' shapes (a dry run plans the
    // first guess and single ORIs only).
    let mut trees = vec![None; assets.len()];
    let auto = if options.dry_run {
        vec![None; assets.len()]
    } else {
        let mut trial_run = |graph: &Graph, read: &mut ReadBuild<'_>| {
            let progress =
                Progress::new(graph, options.progress, options.explain || options.dry_run);
            let build = ori_graph::run(graph, &cache, &run_options, &progress);
            progress.finish();
            add_summary(&mut stages, &build);
            sources_hashed += build.sources_rehashed();
            read(&build);
        };
        let auto = choose_resolutions(&assets, &mut params, limits, &mut trial_run);
        trees = choose_trees(&assets, &params, limits, &mut trial_run);
        auto
    };
    let planned: Vec<PlannedAsset> = assets
        .iter()
        .zip(&params)
        .zip(trees)
        .map(|((asset, params), tree)| PlannedAsset {
            asset: asset.clone(),
            params: params.clone(),
            measure_only: false,
            tree,
        })
        .collect();
    let (graph, jobs) = plan(&planned, limits);
    let progress = Progress::new(&graph, options.progress, options.explain || options.dry_run);
    let build = ori_graph::run(&graph, &cache, &run_options, &progress);
    progress.finish();
    add_summary(&mut stages, &build);
    sources_hashed += build.sources_rehashed();

    let mut report = Report { assets: Vec::new() };
    let mut unreadable_outputs = 0;
    let mut packages = Vec::new();
    for (index, j) in jobs.iter().enumerate() {
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
                Outcome::NotCached => {
                    status = "failed";
                    error = Some(format!(
                        "stage `{}` is not in the cache",
                        graph.job(id).stage.name()
                    ));
                    break;
                }
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
            quality: None,
            resolution: params[index].bake.resolution,
            auto_resolution: auto[index].clone(),
            jobs: j
                .all()
                .iter()
                .map(|&id| {
                    let r = build.result(id);
                    JobReport {
                        stage: graph.job(id).stage.name(),
                        status: match r.outcome {
                            Outcome::Reused => "reused",
                            Outcome::Ran(_) => "ran",
                            Outcome::WouldRun(_) => "would run",
                            Outcome::Failed(_) => "failed",
                            Outcome::Skipped => "skipped",
                            Outcome::NotCached => "not cached",
                        },
                        seconds: secs(r.duration),
                    }
                })
                .collect(),
        };
        // A dry run reads no output: a result found in the remote cache is not downloaded.
        let readable = status == "ok" && !options.dry_run;
        if readable {
            let outputs = quality(&build, j).and_then(|q| {
                let bytes = build
                    .read_output(j.package, package::PACKAGE)
                    .map_err(|e| e.to_string())?;
                Ok((q, bytes))
            });
            match outputs {
                Ok((q, bytes)) => {
                    entry.quality = Some(q);
                    packages.push((j.asset.name.clone(), bytes));
                }
                Err(e) => {
                    unreadable_outputs += 1;
                    entry.status = "failed";
                    entry.error = Some(e);
                }
            }
        }
        if let Some(dir) = options.dump_maps.as_ref().filter(|_| readable)
            && let Err(e) = dump_maps(&build, j, dir)
        {
            unreadable_outputs += 1;
            entry.status = "failed";
            entry.error = Some(e);
        }
        if !options.dry_run && matches!(result.outcome, Outcome::Reused | Outcome::Ran(_)) {
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

    if options.assemble && !options.dry_run {
        let missing: Vec<String> = report
            .assets
            .iter()
            .filter(|a| a.status != "ok")
            .map(|a| match &a.error {
                Some(e) => format!("{}: {e}", a.name),
                None => format!("{}: {}", a.name, a.status),
            })
            .collect();
        if !missing.is_empty() {
            return Err(PipelineError::NotCached(missing));
        }
    }
    let write_release = !options.dry_run && options.shard.is_none();
    if !options.dry_run
        && let Some(dir) = &options.explode
    {
        explode(dir, &packages)?;
    }
    let mut warnings = Vec::new();
    if write_release {
        let written = release::write(&out_dir, &packages)
            .map_err(|(path, message)| PipelineError::Output { path, message })?;
        warnings.extend(written.warnings);
    }
    let report_path = if !write_release {
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

    Ok(BuildSummary {
        assets: assets.len(),
        failed_assets: report
            .assets
            .iter()
            .filter(|a| a.status == "failed")
            .count(),
        warnings,
        stages,
        failed_jobs,
        wall_seconds: secs(start.elapsed()),
        sources_hashed,
        dry_run: options.dry_run,
        report: report_path,
        shard: options.shard.map(|s| (s, all_assets.len())),
        remote: remote.as_deref().map(RemoteSummary::of),
    })
}

/// Add a run's per-stage counts and times to `lines` (by stage name, first-seen order).
fn add_summary(lines: &mut Vec<StageLine>, build: &ori_graph::Build<'_>) {
    for s in build.summary() {
        let i = match lines.iter().position(|l| l.stage == s.stage) {
            Some(i) => i,
            None => {
                lines.push(StageLine {
                    stage: s.stage.to_string(),
                    ran: 0,
                    reused: 0,
                    would_run: 0,
                    failed: 0,
                    skipped: 0,
                    seconds: 0.0,
                });
                lines.len() - 1
            }
        };
        let l = &mut lines[i];
        l.ran += s.ran;
        l.reused += s.reused;
        l.would_run += s.would_run;
        l.failed += s.failed;
        l.skipped += s.skipped;
        l.seconds += secs(s.time);
    }
}

/// Reads what it needs from a finished trial run.
type ReadBuild<'a> = dyn FnMut(&ori_graph::Build<'_>) + 'a;

/// Decide every `bake.resolution = "auto"`: measure the PLT at the resolutions
/// `ori_plt::auto_resolution` asks for (each through the graph, so each is cached), a round
/// of trial runs at a time over the assets still searching, until each is decided; then set
/// the chosen resolution in `params`. An asset whose trial fails keeps the default
/// resolution, and the final run reports its failure.
fn choose_resolutions(
    assets: &[Asset],
    params: &mut [config::StageParams],
    limits: ori_mesh::Limits,
    run: &mut dyn FnMut(&Graph, &mut ReadBuild<'_>),
) -> Vec<Option<AutoReport>> {
    let mut tried: Vec<Vec<(u32, ori_plt::Plt)>> = vec![Vec::new(); assets.len()];
    let mut searching: Vec<bool> = params.iter().map(|p| p.auto_resolution).collect();
    let mut reports = vec![None; assets.len()];
    loop {
        let mut batch = Vec::new();
        for i in 0..assets.len() {
            if !searching[i] {
                continue;
            }
            match ori_plt::auto_resolution(&params[i].plt, &tried[i]) {
                ori_plt::AutoStep::Try(r) => batch.push((i, r)),
                ori_plt::AutoStep::Done {
                    resolution,
                    reached,
                } => {
                    searching[i] = false;
                    params[i].bake.resolution = resolution;
                    reports[i] = Some(AutoReport {
                        target_px: params[i].plt.target_px,
                        reached,
                        tried: tried[i].iter().map(|(r, p)| (*r, p.pixels())).collect(),
                    });
                }
            }
        }
        if batch.is_empty() {
            return reports;
        }
        let planned: Vec<PlannedAsset> = batch
            .iter()
            .map(|&(i, r)| {
                let mut p = params[i].clone();
                p.bake.resolution = r;
                PlannedAsset {
                    asset: assets[i].clone(),
                    params: p,
                    measure_only: true,
                    tree: None,
                }
            })
            .collect();
        let (graph, jobs) = plan(&planned, limits);
        run(&graph, &mut |build| {
            for (&(i, r), j) in batch.iter().zip(&jobs) {
                let plt = build
                    .read_output(j.plt, stages::PLT)
                    .ok()
                    .and_then(|b| ori_plt::Plt::decode(&b).ok());
                match plt {
                    Some(plt) => tried[i].push((r, plt)),
                    None => searching[i] = false,
                }
            }
        });
    }
}

/// Decide the shape of every hierarchy (`[hierarchy] enabled`): measure the root's PLT,
/// clip the children of every node below `target_px` (and above `max_depth`), measure the
/// non-empty ones, and so on, a level per round of trial runs (every job through the cache).
/// `None` for assets without a hierarchy. A node whose measurement fails is kept unsplit:
/// the final run reports its failure.
fn choose_trees(
    assets: &[Asset],
    params: &[config::StageParams],
    limits: ori_mesh::Limits,
    run: &mut dyn FnMut(&Graph, &mut ReadBuild<'_>),
) -> Vec<Option<hierarchy::PlannedTree>> {
    use hierarchy::{Measured, PlannedNode, PlannedTree};
    use ori_hierarchy::Cell;
    let mut trees: Vec<Option<PlannedTree>> = params
        .iter()
        .map(|p| {
            p.hierarchy.enabled.then(|| PlannedTree {
                nodes: vec![PlannedNode {
                    // Set from the root's mesh once measured.
                    cell: Cell {
                        min: [0.0; 3],
                        max: [0.0; 3],
                    },
                    clip: None,
                    depth: 0,
                    children: Vec::new(),
                }],
            })
        })
        .collect();
    let mut measured: Vec<Vec<Option<Measured>>> = assets.iter().map(|_| Vec::new()).collect();
    // Per tree, how many nodes have had their split decided.
    let mut decided = vec![0; assets.len()];
    loop {
        // Measure the nodes added last round (the whole tree is planned; the rest is cached).
        let batch: Vec<usize> = (0..assets.len())
            .filter(|&i| {
                trees[i]
                    .as_ref()
                    .is_some_and(|t| t.nodes.len() > measured[i].len())
            })
            .collect();
        if batch.is_empty() {
            return trees;
        }
        let planned: Vec<PlannedAsset> = batch
            .iter()
            .map(|&i| PlannedAsset {
                asset: assets[i].clone(),
                params: params[i].clone(),
                measure_only: true,
                tree: trees[i].clone(),
            })
            .collect();
        let (graph, jobs) = plan(&planned, limits);
        run(&graph, &mut |build| {
            for (&i, j) in batch.iter().zip(&jobs) {
                let tree = trees[i].as_mut().expect("a hierarchy");
                let kd = params[i].hierarchy.split == ori_package::SplitKind::Kd;
                let from = measured[i].len();
                for (k, &(mesh_job, plt_job)) in j.measured.iter().enumerate().skip(from) {
                    let plt = build
                        .read_output(plt_job, stages::PLT)
                        .ok()
                        .and_then(|b| ori_plt::Plt::decode(&b).ok());
                    // The mesh is read only where it decides something: the root's cube, kd
                    // medians.
                    let mesh = (k == 0 || kd)
                        .then(|| build.read_output(mesh_job, ingest::MESH).ok())
                        .flatten()
                        .and_then(|b| ori_mesh::Mesh::decode(&b).ok());
                    if k == 0 {
                        match mesh
                            .as_ref()
                            .and_then(|m| Cell::bounding_cube(&m.positions))
                        {
                            Some(cube) => tree.nodes[0].cell = cube,
                            None => {
                                measured[i].push(None);
                                continue;
                            }
                        }
                    }
                    measured[i].push(plt.map(|p| Measured {
                        plt_px: p.pixels(),
                        vertices: match (kd, mesh) {
                            (true, Some(m)) => m.positions,
                            _ => Vec::new(),
                        },
                    }));
                }
            }
        });
        // Clip the children of the nodes to split; keep the non-empty ones.
        let mut tries = Vec::new();
        for &i in &batch {
            let tree = trees[i].as_ref().expect("a hierarchy");
            // The nodes measured this round: those the last clip round added.
            let from = decided[i];
            decided[i] = tree.nodes.len();
            let children =
                hierarchy::children_to_try(&params[i].hierarchy, tree, &measured[i], from);
            if !children.is_empty() {
                tries.push((i, children));
            }
        }
        if tries.is_empty() {
            return trees;
        }
        let stages = Stages::new(limits);
        let mut graph = Graph::new();
        let mut clip_jobs = Vec::new();
        for (i, children) in &tries {
            let planned = PlannedAsset {
                asset: assets[*i].clone(),
                params: params[*i].clone(),
                measure_only: true,
                tree: None,
            };
            let ingest = plan_ingest(&mut graph, &stages, &planned);
            let first = trees[*i].as_ref().expect("a hierarchy").nodes.len();
            clip_jobs.push(
                children
                    .iter()
                    .enumerate()
                    .map(|(k, (_, _, clip))| {
                        let label = node_label(&assets[*i].name, first + k);
                        plan_clip(&mut graph, &stages, label, ingest, clip)
                    })
                    .collect::<Vec<_>>(),
            );
        }
        run(&graph, &mut |build| {
            for ((i, children), jobs) in tries.iter().zip(&clip_jobs) {
                let tree = trees[*i].as_mut().expect("a hierarchy");
                for (&(parent, cell, clip), &job) in children.iter().zip(jobs) {
                    // Empty (or unreadable: the final run would fail it the same way) is dropped.
                    if build
                        .read_output(job, ingest::MESH)
                        .is_ok_and(|b| !b.is_empty())
                    {
                        let index = tree.nodes.len();
                        tree.nodes[parent].children.push(index);
                        tree.nodes.push(PlannedNode {
                            cell,
                            clip: Some(clip),
                            depth: tree.nodes[parent].depth + 1,
                            children: Vec::new(),
                        });
                    }
                }
            }
        });
    }
}

/// Write every package as a folder `<dir>/<package path without .ori>/`.
fn explode(dir: &Path, packages: &[(String, Vec<u8>)]) -> Result<(), PipelineError> {
    for (name, bytes) in packages {
        let rel = release::package_path(name);
        let folder = dir.join(rel.trim_end_matches(".ori"));
        let fail = |message: String| PipelineError::Output {
            path: folder.clone(),
            message,
        };
        match ori_package::read_any(bytes).map_err(|e| fail(e.to_string()))? {
            ori_package::AnyPackage::Single(package) => {
                ori_package::explode(&package, &folder).map_err(|e| fail(e.to_string()))?;
            }
            // A hierarchy: its tree as `hierarchy.json`, each node as `node-N/`.
            ori_package::AnyPackage::Hierarchy(h) => {
                for (i, package) in h.nodes.iter().enumerate() {
                    ori_package::explode(package, &folder.join(format!("node-{i}")))
                        .map_err(|e| fail(e.to_string()))?;
                }
                let json = serde_json::to_vec_pretty(&h.manifest).expect("manifest serialises");
                ori_graph::write_atomic(&folder.join("hierarchy.json"), &json)
                    .map_err(|e| fail(format!("cannot write hierarchy.json: {e}")))?;
            }
        }
    }
    Ok(())
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
    if s.dry_run {
        out.push_str(&format!("{} assets would run", s.assets));
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
            "\nshard {shard}: {} of {total} assets; no release written (`cargo xtask assemble` writes it once every shard is built)",
            s.assets
        ));
    }
    if let Some(r) = &s.remote {
        let mb = |b: u64| b as f64 / 1e6;
        let st = &r.stats;
        let mode = match r.mode {
            RemoteMode::ReadOnly => "read-only",
            RemoteMode::ReadWrite => "read-write",
        };
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
    out
}

/// The default configuration file name.
pub fn default_config() -> &'static Path {
    Path::new("pipeline.toml")
}
