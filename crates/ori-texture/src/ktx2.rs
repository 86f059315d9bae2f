//! KTX2 container: a writer and a reader for 2D textures in the formats of the texture
//! budget (R8 depth, BC1 albedo, BC4 depth, BC5 normals), with optional mip levels.
//!
//! Files follow the KTX 2.0 specification: header, level index, a basic Data Format
//! Descriptor matching the vkFormat (colour model, BT.709 primaries, sRGB or linear
//! transfer function), a `KTXwriter` key, no supercompression, and each level aligned to
//! `lcm(texel block size, 4)`, smallest level first in the file. The writer's output is a pure
//! function of the texture. The reader checks every offset and length against the file and
//! the format before copying anything, so arbitrary bytes give an error, never a panic or an
//! allocation larger than the file.

use crate::{TextureError, blocks_along};

/// The file identifier: `«KTX 20»\r\n\x1A\n`.
const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];
const HEADER_LEN: usize = 80;
const LEVEL_ENTRY_LEN: usize = 24;
/// The `KTXwriter` value (no version number, so output bytes do not change with releases).
const WRITER: &str = "ori-texture";

/// The formats this crate writes and reads, with their Vulkan `VkFormat` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VkFormat {
    /// `VK_FORMAT_R8_UNORM` (9): the raw depth map, 1 byte per texel.
    R8Unorm,
    /// `VK_FORMAT_BC1_RGB_UNORM_BLOCK` (131).
    Bc1RgbUnorm,
    /// `VK_FORMAT_BC1_RGB_SRGB_BLOCK` (132): albedo, whose texels are sRGB-encoded.
    Bc1RgbSrgb,
    /// `VK_FORMAT_BC4_UNORM_BLOCK` (139): depth, the denser option.
    Bc4Unorm,
    /// `VK_FORMAT_BC5_UNORM_BLOCK` (141): normal x, y.
    Bc5Unorm,
}

impl VkFormat {
    /// The `VkFormat` enum value.
    pub fn value(self) -> u32 {
        match self {
            VkFormat::R8Unorm => 9,
            VkFormat::Bc1RgbUnorm => 131,
            VkFormat::Bc1RgbSrgb => 132,
            VkFormat::Bc4Unorm => 139,
            VkFormat::Bc5Unorm => 141,
        }
    }

    /// The format with this `VkFormat` value, if it is one of ours.
    pub fn from_value(value: u32) -> Option<VkFormat> {
        [
            VkFormat::R8Unorm,
            VkFormat::Bc1RgbUnorm,
            VkFormat::Bc1RgbSrgb,
            VkFormat::Bc4Unorm,
            VkFormat::Bc5Unorm,
        ]
        .into_iter()
        .find(|f| f.value() == value)
    }

    /// Texel block edge (1 or 4) and bytes per block.
    pub fn block(self) -> (u32, usize) {
        match self {
            VkFormat::R8Unorm => (1, 1),
            VkFormat::Bc1RgbUnorm | VkFormat::Bc1RgbSrgb | VkFormat::Bc4Unorm => (4, 8),
            VkFormat::Bc5Unorm => (4, 16),
        }
    }

    /// Whether texels are sRGB-encoded (the DFD's transfer function).
    pub fn is_srgb(self) -> bool {
        self == VkFormat::Bc1RgbSrgb
    }

    /// Bytes of one image of `width` x `height` texels, or `None` on overflow.
    pub fn image_size(self, width: u32, height: u32) -> Option<usize> {
        let (edge, bytes) = self.block();
        let (bw, bh) = if edge == 1 {
            (width, height)
        } else {
            (blocks_along(width), blocks_along(height))
        };
        (bw as usize).checked_mul(bh as usize)?.checked_mul(bytes)
    }

