//! Real textures from `../shared/models`, shared by the tests and the `compare` benchmark.

#![allow(dead_code)] // each test binary uses a different part

use std::path::{Path, PathBuf};

use ori_texture::{RgbaImage, load_png_file};

/// The shared models folder beside the repository.
pub fn models_dir() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/models"
    ))
}

/// A PNG under the models folder.
pub fn png(relative: &str) -> RgbaImage {
    let path = models_dir().join(relative);
    load_png_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every image embedded in a GLB under the models folder, in the file's image order (PNG
/// through our loader, JPEG through zune-jpeg with its SIMD paths off).
pub fn glb_images(relative: &str) -> Vec<RgbaImage> {
    let path = models_dir().join(relative);
    let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let gltf = gltf::Gltf::from_slice(&bytes).expect("valid GLB");
    let blob = gltf.blob.as_deref().expect("GLB binary chunk");
    gltf.document
        .images()
        .map(|image| match image.source() {
            gltf::image::Source::View { view, .. } => {
                decode(&blob[view.offset()..view.offset() + view.length()], &path)
            }
            gltf::image::Source::Uri { .. } => panic!("{}: external image", path.display()),
        })
        .collect()
}

fn decode(bytes: &[u8], path: &Path) -> RgbaImage {
    if bytes.starts_with(b"\x89PNG") {
        return ori_texture::load_png(bytes).expect("embedded PNG");
    }
    use zune_core::colorspace::ColorSpace;
    use zune_core::options::DecoderOptions;
    let options = DecoderOptions::default()
        .set_use_unsafe(false)
        .jpeg_set_out_colorspace(ColorSpace::RGBA);
    let mut decoder =
        zune_jpeg::JpegDecoder::new_with_options(std::io::Cursor::new(bytes), options);
    let pixels = decoder
        .decode()
        .unwrap_or_else(|e| panic!("{}: embedded JPEG: {e:?}", path.display()));
    let info = decoder.info().expect("JPEG header");
    RgbaImage::new(u32::from(info.width), u32::from(info.height), pixels).expect("JPEG size")
}

/// The same image with alpha forced opaque (what an RGB texture means).
pub fn opaque(image: &RgbaImage) -> RgbaImage {
    let mut data = image.data().to_vec();
    for t in data.chunks_exact_mut(4) {
        t[3] = 255;
    }
    RgbaImage::new(image.width(), image.height(), data).expect("same size")
}
