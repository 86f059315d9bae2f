//! Relief-map baking.
//!
//! For each planned direction the mesh is rendered orthographically into a square relief map
//! (the guide's "Relief texel"): depth (8 bits, 0 at the near plane, 254 at the far side of
//! the object, 255 = empty: the ray passes), the shading normal in the impostor frame (x and
//! y stored, z >= 0 rebuilt), and the albedo (base-colour factor x texture x vertex colour,
//! sRGB). Alpha-tested (MASK) materials cut holes, and single-sided materials are seen from
//! the front only (`Mesh::single_sided`: back faces culled, as an engine draws the mesh), so
//! that a hole in an open scan stays a hole instead of showing the scan's inside.
//!
//! Choices:
//! - Depth comes from the texel centre, so every texel whose centre hits lies on the surface
//!   within half a depth step. Coverage is conservative: a texel whose centre misses but one
//!   of its `supersample`^2 sub-samples hits is kept, at the nearest hit sub-sample's depth
//!   (otherwise silhouettes lose up to half a texel at runtime). Colour and normal are
//!   averaged over the sub-samples that hit the surface (antialiasing without mixing in
//!   background).
//! - Textures are minified through a mip chain (level picked per triangle from its texel-to-
//!   sample ratio) and bilinear filtering, in linear space.
//! - Empty texels get colour and normal by pull-push fill from the nearest surface, so
//!   filtering and mipmaps never bleed background into the silhouette.
//! - Every map is computed by one thread in a fixed order; maps run in parallel, so the result
//!   is bit-identical for any thread count. No NaN reaches a map: non-finite values are caught
//!   where they could arise and the mesh's positions are finite by construction.

mod fill;
mod png;
mod sample;

use ori_mesh::{AlphaMode, Mesh};
use std::sync::Arc;

use ori_raster::{AlphaTest, Culling, EMPTY, Frame, OrthoView, Raster, rasterize_scales};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use ori_relief::{DecodeError, EMPTY_DEPTH, MAX_DEPTH, ReliefMap, ReliefSet};

/// `[bake]` parameters.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BakeParams {
    /// Relief-map edge in texels (power of two recommended for mipmaps and block compression).
    pub resolution: u32,
    /// Colour and normal samples per texel edge: 1 (no antialiasing), 2 or 4.
    pub supersample: u32,
    /// Empty texels kept around the object's projection on each side.
    pub margin: u32,
}

impl Default for BakeParams {
    fn default() -> Self {
        BakeParams {
            resolution: 256,
            supersample: 2,
            margin: 2,
        }
    }
}

impl BakeParams {
    /// Check every field, with a message that names the key and what it accepts.
    pub fn validate(&self) -> Result<(), BakeError> {
        // Powers of two only: block compression, mipmaps and the package format need them.
        if !self.resolution.is_power_of_two() || !(8..=8192).contains(&self.resolution) {
            return Err(BakeError::Params(format!(
                "bake.resolution = {} must be a power of two from 8 to 8192 (or \"auto\")",
                self.resolution
            )));
        }
        if ![1, 2, 4].contains(&self.supersample) {
            return Err(BakeError::Params(format!(
                "bake.supersample = {} must be 1, 2 or 4",
                self.supersample
            )));
        }
        if self.margin >= self.resolution / 4 {
            return Err(BakeError::Params(format!(
                "bake.margin = {} must be less than a quarter of the resolution ({})",
                self.margin, self.resolution
            )));
        }
        Ok(())
    }
}

/// Why baking failed.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("{0}")]
    Params(String),
    #[error("cannot frame view {index} (direction {direction:?}): {reason}")]
    Frame {
        index: usize,
        direction: [f64; 3],
        reason: String,
    },
}

/// Bake one relief map per direction.
pub fn bake(
    mesh: &Mesh,
    directions: &[[f64; 3]],
    params: &BakeParams,
) -> Result<ReliefSet, BakeError> {
    Baker::new(mesh).bake(directions, params)
}

