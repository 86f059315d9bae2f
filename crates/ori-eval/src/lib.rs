//! The image-space evaluator: a CPU renderer used for every measurement of an ORI.
//!
//! From any direction `w` (unit, from the object towards the viewer) it renders, orthographically
//! at `s0` x `s0` pixels framed so that the square bounding box of the object's projection has
//! edge `s0` ([`eval_view`]):
//!
//! - the reference mesh: coverage ([`Evaluator::mesh_coverage`], the fast path, equal pixel
//!   for pixel to `ori_raster::rasterize`), or coverage, depth, albedo and normal
//!   ([`Evaluator::render_mesh`]); for a part of a larger model (a hierarchy node,
//!   [`Evaluator::part_of`]) only the pixels where the whole model's nearest surface is the
//!   part's;
//! - an ORI drawn with an ordered subset of impostors, following the runtime rule of
//!   `GUIDE.md` step by step ([`march`] states it): per impostor a [`Layer`] of fragments, or
//!   only its coverage [`Mask`] ([`Evaluator::impostor_mask`]), composed with a fragment
//!   [`Priority`];
//! - per view the errors ([`ViewErrors`]: coverage error as a count and a percentage,
//!   inverse coverage, p_dif, depth error) and the error picture ([`error_image`]).
//!
//! Coverage is a union: a subset's coverage is the OR of its members' masks, so selection
//! traces each candidate impostor at most once per view (when its subset search first reads
//! it) and combines masks with OR and popcount.
//!
//! # Choices the guide leaves open
//!
//! - **Pixels.** Pixel `(x, y)` is the ray through its centre `(x + 0.5, y + 0.5)`. The mesh
//!   covers it when the centre is inside a triangle (`ori_raster`'s fill rule, the bake's
//!   alpha test) that is drawn from this side.
//! - **The mesh as an engine draws it.** Triangles of single-sided materials are culled
//!   where they face away from the viewer (`ori_mesh::Mesh::single_sided`: glTF's
//!   `doubleSided: false`, and every OBJ or PLY, which carry no flag), both here and in the
//!   bake. On a closed, consistently wound model this changes nothing (the nearest surface
//!   always faces the viewer). An open scan shows what a game shows: through a hole the
//!   inside of the shell is culled and the viewer sees past it. Double-sided materials draw
//!   both windings.
//! - **Facing.** An impostor faces the viewer when `d . w > 0`; only facing impostors draw.
//!   Its quad is extended for skewed views: every pixel whose ray meets the relief volume is
//!   traced; the search covers the part of the ray inside the volume, narrowed to the
//!   columns of the map's 8 x 8-texel cells that the ray crosses ([`march`], rule 2).
//! - **Lookups.** Nearest texel, with the exact rules of [`march`] (a shader mirrors them
//!   with `textureLoad` of `floor(position)`); empty texels and the outside of the map read
//!   255, which no ray depth reaches.
//! - **Vertical walls.** The two samples that bracket the hit are those of the final binary
//!   bracket; their stored depth codes are compared. An empty sample has no depth: a bracket
//!   between an empty and a surface texel is always a wall (the projection's silhouette).
//!   The default threshold is 0.25 of the impostor's depth range (63.5 codes), chosen by
//!   measurement (n = 20, 256 x 256 maps, s0 = 256, best:6, the column-narrowed search;
//!   coverage error average / maximum, impostors per view, inverse coverage average, p_dif,
//!   over the 320 directions):
//!
//!   | threshold | armadillo                               | Stanford bunny                          |
//!   |-----------|-----------------------------------------|-----------------------------------------|
//!   | 0.0625    | 0.160 / 0.650 %, 3.42, 0.498 %, 17.3     | 0.191 / 1.926 %, 3.11, 0.493 %, 12.2     |
//!   | 0.125     | 0.150 / 0.635 %, 3.21, 0.570 %, 18.8     | 0.185 / 1.854 %, 2.91, 0.527 %, 13.0     |
//!   | 0.1875    | 0.139 / 0.597 %, 2.98, 0.702 %, 21.6     | 0.165 / 1.645 %, 2.77, 0.599 %, 14.0     |
//!   | **0.25**  | 0.130 / 0.362 %, 2.72, 0.964 %, 26.6     | 0.151 / 1.573 %, 2.65, 0.681 %, 15.2     |
//!   | 0.5       | 0.112 / 0.282 %, 2.14, 2.405 %, 52.6     | 0.119 / 1.393 %, 2.27, 1.233 %, 22.7     |
//!
//!   Higher thresholds buy coverage by keeping relief "shadow volumes": the pixels they
//!   cover are drawn with the wrong surface, and some fall outside the mesh. 0.25 is the
//!   smallest value at which the armadillo reaches the paper's figures (0.17 / 0.37 %, 2.9
//!   impostors per view), and the bunny its average and impostors per view; the cost on the
//!   armadillo is +0.39 points of inverse coverage and p_dif +41 % against 0.125. 0.5
//!   doubles both again. Real
//!   surfaces steeper than about 89 degrees from the impostor direction (steps over 63
//!   codes between neighbouring texels) are still discarded as walls.
//! - **Priority.** Option 3 (default): the list order, closest direction first. Option 5:
//!   the least `view depth - cos(impostor direction, stored normal) / 32`, depth in units of
//!   the view's depth range (ties: earlier in the list).
//! - **Depth.** Measured in the evaluation view: 0 at the near side of the object, 1 at its
//!   far side (the object's extent along `w`); the ORI's depth is that of the ray at the hit.
//! - **Colour.** p_dif compares shaded colours ([`Shading`]: albedo x (0.3 + 0.7 n . l), a
//!   light fixed to the view) as 8-bit sRGB, 0 to 765 per pixel, background black, averaged
//!   over the union of both silhouettes. The reference albedo and normal come from a relief
//!   map baked along the view itself, so shading and filtering are the impostors' own.
//!
//! # Speed
//!
//! Selection needs, per direction, the mesh's coverage and six impostor masks over the
//! pixels the mesh covers. Mesh coverage skips triangles whose candidate pixels are covered
//! already, in a cache-friendly triangle order; impostor masks search eight rays at a time in
//! AVX lanes where the processor has AVX2 (chosen at run time; four in SSE lanes otherwise,
//! [`Simd`]) and skip the binary search where its outcome is already decided (one texel, or
//! no wall near the bracket). Full renders (a [`Layer`]'s fragments, for colour, depth and
//! pictures) search in the same lanes, without the shortcuts. Impostor masks are tested equal
//! to the full renders' masks, and both searches, at every lane width, to the scalar rule
//! ([`ImpostorRays::covers`], [`ImpostorRays::trace`]), so the processor changes the speed,
//! never a bit of the result.
//! On the 2-core build machine, eight lanes took selection + PLT on dragon_res2 from 3.4 s
//! (four lanes) to 2.5 s in release (`cargo xtask bench select`).
//!
//! Determinism: everything here is single-threaded per view, uses only IEEE arithmetic and
//! `ori_math`, and iterates in a fixed order; callers parallelise over views.

