//! What the loader tests share: models loaded from memory, and small PNG files.
#![allow(dead_code)] // each test file uses a part

use std::io;
use std::path::Path;

use ori_mesh::{LoadOptions, Loaded, MeshError};

/// Load `bytes` as `name` with `options`; the resolver reads `files` (by exact reference) only.
pub fn load_from(
    name: &str,
    bytes: &[u8],
    files: &[(&str, &[u8])],
    options: &LoadOptions,
) -> Result<Loaded, MeshError> {
    let mut resolver = |uri: &str| {
        files
            .iter()
            .find(|(n, _)| *n == uri)
            .map(|(_, b)| b.to_vec())
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, format!("no file `{uri}`")))
    };
    ori_mesh::load(Path::new(name), bytes, options, &mut resolver)
}

/// A PNG of `width x height` pixels of one colour.
pub fn png(width: u32, height: u32, rgba: [u8; 4]) -> Vec<u8> {
    let mut bytes = io::Cursor::new(Vec::new());
    image::RgbaImage::from_pixel(width, height, image::Rgba(rgba))
        .write_to(&mut bytes, image::ImageFormat::Png)
        .expect("encode PNG");
    bytes.into_inner()
}
