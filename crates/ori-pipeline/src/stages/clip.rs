//! clip: the asset's mesh clipped to a box, the mesh of one hierarchy node. Its output is
//! empty when nothing of the mesh is inside (the node is then dropped).
//!
//! A node's place, select and plt jobs measure it in its own pixels (`ori_eval::Whole`): their
//! parameters carry the box ([`PartOf`]) and they read the asset's whole mesh as input
//! [`WHOLE`].

use ori_graph::{JobContext, StageError};
use ori_mesh::Mesh;
use serde::{Deserialize, Serialize};

use super::{PipelineStage, Slot, ingest::MESH};

/// The asset's whole mesh (ingest's `mesh`), as the input of a node's measuring jobs.
pub const WHOLE: Slot<Mesh> = Slot::new("whole");

/// In the parameters of a hierarchy node's place, select and plt jobs: the box the node's mesh
/// was clipped to (absent for a single ORI or a root, whose keys it leaves unchanged).
pub type PartOf = Option<ClipParams>;

/// The whole mesh and clip box of a job that measures a part.
pub struct WholeMesh {
    mesh: Mesh,
    clip: ClipParams,
}

impl WholeMesh {
    /// Read by a job whose parameters say it measures a part (`None` otherwise).
    pub fn read(
        part_of: PartOf,
        job: &mut JobContext<'_>,
    ) -> Result<Option<WholeMesh>, StageError> {
        part_of
            .map(|clip| {
                Ok(WholeMesh {
                    mesh: WHOLE.read(job)?,
                    clip,
                })
            })
            .transpose()
    }

    /// As the measure takes it.
    pub fn whole(&self) -> ori_eval::Whole<'_> {
        ori_eval::Whole {
            mesh: &self.mesh,
            clip: [self.clip.min, self.clip.max],
        }
    }
}

/// The parameters of a clip job: the box the mesh is clipped to (the cell, inflated).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipParams {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl ClipParams {
    pub fn of(cell: &ori_hierarchy::Cell) -> ClipParams {
        ClipParams {
            min: cell.min,
            max: cell.max,
        }
    }
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
