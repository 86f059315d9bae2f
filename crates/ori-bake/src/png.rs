//! Debug PNG dumps of relief maps, for looking at what was baked.

use std::path::{Path, PathBuf};

use crate::{EMPTY_DEPTH, ReliefMap};

/// Write `<prefix>-depth.png` (grey, empty texels black, near bright), `<prefix>-normal.png`
/// (frame normal as RGB, z rebuilt) and `<prefix>-albedo.png` into `dir`; returns the paths.
pub fn write_pngs(map: &ReliefMap, dir: &Path, prefix: &str) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let n = map.size();
    let depth: Vec<u8> = map
        .depth
        .iter()
        .map(|&d| if d == EMPTY_DEPTH { 0 } else { 255 - d })
        .collect();
    let normal: Vec<u8> = map
        .normal
        .iter()
        .flat_map(|&xy| {
            let z = ReliefMap::decode_normal(xy)[2];
            [xy[0], xy[1], (z * 255.0).round() as u8]
        })
        .collect();
    let albedo: Vec<u8> = map.albedo.iter().flatten().copied().collect();
    let mut written = Vec::new();
    for (name, bytes, color) in [
        ("depth", depth, image::ExtendedColorType::L8),
        ("normal", normal, image::ExtendedColorType::Rgb8),
        ("albedo", albedo, image::ExtendedColorType::Rgb8),
    ] {
        let path = dir.join(format!("{prefix}-{name}.png"));
        image::save_buffer_with_format(&path, &bytes, n, n, color, image::ImageFormat::Png)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}
