//! The runtime renderer on wgpu: loads `.ori` packages into GPU textures and draws them with
//! the WGSL shaders of `shaders/` (`ori.wgsl` for impostors, `mesh.wgsl` for reference
//! meshes), headless, into images read back on the CPU.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use ori_render::{Camera, Renderer};
//! let package = ori_package::read(&std::fs::read("bunny.ori")?)?;
//! let renderer = Renderer::new()?;
//! println!("adapter: {}", renderer.adapter_summary());
//! let ori = renderer.load_package(&package)?;
//! let (center, radius) = ori.bounding_sphere();
//! let camera = Camera::ortho_framing(center, radius, [0.0, 0.3, 1.0]);
//! let image = renderer.render_ori(&ori, &camera, 512, 512)?;
//! image.save_png("bunny.png".as_ref())?;
//! # Ok(()) }
//! ```
//!
//! - [`Renderer`]: the adapter (whatever exists, software drivers included; none is a
//!   [`RenderError::NoAdapter`], never a panic), the device and the two pipelines.
//! - [`GpuOri`]: a package's maps as texture arrays, BC-compressed where the adapter samples
//!   BC, else decoded on the CPU; its selection table over the 320 evaluation directions.
//! - [`GpuMesh`]: a mesh (positions, normals, UVs, vertex colours; base-colour factor x
//!   texture x vertex colour; alpha test).
//! - [`Camera`]: orthographic (the evaluator's framing with [`Camera::from_view`]) or
//!   perspective.
//! - [`Renderer::render`] draws any list of [`Draw`]s into one [`Image`]: colour, coverage,
//!   depth and, per pixel, which impostor (or mesh) drew it.
//! - [`GpuHierarchy`]: a hierarchy package (format version 2): every node's ORI with option
//!   5, [`GpuHierarchy::traverse`] (the runtime rule: a node's ORI where its PLT holds, else
//!   its children, else the leaf's mesh) and [`GpuHierarchy::draws`].
//!
//! # Invariants
//!
//! - **One rule.** The fragment shader is `ori_eval::march`'s rule step for step (ray from
//!   the pixel centre, clip to the occupied volume and narrow to the columns it crosses
//!   ([`column_tops`], computed at load), 16 linear + 7 binary steps with nearest
//!   texel lookups, wall discard with empty as an unbounded wall, fragment = texel `hi`), in
//!   the same `f32` operations in the same order; for an orthographic camera the ray setup is
//!   the evaluator's, computed in `f64` on the CPU and rounded once, so its rays are the
//!   evaluator's bit for bit. Step counts and the wall threshold are per-impostor uniforms,
//!   taken from the package's `params.select` (defaults 16, 7, 0.25). The parity test holds
//!   GPU and CPU together (coverage, colour, depth, which impostor drew each pixel).
//! - **Priority, per ORI ([`GpuOri::set_priority`]), as the evaluator's
//!   `ori_eval::Priority`.**
//!   - *Closest direction first (option 3, the default), "first writer wins".* The selected
//!     impostors draw in table order with the ORI's stencil reference; a fragment passes
//!     only where the stencil is not yet that reference and claims the pixel whether or not
//!     the depth test passes. So the first impostor in the list that produces a fragment
//!     owns the pixel, as in the evaluator. Up to 255 ORIs per render (8-bit stencil).
//!   - *Biased depth (option 5, [`Priority::BiasedDepth`]).* The least `depth - cos / 32`
//!     wins, `cos` the stored normal's component along the impostor direction, depth in
//!     units of [`GpuOri::depth_range`] (the evaluator's unit when set to the evaluation
//!     view's range); ties go to the earlier impostor. No stencil: each fragment writes the
//!     depth of its hit pushed away from the viewer by `(1 - cos) / 32` of that range (the
//!     same order, never nearer than the hit), the depth test is LESS and the impostors draw
//!     in list order, so the least biased depth wins and the earlier impostor keeps a tie.
//! - **True depth.** Under option 3 every impostor fragment writes the depth of its hit
//!   point, so ORIs and meshes composite through one depth buffer in any draw order. Under
//!   option 5 the depth buffer holds the *biased* depth (the true depth plus up to 1/32 of
//!   the depth range): a mesh surface less than that in front of or behind an impostor hit
//!   may composite wrongly against it. [`Image::depth`] holds the true depth under both
//!   rules.
//! - **Coverage is exact-conservative.** Each impostor draws the back faces of its occupied
//!   relief box (grown by 1/16 texel for the rasteriser only), so every pixel whose ray
//!   meets the box runs the shader once, however skewed the view, and the shader clips
//!   exactly.
//! - **Same shading.** Impostors and meshes use the evaluator's comparison shading
//!   (`ori_eval::Shading`): albedo x (0.3 + 0.7 max(0, n . l)), `l = normalize(0.3 u + 0.5 v
//!   + d)` of the camera frame, in linear light, written to an sRGB target.
//! - **Errors, not panics.** Invalid packages, meshes, cameras, sizes and wgpu validation
//!   errors (captured with error scopes) come back as [`RenderError`].

