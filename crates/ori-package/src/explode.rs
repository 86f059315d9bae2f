//! [`explode`]: a package as a folder of files a person can open.

use std::path::{Path, PathBuf};

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use ori_texture::decode::to_u8;
use ori_texture::{Ktx2, VkFormat, decode_bc1, decode_bc4, decode_bc5};

use crate::validate::manifest_bytes;
use crate::{Package, PackageError};

/// Depth code of an empty texel.
const EMPTY: u8 = 255;

/// Writes `package` into `dir` (created if needed) as files to inspect:
///
/// - `manifest.json`: the manifest, pretty-printed (`params` keys sorted);
/// - `impostor-NN-{depth,normal,albedo}.ktx2`: the textures as stored;
/// - `impostor-NN-{depth,normal,albedo}.png`: previews of level 0, block formats decoded
///   with `ori-texture`'s decoders. Depth: grey, nearest (code 0) white down to code 254 at
///   grey 32, empty texels (code 255) black. Normal: x, y in red and green as stored, z
///   rebuilt (`sqrt(1 - x^2 - y^2)`, x, y in `[-1, 1]`) in blue. Albedo: the sRGB values.
///
/// `NN` is the impostor index, two digits at least. Returns the paths written, in that
/// order per impostor after `manifest.json`. Errors name the path.
pub fn explode(package: &Package, dir: &Path) -> Result<Vec<PathBuf>, PackageError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| PackageError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut written = Vec::new();
    let mut put = |name: String, bytes: &[u8]| -> Result<(), PackageError> {
        let path = dir.join(name);
        std::fs::write(&path, bytes).map_err(io(&path))?;
        written.push(path);
        Ok(())
    };

    let compact = manifest_bytes(&package.manifest)?;
    let value: serde_json::Value = serde_json::from_slice(&compact)
        .map_err(|e| PackageError::Manifest(format!("cannot re-read for printing: {e}")))?;
    let mut pretty = serde_json::to_vec_pretty(&value)
        .map_err(|e| PackageError::Manifest(format!("cannot print: {e}")))?;
    pretty.push(b'\n');
    put("manifest.json".into(), &pretty)?;

    for (i, tex) in package.textures.iter().enumerate() {
        for (map, bytes) in tex.maps() {
            put(format!("impostor-{i:02}-{map}.ktx2"), bytes)?;
        }
        for (map, bytes) in tex.maps() {
            let bad = |reason: String| PackageError::Texture {
                impostor: i,
                map,
                reason,
            };
            let ktx = Ktx2::from_bytes(bytes).map_err(|e| bad(e.to_string()))?;
            let (w, h) = (ktx.width(), ktx.height());
            let rgb = preview(&ktx).map_err(|e| bad(format!("cannot decode: {e}")))?;
            let mut png = Vec::new();
            PngEncoder::new(&mut png)
                .write_image(&rgb, w, h, ExtendedColorType::Rgb8)
                .map_err(|e| bad(format!("cannot encode the PNG preview: {e}")))?;
            put(format!("impostor-{i:02}-{map}.png"), &png)?;
        }
    }
    Ok(written)
}

/// Level 0 of `ktx` as row-major RGB8 for a preview (see [`explode`]).
fn preview(ktx: &Ktx2) -> Result<Vec<u8>, ori_texture::TextureError> {
    let (w, h) = (ktx.width(), ktx.height());
    let level = &ktx.levels()[0];
    let grey = |codes: &mut dyn Iterator<Item = u8>| -> Vec<u8> {
        codes
            .flat_map(|c| {
                let g = if c == EMPTY {
                    0
                } else {
                    // 0 -> 255, 254 -> 32: never black, so empty stays distinct.
                    (255 - u32::from(c) * 223 / 254) as u8
                };
                [g; 3]
            })
            .collect()
    };
    Ok(match ktx.format() {
        VkFormat::R8Unorm => grey(&mut level.iter().copied()),
        VkFormat::Bc4Unorm => grey(&mut decode_bc4(level, w, h)?.into_iter().map(to_u8)),
        VkFormat::Bc5Unorm => decode_bc5(level, w, h)?
            .into_iter()
            .flat_map(|[x, y]| {
                let (nx, ny) = (2.0 * x - 1.0, 2.0 * y - 1.0);
                let z = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
                [to_u8(x), to_u8(y), to_u8(0.5 + 0.5 * z)]
            })
            .collect(),
        VkFormat::Bc1RgbSrgb | VkFormat::Bc1RgbUnorm => decode_bc1(level, w, h)?
            .into_iter()
            .flat_map(|[r, g, b, _]| [to_u8(r), to_u8(g), to_u8(b)])
            .collect(),
    })
}
