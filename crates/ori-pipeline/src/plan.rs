//! The plan: the jobs of every asset, wired from the registry's stages. One ORI is the
//! chain `views -> place -> bake -> select -> plt`, then `compress -> package`; a hierarchy
//! adds a clip and a chain per node and a `hierarchy` job that gathers the node packages.

use ori_graph::{Graph, Input, JobId, JobSpec};

use crate::config::StageParams;
use crate::discover::Asset;
use crate::hierarchy::PlannedTree;
use crate::stages::bake::{Bake, MAPS};
use crate::stages::clip::{Clip, ClipParams, WHOLE};
use crate::stages::compress::{Compress, TEXTURES, lossy_depth};
use crate::stages::hierarchy::{Hierarchy, TreeParams, node_input};
use crate::stages::ingest::{Ingest, IngestJob, MESH, SOURCE};
use crate::stages::package::{PACKAGE, Package, PackageParams, tool};
use crate::stages::place::{Place, PlaceJob};
use crate::stages::plt::{PLT, PltJob, PltStage};
use crate::stages::select::{SELECTION, Select, SelectJob};
use crate::stages::views::{PLAN, Views};
use crate::stages::{Job, Makes, PipelineStage, Registry, params_json};
use ori_mesh::Mesh;

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
    /// The root node's package job, then the other nodes' jobs of a hierarchy (clip and
    /// chain), upstream first.
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
    pub params: StageParams,
    pub measure_only: bool,
    pub tree: Option<PlannedTree>,
}

/// A graph being planned, with the registry its jobs take their stages from.
pub struct Planner {
    pub graph: Graph,
    stages: Registry,
}

/// The jobs from a mesh to a package (`compress` and `package` are `None` when measuring).
struct Chain {
    views: Job<Views>,
    place: Job<Place>,
    bake: Job<Bake>,
    select: Job<Select>,
    plt: Job<PltStage>,
    compress: Option<Job<Compress>>,
    package: Option<Job<Package>>,
}

impl Chain {
    fn jobs(&self) -> Vec<JobId> {
        let mut jobs = vec![
            self.views.id,
            self.place.id,
            self.bake.id,
            self.select.id,
            self.plt.id,
        ];
        jobs.extend(self.compress.map(|j| j.id));
        jobs.extend(self.package.map(|j| j.id));
        jobs
    }
}

/// How a hierarchy node's jobs are labelled in progress lines and messages.
pub fn node_label(asset: &str, node: usize) -> String {
    format!("{asset} [node {node}]")
}

impl Planner {
    /// An empty graph; models will be loaded within `limits`.
    pub fn new(limits: ori_mesh::Limits) -> Planner {
        Planner {
            graph: Graph::new(),
            stages: Registry::new(limits),
        }
    }

    /// Add a job of stage `S`, labelled `label` (its asset, or a hierarchy node of it).
    fn add<S: PipelineStage>(
        &mut self,
        label: &str,
        params: &S::Params,
        inputs: Vec<(&str, Input)>,
    ) -> Job<S> {
        Job::new(
            self.graph.add(JobSpec {
                asset: label.to_string(),
                stage: self.stages.get::<S>(),
                params: params_json::<S>(params),
                inputs: inputs
                    .into_iter()
                    .map(|(name, input)| (name.to_string(), input))
                    .collect(),
            }),
        )
    }

    /// The ingest job of an asset.
    pub fn ingest(&mut self, planned: &PlannedAsset) -> Job<Ingest> {
        let asset = &planned.asset;
        self.add::<Ingest>(
            &asset.name,
            &IngestJob::new(&asset.path, &planned.params.ingest),
            vec![(SOURCE, Input::Source(asset.path.clone()))],
        )
    }

    /// The clip job of a hierarchy node: the asset's mesh clipped to `clip`.
    pub fn clip(
        &mut self,
        label: &str,
        ingest: Job<Ingest>,
        clip: &ori_hierarchy::Cell,
    ) -> Job<Clip> {
        self.add::<Clip>(label, &ClipParams::of(clip), vec![MESH.from(ingest)])
    }