#![warn(missing_docs)]

mod camera;
mod hierarchy;
mod image;
mod mesh;
mod ori;
mod pipelines;
mod rays;
mod renderer;
mod targets;

pub use camera::{Camera, Projection};
pub use hierarchy::GpuHierarchy;
pub use image::{Image, SOURCE_MESH, SOURCE_NONE};
pub use mesh::GpuMesh;
pub use ori::{COLUMN_CELL, GpuOri, column_tops};
pub use ori_hierarchy::Visit;
pub use renderer::{Renderer, RendererOptions};
/// The bias of option 5 ([`Priority::BiasedDepth`]): `cos / OPTION5_BIAS_DIVISOR` of the
/// depth range, as `ori_eval`'s evaluator.
const OPTION5_BIAS_DIVISOR: f64 = 32.0;
/// The wgpu version this crate is built on, for callers that use [`Renderer::device`].
pub use wgpu;

/// Search parameters of the runtime rule (the evaluator's `ori_eval::MarchParams`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchParams {
    /// Linear-search steps (default 16).
    pub linear_steps: u32,
    /// Binary-search steps (default 7).
    pub binary_steps: u32,
    /// Vertical-wall threshold, a fraction of the impostor's depth range (default 0.25:
    /// `0.25 * 254` codes, computed in `f32`).
    pub wall_threshold: f32,
}

impl Default for MarchParams {
    fn default() -> Self {
        MarchParams {
            linear_steps: 16,
            binary_steps: 7,
            wall_threshold: 0.25,
        }
    }
}

impl MarchParams {
    /// The parameters a package was measured with, each defaulted when it records none.
    pub fn from_manifest(manifest: &ori_package::Manifest) -> MarchParams {
        let d = MarchParams::default();
        let recorded = manifest.recorded_march();
        MarchParams {
            linear_steps: recorded.linear_steps.unwrap_or(d.linear_steps),
            binary_steps: recorded.binary_steps.unwrap_or(d.binary_steps),
            wall_threshold: recorded
                .wall_threshold
                .map_or(d.wall_threshold, |w| w as f32),
        }
    }
}

/// Which fragment wins where several impostors of one ORI produce one (the evaluator's
/// `ori_eval::Priority`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Priority {
    /// Option 3: the impostor closest to the view direction (first in the selection's
    /// order), whatever its depth: "first writer wins" in the stencil buffer.
    #[default]
    ClosestDirection,
    /// Option 5: the least `view depth - cos(impostor direction, stored normal) / 32`, depth
    /// in units of the ORI's depth range ([`GpuOri::depth_range`]); ties go to the earlier
    /// impostor in the selection's order. Drawn with the biased depth in the depth buffer
    /// (see the crate's invariants).
    BiasedDepth,
}

/// One thing to draw in [`Renderer::render`].
#[derive(Clone, Copy)]
pub enum Draw<'a> {
    /// A mesh.
    Mesh(&'a GpuMesh),
    /// An ORI with the impostors its selection table gives for the camera's view direction
    /// (from the bounding sphere's centre towards the eye).
    Ori(&'a GpuOri),
    /// An ORI with these impostors, in this priority order (closest direction first).
    OriSubset(&'a GpuOri, &'a [u16]),
}

/// Why the renderer could not start, load or draw.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No graphics adapter exists (install a Vulkan driver; on Linux without a GPU, Mesa's
    /// lavapipe: `mesa-vulkan-drivers`).
    #[error(
        "no graphics adapter found ({0}); on Linux without a GPU install Mesa's lavapipe (mesa-vulkan-drivers)"
    )]
    NoAdapter(String),
    /// The adapter refused to open a device.
    #[error("cannot open the graphics device: {0}")]
    Device(String),
    /// The package cannot be uploaded.
    #[error("cannot load the package: {0}")]
    Package(String),
    /// The mesh cannot be uploaded.
    #[error("cannot load the mesh: {0}")]
    Mesh(String),
    /// The camera is degenerate.
    #[error("invalid camera: {0}")]
    Camera(String),
    /// The image size is zero or beyond the adapter's limit.
    #[error("invalid image size {width} x {height} (1 to {max} per edge)")]
    Size {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// The adapter's largest texture edge.
        max: u32,
    },
    /// The draw list cannot be drawn (an impostor index out of range, too many ORIs).
    #[error("invalid scene: {0}")]
    Scene(String),
    /// wgpu reported an error (validation, out of memory).
    #[error("gpu error: {0}")]
    Gpu(String),
    /// Reading the image back failed.
    #[error("cannot read the image back: {0}")]
    Readback(String),
}