mod compare;
mod coverage;
mod lanes;
pub mod march;
mod mask;
mod part;
mod reference;
mod render;

use ori_mesh::Mesh;
use ori_raster::OrthoView;
use ori_relief::ReliefSet;
use serde::{Deserialize, Serialize};

pub use compare::{
    ShadedMesh, Shading, ViewErrors, compare, error_image, percent, write_error_png,
};
pub use march::{ImpostorRays, MarchParams, Simd, Trace, WallMap};
pub use mask::{Mask, PartialMask};
pub use part::Whole;
pub use reference::eval_view;
pub use render::{Layer, NO_SOURCE, Render};

/// The full render of any mesh (the baker's) through `view` (what
/// [`Evaluator::render_mesh`] draws for a whole model), for drawing another mesh, such as a
/// simplified one, in the evaluation view of the original.
pub fn render_mesh(baker: &ori_bake::Baker, view: &OrthoView) -> Result<Render, EvalError> {
    reference::render(baker, view)
}

/// Which fragment wins where several impostors draw the same pixel (ORI paper, 3.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Priority {
    /// Option 3: the impostor closest to the view direction (first in the subset's order).
    #[default]
    #[serde(rename = "closest")]
    ClosestDirection,
    /// Option 5: the least view depth, decreased by `cos(impostor direction, stored normal)
    /// / 32` so that well-sampled fragments win (the rule between nodes of a hierarchy).
    #[serde(rename = "biased-depth")]
    BiasedDepth,
}

/// Parameters of the evaluator and of the runtime rule it follows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EvalParams {
    /// Evaluation image edge s0 in pixels (default 256).
    pub s0: u32,
    /// Linear-search steps of the ray-heightfield search (default 16).
    pub linear_steps: u32,
    /// Binary-search steps (default 7).
    pub binary_steps: u32,
    /// Vertical-wall threshold: the largest depth step between the two samples bracketing a
    /// hit that is still a surface, as a fraction of the impostor's depth range (default
    /// 0.25, i.e. 63.5 depth codes; from 1 on no depth step is a wall, while a bracket that
    /// starts over an empty texel always is).
    pub wall_threshold: f64,
    /// Fragment priority (default option 3, closest direction).
    pub priority: Priority,
}

impl Default for EvalParams {
    fn default() -> Self {
        EvalParams {
            s0: 256,
            linear_steps: 16,
            binary_steps: 7,
            wall_threshold: 0.25,
            priority: Priority::ClosestDirection,
        }
    }
}