/// [`bake`] at any resolution from 8 to 8192 texels, for maps that never become a package's
/// textures (the rival techniques of `ori-rivals`), which need no power of two.
pub fn bake_any_resolution(
    mesh: &Mesh,
    directions: &[[f64; 3]],
    params: &BakeParams,
) -> Result<ReliefSet, BakeError> {
    Baker::new(mesh).bake_any_resolution(directions, params)
}

/// [`BakeParams::validate`] for a resolution of 8 to 8192 texels, a power of two or not.
fn validate_any_resolution(params: &BakeParams) -> Result<(), BakeError> {
    if !(8..=8192).contains(&params.resolution) {
        return Err(BakeError::Params(format!(
            "resolution {} must be 8 to 8192 texels",
            params.resolution
        )));
    }
    BakeParams {
        resolution: params.resolution.next_power_of_two(),
        ..params.clone()
    }
    .validate()
}

/// What every bake of one mesh shares: its textures, decoded and mipmapped, its triangles in
/// the order that draws fastest, and which of them are alpha-tested and culled from behind.
/// Keep one to bake a mesh many times.
pub struct Baker {
    /// The mesh's surface in [`Mesh::spatial_order`] (without its textures): drawn and shaded
    /// in that order, so that neighbouring pixels read neighbouring memory. Rasters say which
    /// triangle of the original mesh they saw.
    mesh: Mesh,
    /// The original index of each triangle of `mesh`.
    original: Vec<u32>,
    textures: Arc<Textures>,
    /// Per triangle of `mesh`: alpha-tested, and culled from behind (as the reference mesh is
    /// drawn).
    masked: Vec<bool>,
    culling: Culling,
}

impl Baker {
    pub fn new(mesh: &Mesh) -> Baker {
        Baker::with_textures(mesh, Arc::new(Textures::new(mesh)))
    }

    /// A baker of a mesh with the same materials (so the same texture indices) as the one
    /// `textures` were made for, such as a part of it; its own textures are not read.
    pub fn with_textures(mesh: &Mesh, textures: Arc<Textures>) -> Baker {
        let original = mesh.spatial_order();
        Baker::in_order(mesh.reordered(&original), original, textures)
    }

    /// [`Baker::with_textures`] for `mesh.reordered(&original)` of a mesh whose order is
    /// `original` (its own [`Mesh::spatial_order`] or another mesh's of the same
    /// triangles, such as the mesh it was warped from): the maps and rasters are those of the
    /// mesh in its original order, and making the baker costs no sort.
    pub fn in_order(mesh: Mesh, original: Vec<u32>, textures: Arc<Textures>) -> Baker {
        Baker {
            textures,
            masked: mesh
                .triangle_materials
                .iter()
                .map(|&m| mesh.materials[m as usize].alpha_mode == AlphaMode::Mask)
                .collect(),
            culling: Culling::new(&mesh.positions, &mesh.triangles, mesh.single_sided()),
            mesh,
            original,
        }
    }

    /// See [`bake`].
    pub fn bake(
        &self,
        directions: &[[f64; 3]],
        params: &BakeParams,
    ) -> Result<ReliefSet, BakeError> {
        params.validate()?;
        self.bake_valid(directions, params)
    }

    /// See [`bake_any_resolution`].
    pub fn bake_any_resolution(
        &self,
        directions: &[[f64; 3]],
        params: &BakeParams,
    ) -> Result<ReliefSet, BakeError> {
        validate_any_resolution(params)?;
        self.bake_valid(directions, params)
    }

    /// The map of the mesh through `view` (any view of 8 to 8192 texels, such as another
    /// mesh's evaluation view), and the raster of its texel centres: the mesh's exact heights
    /// and triangles there, which the evaluator's reference render needs beside the map.
    pub fn bake_view(
        &self,
        view: &OrthoView,
        supersample: u32,
    ) -> Result<(ReliefMap, Raster), BakeError> {
        self.view_map(view, supersample, EmptyTexels::Filled)
    }

