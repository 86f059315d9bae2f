//! select: for each of the 320 evaluation directions, the impostors to draw (`[select]`),
//! measured by the CPU evaluator or, with `--backend gpu`, the wgpu renderer.

use ori_artifact::DecodeError;
use ori_graph::{JobContext, StageError};
use ori_select::{SelectParams, Selection};
use serde::{Deserialize, Serialize};

use super::clip::{PartOf, WholeMesh};
use super::compress::{CompressParams, as_shipped, lossy_depth};
use super::{Artifact, PipelineStage, Slot, bake::MAPS, ingest::MESH};

/// The selection table and its statistics.
pub const SELECTION: Slot<Selection> = Slot::new("selection");

impl Artifact for Selection {
    fn encode(&self) -> Vec<u8> {
        Selection::encode(self)
    }

    fn decode(bytes: &[u8]) -> Result<Selection, DecodeError> {
        Selection::decode(bytes)
    }
}

pub struct Select;

/// The select job's parameters: `[select]`, and the GPU adapter when the GPU measures (its
/// results are device-dependent, so they get their own cache entries).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SelectJob {
    #[serde(flatten)]
    pub select: SelectParams,
    #[serde(flatten, default, skip_serializing_if = "Option::is_none")]
    pub gpu: Option<GpuBackend>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part_of: PartOf,
    /// Lossy depth compression of the package: selection measures the depth it ships
    /// (`compress::lossy_depth`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shipped_depth: Option<CompressParams>,
}

/// Selection measured with the wgpu renderer on `device` (`--backend gpu`).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GpuBackend {
    /// Always `"gpu"`.
    pub backend: String,
    /// The adapter's summary (`gpu_select::renderer`).
    pub device: String,
}

impl SelectJob {
    pub fn new(
        select: &SelectParams,
        device: Option<&str>,
        part_of: PartOf,
        compress: &CompressParams,
    ) -> SelectJob {
        SelectJob {
            part_of,
            shipped_depth: lossy_depth(compress),
            select: select.clone(),
            gpu: device.map(|d| GpuBackend {
                backend: "gpu".to_string(),
                device: d.to_string(),
            }),
        }
    }
}

impl PipelineStage for Select {
    const NAME: &'static str = "select";
    /// 2: the linear search spans the columns the ray crosses (`ori_eval::march::Columns`).
    /// 3: single-sided materials are culled from behind in the reference.
    /// 4: `best:M` subsets are chosen over each entry's region of directions.
    /// 5: the region is a grid over the entry's triangle, not only its corners and midpoints.
    /// (BC4 packages: measured on the decoded depth, `shipped_depth`, a key of its own.)
    const VERSION: u32 = 5;
    type Params = SelectJob;

    fn run(&self, params: SelectJob, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let mesh = MESH.read(job)?;
        let set = as_shipped(MAPS.read(job)?, params.shipped_depth.as_ref())
            .map_err(StageError::asset)?;
        let whole = WholeMesh::read(params.part_of, job)?;
        let whole = whole.as_ref().map(WholeMesh::whole);
        let selection = if params.gpu.is_some() {
            crate::gpu_select::renderer()
                .and_then(|r| crate::gpu_select::select(&mesh, &set, &params.select, whole, r))
                .map_err(|e| StageError::asset(format!("GPU selection: {e}")))?
        } else {
            crate::ori::select(&mesh, &set, &params.select, whole).map_err(StageError::asset)?
        };
        SELECTION.write(job, &selection);
        Ok(())
    }
}

impl super::Makes<Selection> for Select {}
