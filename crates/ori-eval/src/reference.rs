//! Reference renders of the mesh: the evaluation view's framing, coverage (with the same
//! alpha test as baking), and the full render (depth, albedo, normal) that colour and depth
//! errors compare against.

use ori_bake::Baker;
use ori_mesh::{AlphaMode, Mesh, Wrap};
use ori_raster::{EMPTY, Frame, OrthoView};
use ori_relief::ReliefMap;

use crate::{EvalError, NO_SOURCE, Render};

/// The evaluation view of `mesh` along `w` (unit, towards the viewer): orthographic, `s0`
/// pixels square, framed so that the square bounding box of the object's projection has edge
/// `s0` (`OrthoView::fit` with no margin); depth 0..1 spans the object's extent along `w`.
pub fn eval_view(mesh: &Mesh, w: [f64; 3], s0: u32) -> Result<OrthoView, EvalError> {
    OrthoView::fit(Frame::from_direction(w), &mesh.positions, s0, 0)
        .map_err(|e| EvalError::View(format!("direction {w:?}: {e}")))
}

/// The alpha test of cut-out (MASK) materials, computed exactly as `ori_bake` computes it
/// (factor x level-0 bilinear texture x vertex colour alpha, in `f32`, in the same order), so
/// that reference coverage and baked coverage agree texel for texel.
pub(crate) struct AlphaCut<'m> {
    mesh: &'m Mesh,
    pub masked: Vec<bool>,
}

impl<'m> AlphaCut<'m> {
    /// `None` when no material is alpha-tested.
    pub fn new(mesh: &'m Mesh) -> Option<AlphaCut<'m>> {
        let masked: Vec<bool> = mesh
            .triangle_materials
            .iter()
            .map(|&m| mesh.materials[m as usize].alpha_mode == AlphaMode::Mask)
            .collect();
        masked
            .iter()
            .any(|&m| m)
            .then_some(AlphaCut { mesh, masked })
    }

    pub fn keeps(&self, tri: u32, bary: [f32; 3]) -> bool {
        let mesh = self.mesh;
        let t = mesh.triangles[tri as usize];
        let material = &mesh.materials[mesh.triangle_materials[tri as usize] as usize];
        let mut alpha = material.base_color_factor[3];
        if let Some(tex) = material.base_color_texture {
            let mut uv = [0.0f32; 2];
            if let Some(uvs) = &mesh.uvs {
                for k in 0..3 {
                    let c = uvs[t[k] as usize];
                    uv[0] += bary[k] * c[0];
                    uv[1] += bary[k] * c[1];
                }
            }
            alpha *= sample_alpha(&mesh.textures[tex as usize], uv);
        }
        if let Some(colors) = &mesh.colors {
            let mut v = 0.0f32;
            for k in 0..3 {
                v += bary[k] * colors[t[k] as usize][3];
            }
            alpha *= v;
        }
        let alpha = if alpha.is_finite() {
            alpha.clamp(0.0, 1.0)
        } else {
            0.0
        };
        alpha >= material.alpha_cutoff
    }
}

/// Bilinear alpha of level 0 at `uv` (glTF convention), as `ori_bake`'s texture sampler.
fn sample_alpha(texture: &ori_mesh::Texture, uv: [f32; 2]) -> f32 {
    let (w, h) = (texture.width as usize, texture.height as usize);
    let texel = |i: usize| f32::from(texture.rgba8[4 * i + 3]) / 255.0;
    let x = uv[0] * w as f32 - 0.5;
    let y = uv[1] * h as f32 - 0.5;
    if !(x.is_finite() && y.is_finite()) {
        return texel(0);
    }
    let (fx, fy) = (x.floor(), y.floor());
    let (tx, ty) = (x - fx, y - fy);
    let (ix, iy) = (fx as i64, fy as i64);
    let at = |i: i64, j: i64| {
        let i = wrap(i, w, texture.wrap_s);
        let j = wrap(j, h, texture.wrap_t);
        texel(j * w + i)
    };
    let (a, b, c, d) = (
        at(ix, iy),
        at(ix + 1, iy),
        at(ix, iy + 1),
        at(ix + 1, iy + 1),
    );
    let top = a + (b - a) * tx;
    let bottom = c + (d - c) * tx;
    top + (bottom - top) * ty
}

fn wrap(i: i64, n: usize, mode: Wrap) -> usize {
    let n = n as i64;
    let r = match mode {
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::MirroredRepeat => {
            let p = i.rem_euclid(2 * n);
            if p < n { p } else { 2 * n - 1 - p }
        }
    };
    r as usize
}

/// The full reference: coverage and exact depth from the rasterizer, albedo and normal from a
/// relief map baked through the view itself (same shading, filtering and 8-bit encoding as
/// the impostors, so colour errors measure the impostors and not a difference of shaders).
/// The bake's alpha test and culling are the reference's (see [`AlphaCut`]), so its raster
/// of texel centres is the reference's raster.
pub(crate) fn render(baker: &Baker, view: &OrthoView) -> Result<Render, EvalError> {
    let (map, r) = baker
        .render_view(view, 2)
        .map_err(|e| EvalError::View(e.to_string()))?;
    let n = view.size as usize;
    let mut out = Render::empty(view.size);
    for i in 0..n * n {
        if r.tri[i] == EMPTY {
            continue;
        }
        out.coverage.set(i);
        out.depth[i] = view.depth_of_height(r.height[i]) as f32;
        out.albedo[i] = map.albedo[i];
        out.normal[i] = world_normal(&map, i);
        out.source[i] = NO_SOURCE;
    }
    Ok(out)
}

/// The unit world-space normal stored in texel `i` of `map`.
pub(crate) fn world_normal(map: &ReliefMap, i: usize) -> [f32; 3] {
    let l = ReliefMap::decode_normal(map.normal[i]);
    map.view.frame.to_world(l).map(|c| c as f32)
}
