//! 8-bit RGBA images, PNG loading, and the gathering of 4x4 blocks with edge padding.

use std::path::Path;

use crate::TextureError;

/// Largest accepted image edge; bigger files are refused before any pixel is allocated.
const MAX_EDGE: u32 = 16_384;

/// A row-major 8-bit RGBA image; colour as stored in the file (sRGB-encoded for albedo).
///
/// Invariant: `width >= 1`, `height >= 1` and `data.len() == width * height * 4`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbaImage {
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl RgbaImage {
    /// Wraps row-major RGBA8 texels; fails if the size is zero or `data` does not match it.
    pub fn new(width: u32, height: u32, data: Vec<u8>) -> Result<Self, TextureError> {
        crate::check_size(width, height, 4, data.len())?;
        Ok(RgbaImage {
            width,
            height,
            data,
        })
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Row-major RGBA8 texels.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// The texel at (x, y), which must be inside the image.
    pub fn texel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = (y as usize * self.width as usize + x as usize) * 4;
        [
            self.data[i],
            self.data[i + 1],
            self.data[i + 2],
            self.data[i + 3],
        ]
    }

    /// One channel (0 = red ... 3 = alpha) as a row-major plane, e.g. the BC4 input.
    pub fn channel(&self, c: usize) -> Vec<u8> {
        self.data.chunks_exact(4).map(|t| t[c]).collect()
    }

    /// Red and green interleaved, e.g. the BC5 input of a normal map.
    pub fn red_green(&self) -> Vec<u8> {
        self.data
            .chunks_exact(4)
            .flat_map(|t| [t[0], t[1]])
            .collect()
    }

    /// The `width` x `height` rectangle at (x, y), clipped to the image (at least 1 x 1).
    pub fn crop(&self, x: u32, y: u32, width: u32, height: u32) -> RgbaImage {
        let x = x.min(self.width - 1);
        let y = y.min(self.height - 1);
        let w = width.clamp(1, self.width - x);
        let h = height.clamp(1, self.height - y);
        let mut data = Vec::with_capacity(w as usize * h as usize * 4);
        for row in y..y + h {
            let start = (row as usize * self.width as usize + x as usize) * 4;
            data.extend_from_slice(&self.data[start..start + w as usize * 4]);
        }
        RgbaImage {
            width: w,
            height: h,
            data,
        }
    }
}

/// Decodes a PNG of any bit depth and colour type into RGBA8: grey is replicated into R, G
/// and B, 16-bit samples are rounded to 8 bits, a missing alpha is opaque.
pub fn load_png(bytes: &[u8]) -> Result<RgbaImage, TextureError> {
    if !bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        return Err(TextureError::Png("not a PNG file (bad signature)".into()));
    }
    let mut reader =
        ::image::ImageReader::with_format(std::io::Cursor::new(bytes), ::image::ImageFormat::Png);
    let mut limits = ::image::Limits::default();
    limits.max_image_width = Some(MAX_EDGE);
    limits.max_image_height = Some(MAX_EDGE);
    reader.limits(limits);
    let rgba = reader
        .decode()
        .map_err(|e| TextureError::Png(e.to_string()))?
        .into_rgba8();
    let (width, height) = rgba.dimensions();
    RgbaImage::new(width, height, rgba.into_raw())
}

/// Reads and decodes a PNG file; errors say what failed, the caller names the file.
pub fn load_png_file(path: &Path) -> Result<RgbaImage, TextureError> {
    load_png(&std::fs::read(path)?)
}

/// Row-major texel indices of the 4x4 block at block coordinates (bx, by), with positions
/// past the right or bottom edge replaced by the nearest edge texel, and whether each of the
/// 16 positions lies inside the image (padding is never visible, so encoders ignore it).
pub(crate) fn block_texels(bx: u32, by: u32, width: u32, height: u32) -> ([usize; 16], [bool; 16]) {
    let mut index = [0usize; 16];
    let mut inside = [false; 16];
    for j in 0..4 {
        let y = by * 4 + j;
        let yc = y.min(height - 1) as usize;
        for i in 0..4 {
            let x = bx * 4 + i;
            let xc = x.min(width - 1) as usize;
            let k = (j * 4 + i) as usize;
            index[k] = yc * width as usize + xc;
            inside[k] = x < width && y < height;
        }
    }
    (index, inside)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_replicate_edges_and_flag_padding() {
        let (index, inside) = block_texels(1, 0, 5, 2);
        // Column 4 exists, columns 5.. repeat it; row 1 exists, rows 2.. repeat it.
        assert_eq!(index[0], 4);
        assert_eq!(index[1], 4);
        assert_eq!(index[4], 9);
        assert_eq!(index[15], 9);
        assert!(inside[0] && inside[4]);
        assert!(!inside[1] && !inside[8] && !inside[15]);
    }

    #[test]
    fn crop_clips_to_the_image() {
        let img = RgbaImage::new(3, 2, (0..24).collect()).unwrap();
        let c = img.crop(2, 1, 10, 10);
        assert_eq!((c.width(), c.height()), (1, 1));
        assert_eq!(c.data(), &[20, 21, 22, 23]);
    }
}
