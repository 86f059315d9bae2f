//! Texture compression for relief maps: BC1 (albedo), BC4 (depth, optional), BC5 (normal
//! x, y), and the KTX2 container they ship in.
//!
//! The texture budget (`GUIDE.md`, "Texture budget") is 2.5 bytes per texel: depth as R8
//! (1 B), normal x, y as BC5 (1 B), albedo as BC1 (0.5 B). BC4 depth (0.5 B) is an option.
//!
//! - [`encode_bc1`]: 4-colour BC1 blocks; optionally mask-aware, so texels the depth map marks
//!   empty are "don't care" and the endpoints fit only real colour.
//! - [`encode_bc4`], [`encode_bc5`]: both the 8-value and the 6-value (with 0 and 255) modes
//!   are tried per block; BC5 is two BC4 channels, and at [`Quality::High`] it weighs each
//!   channel's error by its effect on the angle of the rebuilt normal.
//! - [`decode`]: D3D10 block decoding with float interpolation (the decode model the encoders
//!   optimise for and the metrics measure with).
//! - [`Ktx2`]: a spec-conformant KTX2 writer and a reader that never panics or over-allocates
//!   on arbitrary bytes.
//! - [`metrics`]: PSNR and the angular error of rebuilt normals, with the 8-bit floor.
//!
//! Determinism: every encoder is a pure function of its input, computed block by block with
//! only `+ - * /` and `sqrt` in a fixed order (no platform libm, no CPU-feature dispatch), so
//! the same input gives the same bytes on every machine and for any rayon thread count. Work
//! is spread over rows of blocks with rayon and collected in order; run inside a one-thread
//! rayon pool for a sequential encode.

// Block code walks several parallel per-texel arrays with one index; that reads clearer
// than zipped iterators.
#![allow(clippy::needless_range_loop)]

mod bc1;
mod bc4;
pub mod decode;
mod image;
mod ktx2;
mod lanes;
pub mod metrics;

pub use bc1::encode_bc1;
pub use bc4::{encode_bc4, encode_bc5};
pub use decode::{decode_bc1, decode_bc4, decode_bc5};
pub use image::{RgbaImage, load_png, load_png_file};
pub use ktx2::{Ktx2, VkFormat};

/// How hard the encoders search. Both levels are deterministic.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Quality {
    /// Principal axis or range, then one least-squares refinement: for previews and tests.
    Fast,
    /// Iterated least squares and a search around the quantised endpoints: for packages.
    #[default]
    High,
}

/// Everything that can go wrong in this crate. Messages say what is wrong; callers add the
/// file name.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// The PNG could not be decoded (corrupt, truncated, unsupported or too large).
    #[error("cannot decode PNG: {0}")]
    Png(String),
    /// A KTX2 file is malformed or uses something this reader does not support.
    #[error("invalid KTX2 file: {0}")]
    Ktx2(String),
    /// Arguments that do not fit together (sizes, lengths, empty images).
    #[error("{0}")]
    InvalidInput(String),
    /// Reading a file failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// Number of 4x4 blocks along an edge of `size` texels (partial blocks are padded).
pub fn blocks_along(size: u32) -> u32 {
    size.div_ceil(4)
}

/// Bytes of a BCn image of `width` x `height` texels with `block_bytes` per 4x4 block.
pub fn compressed_size(width: u32, height: u32, block_bytes: usize) -> usize {
    blocks_along(width) as usize * blocks_along(height) as usize * block_bytes
}

/// Checks that an image's size is usable and that `len` values cover it with `channels`
/// values per texel.
pub(crate) fn check_size(
    width: u32,
    height: u32,
    channels: usize,
    len: usize,
) -> Result<(), TextureError> {
    if width == 0 || height == 0 {
        return Err(TextureError::InvalidInput(format!(
            "image has no texels ({width} x {height})"
        )));
    }
    let expected = (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(channels));
    if expected != Some(len) {
        return Err(TextureError::InvalidInput(format!(
            "{width} x {height} texels with {channels} channel(s) need {} values, got {len}",
            expected.map_or_else(|| "too many".to_string(), |n| n.to_string())
        )));
    }
    Ok(())
}
