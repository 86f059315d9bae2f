//! What a render gives back on the CPU: colour, coverage, depth and which draw made each
//! pixel.

use std::path::Path;

/// [`Image::source`] of a pixel nothing drew.
pub const SOURCE_NONE: u16 = u16::MAX;
/// [`Image::source`] of a pixel a mesh drew.
pub const SOURCE_MESH: u16 = u16::MAX - 1;

/// A rendered image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// 8-bit sRGB colour and alpha: alpha 255 where something was drawn, else 0 (and the
    /// colour black).
    pub rgba: Vec<u8>,
    /// Depth in the camera's `[0, 1]` range (clip z / w) where something was drawn, NaN
    /// elsewhere. For an orthographic camera [`crate::Camera::ortho_height`] converts it.
    pub depth: Vec<f32>,
    /// Per pixel, the impostor index that drew it, [`SOURCE_MESH`] or [`SOURCE_NONE`].
    pub source: Vec<u16>,
}

impl Image {
    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Whether the image has no pixels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether pixel `i` (row-major index) was drawn.
    pub fn covered(&self, i: usize) -> bool {
        self.source[i] != SOURCE_NONE
    }

    /// Number of pixels drawn.
    pub fn coverage_count(&self) -> usize {
        self.source.iter().filter(|&&s| s != SOURCE_NONE).count()
    }

    /// The sRGB colour of pixel `i`.
    pub fn rgb(&self, i: usize) -> [u8; 3] {
        [self.rgba[4 * i], self.rgba[4 * i + 1], self.rgba[4 * i + 2]]
    }

    /// Write the colour and coverage (as alpha) as an RGBA PNG file.
    pub fn save_png(&self, path: &Path) -> Result<(), String> {
        image::save_buffer_with_format(
            path,
            &self.rgba,
            self.width,
            self.height,
            image::ExtendedColorType::Rgba8,
            image::ImageFormat::Png,
        )
        .map_err(|e| format!("{}: {e}", path.display()))
    }
}