impl EvalParams {
    /// Check every field, with a message that names the key and what it accepts.
    pub fn validate(&self) -> Result<(), EvalError> {
        let bad = |m: String| Err(EvalError::Params(m));
        if !(8..=4096).contains(&self.s0) {
            return bad(format!("s0 = {} must be 8 to 4096 pixels", self.s0));
        }
        if !(1..=1024).contains(&self.linear_steps) {
            return bad(format!(
                "linear_steps = {} must be 1 to 1024",
                self.linear_steps
            ));
        }
        if self.binary_steps > 32 {
            return bad(format!(
                "binary_steps = {} must be 0 to 32",
                self.binary_steps
            ));
        }
        if !(self.wall_threshold >= 0.0 && self.wall_threshold.is_finite()) {
            return bad(format!(
                "wall_threshold = {} must be a finite fraction >= 0",
                self.wall_threshold
            ));
        }
        Ok(())
    }

    /// The search parameters of the runtime rule.
    pub fn march(&self) -> MarchParams {
        MarchParams {
            linear_steps: self.linear_steps,
            binary_steps: self.binary_steps,
            wall_threshold: self.wall_threshold as f32,
        }
    }
}

/// Why an evaluation could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EvalError {
    /// A parameter is out of range; the message names it.
    #[error("invalid evaluation parameters: {0}")]
    Params(String),
    /// The relief set cannot be drawn (empty, too many maps, inconsistent sizes).
    #[error("invalid relief set: {0}")]
    Set(String),
    /// A view could not be framed or rendered.
    #[error("cannot evaluate view: {0}")]
    View(String),
}

/// The pixels a whole mesh covers ([`Evaluator::mesh_coverage`] without a relief set, for
/// what is measured by its silhouette alone): the coverage of its full render
/// ([`render_mesh`]) for a fraction of the work.
pub struct MeshCoverage<'a> {
    mesh: coverage::CoverageMesh,
    alpha: Option<reference::AlphaCut<'a>>,
}

impl<'a> MeshCoverage<'a> {
    pub fn new(mesh: &'a Mesh) -> MeshCoverage<'a> {
        MeshCoverage {
            mesh: coverage::CoverageMesh::new(mesh, &mesh.single_sided()),
            alpha: reference::AlphaCut::new(mesh),
        }
    }

    /// The pixels the mesh covers in `view`.
    pub fn of(&self, view: &OrthoView) -> Mask {
        coverage::coverage(view, &self.mesh, self.alpha.as_ref())
    }
}

/// The evaluator of one mesh and its relief set.
pub struct Evaluator<'a> {
    mesh: &'a Mesh,
    set: &'a ReliefSet,
    params: EvalParams,
    /// The mesh's textures, read by every reference render (made by the first).
    baker: std::sync::OnceLock<ori_bake::Baker>,
    /// Per map, where its walls are (for the fast coverage test).
    walls: Vec<WallMap>,
    /// Per map, its occupied volume and column grid (rule 2).
    occupancy: Vec<march::Occupancy>,
    coverage: MeshCoverage<'a>,
    /// When the mesh is a part of a larger model: the model (see [`Evaluator::part_of`]).
    whole: Option<part::WholeModel<'a>>,
}

