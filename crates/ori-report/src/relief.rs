//! A package's textures decoded back into relief maps, so the CPU evaluator draws exactly
//! what ships (block compression included).

use ori_package::{Package, TextureFormat};
use ori_raster::{Frame, OrthoView};
use ori_relief::{ReliefMap, ReliefSet};

/// The relief maps a package carries, decoded.
pub fn relief_set(package: &Package) -> Result<ReliefSet, String> {
    let m = &package.manifest;
    let n = m.resolution;
    let mut maps = Vec::with_capacity(m.impostors.len());
    for (i, imp) in m.impostors.iter().enumerate() {
        let fail = |what: &str, e: ori_texture::TextureError| format!("impostor {i} {what}: {e}");
        let depth_tex = package.depth(i);
        let level0 = |t: &ori_texture::Ktx2| t.levels()[0].clone();
        let depth = match m.depth_format {
            TextureFormat::Bc4 => ori_texture::decode_bc4(&level0(&depth_tex), n, n)
                .map_err(|e| fail("depth", e))?
                .into_iter()
                .map(to_u8)
                .collect(),
            _ => level0(&depth_tex),
        };
        let normal = ori_texture::decode_bc5(&level0(&package.normal(i)), n, n)
            .map_err(|e| fail("normal", e))?
            .into_iter()
            .map(|xy| xy.map(to_u8))
            .collect();
        let albedo = ori_texture::decode_bc1(&level0(&package.albedo(i)), n, n)
            .map_err(|e| fail("albedo", e))?
            .into_iter()
            .map(|c| [to_u8(c[0]), to_u8(c[1]), to_u8(c[2])])
            .collect();
        let [u, v, d] = imp.frame;
        maps.push(ReliefMap {
            view: OrthoView {
                frame: Frame { u, v, d },
                center: imp.center,
                half_size: imp.half_size,
                near: imp.near,
                far: imp.far,
                size: n,
            },
            depth,
            normal,
            albedo,
        });
    }
    Ok(ReliefSet { maps })
}

/// A decoded `[0, 1]` value back to its byte (the decoders are exact at block endpoints).
fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}
