//! Block decoders following the D3D10 block-compression specification, with float
//! interpolation. This is the decode model the encoders optimise for and the metrics use.
//!
//! # Decode model
//!
//! Values are UNORM floats in `[0, 1]`, computed in `f32` exactly as written here:
//!
//! - **BC1.** `c0`, `c1` are the two little-endian RGB565 words; each channel expands as
//!   `r / 31`, `g / 63`, `b / 31` (no bit replication). If `c0 > c1` (as unsigned words) the
//!   block has four opaque colours: `c0`, `c1`, `(2 c0 + c1) / 3`, `(c0 + 2 c1) / 3`.
//!   Otherwise three colours and transparent black: `c0`, `c1`, `(c0 + c1) / 2`, `(0, 0, 0, 0)`.
//!   Texel `i` (row-major) takes 2-bit index `i` of the little-endian 32-bit word after the
//!   endpoints. For the sRGB format the interpolation is on the stored (sRGB-encoded) values
//!   and the sampler's sRGB-to-linear conversion applies to the result.
//! - **BC4 (UNORM).** Endpoints `r0`, `r1` are bytes, expanded as `r / 255`. If `r0 > r1`:
//!   eight values `r0`, `r1`, then `((7 - i) r0 + i r1) / 7` for `i = 1..=6`. Otherwise six:
//!   `r0`, `r1`, `((5 - i) r0 + i r1) / 5` for `i = 1..=4`, then `0` and `1`. Texel `i` takes
//!   the 3-bit index `i` of the little-endian 48-bit field after the endpoints.
//! - **BC5 (UNORM).** Two BC4 blocks: red (x) then green (y).
//!
//! The encoders emit only 4-colour BC1 blocks, but the decoder handles both modes. Hardware
//! may round interpolants to 8 bits or use `(2 c0 + c1 + 1) / 3` integer forms; those differ
//! from this model by less than one 8-bit step.

use crate::{TextureError, blocks_along, compressed_size};

/// Decodes one BC1 block into 16 row-major RGBA texels in `[0, 1]`.
pub fn decode_bc1_block(block: &[u8; 8]) -> [[f32; 4]; 16] {
    let w0 = u16::from_le_bytes([block[0], block[1]]);
    let w1 = u16::from_le_bytes([block[2], block[3]]);
    let c0 = expand_565(w0);
    let c1 = expand_565(w1);
    let mut palette = [[0.0f32; 4]; 4];
    palette[0] = [c0[0], c0[1], c0[2], 1.0];
    palette[1] = [c1[0], c1[1], c1[2], 1.0];
    if w0 > w1 {
        for c in 0..3 {
            palette[2][c] = (2.0 * c0[c] + c1[c]) / 3.0;
            palette[3][c] = (c0[c] + 2.0 * c1[c]) / 3.0;
        }
        palette[2][3] = 1.0;
        palette[3][3] = 1.0;
    } else {
        for c in 0..3 {
            palette[2][c] = (c0[c] + c1[c]) / 2.0;
        }
        palette[2][3] = 1.0;
        // palette[3] stays transparent black.
    }
    let bits = u32::from_le_bytes([block[4], block[5], block[6], block[7]]);
    std::array::from_fn(|i| palette[((bits >> (2 * i)) & 3) as usize])
}

/// The RGB565 word as UNORM floats.
fn expand_565(w: u16) -> [f32; 3] {
    [
        f32::from((w >> 11) & 31) / 31.0,
        f32::from((w >> 5) & 63) / 63.0,
        f32::from(w & 31) / 31.0,
    ]
}

/// The eight BC4 palette values of endpoints `r0`, `r1`, indexed by the 3-bit code.
pub fn bc4_palette(r0: u8, r1: u8) -> [f32; 8] {
    let a = f32::from(r0) / 255.0;
    let b = f32::from(r1) / 255.0;
    let mut p = [0.0f32; 8];
    p[0] = a;
    p[1] = b;
    if r0 > r1 {
        for i in 1..=6 {
            p[i + 1] = ((7 - i) as f32 * a + i as f32 * b) / 7.0;
        }
    } else {
        for i in 1..=4 {
            p[i + 1] = ((5 - i) as f32 * a + i as f32 * b) / 5.0;
        }
        p[6] = 0.0;
        p[7] = 1.0;
    }
    p
}

