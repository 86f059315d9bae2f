//! Selection measured on the GPU (`cargo xtask build-assets --backend gpu`): the same
//! selection as `ori_select::select`, but each impostor's coverage mask is drawn by the wgpu
//! runtime renderer with the shaders of `shaders/` instead of traced by the CPU evaluator.
//!
//! Framing, the views to measure (`ori_select::MaskPlan`) and the reference mesh coverage stay
//! on the CPU evaluator, and the masks go through `ori_select::select_from_masks`, so the two
//! backends differ only where the device's arithmetic differs from the CPU's (on the software
//! driver they agree pixel for pixel; see `ori-render`'s parity test). The results are
//! therefore device-dependent:
//! the select job's parameters name the backend and the adapter, so GPU results get their own
//! cache keys and never stand in for CPU results.

use std::sync::OnceLock;

use ori_eval::Mask;
use ori_mesh::Mesh;
use ori_relief::ReliefSet;
use ori_render::{Camera, Draw, Renderer};
use ori_select::{MaskPlan, SelectParams, Selection, ViewMasks};

/// The process's renderer, made on first use (a device per job would cost more than the
/// work); the error is kept so every job reports it.
pub fn renderer() -> Result<&'static Renderer, String> {
    static RENDERER: OnceLock<Result<Renderer, String>> = OnceLock::new();
    RENDERER
        .get_or_init(|| Renderer::new().map_err(|e| e.to_string()))
        .as_ref()
        .map_err(Clone::clone)
}

/// `ori_select::select` with the coverage masks drawn by `renderer` (of a part of `whole`
/// when given: `crate::ori::select`).
pub fn select(
    mesh: &Mesh,
    set: &ReliefSet,
    params: &SelectParams,
    whole: Option<ori_eval::Whole<'_>>,
    renderer: &Renderer,
) -> Result<Selection, String> {
    params.validate().map_err(|e| e.to_string())?;
    let evaluator = crate::ori::evaluator(mesh, set, params, whole).map_err(|e| e.to_string())?;
    // The renderer loads packages: wrap the maps in one (exact R8 depth, which is all that
    // coverage reads; quickly compressed colour and normal; a placeholder table).
    let package = crate::stages::package::measuring_package(set, params)?;
    let mut ori = renderer.load_package(&package).map_err(|e| e.to_string())?;
    ori.set_march(ori_render::MarchParams {
        linear_steps: params.linear_steps,
        binary_steps: params.binary_steps,
        wall_threshold: params.wall_threshold as f32,
    });
    let plan = MaskPlan::new(&evaluator, params);
    let mut masks = Vec::new();
    for (k, impostors) in plan.impostors.iter().enumerate() {
        let view = plan.view(&evaluator, k).map_err(|e| e.to_string())?;
        let reference = evaluator.mesh_coverage(&view);
        let camera = Camera::from_view(&view);
        let mut candidates = Vec::new();
        for &i in impostors {
            let index = [i as u16];
            let image = renderer
                .render(
                    &[Draw::OriSubset(&ori, &index)],
                    &camera,
                    view.size,
                    view.size,
                )
                .map_err(|e| e.to_string())?;
            let mut mask = Mask::new(view.size);
            for p in reference.ones().filter(|&p| image.covered(p)) {
                mask.set(p);
            }
            candidates.push((i, mask));
        }
        masks.push(ViewMasks {
            reference,
            candidates,
        });
    }
    ori_select::select_from_masks(&masks, params, set.maps.len()).map_err(|e| e.to_string())
}
