//! View planning: the directions an omni-directional relief impostor (ORI) is baked from.
//!
//! The views stage turns a canonical [`Mesh`](ori_mesh::Mesh) into a [`ViewPlan`]: n unit
//! directions (from the object towards the viewer) and their viewpoint entropies. The three
//! strategies of the ORI paper (section 3.1) are available through [`ViewParams`], the
//! `[views]` section of `pipeline.toml`:
//!
//! - `"regular"`: a regularly spaced set ([`icosahedron_directions`], [`axis_directions`]);
//! - `"minimal"`: the n most informative of the 320 [`evaluation_directions`];
//! - `"perturbed"` (default): each regular direction moved to the most informative direction
//!   within a few degrees.
//!
//! "Informative" is [`viewpoint_entropy`] (Vázquez et al. 2003) on an orthographic item buffer
//! drawn by `ori_raster`. [`sampling_coverage`] measures the paper's Figure 2: how many
//! impostors sample each part of the visible surface.
//!
//! Determinism: directions use only `+ - * /`, `sqrt` and `ori_math`'s portable functions;
//! parallel work is collected in order or summed in integers, so a plan's bytes
//! ([`ViewPlan::encode`]) are the same for any thread count and on every machine.

mod codec;
mod coverage;
mod directions;
mod entropy;
mod params;
mod plan;

pub use coverage::{
    SamplingCoverage, sampling_coverage, sampling_coverage_with_visible, visible_surface,
};
pub use directions::{
    DEFAULT_HELD_OUT_SEED, EvaluationRegions, HELD_OUT_RANDOM, HELD_OUT_REGULAR, axis_directions,
    evaluation_corners, evaluation_directions, evaluation_regions, held_out_directions,
    icosahedron_directions,
};
pub use entropy::{BoundingSphere, viewpoint_entropy};
pub use params::{Strategy, ViewParams};
pub use plan::{ViewPlan, plan_views};

/// Why views could not be planned, or a plan not decoded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ViewError {
    /// A `[views]` parameter is out of range; the message names the key.
    #[error("invalid view parameters: {0}")]
    Params(String),
    /// The mesh cannot be looked at (no extent).
    #[error("cannot plan views: {0}")]
    Mesh(String),
    /// Bytes that are not a valid encoded [`ViewPlan`].
    #[error(transparent)]
    Decode(#[from] ori_artifact::DecodeError),
}