    /// Add the chain of one ORI of `planned` (labelled `label` in progress and messages) over
    /// the mesh output of `mesh`: the asset's own mesh (ingest), or a hierarchy node's part
    /// of it (clip), when `part` gives the asset's ingest and the clip box: the node is then
    /// measured in its own pixels (`ori_eval::Whole`), where the rest of the model is not in
    /// front of it.
    fn chain<M: Makes<Mesh>>(
        &mut self,
        label: &str,
        planned: &PlannedAsset,
        mesh: Job<M>,
        part: Option<(Job<Ingest>, ClipParams)>,
        depth: u32,
    ) -> Chain {
        let (asset, params) = (&planned.asset, &planned.params);
        let goals = params.hierarchy.node_select(&params.select, depth);
        let part_of = part.map(|(_, clip)| clip);
        // The measuring jobs' inputs: the mesh, `more`, and the whole mesh of a part.
        let measuring = |more: Vec<(&'static str, Input)>| {
            let whole = part.map(|(ingest, _)| (WHOLE.name, MESH.of(ingest)));
            [MESH.from(mesh)]
                .into_iter()
                .chain(more)
                .chain(whole)
                .collect()
        };
        let views = self.add::<Views>(label, &params.views, vec![MESH.from(mesh)]);
        let place_job = PlaceJob {
            place: params
                .hierarchy
                .node_place(&params.place, goals.rule.m(), depth),
            bake: params.bake.clone(),
            goal: crate::ori::PlacementGoal::of(&goals),
            item_buffer_size: params.views.item_buffer_size,
            part_of,
        };
        let place = self.add::<Place>(label, &place_job, measuring(vec![PLAN.from(views)]));
        let bake = self.add::<Bake>(label, &params.bake, vec![MESH.from(mesh), PLAN.from(place)]);
        let select = self.add::<Select>(
            label,
            &SelectJob::new(
                &goals,
                params.select_device.as_deref(),
                part_of,
                &params.compress,
            ),
            measuring(vec![MAPS.from(bake)]),
        );
        let plt_job = PltJob {
            select: goals,
            held_out_seed: params.plt.held_out_seed,
            part_of,
            shipped_depth: lossy_depth(&params.compress),
        };
        let plt = self.add::<PltStage>(
            label,
            &plt_job,
            measuring(vec![MAPS.from(bake), SELECTION.from(select)]),
        );
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
        let compress = self.add::<Compress>(label, &params.compress, vec![MAPS.from(bake)]);
        let package_params = PackageParams {
            name: asset.name.clone(),
            tool: tool(),
            depth: params.compress.depth,
            pipeline: params.recorded(),
            measured_on: params.select_device.clone(),
        };
        let package = self.add::<Package>(
            label,
            &package_params,
            vec![
                // Hashed, never read: the manifest records the source's content hash.
                (SOURCE, Input::Hashed(asset.path.clone())),
                MAPS.from(bake),
                SELECTION.from(select),
                PLT.from(plt),
                TEXTURES.from(compress),
            ],
        );
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

    /// Add every job of one asset.
    pub fn asset(&mut self, planned: &PlannedAsset) -> AssetJobs {
        let asset = &planned.asset;
        let ingest = self.ingest(planned);
        let root = self.chain(&asset.name, planned, ingest, None, 0);
        let mut nodes = Vec::new();
        let mut measured = vec![(ingest.id, root.plt.id)];
        let mut package = root.package.map(|j| j.id);
        if let Some(tree) = &planned.tree {
            // The root node's package is one of the asset's jobs like any node's.
            nodes.extend(root.package.map(|j| j.id));
            let mut node_packages = vec![root.package];
            for (i, node) in tree.nodes.iter().enumerate().skip(1) {
                let label = node_label(&asset.name, i);
                let cell = node.clip.as_ref().unwrap_or(&node.cell);
                let clip = self.clip(&label, ingest, cell);
                let part = Some((ingest, ClipParams::of(cell)));
                let chain = self.chain(&label, planned, clip, part, node.depth);
                nodes.push(clip.id);
                nodes.extend(chain.jobs());
                measured.push((clip.id, chain.plt.id));
                node_packages.push(chain.package);
            }
            if !planned.measure_only {
                let params = TreeParams::new(&asset.name, &planned.params.hierarchy, tree);
                let names: Vec<String> = (0..node_packages.len()).map(node_input).collect();
                let mut inputs = vec![(SOURCE, Input::Hashed(asset.path.clone()))];
                for (name, p) in names.iter().zip(&node_packages) {
                    let p = p.expect("a full chain has a package job");
                    inputs.push((name.as_str(), PACKAGE.of(p)));
                }
                package = Some(self.add::<Hierarchy>(&asset.name, &params, inputs).id);
            }
        }
        AssetJobs {
            asset: asset.clone(),
            ingest: ingest.id,
            views: root.views.id,
            place: root.place.id,
            bake: root.bake.id,
            select: root.select.id,
            plt: root.plt.id,
            compress: root.compress.map_or(root.plt.id, |j| j.id),
            package: package.unwrap_or(root.plt.id),
            nodes,
            measured,
        }
    }
}

/// Build the job graph for `assets`; models are loaded within `limits`.
pub fn plan(assets: &[PlannedAsset], limits: ori_mesh::Limits) -> (Graph, Vec<AssetJobs>) {
    let mut planner = Planner::new(limits);
    let jobs = assets.iter().map(|a| planner.asset(a)).collect();
    (planner.graph, jobs)
}
