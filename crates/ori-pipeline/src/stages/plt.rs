//! plt: the runtime rule measured at the held-out directions, and from its worst view GC(s0)
//! and the projected length threshold.

use ori_artifact::DecodeError;
use ori_graph::{JobContext, StageError};
use ori_plt::Plt;
use ori_select::{HeldOut, SelectParams};
use serde::{Deserialize, Serialize};

use super::clip::{PartOf, WholeMesh};
use super::compress::{CompressParams, as_shipped};
use super::{Artifact, PipelineStage, Slot, bake::MAPS, ingest::MESH, select::SELECTION};

/// The measured PLT.
pub const PLT: Slot<Plt> = Slot::new("plt");
/// The coverage error and impostors drawn at each held-out direction.
pub const HELD_OUT: Slot<HeldOut> = Slot::new("held_out");

impl Artifact for Plt {
    fn encode(&self) -> Vec<u8> {
        Plt::encode(self)
    }

    fn decode(bytes: &[u8]) -> Result<Plt, DecodeError> {
        Plt::decode(bytes)
    }
}

impl Artifact for HeldOut {
    fn encode(&self) -> Vec<u8> {
        HeldOut::encode(self)
    }

    fn decode(bytes: &[u8]) -> Result<HeldOut, DecodeError> {
        HeldOut::decode(bytes)
    }
}

pub struct PltStage;

/// What the measure depends on: the evaluator's parameters (those of the selection) and the
/// seed of the held-out directions.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PltJob {
    pub select: SelectParams,
    pub held_out_seed: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part_of: PartOf,
    /// Lossy depth compression of the package: the PLT is measured on the depth it ships.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shipped_depth: Option<CompressParams>,
}

impl PipelineStage for PltStage {
    const NAME: &'static str = "plt";
    /// 2: measured at the held-out directions, not the table's.
    const VERSION: u32 = 2;
    type Params = PltJob;

    fn run(&self, params: PltJob, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let mesh = MESH.read(job)?;
        let set = as_shipped(MAPS.read(job)?, params.shipped_depth.as_ref())
            .map_err(StageError::asset)?;
        let selection = SELECTION.read(job)?;
        let whole = WholeMesh::read(params.part_of, job)?;
        let held_out = crate::ori::held_out(
            &mesh,
            &set,
            &selection,
            &params.select,
            params.held_out_seed,
            whole.as_ref().map(WholeMesh::whole),
        )
        .map_err(StageError::asset)?;
        PLT.write(job, &crate::ori::plt(&held_out));
        HELD_OUT.write(job, &held_out);
        Ok(())
    }
}

impl super::Makes<Plt> for PltStage {}
impl super::Makes<HeldOut> for PltStage {}
