//! `report/viewer.html`: the interactive WebGL2 viewer, one self-contained page (its scripts
//! inlined) that reads the release's packages itself, and the compact mesh (`mesh.bin` in each
//! asset's picture folder) it draws as the reference.
//!
//! The page's scripts live in `crates/ori-report/viewer/` and are written from
//! `docs/FORMAT.md` and `docs/RUNTIME.md` alone: this crate only places them and lists the
//! assets.

use serde::Serialize;

/// The viewer's file name in the report folder.
pub const VIEWER: &str = "viewer.html";
/// The mesh file the viewer draws as the reference, in an asset's picture folder.
pub const MESH_FILE: &str = "mesh.bin";

const PAGE: &str = include_str!("../viewer/viewer.html");
const SCRIPTS: [&str; 3] = [
    include_str!("../viewer/blake3.js"),
    include_str!("../viewer/package.js"),
    include_str!("../viewer/render.js"),
];

/// One asset the viewer can open: paths relative to the report folder.
#[derive(Debug, Serialize)]
pub struct ViewerAsset {
    pub name: String,
    pub package: String,
    pub mesh: Option<String>,
}

/// The viewer page listing `assets`.
pub fn page(assets: &[ViewerAsset]) -> String {
    // Inside a <script> element nothing may look like its end tag.
    let list = serde_json::to_string(assets)
        .expect("serialises")
        .replace('<', "\\u003c");
    // The scripts first: the asset list is the one text not ours.
    PAGE.replace("{{SCRIPTS}}", &SCRIPTS.join("\n"))
        .replace("{{ASSETS}}", &list)
}

/// `mesh.bin`: magic `ORIMESH1`, u32 vertex and triangle counts, f32 x 3 lowest corner and
/// f32 x 3 extent, positions as u16 x 3 fractions of the extent (padded to 4 bytes), each
/// vertex's albedo as sRGB RGBA8, its unit normal as i8 x 3 (x 127, one byte of padding),
/// then u32 x 3 triangles; little-endian.
pub fn mesh_bytes(mesh: &ori_mesh::Mesh) -> Vec<u8> {
    let (lo, hi) = mesh.bounds();
    let extent: [f32; 3] = std::array::from_fn(|k| (hi[k] - lo[k]).max(f32::MIN_POSITIVE));
    let mut out = b"ORIMESH1".to_vec();
    out.extend((mesh.positions.len() as u32).to_le_bytes());
    out.extend((mesh.triangles.len() as u32).to_le_bytes());
    for v in lo.iter().chain(&extent) {
        out.extend(v.to_le_bytes());
    }
    for p in &mesh.positions {
        for k in 0..3 {
            let t = ((p[k] - lo[k]) / extent[k]).clamp(0.0, 1.0);
            out.extend(((t * 65535.0).round() as u16).to_le_bytes());
        }
    }
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
    for c in vertex_albedo(mesh) {
        out.extend(c);
    }
    for i in 0..mesh.positions.len() {
        let n = mesh.normals.get(i).copied().unwrap_or([0.0; 3]);
        for c in n {
            out.push(((c.clamp(-1.0, 1.0) * 127.0).round() as i8) as u8);
        }
        out.push(0);
    }
    for t in &mesh.triangles {
        for i in t {
            out.extend(i.to_le_bytes());
        }
    }
    out
}

/// Each vertex's albedo (sRGB bytes): its colour times the base colour (and texture, sampled
/// at its texture coordinate) of the first triangle's material that uses it.
fn vertex_albedo(mesh: &ori_mesh::Mesh) -> Vec<[u8; 4]> {
    let mut material = vec![None; mesh.positions.len()];
    for (t, m) in mesh.triangles.iter().zip(&mesh.triangle_materials) {
        for &i in t {
            material[i as usize].get_or_insert(*m as usize);
        }
    }
    (0..mesh.positions.len())
        .map(|i| {
            let mut c = mesh.colors.as_ref().map_or([1.0; 4], |c| c[i]);
            if let Some(m) = material[i].and_then(|m| mesh.materials.get(m)) {
                for (c, f) in c.iter_mut().zip(m.base_color_factor) {
                    *c *= f;
                }
                let texture = m
                    .base_color_texture
                    .and_then(|t| mesh.textures.get(t as usize));
                if let (Some(t), Some(uv)) = (texture, mesh.uvs.as_ref().map(|u| u[i])) {
                    let texel = sample(t, uv);
                    for (c, t) in c.iter_mut().zip(&texel[..3]) {
                        *c *= ori_math::srgb_to_linear(f64::from(*t) / 255.0) as f32;
                    }
                }
            }
            let e = |v: f32| (ori_math::linear_to_srgb(f64::from(v)) * 255.0).round() as u8;
            [e(c[0]), e(c[1]), e(c[2]), 255]
        })
        .collect()
}

/// The nearest texel at `uv`, repeating.
fn sample(t: &ori_mesh::Texture, uv: [f32; 2]) -> [u8; 4] {
    if t.width == 0 || t.height == 0 || t.rgba8.len() < (t.width * t.height * 4) as usize {
        return [255; 4];
    }
    let at = |c: f32, n: u32| ((c.rem_euclid(1.0) * n as f32) as u32).min(n - 1) as usize;
    let (x, y) = (at(uv[0], t.width), at(uv[1], t.height));
    let o = (y * t.width as usize + x) * 4;
    [t.rgba8[o], t.rgba8[o + 1], t.rgba8[o + 2], t.rgba8[o + 3]]
}
