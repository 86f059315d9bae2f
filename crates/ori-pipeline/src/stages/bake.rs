//! bake: one relief map per planned direction (`[bake]`).

use ori_artifact::DecodeError;
use ori_bake::BakeParams;
use ori_graph::{JobContext, StageError};
use ori_relief::ReliefSet;

use super::{Artifact, PipelineStage, Slot, ingest::MESH, views::PLAN};

/// The relief maps.
pub const MAPS: Slot<ReliefSet> = Slot::new("maps");

impl Artifact for ReliefSet {
    fn encode(&self) -> Vec<u8> {
        ReliefSet::encode(self)
    }

    fn decode(bytes: &[u8]) -> Result<ReliefSet, DecodeError> {
        ReliefSet::decode(bytes)
    }
}

pub struct Bake;

impl PipelineStage for Bake {
    const NAME: &'static str = "bake";
    // 2: conservative edge texels (a texel whose centre misses but a sub-sample hits).
    // 3: single-sided materials culled from behind.
    const VERSION: u32 = 3;
    type Params = BakeParams;

    fn run(&self, params: BakeParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let mesh = MESH.read(job)?;
        let plan = PLAN.read(job)?;
        let set = ori_bake::bake(&mesh, &plan.directions, &params).map_err(StageError::asset)?;
        MAPS.write(job, &set);
        Ok(())
    }
}

impl super::Makes<ReliefSet> for Bake {}
