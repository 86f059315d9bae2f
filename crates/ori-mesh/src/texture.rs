//! Image decoding for base-colour textures (PNG and JPEG).
//!
//! JPEG goes through zune-jpeg with its platform intrinsics switched off: its SIMD and scalar
//! IDCT / colour-conversion paths are not promised to round alike, and texels reach artifact
//! bytes, which must be identical on every machine. PNG decoding is exact integer work.

use crate::{ErrorKind, Limits, Texture, Wrap};

/// Largest accepted image edge; bigger files are refused before any pixel is allocated.
const MAX_EDGE: u32 = 16_384;

/// What is left of a model's texture limits as its images are decoded.
pub(crate) struct TextureBudget {
    per_image: u64,
    remaining: u64,
}

impl TextureBudget {
    pub(crate) fn new(limits: &Limits) -> TextureBudget {
        TextureBudget {
            per_image: limits.max_texture_pixels,
            remaining: limits.max_total_texture_pixels,
        }
    }

    /// Take a `width x height` image out of the budget, or say which limit it breaks.
    fn take(&mut self, name: &str, width: u32, height: u32) -> Result<(), ErrorKind> {
        let pixels = u64::from(width) * u64::from(height);
        if pixels > self.per_image {
            return Err(ErrorKind::Limit {
                what: format!("texture `{name}` ({width} x {height}): its pixel count"),
                value: pixels,
                limit: self.per_image,
                key: "[limits] max_texture_pixels",
            });
        }
        if pixels > self.remaining {
            return Err(ErrorKind::Limit {
                what: format!(
                    "texture `{name}` ({width} x {height}) with the textures before it: the pixel count left"
                ),
                value: pixels,
                limit: self.remaining,
                key: "[limits] max_total_texture_pixels",
            });
        }
        self.remaining -= pixels;
        Ok(())
    }
}

/// Decode PNG or JPEG bytes (format sniffed from the content) into an RGBA8 texture with
/// repeat wrapping and bilinear filtering; `name` identifies it in messages. The image's
/// size is read from its header and taken from `budget` before any pixel is decoded.
pub(crate) fn decode(
    name: &str,
    bytes: &[u8],
    budget: &mut TextureBudget,
) -> Result<Texture, ErrorKind> {
    let fail = |message: String| ErrorKind::Image {
        name: format!("`{name}`"),
        message,
    };
    let (width, height, rgba8) = if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        let (w, h) = jpeg_size(bytes).map_err(fail)?;
        budget.take(name, w, h)?;
        decode_jpeg(bytes).map_err(fail)?
    } else if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        let (w, h) = png_size(bytes).map_err(fail)?;
        budget.take(name, w, h)?;
        decode_png(bytes).map_err(fail)?
    } else if let Some(format) = unsupported_format(bytes) {
        return Err(ErrorKind::UnsupportedImage {
            name: name.to_string(),
            format,
        });
    } else {
        return Err(fail("not a PNG or JPEG file".into()));
    };
    if u64::from(width) * u64::from(height) * 4 != rgba8.len() as u64 {
        return Err(fail("the decoded size differs from the header's".into()));
    }
    Ok(Texture {
        name: name.to_string(),
        width,
        height,
        rgba8,
        wrap_s: Wrap::Repeat,
        wrap_t: Wrap::Repeat,
        nearest: false,
    })
}

/// The image formats glTF extensions and engines use that [`decode`] does not, by signature.
fn unsupported_format(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\xABKTX 20\xBB\r\n\x1A\n") {
        Some("KTX2")
    } else if bytes.starts_with(b"\xABKTX 11\xBB\r\n\x1A\n") {
        Some("KTX")
    } else if bytes.len() >= 12 && bytes.starts_with(b"RIFF") && &bytes[8..12] == b"WEBP" {
        Some("WebP")
    } else if bytes.starts_with(b"DDS ") {
        Some("DDS")
    } else {
        None
    }
}

fn png_size(bytes: &[u8]) -> Result<(u32, u32), String> {
    image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png)
        .into_dimensions()
        .map_err(|e| e.to_string())
}

fn jpeg_size(bytes: &[u8]) -> Result<(u32, u32), String> {
    let options = zune_core::options::DecoderOptions::default()
        .set_max_width(MAX_EDGE as usize)
        .set_max_height(MAX_EDGE as usize);
    let mut decoder =
        zune_jpeg::JpegDecoder::new_with_options(std::io::Cursor::new(bytes), options);
    decoder.decode_headers().map_err(|e| format!("{e:?}"))?;
    let info = decoder.info().ok_or("no image header")?;
    Ok((u32::from(info.width), u32::from(info.height)))
}

fn decode_png(bytes: &[u8]) -> Result<(u32, u32, Vec<u8>), String> {
    let mut reader =
        image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_EDGE);
    limits.max_image_height = Some(MAX_EDGE);
    reader.limits(limits);
    let rgba = reader.decode().map_err(|e| e.to_string())?.into_rgba8();
    Ok((rgba.width(), rgba.height(), rgba.into_raw()))
}

fn decode_jpeg(bytes: &[u8]) -> Result<(u32, u32, Vec<u8>), String> {
    use zune_core::colorspace::ColorSpace;
    use zune_core::options::DecoderOptions;
    let options = DecoderOptions::default()
        .set_use_unsafe(false)
        .set_max_width(MAX_EDGE as usize)
        .set_max_height(MAX_EDGE as usize)
        .jpeg_set_out_colorspace(ColorSpace::RGBA);
    let mut decoder =
        zune_jpeg::JpegDecoder::new_with_options(std::io::Cursor::new(bytes), options);
    let pixels = decoder.decode().map_err(|e| format!("{e:?}"))?;
    let info = decoder.info().ok_or("no image header")?;
    let (w, h) = (u32::from(info.width), u32::from(info.height));
    if pixels.len() != w as usize * h as usize * 4 {
        return Err(format!(
            "decoder gave {} bytes for {w} x {h} RGBA",
            pixels.len()
        ));
    }
    Ok((w, h, pixels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        for bytes in [
            &b""[..],
            b"\xFF\xD8\xFF\x00\x01",
            b"\x89PNG\r\n\x1a\nxx",
            b"GIF89a",
        ] {
            let mut budget = TextureBudget::new(&Limits::default());
            assert!(decode("t", bytes, &mut budget).is_err());
        }
    }
}
