//! The view-planning and baking stages: thin adapters from the graph to `ori_views` and
//! `ori_bake`. (Ingest, which reads files, lives in `ingest.rs`.)

use ori_bake::{BakeParams, ReliefSet};
use ori_graph::{JobContext, Stage, StageError};
use ori_mesh::Mesh;
use ori_views::{ViewParams, ViewPlan};

/// Output names.
pub const VIEWS: &str = "views";
pub const MAPS: &str = "maps";

pub(crate) fn params<T: serde::de::DeserializeOwned>(
    ctx: &JobContext<'_>,
) -> Result<T, StageError> {
    serde_json::from_value(ctx.params().clone())
        .map_err(|e| StageError::new(format!("bad parameters: {e}")))
}

pub(crate) fn mesh(ctx: &mut JobContext<'_>) -> Result<Mesh, StageError> {
    let bytes = ctx.input(crate::ingest::MESH)?;
    Mesh::decode(&bytes).map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))
}

/// Plans the impostor directions (`[views]` parameters) from the canonical mesh.
pub struct ViewsStage;

impl Stage for ViewsStage {
    fn name(&self) -> &'static str {
        "views"
    }

    fn version(&self) -> u32 {
        1
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        let params: ViewParams = params(ctx)?;
        let mesh = mesh(ctx)?;
        let plan = ori_views::plan_views(&mesh, &params)
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        ctx.output(VIEWS, plan.encode());
        Ok(())
    }
}

/// Moves the planned directions where the evaluator shows they are needed (`[place]`, see
/// `ori_place`); measured with the `[bake]` and `[select]` parameters of the stages after it.
pub struct PlaceStage;

/// The place job's parameters (built by `place_params` in `lib.rs`).
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PlaceJobParams {
    place: ori_place::PlaceParams,
    bake: BakeParams,
    select: ori_select::SelectParams,
    item_buffer_size: u32,
}

impl Stage for PlaceStage {
    fn name(&self) -> &'static str {
        "place"
    }

    fn version(&self) -> u32 {
        1
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        let params: PlaceJobParams = params(ctx)?;
        let mesh = mesh(ctx)?;
        let plan = ViewPlan::decode(&ctx.input(VIEWS)?)
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        let measure = ori_place::Measure {
            bake: &params.bake,
            eval: &params.select.eval_params(),
            closest: params.select.rule.m() as usize,
            goal_pixels: params.select.goal_pixels(),
            entropy_size: params.item_buffer_size,
        };
        let placed = ori_place::place(&mesh, &plan, &measure, &params.place)
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        ctx.output(VIEWS, placed.plan.encode());
        Ok(())
    }
}

/// Bakes one relief map per planned direction (`[bake]` parameters).
pub struct BakeStage;

impl Stage for BakeStage {
    fn name(&self) -> &'static str {
        "bake"
    }

    fn version(&self) -> u32 {
        // 2: conservative edge texels (a texel whose centre misses but a sub-sample hits).
        // 3: single-sided materials culled from behind.
        3
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        let params: BakeParams = params(ctx)?;
        let mesh = mesh(ctx)?;
        let plan = ViewPlan::decode(&ctx.input(VIEWS)?)
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        let set = ori_bake::bake(&mesh, &plan.directions, &params)
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        ctx.output(MAPS, set.encode());
        Ok(())
    }
}

/// Decode a bake output (for dumps and reports).
pub fn decode_maps(bytes: &[u8]) -> Result<ReliefSet, String> {
    ReliefSet::decode(bytes).map_err(|e| e.to_string())
}

/// Output names of the selection and PLT stages.
pub const SELECTION: &str = "selection";
pub const PLT: &str = "plt";

/// The `backend` parameter of a select job measured with the GPU renderer.
pub const GPU_BACKEND: &str = "gpu";

/// Chooses, for each of the 320 evaluation directions, the impostors to draw (`[select]`).
pub struct SelectStage;

impl Stage for SelectStage {
    fn name(&self) -> &'static str {
        "select"
    }

    /// 2: the linear search spans the columns the ray crosses (`ori_eval::march::Columns`).
    /// 3: single-sided materials are culled from behind in the reference.
    fn version(&self) -> u32 {
        3
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        // `backend` and `device` (set by `--backend gpu`) are not selection parameters: they
        // make GPU results their own cache entries.
        let mut json = ctx.params().clone();
        let gpu = json.get("backend").and_then(|b| b.as_str()) == Some(GPU_BACKEND);
        if let Some(map) = json.as_object_mut() {
            map.remove("backend");
            map.remove("device");
        }
        let params: ori_select::SelectParams = serde_json::from_value(json)
            .map_err(|e| StageError::new(format!("bad parameters: {e}")))?;
        let mesh = mesh(ctx)?;
        let set = ReliefSet::decode(&ctx.input(MAPS)?)
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        let selection = if gpu {
            crate::gpu_select::renderer()
                .and_then(|r| crate::gpu_select::select(&mesh, &set, &params, r))
                .map_err(|e| StageError::new(format!("{}: GPU selection: {e}", ctx.asset())))?
        } else {
            ori_select::select(&mesh, &set, &params)
                .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?
        };
        ctx.output(SELECTION, selection.encode());
        Ok(())
    }
}

/// Measures GC(s0) and the projected length threshold from the selection table.
pub struct PltStage;

impl Stage for PltStage {
    fn name(&self) -> &'static str {
        "plt"
    }

    fn version(&self) -> u32 {
        1
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        let selection = ori_select::Selection::decode(&ctx.input(SELECTION)?)
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        let missed: Vec<u32> = selection.entries.iter().map(|e| e.missed).collect();
        let plt = ori_plt::estimate(selection.s0, &missed);
        ctx.output(PLT, plt.encode());
        Ok(())
    }
}
