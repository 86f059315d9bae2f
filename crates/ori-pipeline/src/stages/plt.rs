//! plt: GC(s0) and the projected length threshold, from the selection table.

use ori_artifact::DecodeError;
use ori_graph::{JobContext, StageError};
use ori_plt::Plt;
use serde::{Deserialize, Serialize};

use super::{Artifact, PipelineStage, Slot, select::SELECTION};

/// The measured PLT.
pub const PLT: Slot<Plt> = Slot::new("plt");

impl Artifact for Plt {
    fn encode(&self) -> Vec<u8> {
        Plt::encode(self)
    }

    fn decode(bytes: &[u8]) -> Result<Plt, DecodeError> {
        Plt::decode(bytes)
    }
}

pub struct PltStage;

/// The plt job has no parameters (an empty object).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

impl PipelineStage for PltStage {
    const NAME: &'static str = "plt";
    const VERSION: u32 = 1;
    type Params = NoParams;

    fn run(&self, _: NoParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let selection = SELECTION.read(job)?;
        PLT.write(job, &crate::ori::plt(&selection));
        Ok(())
    }
}

impl super::Makes<Plt> for PltStage {}
