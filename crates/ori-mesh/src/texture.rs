//! Image decoding for base-colour textures (PNG and JPEG).
//!
//! JPEG goes through zune-jpeg with its platform intrinsics switched off: its SIMD and scalar
//! IDCT / colour-conversion paths are not promised to round alike, and texels reach artifact
//! bytes, which must be identical on every machine. PNG decoding is exact integer work.

use crate::{ErrorKind, Texture, Wrap};

/// Largest accepted image edge; bigger files are refused before any pixel is allocated.
const MAX_EDGE: u32 = 16_384;

/// Decode PNG or JPEG bytes (format sniffed from the content) into an RGBA8 texture with
/// repeat wrapping and bilinear filtering; `name` identifies it in messages.
pub(crate) fn decode(name: &str, bytes: &[u8]) -> Result<Texture, ErrorKind> {
    let fail = |message: String| ErrorKind::Image {
        name: format!("`{name}`"),
        message,
    };
    let (width, height, rgba8) = if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        decode_jpeg(bytes).map_err(fail)?
    } else if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes).map_err(fail)?
    } else {
        return Err(fail("not a PNG or JPEG file".into()));
    };
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
            assert!(decode("t", bytes).is_err());
        }
    }
}