impl<'a> Evaluator<'a> {
    pub fn new(
        mesh: &'a Mesh,
        set: &'a ReliefSet,
        params: &EvalParams,
    ) -> Result<Evaluator<'a>, EvalError> {
        params.validate()?;
        if set.maps.is_empty() || set.maps.len() >= usize::from(NO_SOURCE) {
            return Err(EvalError::Set(format!(
                "{} relief maps (1 to {} are drawable)",
                set.maps.len(),
                NO_SOURCE - 1
            )));
        }
        for (i, m) in set.maps.iter().enumerate() {
            let n = m.size() as usize * m.size() as usize;
            if m.size() == 0 || m.depth.len() != n || m.normal.len() != n || m.albedo.len() != n {
                return Err(EvalError::Set(format!(
                    "map {i}: texel arrays do not match its size {}",
                    m.size()
                )));
            }
        }
        Ok(Evaluator {
            mesh,
            set,
            params: params.clone(),
            baker: std::sync::OnceLock::new(),
            walls: set
                .maps
                .iter()
                .map(|m| WallMap::new(&m.depth, m.size(), params.march().threshold_codes()))
                .collect(),
            occupancy: set.maps.iter().map(march::Occupancy::new).collect(),
            coverage: MeshCoverage::new(mesh),
            whole: None,
        })
    }

    /// Measure the mesh as a part of `whole` (a hierarchy node): the reference keeps only the
    /// pixels where the whole model's nearest surface lies inside the box the part was
    /// clipped to; at the others the rest of the model is in front of the part. `None`: the
    /// mesh is the whole model.
    pub fn part_of(mut self, whole: Option<Whole<'a>>) -> Evaluator<'a> {
        self.whole = whole.map(part::WholeModel::new);
        self
    }

    pub fn params(&self) -> &EvalParams {
        &self.params
    }

    pub fn mesh(&self) -> &'a Mesh {
        self.mesh
    }

    pub fn set(&self) -> &'a ReliefSet {
        self.set
    }

    /// The evaluation view along `w` at `s0` (see [`eval_view`]).
    pub fn view(&self, w: [f64; 3]) -> Result<OrthoView, EvalError> {
        eval_view(self.mesh, w, self.params.s0)
    }

    /// The impostors facing `w` (`d . w > 0`), closest direction first (largest `d . w`;
    /// ties: lower index first).
    pub fn facing(&self, w: [f64; 3]) -> Vec<usize> {
        let dots: Vec<f64> = self
            .set
            .maps
            .iter()
            .map(|m| {
                let d = m.view.frame.d;
                d[0] * w[0] + d[1] * w[1] + d[2] * w[2]
            })
            .collect();
        let mut order: Vec<usize> = (0..dots.len()).filter(|&i| dots[i] > 0.0).collect();
        // Stable: equal dot products keep index order.
        order.sort_by(|&a, &b| dots[b].total_cmp(&dots[a]));
        order
    }

    /// Pixels the mesh covers (single-sided triangles only from the front; for a part, only
    /// its own: [`Evaluator::part_of`]).
    pub fn mesh_coverage(&self, view: &OrthoView) -> Mask {
        let mut coverage = self.coverage.of(view);
        if let Some(whole) = &self.whole {
            coverage.remove(&whole.in_front(view, &coverage));
        }
        coverage
    }

    /// The full reference render of the mesh (for a part, of its own pixels only).
    pub fn render_mesh(&self, view: &OrthoView) -> Result<Render, EvalError> {
        let baker = self.baker.get_or_init(|| ori_bake::Baker::new(self.mesh));
        let mut render = reference::render(baker, view)?;
        if let Some(whole) = &self.whole {
            let hidden = whole.in_front(view, &render.coverage);
            for i in hidden.ones() {
                render.clear(i);
            }
            render.coverage.remove(&hidden);
        }
        Ok(render)
    }

    /// The rays of `view` in impostor `impostor`'s texture space (`None` when it does not
    /// face the viewer).
    pub fn rays(&self, view: &OrthoView, impostor: usize) -> Option<ImpostorRays> {
        ImpostorRays::new(
            view,
            &self.set.maps[impostor],
            &self.occupancy[impostor],
            self.params.march(),
        )
    }

    /// Pixels where impostor `impostor` produces a fragment, traced only at the pixels of
    /// `within` when given (the others are left out of the mask).
    pub fn impostor_mask(&self, view: &OrthoView, impostor: usize, within: Option<&Mask>) -> Mask {
        let mut mask = Mask::new(view.size);
        let Some(rays) = self.rays(view, impostor) else {
            return mask;
        };
        let depth = &self.set.maps[impostor].depth;
        let walls = &self.walls[impostor];
        let pixels = render::pixels_to_trace(&rays, view.size, within);
        rays.covers_many(depth, walls, &pixels, |i, covered| {
            if covered {
                mask.set(i);
            }
        });
        mask
    }

    /// Every fragment impostor `impostor` draws in `view` (at the pixels of `within` only,
    /// when given).
    pub fn layer(&self, view: &OrthoView, impostor: usize, within: Option<&Mask>) -> Layer {
        Layer::trace(
            view,
            &self.set.maps[impostor],
            impostor,
            self.rays(view, impostor),
            within,
        )
    }

    /// Compose layers given in priority order (closest direction first) into the ORI's image.
    pub fn compose(&self, view: &OrthoView, layers: &[&Layer]) -> Render {
        render::compose(self.set, view.size, layers, self.params.priority)
    }

    /// The ORI drawn with the impostors of `subset`, in that order.
    pub fn render_ori(&self, view: &OrthoView, subset: &[usize]) -> Render {
        let mut layers: Vec<Layer> = Vec::with_capacity(subset.len());
        // Where the closest direction wins, an impostor is seen only where those before it
        // draw nothing, so it is traced there alone.
        let mut open: Option<Mask> = None;
        for &i in subset {
            let layer = self.layer(view, i, open.as_ref());
            if self.params.priority == Priority::ClosestDirection {
                let mut rest = open.unwrap_or_else(|| Mask::full(view.size));
                rest.remove(layer.mask());
                open = Some(rest);
            }
            layers.push(layer);
        }
        let refs: Vec<&Layer> = layers.iter().collect();
        self.compose(view, &refs)
    }
}