/// Decodes one BC4 (UNORM) block into 16 row-major values in `[0, 1]`.
pub fn decode_bc4_block(block: &[u8; 8]) -> [f32; 16] {
    let palette = bc4_palette(block[0], block[1]);
    let mut bits = 0u64;
    for (k, &byte) in block[2..].iter().enumerate() {
        bits |= u64::from(byte) << (8 * k);
    }
    std::array::from_fn(|i| palette[((bits >> (3 * i)) & 7) as usize])
}

/// Checks that `data` holds exactly the blocks of a `width` x `height` image.
fn check_blocks(
    data: &[u8],
    width: u32,
    height: u32,
    block_bytes: usize,
) -> Result<(), TextureError> {
    if width == 0 || height == 0 {
        return Err(TextureError::InvalidInput(format!(
            "image has no texels ({width} x {height})"
        )));
    }
    let expected = compressed_size(width, height, block_bytes);
    if data.len() != expected {
        return Err(TextureError::InvalidInput(format!(
            "{width} x {height} texels need {expected} bytes of blocks, got {}",
            data.len()
        )));
    }
    Ok(())
}

/// Decodes row-major blocks into `width * height` row-major texels, dropping the padding.
fn decode_image<const N: usize, T: Copy + Default>(
    data: &[u8],
    width: u32,
    height: u32,
    decode: impl Fn(&[u8; N]) -> [T; 16],
) -> Result<Vec<T>, TextureError> {
    check_blocks(data, width, height, N)?;
    let (w, h) = (width as usize, height as usize);
    let bw = blocks_along(width) as usize;
    let mut out = vec![T::default(); w * h];
    for (b, chunk) in data.chunks_exact(N).enumerate() {
        let (bx, by) = (b % bw, b / bw);
        let texels = decode(chunk.try_into().expect("chunks_exact gives N bytes"));
        for (i, &t) in texels.iter().enumerate() {
            let (x, y) = (bx * 4 + i % 4, by * 4 + i / 4);
            if x < w && y < h {
                out[y * w + x] = t;
            }
        }
    }
    Ok(out)
}

/// Decodes a BC1 image (blocks row-major) into row-major RGBA texels in `[0, 1]`.
pub fn decode_bc1(data: &[u8], width: u32, height: u32) -> Result<Vec<[f32; 4]>, TextureError> {
    decode_image(data, width, height, decode_bc1_block)
}

/// Decodes a BC4 image into row-major values in `[0, 1]`.
pub fn decode_bc4(data: &[u8], width: u32, height: u32) -> Result<Vec<f32>, TextureError> {
    decode_image(data, width, height, decode_bc4_block)
}

/// Decodes a BC5 image into row-major (x, y) pairs in `[0, 1]`.
pub fn decode_bc5(data: &[u8], width: u32, height: u32) -> Result<Vec<[f32; 2]>, TextureError> {
    decode_image(data, width, height, |block: &[u8; 16]| {
        let x = decode_bc4_block(block[..8].try_into().expect("8 bytes"));
        let y = decode_bc4_block(block[8..].try_into().expect("8 bytes"));
        std::array::from_fn(|i| [x[i], y[i]])
    })
}

/// An `n` x `n` level decoded to 8-bit texels, row-major: R (R8, BC4), RG (BC5) or RGBA (BC1,
/// sRGB kept encoded, alpha 255). Each value is [`to_u8`] of the decoded one, so a BC4 depth
/// map gives back the codes a runtime reads (`docs/RUNTIME.md`, "Depth codes").
pub fn to_bytes(format: crate::VkFormat, level: &[u8], n: u32) -> Result<Vec<u8>, TextureError> {
    use crate::VkFormat;
    Ok(match format {
        VkFormat::Bc4Unorm => decode_bc4(level, n, n)?.into_iter().map(to_u8).collect(),
        VkFormat::Bc5Unorm => decode_bc5(level, n, n)?
            .into_iter()
            .flat_map(|t| t.map(to_u8))
            .collect(),
        VkFormat::Bc1RgbSrgb | VkFormat::Bc1RgbUnorm => decode_bc1(level, n, n)?
            .into_iter()
            .flat_map(|t| [to_u8(t[0]), to_u8(t[1]), to_u8(t[2]), 255])
            .collect(),
        VkFormat::R8Unorm => level.to_vec(),
    })
}

/// Rounds a `[0, 1]` value to the nearest byte (for writing decoded images out).
pub fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}
