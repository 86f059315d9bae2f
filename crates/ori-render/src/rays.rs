//! Per impostor and camera, what the fragment shader needs: the affine map from pixel centres
//! to rays in the impostor's texture space, texture space to clip space, the occupied relief
//! volume and the search parameters.
//!
//! For an orthographic camera the ray setup is `ori_eval::ImpostorRays::new` operation for
//! operation (`f64` here, rounded once to `f32`), so the shader's rays equal the evaluator's
//! bit for bit and the searches that follow take the same steps.

use bytemuck::{Pod, Zeroable};
use ori_package::Impostor;

use crate::MarchParams;
use crate::camera::{Camera, Projection, mul, to_gpu};

/// The deepest depth code (code 255 is "empty").
const MAX_DEPTH: f64 = 254.0;

/// One impostor as the shader sees it (`struct Impostor` in `shaders/ori.wgsl`; std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct ImpostorRecord {
    tex_to_clip: [[f32; 4]; 4],
    frame_u: [f32; 4],
    frame_v: [f32; 4],
    frame_d: [f32; 4],
    o0_ex: [f32; 4],
    ey_dir: [f32; 4],
    eye: [f32; 4],
    r0: [f32; 4],
    rx: [f32; 4],
    ry: [f32; 4],
    bounds: [f32; 4],
    depth_range: [f32; 4],
    /// x: option 5's bias per unit cos, a world length (`depth range / 32`); 0 under option
    /// 3 (the fragment depth is then the true depth).
    pub bias: [f32; 4],
    info: [u32; 4],
    ids: [u32; 4],
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn vec4(a: [f64; 3]) -> [f32; 4] {
    [a[0] as f32, a[1] as f32, a[2] as f32, 0.0]
}

/// Where to find an impostor's maps and what to call it.
pub(crate) struct Slot {
    /// Texture array layer.
    pub layer: u32,
    /// Impostor index, written to [`crate::Image::source`].
    pub index: u16,
    /// Cells per side of the maps' column grids.
    pub column_cells: u32,
}