    /// Khronos Data Format colour model: RGBSDA (1), BC1A (128), BC4 (131), BC5 (132).
    fn color_model(self) -> u8 {
        match self {
            VkFormat::R8Unorm => 1,
            VkFormat::Bc1RgbUnorm | VkFormat::Bc1RgbSrgb => 128,
            VkFormat::Bc4Unorm => 131,
            VkFormat::Bc5Unorm => 132,
        }
    }

    /// The basic DFD block's samples: (bit offset, bit length, channel id, lower, upper).
    fn samples(self) -> &'static [(u16, u8, u8, u32, u32)] {
        match self {
            VkFormat::R8Unorm => &[(0, 8, 0, 0, 255)],
            VkFormat::Bc1RgbUnorm | VkFormat::Bc1RgbSrgb | VkFormat::Bc4Unorm => {
                &[(0, 64, 0, 0, u32::MAX)]
            }
            // Red then green, one 64-bit BC4 block each.
            VkFormat::Bc5Unorm => &[(0, 64, 0, 0, u32::MAX), (64, 64, 1, 0, u32::MAX)],
        }
    }

    /// The Data Format Descriptor (total size word and one basic block), as written.
    fn dfd(self) -> Vec<u8> {
        let samples = self.samples();
        let block_size = 24 + 16 * samples.len();
        let mut out = Vec::with_capacity(4 + block_size);
        out.extend_from_slice(&((4 + block_size) as u32).to_le_bytes());
        // Vendor 0 (Khronos), descriptor type 0 (basic); version 2 and block size.
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&(2u32 | (block_size as u32) << 16).to_le_bytes());
        let transfer = if self.is_srgb() { 2 } else { 1 };
        // Colour model, primaries BT.709, transfer function, flags (straight alpha).
        out.extend_from_slice(&[self.color_model(), 1, transfer, 0]);
        let (edge, bytes) = self.block();
        out.extend_from_slice(&[(edge - 1) as u8, (edge - 1) as u8, 0, 0]);
        out.extend_from_slice(&[bytes as u8, 0, 0, 0, 0, 0, 0, 0]);
        for &(offset, bits, channel, lower, upper) in samples {
            out.extend_from_slice(&offset.to_le_bytes());
            out.extend_from_slice(&[bits - 1, channel]);
            out.extend_from_slice(&[0, 0, 0, 0]);
            out.extend_from_slice(&lower.to_le_bytes());
            out.extend_from_slice(&upper.to_le_bytes());
        }
        out
    }
}

/// A 2D texture and its mip levels (level 0 first), in one of the [`VkFormat`]s.
///
/// Invariant: at least one level, no more than the full chain, and level `l` holds exactly
/// the bytes of a `max(1, width >> l)` x `max(1, height >> l)` image in the format.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ktx2 {
    format: VkFormat,
    width: u32,
    height: u32,
    levels: Vec<Vec<u8>>,
}

/// Size of mip level `level` of an edge of `size` texels.
fn level_edge(size: u32, level: usize) -> u32 {
    (size >> level.min(31)).max(1)
}

/// Number of levels in the full mip chain of a `width` x `height` image.
fn full_chain(width: u32, height: u32) -> usize {
    (32 - width.max(height).leading_zeros()) as usize
}

impl Ktx2 {
    /// A texture from its levels (level 0 first); fails if a size does not fit the format.
    pub fn new(
        format: VkFormat,
        width: u32,
        height: u32,
        levels: Vec<Vec<u8>>,
    ) -> Result<Ktx2, TextureError> {
        if width == 0 || height == 0 {
            return Err(TextureError::InvalidInput(format!(
                "texture has no texels ({width} x {height})"
            )));
        }
        if levels.is_empty() || levels.len() > full_chain(width, height) {
            return Err(TextureError::InvalidInput(format!(
                "{} mip levels for {width} x {height} (1 to {} allowed)",
                levels.len(),
                full_chain(width, height)
            )));
        }
        for (l, data) in levels.iter().enumerate() {
            let (w, h) = (level_edge(width, l), level_edge(height, l));
            let expected = format.image_size(w, h);
            if expected != Some(data.len()) {
                return Err(TextureError::InvalidInput(format!(
                    "level {l} ({w} x {h}, {format:?}) needs {} bytes, got {}",
                    expected.map_or_else(|| "too many".into(), |n| n.to_string()),
                    data.len()
                )));
            }
        }
        Ok(Ktx2 {
            format,
            width,
            height,
            levels,
        })
    }

