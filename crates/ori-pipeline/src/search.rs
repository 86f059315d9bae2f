//! The searches that decide a plan before it is built, each as rounds of trial runs through
//! the graph (every job cached, so a rebuild replays them from the cache): the resolution of
//! every `bake.resolution = "auto"` asset, then the shape of every hierarchy.

use ori_hierarchy::Cell;
use ori_release::AutoReport;

use crate::config::StageParams;
use crate::discover::Asset;
use crate::hierarchy::{self, Measured, PlannedNode, PlannedTree};
use crate::plan::{PlannedAsset, Planner, node_label, plan};
use crate::runs::Runs;
use crate::stages::ingest::MESH;
use crate::stages::plt::PLT;

/// Decide every `bake.resolution = "auto"`: measure the PLT at the resolutions
/// `ori_plt::auto_resolution` asks for (each through the graph, so each is cached), a round
/// of trial runs at a time over the assets still searching, until each is decided; then set
/// the chosen resolution in `params`. An asset whose trial fails keeps the default
/// resolution, and the final run reports its failure.
pub fn choose_resolutions(
    assets: &[Asset],
    params: &mut [StageParams],
    limits: ori_mesh::Limits,
    runs: &mut Runs<'_>,
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
        let build = runs.run(&graph);
        for (&(i, r), j) in batch.iter().zip(&jobs) {
            match PLT.read_from(&build, j.plt) {
                Ok(plt) => tried[i].push((r, plt)),
                Err(_) => searching[i] = false,
            }
        }
    }
}

/// Decide the shape of every hierarchy (`[hierarchy] enabled`): measure the root's PLT,
/// clip the children of every node below `target_px` (and above `max_depth`), measure the
/// non-empty ones, and so on, a level per round of trial runs (every job through the cache).
/// `None` for assets without a hierarchy. A node whose measurement fails is kept unsplit:
/// the final run reports its failure.
pub fn choose_trees(
    assets: &[Asset],
    params: &[StageParams],
    limits: ori_mesh::Limits,
    runs: &mut Runs<'_>,
) -> Vec<Option<PlannedTree>> {
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
        let build = runs.run(&graph);
        for (&i, j) in batch.iter().zip(&jobs) {
            let tree = trees[i].as_mut().expect("a hierarchy");
            let kd = params[i].hierarchy.split == ori_package::SplitKind::Kd;
            let from = measured[i].len();
            for (k, &(mesh_job, plt_job)) in j.measured.iter().enumerate().skip(from) {
                let plt = PLT.read_from(&build, plt_job).ok();
                // The mesh is read only where it decides something: the root's cube, kd
                // medians.
                let mesh = (k == 0 || kd)
                    .then(|| MESH.read_from(&build, mesh_job).ok())
                    .flatten();
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
        let mut planner = Planner::new(limits);
        let mut clip_jobs = Vec::new();
        for (i, children) in &tries {
            let planned = PlannedAsset {
                asset: assets[*i].clone(),
                params: params[*i].clone(),
                measure_only: true,
                tree: None,
            };
            let ingest = planner.ingest(&planned);
            let first = trees[*i].as_ref().expect("a hierarchy").nodes.len();
            clip_jobs.push(
                children
                    .iter()
                    .enumerate()
                    .map(|(k, (_, _, clip))| {
                        let label = node_label(&assets[*i].name, first + k);
                        planner.clip(&label, ingest, clip)
                    })
                    .collect::<Vec<_>>(),
            );
        }
        let graph = planner.graph;
        let build = runs.run(&graph);
        for ((i, children), jobs) in tries.iter().zip(&clip_jobs) {
            let tree = trees[*i].as_mut().expect("a hierarchy");
            for (&(parent, cell, clip), &job) in children.iter().zip(jobs) {
                // Empty (or unreadable: the final run would fail it the same way) is dropped.
                if build
                    .read_output(job.id, MESH.name)
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
    }
}