/// The record of impostor `imp` (maps `resolution` texels square) for `camera` drawing a
/// `width x height` image; `None` when the impostor cannot draw (an orthographic view from
/// behind, `d . w <= 0`, as the evaluator; degenerate geometry; an empty map).
pub(crate) fn record(
    imp: &Impostor,
    resolution: u32,
    camera: &Camera,
    width: u32,
    height: u32,
    slot: Slot,
    march: &MarchParams,
) -> Option<ImpostorRecord> {
    let [u, v, d] = imp.frame;
    let occ = imp.occupied;
    if !(occ[0] < occ[1] && occ[2] < occ[3]) {
        return None; // no surface
    }
    let k = f64::from(resolution) / (2.0 * imp.half_size); // texels per world unit
    let depth_scale = MAX_DEPTH / (imp.near - imp.far); // codes per world unit
    if !(k.is_finite() && depth_scale.is_finite() && depth_scale > 0.0) {
        return None;
    }
    // Texture coordinates and depth code of a point, and of a vector (the linear part).
    let point = |q: [f64; 3]| {
        [
            (dot(u, q) - imp.center[0] + imp.half_size) * k,
            (imp.center[1] + imp.half_size - dot(v, q)) * k,
            (imp.near - dot(d, q)) * depth_scale,
        ]
    };
    let vector = |g: [f64; 3]| [dot(u, g) * k, -dot(v, g) * k, -dot(d, g) * depth_scale];

    let mut rec = ImpostorRecord::zeroed();
    match camera.projection {
        Projection::Orthographic {
            center, half_size, ..
        } => {
            let (ue, ve, w) = (camera.frame.u, camera.frame.v, camera.frame.d);
            let facing = dot(d, w);
            let zr = facing * depth_scale; // codes per world unit along the ray
            if !(facing > 0.0 && zr > 0.0 && zr.is_finite()) {
                return None;
            }
            let dir = [-dot(u, w) * k / zr, dot(v, w) * k / zr];
            // Pixel coordinates (px, py) -> point on the plane through the origin, as the
            // evaluator: q = q00 + px * gx + py * gy.
            // (For a square image `half_w == half_size` exactly.)
            let pixel = 2.0 * half_size / f64::from(height);
            let half_w = half_size * (f64::from(width) / f64::from(height));
            let (left, top) = (center[0] - half_w, center[1] + half_size);
            let q00: [f64; 3] = std::array::from_fn(|i| ue[i] * left + ve[i] * top);
            let gx = ue.map(|c| c * pixel);
            let gy = ve.map(|c| -c * pixel);
            // Slide along the ray to depth code 0.
            let crossing = |t: [f64; 3]| [t[0] - t[2] * dir[0], t[1] - t[2] * dir[1]];
            let (o0, ex, ey) = (
                crossing(point(q00)),
                crossing(vector(gx)),
                crossing(vector(gy)),
            );
            rec.o0_ex = [o0[0] as f32, o0[1] as f32, ex[0] as f32, ex[1] as f32];
            rec.ey_dir = [ey[0] as f32, ey[1] as f32, dir[0] as f32, dir[1] as f32];
            rec.info[1] = 0;
        }
        Projection::Perspective { eye, fov_y, .. } => {
            let (ue, ve, w) = (camera.frame.u, camera.frame.v, camera.frame.d);
            let t = (0.5 * fov_y).tan();
            let aspect = f64::from(width) / f64::from(height);
            // World ray direction of pixel (px, py): r0 + px * rx + py * ry.
            let sx = 2.0 * t * aspect / f64::from(width);
            let sy = 2.0 * t / f64::from(height);
            let r0: [f64; 3] = std::array::from_fn(|i| -w[i] - ue[i] * t * aspect + ve[i] * t);
            let rx = ue.map(|c| c * sx);
            let ry = ve.map(|c| -c * sy);
            rec.eye = vec4(point(eye));
            rec.r0 = vec4(vector(r0));
            rec.rx = vec4(vector(rx));
            rec.ry = vec4(vector(ry));
            rec.info[1] = 1;
        }
    }
    // Texture space -> world: p = p0 + x u / k - y v / k - z d / depth_scale.
    let p0: [f64; 3] = std::array::from_fn(|i| {
        u[i] * (imp.center[0] - imp.half_size)
            + v[i] * (imp.center[1] + imp.half_size)
            + d[i] * imp.near
    });
    let tex_to_world: [[f64; 4]; 4] = [
        [u[0] / k, -v[0] / k, -d[0] / depth_scale, p0[0]],
        [u[1] / k, -v[1] / k, -d[1] / depth_scale, p0[1]],
        [u[2] / k, -v[2] / k, -d[2] / depth_scale, p0[2]],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let tex_to_clip = mul(&camera.world_to_clip(width, height), &tex_to_world);
    rec.tex_to_clip = to_gpu(&tex_to_clip);
    rec.frame_u = vec4(u);
    rec.frame_v = vec4(v);
    rec.frame_d = vec4(d);
    rec.bounds = [occ[0], occ[1], occ[2], occ[3]];
    rec.depth_range = [
        occ[4],
        occ[5],
        resolution as f32,
        march.wall_threshold * MAX_DEPTH as f32,
    ];
    rec.info[0] = slot.layer;
    rec.info[2] = march.linear_steps;
    rec.info[3] = march.binary_steps;
    rec.ids[0] = u32::from(slot.index);
    rec.ids[1] = slot.column_cells;
    // Every float field (all but the last two `vec4<u32>`) must be finite.
    let floats = bytemuck::cast_slice::<_, f32>(std::slice::from_ref(&rec));
    floats[..floats.len() - 8]
        .iter()
        .all(|c| c.is_finite())
        .then_some(rec)
}