    /// The texel format.
    pub fn format(&self) -> VkFormat {
        self.format
    }

    /// Width of level 0 in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height of level 0 in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The levels' bytes, level 0 (largest) first.
    pub fn levels(&self) -> &[Vec<u8>] {
        &self.levels
    }

    /// The KTX2 file.
    pub fn to_bytes(&self) -> Vec<u8> {
        let n = self.levels.len();
        let dfd = self.format.dfd();
        let mut kvd = Vec::new();
        let entry = format!("KTXwriter\0{WRITER}\0");
        kvd.extend_from_slice(&(entry.len() as u32).to_le_bytes());
        kvd.extend_from_slice(entry.as_bytes());
        kvd.resize(kvd.len().next_multiple_of(4), 0);

        let dfd_offset = HEADER_LEN + n * LEVEL_ENTRY_LEN;
        let kvd_offset = dfd_offset + dfd.len();
        let (_, block_bytes) = self.format.block();
        // lcm(block bytes, 4): block sizes here are 1, 8 or 16.
        let align = block_bytes.max(4);
        // Levels are stored smallest first.
        let mut offsets = vec![0usize; n];
        let mut end = kvd_offset + kvd.len();
        for l in (0..n).rev() {
            end = end.next_multiple_of(align);
            offsets[l] = end;
            end += self.levels[l].len();
        }

        let mut out = Vec::with_capacity(end);
        out.extend_from_slice(&IDENTIFIER);
        for word in [
            self.format.value(),
            1, // typeSize: 1 for block-compressed and 8-bit formats
            self.width,
            self.height,
            0, // pixelDepth: 2D
            0, // layerCount: not an array
            1, // faceCount
            n as u32,
            0, // supercompressionScheme: none
            dfd_offset as u32,
            dfd.len() as u32,
            kvd_offset as u32,
            kvd.len() as u32,
        ] {
            out.extend_from_slice(&word.to_le_bytes());
        }
        out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteOffset
        out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteLength
        for (l, level) in self.levels.iter().enumerate() {
            let len = level.len() as u64;
            out.extend_from_slice(&(offsets[l] as u64).to_le_bytes());
            out.extend_from_slice(&len.to_le_bytes());
            out.extend_from_slice(&len.to_le_bytes()); // uncompressed = stored
        }
        out.extend_from_slice(&dfd);
        out.extend_from_slice(&kvd);
        for l in (0..n).rev() {
            out.resize(offsets[l], 0);
            out.extend_from_slice(&self.levels[l]);
        }
        out
    }

