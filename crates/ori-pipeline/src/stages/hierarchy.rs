//! hierarchy: the node packages gathered into one hierarchy package (format version 2).

use ori_graph::{JobContext, StageError};
use ori_package::{HierarchyManifest, HierarchyNode, Source, SplitKind};
use serde::{Deserialize, Serialize};

use super::PipelineStage;
use super::package::{PACKAGE, PackageBytes};
use crate::hierarchy::{HierarchyParams, PlannedTree};

/// Parameters of the hierarchy job: the tree, and what its manifest records.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TreeParams {
    pub name: String,
    pub tool: String,
    pub split: SplitKind,
    pub target_px: f64,
    /// Per node: `[min, max]` and its children.
    pub nodes: Vec<([[f64; 3]; 2], Vec<u32>)>,
}

impl TreeParams {
    pub fn new(name: &str, params: &HierarchyParams, tree: &PlannedTree) -> TreeParams {
        TreeParams {
            name: name.to_string(),
            tool: super::package::tool(),
            split: params.split,
            target_px: params.target_px,
            nodes: tree
                .nodes
                .iter()
                .map(|n| {
                    (
                        n.cell.bounds(),
                        n.children.iter().map(|&c| c as u32).collect(),
                    )
                })
                .collect(),
        }
    }
}

/// The input name of node `i`'s package in the hierarchy job.
pub fn node_input(i: usize) -> String {
    format!("node{i}")
}

/// Gathers the node packages into one hierarchy package (format version 2).
pub struct Hierarchy;

impl PipelineStage for Hierarchy {
    const NAME: &'static str = "hierarchy";
    const VERSION: u32 = 1;
    type Params = TreeParams;

    fn run(&self, p: TreeParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let source = job
            .input_hash(super::ingest::SOURCE)
            .ok_or_else(|| StageError::Plan("the hierarchy job has no source input".into()))?;
        let mut packages = Vec::with_capacity(p.nodes.len());
        for i in 0..p.nodes.len() {
            packages.push(job.input(&node_input(i))?);
        }
        let manifest = HierarchyManifest {
            format_version: ori_package::HIERARCHY_FORMAT_VERSION,
            tool: p.tool,
            source: Source {
                name: p.name,
                blake3: source.to_hex().to_string(),
            },
            split: p.split,
            target_px: p.target_px,
            nodes: p
                .nodes
                .into_iter()
                .map(|(bounds, children)| HierarchyNode::new(bounds, children))
                .collect(),
        };
        let bytes =
            ori_package::write_hierarchy(&manifest, &packages).map_err(StageError::asset)?;
        PACKAGE.write(job, &PackageBytes(bytes));
        Ok(())
    }
}

impl super::Makes<super::package::PackageBytes> for Hierarchy {}