    /// [`Baker::bake_view`] with the texels no sample hits left zero rather than filled: what
    /// a render of the mesh reads (its covered texels) for less work.
    pub fn render_view(
        &self,
        view: &OrthoView,
        supersample: u32,
    ) -> Result<(ReliefMap, Raster), BakeError> {
        self.view_map(view, supersample, EmptyTexels::Zero)
    }

    fn view_map(
        &self,
        view: &OrthoView,
        supersample: u32,
        empty: EmptyTexels,
    ) -> Result<(ReliefMap, Raster), BakeError> {
        validate_any_resolution(&BakeParams {
            resolution: view.size,
            supersample,
            margin: 0,
        })?;
        Ok(bake_one(self, *view, supersample, empty))
    }

    fn bake_valid(
        &self,
        directions: &[[f64; 3]],
        params: &BakeParams,
    ) -> Result<ReliefSet, BakeError> {
        if directions
            .iter()
            .any(|d| !d.iter().all(|c| c.is_finite()) || d.iter().all(|&c| c == 0.0))
        {
            return Err(BakeError::Params(
                "a direction is zero or not finite".into(),
            ));
        }
        let maps = directions
            .par_iter()
            .enumerate()
            .map(|(index, &direction)| {
                let frame = Frame::from_direction(direction);
                OrthoView::fit(
                    frame,
                    &self.mesh.positions,
                    params.resolution,
                    params.margin,
                )
                .map(|view| bake_one(self, view, params.supersample, EmptyTexels::Filled).0)
                .map_err(|e| BakeError::Frame {
                    index,
                    direction,
                    reason: e.0,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(ReliefSet { maps })
    }
}

/// What a map holds where no sample hits the mesh.
#[derive(Clone, Copy, PartialEq, Eq)]
enum EmptyTexels {
    /// The nearest covered texels' values ([`fill::pull_push`]), as every baked map.
    Filled,
    /// Zero.
    Zero,
}

fn bake_one(
    baker: &Baker,
    view: OrthoView,
    supersample: u32,
    empty: EmptyTexels,
) -> (ReliefMap, Raster) {
    let (mesh, frame) = (&baker.mesh, view.frame);
    let shader = &sample::Shader {
        mesh,
        textures: &baker.textures,
    };
    let keep = |tri: u32, bary: [f32; 3]| shader.alpha_keeps(tri, bary);
    let alpha = AlphaTest {
        masked: &baker.masked,
        keep: &keep,
    };
    let alpha = baker.masked.iter().any(|&m| m).then_some(&alpha);
    let culling = Some(&baker.culling);

    let n = view.size as usize;
    let s = supersample as usize;
    let fine_view = view.with_size(view.size * supersample);
    // Depth and coverage at texel centres, colour and normal from the sub-samples: one pass.
    let scales: &[u32] = if s == 1 { &[1] } else { &[1, supersample] };
    let mut rasters = rasterize_scales(
        &view,
        &mesh.positions,
        &mesh.triangles,
        alpha,
        culling,
        Some(&baker.original),
        scales,
    );
    let fine = rasters.pop().expect("at least one raster");
    let mut centre = rasters.pop().unwrap_or_else(|| fine.clone());
    // Texture level per triangle: texels of level 0 per sample.
    let sample_area = {
        let w = 2.0 * view.half_size / fine_view.size as f64;
        w * w
    };
    let level_of = |tri: u32| -> usize {
        let Some(texel_area) = shader.texel_area(tri) else {
            return 0;
        };
        let t = mesh.triangles[tri as usize].map(|i| mesh.positions[i as usize].map(f64::from));
        let a = frame.to_local(t[0]);
        let b = frame.to_local(t[1]);
        let c = frame.to_local(t[2]);
        let projected = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs();
        if projected <= 0.0 {
            return 0;
        }
        let ratio = texel_area / (projected / sample_area);
        let material =
            mesh.materials[mesh.triangle_materials[tri as usize] as usize].base_color_texture;
        material
            .and_then(|t| baker.textures.mips(t))
            .map_or(0, |m| m.level_for(ratio))
    };

    let encoder = sample::SrgbEncoder::new();
    let mut depth = vec![EMPTY_DEPTH; n * n];
    let mut color = vec![[0.0f32; 3]; n * n];
    let mut normal = vec![[0.0f32; 3]; n * n];
    let mut weight = vec![0.0f32; n * n];
    let fine_n = n * s;
    for y in 0..n {
        for x in 0..n {
            let i = y * n + x;
            let mut c = [0.0f32; 3];
            let mut nm = [0.0f64; 3];
            let mut hits = 0u32;
            let mut top = f64::NEG_INFINITY;
            for sy in 0..s {
                for sx in 0..s {
                    let f = (y * s + sy) * fine_n + x * s + sx;
                    let tri = fine.tri[f];
                    if tri == EMPTY {
                        continue;
                    }
                    let col = shader.base_color(tri, fine.bary[f], level_of(tri));
                    let nn = shader.normal(tri, fine.bary[f], frame.d);
                    for k in 0..3 {
                        c[k] += col[k];
                        nm[k] += nn[k];
                    }
                    top = top.max(fine.height[f]);
                    hits += 1;
                }
            }
            let tri = centre.tri[i];
            if tri != EMPTY {
                let d = view.depth_of_height(centre.height[i]);
                depth[i] = (d.clamp(0.0, 1.0) * f64::from(MAX_DEPTH)).round() as u8;
                if hits == 0 {
                    // A sliver the centre hits but no sub-sample does: shade the centre.
                    let col = shader.base_color(tri, centre.bary[i], level_of(tri));
                    let nn = shader.normal(tri, centre.bary[i], frame.d);
                    c = [col[0], col[1], col[2]];
                    nm = nn;
                    hits = 1;
                }
            } else if hits > 0 {
                // An edge texel: the centre misses but a sub-sample hits. Keeping it (at the
                // nearest sub-sample's depth) makes the silhouette conservative; leaving it
                // empty loses about a third of a pixel along every silhouette at runtime
                // (armadillo best:6 average coverage error 0.398 % -> 0.271 %).
                let d = view.depth_of_height(top);
                depth[i] = (d.clamp(0.0, 1.0) * f64::from(MAX_DEPTH)).round() as u8;
            }
            if hits > 0 {
                let inv = 1.0 / hits as f32;
                color[i] = c.map(|v| v * inv);
                let local = frame.to_local(nm);
                normal[i] = local.map(|v| v as f32);
                weight[i] = 1.0;
            }
        }
    }
    if empty == EmptyTexels::Filled {
        fill::pull_push(n, &mut color, &weight, [0.5, 0.5, 0.5]);
        fill::pull_push(n, &mut normal, &weight, [0.0, 0.0, 1.0]);
    }
    let hit = |i: usize| empty == EmptyTexels::Filled || weight[i] > 0.0;
    let albedo = color
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if hit(i) {
                c.map(|v| encoder.encode(v))
            } else {
                [0; 3]
            }
        })
        .collect();
    let normal = normal
        .iter()
        .enumerate()
        .map(|(i, v)| {
            if !hit(i) {
                return [0; 2];
            }
            let (x, y, z) = (f64::from(v[0]), f64::from(v[1]), f64::from(v[2]).max(0.0));
            let len = (x * x + y * y + z * z).sqrt();
            let (x, y) = if len > 1e-12 && len.is_finite() {
                (x / len, y / len)
            } else {
                (0.0, 0.0)
            };
            [x, y].map(|c| ((c.clamp(-1.0, 1.0) + 1.0) * 0.5 * 255.0).round() as u8)
        })
        .collect();
    let map = ReliefMap {
        view,
        depth,
        normal,
        albedo,
    };
    // The raster names the original mesh's triangles.
    for t in centre.tri.iter_mut().filter(|t| **t != EMPTY) {
        *t = baker.original[*t as usize];
    }
    (map, centre)
}

pub use png::write_pngs;
pub use sample::Textures;
