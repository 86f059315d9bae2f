//! views: the impostor directions (`[views]`), planned from the canonical mesh.

use ori_artifact::DecodeError;
use ori_graph::{JobContext, StageError};
use ori_views::{ViewError, ViewParams, ViewPlan};

use super::{Artifact, PipelineStage, Slot, ingest::MESH};

/// The planned (and, after `place`, placed) directions.
pub const PLAN: Slot<ViewPlan> = Slot::new("views");

impl Artifact for ViewPlan {
    fn encode(&self) -> Vec<u8> {
        ViewPlan::encode(self)
    }

    fn decode(bytes: &[u8]) -> Result<ViewPlan, DecodeError> {
        ViewPlan::decode(bytes).map_err(|e| match e {
            ViewError::Decode(e) => e,
            other => DecodeError {
                kind: "view plan",
                detail: other.to_string(),
            },
        })
    }
}

pub struct Views;

impl PipelineStage for Views {
    const NAME: &'static str = "views";
    const VERSION: u32 = 1;
    type Params = ViewParams;

    fn run(&self, params: ViewParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let mesh = MESH.read(job)?;
        let plan = ori_views::plan_views(&mesh, &params).map_err(StageError::asset)?;
        PLAN.write(job, &plan);
        Ok(())
    }
}

impl super::Makes<ViewPlan> for Views {}
