//! clip: the asset's mesh clipped to a box, the mesh of one hierarchy node. Its output is
//! empty when nothing of the mesh is inside (the node is then dropped).

use ori_graph::{JobContext, StageError};
use serde::{Deserialize, Serialize};

use super::{PipelineStage, ingest::MESH};

/// The parameters of a clip job: the box the mesh is clipped to (the cell, inflated).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipParams {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

pub struct Clip;

impl PipelineStage for Clip {
    const NAME: &'static str = "clip";
    const VERSION: u32 = 1;
    type Params = ClipParams;

    fn run(&self, p: ClipParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let mesh = MESH.read(job)?;
        let bytes =
            ori_mesh::clip_to_box(&mesh, p.min, p.max).map_or_else(Vec::new, |m| m.encode());
        job.output(MESH.name, bytes);
        Ok(())
    }
}

impl super::Makes<ori_mesh::Mesh> for Clip {}
