//! place: moves the planned directions where the evaluator shows they are needed (`[place]`,
//! see `ori_place`), measured with the `[bake]` parameters and what it reads of `[select]`
//! (`ori::PlacementGoal`) of the stages after it.

use ori_bake::BakeParams;
use ori_graph::{JobContext, StageError};
use serde::{Deserialize, Serialize};

use super::clip::{PartOf, WholeMesh};
use super::{PipelineStage, ingest::MESH, views::PLAN};

pub struct Place;

/// The place job's parameters: its own, and those of the bake and selection it measures
/// with (its result depends on them, and on nothing else).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaceJob {
    pub place: ori_place::PlaceParams,
    pub bake: BakeParams,
    pub goal: crate::ori::PlacementGoal,
    pub item_buffer_size: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part_of: PartOf,
}

impl PipelineStage for Place {
    const NAME: &'static str = "place";
    const VERSION: u32 = 4;
    type Params = PlaceJob;

    fn run(&self, params: PlaceJob, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let mesh = MESH.read(job)?;
        let plan = PLAN.read(job)?;
        let whole = WholeMesh::read(params.part_of, job)?;
        let placed = crate::ori::place(
            &mesh,
            &plan,
            &params.place,
            &params.bake,
            &params.goal,
            params.item_buffer_size,
            whole.as_ref().map(WholeMesh::whole),
        )
        .map_err(StageError::asset)?;
        PLAN.write(job, &placed.plan);
        Ok(())
    }
}

impl super::Makes<ori_views::ViewPlan> for Place {}