    /// Reads a KTX2 file in one of our formats: a 2D texture, no supercompression, a basic
    /// DFD that agrees with the vkFormat.
    pub fn from_bytes(bytes: &[u8]) -> Result<Ktx2, TextureError> {
        let bad = |message: String| TextureError::Ktx2(message);
        if bytes.len() < HEADER_LEN {
            return Err(bad(format!(
                "{} bytes is shorter than the {HEADER_LEN}-byte header",
                bytes.len()
            )));
        }
        if bytes[..12] != IDENTIFIER {
            return Err(bad("not a KTX2 file (bad identifier)".into()));
        }
        let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4"));
        let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8"));
        let value = u32_at(12);
        let format = VkFormat::from_value(value)
            .ok_or_else(|| bad(format!("unsupported vkFormat {value}")))?;
        let (width, height) = (u32_at(20), u32_at(24));
        if u32_at(16) != 1 {
            return Err(bad(format!("typeSize {} (expected 1)", u32_at(16))));
        }
        if width == 0 || height == 0 || u32_at(28) != 0 {
            return Err(bad(format!(
                "only 2D textures are supported ({width} x {height} x {})",
                u32_at(28)
            )));
        }
        if u32_at(32) > 1 || u32_at(36) != 1 {
            return Err(bad("array and cube-map textures are not supported".into()));
        }
        if u32_at(44) != 0 {
            return Err(bad(format!(
                "supercompression scheme {} is not supported",
                u32_at(44)
            )));
        }
        // levelCount 0 means "generate mips at load": one level is stored.
        let level_count = (u32_at(40) as usize).max(1);
        if level_count > full_chain(width, height) {
            return Err(bad(format!("{level_count} levels for {width} x {height}")));
        }
        let index_end = HEADER_LEN + level_count * LEVEL_ENTRY_LEN;
        if bytes.len() < index_end {
            return Err(bad("truncated level index".into()));
        }
        check_dfd(bytes, format, u32_at(48) as usize, u32_at(52) as usize)?;

        let mut levels = Vec::with_capacity(level_count);
        for l in 0..level_count {
            let entry = HEADER_LEN + l * LEVEL_ENTRY_LEN;
            let (offset, length, uncompressed) =
                (u64_at(entry), u64_at(entry + 8), u64_at(entry + 16));
            let (w, h) = (level_edge(width, l), level_edge(height, l));
            let expected = format
                .image_size(w, h)
                .ok_or_else(|| bad(format!("level {l} is too large")))?;
            if length != expected as u64 || uncompressed != length {
                return Err(bad(format!(
                    "level {l} ({w} x {h}) has {length} bytes, expected {expected}"
                )));
            }
            // The length matches the format, so this slice is at most the file's size.
            let start = usize::try_from(offset).ok();
            let data = start
                .and_then(|s| bytes.get(s..s.checked_add(expected)?))
                .ok_or_else(|| bad(format!("level {l} lies outside the file (truncated?)")))?;
            levels.push(data.to_vec());
        }
        Ktx2::new(format, width, height, levels)
    }
}

/// Checks that the Data Format Descriptor is a basic block agreeing with `format`.
fn check_dfd(
    bytes: &[u8],
    format: VkFormat,
    offset: usize,
    length: usize,
) -> Result<(), TextureError> {
    let bad = |message: &str| {
        Err(TextureError::Ktx2(format!(
            "data format descriptor: {message}"
        )))
    };
    let Some(dfd) = offset
        .checked_add(length)
        .and_then(|end| bytes.get(offset..end))
    else {
        return bad("lies outside the file (truncated?)");
    };
    if dfd.len() < 28 || u32::from_le_bytes(dfd[..4].try_into().expect("4")) as usize != dfd.len() {
        return bad("wrong size");
    }
    if dfd[4..8] != [0, 0, 0, 0] {
        return bad("the first block is not a Khronos basic block");
    }
    let model = dfd[12];
    if model != format.color_model() {
        return bad(&format!(
            "colour model {model} does not match {format:?} (expected {})",
            format.color_model()
        ));
    }
    let transfer = dfd[14];
    let expected = if format.is_srgb() { 2 } else { 1 };
    if transfer != expected {
        return bad(&format!(
            "transfer function {transfer} does not match {format:?} (expected {expected})"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_chain_counts_levels() {
        assert_eq!(full_chain(1, 1), 1);
        assert_eq!(full_chain(256, 256), 9);
        assert_eq!(full_chain(5, 3), 3);
    }

    #[test]
    fn format_values_round_trip() {
        for v in 0..300 {
            if let Some(f) = VkFormat::from_value(v) {
                assert_eq!(f.value(), v);
            }
        }
        assert_eq!(VkFormat::from_value(132), Some(VkFormat::Bc1RgbSrgb));
    }
}
