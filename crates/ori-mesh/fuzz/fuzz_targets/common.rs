//! What every loader target shares: the files a model may reference, tight limits (so that no
//! input may allocate much), and the checks on whatever loads.

use std::path::Path;
use std::sync::OnceLock;

/// A 4 x 4 PNG, served for every image reference.
pub fn png() -> &'static [u8] {
    static PNG: OnceLock<Vec<u8>> = OnceLock::new();
    PNG.get_or_init(|| {
        let image = image::RgbaImage::from_fn(4, 4, |x, y| {
            image::Rgba([x as u8 * 60, y as u8 * 60, 128, 200])
        });
        let mut bytes = Vec::new();
        image
            .write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )
            .expect("encode");
        bytes
    })
}

/// Load `bytes` as the model `name`; references resolve through `files` (by exact name),
/// then any `.png`/`.jpg` to [`png`] and any `.bin` to `bin`. Whatever loads must encode and
/// decode back to itself, and load again to the same mesh.
pub fn check(name: &str, bytes: &[u8], files: &[(&str, &[u8])], bin: &[u8]) {
    let mut resolver = |uri: &str| -> std::io::Result<Vec<u8>> {
        if let Some((_, b)) = files.iter().find(|(n, _)| *n == uri) {
            return Ok(b.to_vec());
        }
        let lower = uri.to_ascii_lowercase();
        if lower.ends_with(".png") || lower.ends_with(".jpg") || lower.ends_with(".jpeg") {
            return Ok(png().to_vec());
        }
        if lower.ends_with(".bin") {
            return Ok(bin.to_vec());
        }
        Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            uri.to_string(),
        ))
    };
    let options = ori_mesh::LoadOptions {
        recompute_normals: false,
        limits: ori_mesh::Limits {
            max_texture_pixels: 1 << 20,
            max_total_texture_pixels: 1 << 21,
            max_face_corners: 4096,
            max_triangles: 1_000_000,
            max_vertices: 1_000_000,
            max_depth_complexity: 64,
        },
    };
    let Ok(loaded) = ori_mesh::load(Path::new(name), bytes, &options, &mut resolver) else {
        return;
    };
    let encoded = loaded.mesh.encode();
    let decoded = ori_mesh::Mesh::decode(&encoded).expect("a loaded mesh decodes");
    assert!(decoded.encode() == encoded, "decode(encode(mesh)) differs");
    let again =
        ori_mesh::load(Path::new(name), bytes, &options, &mut resolver).expect("loads twice");
    assert!(
        again.mesh.encode() == encoded,
        "loading is not deterministic"
    );
}
