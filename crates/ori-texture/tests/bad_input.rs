//! Awkward and broken input: odd and tiny sizes, 16-bit and grey PNGs, corrupt files and
//! mismatched lengths are handled or give a clear error, never a panic.

use std::io::Cursor;

use image::{ImageBuffer, ImageFormat, Luma, LumaA, Rgb};
use ori_texture::{Quality, RgbaImage, decode_bc1, decode_bc4, decode_bc5, load_png};

fn png_bytes<P: image::PixelWithColorType>(img: ImageBuffer<P, Vec<P::Subpixel>>) -> Vec<u8>
where
    [P::Subpixel]: image::EncodableLayout,
{
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, ImageFormat::Png).unwrap();
    out.into_inner()
}

/// Encodes with every encoder and checks the decoded size and rough fidelity.
fn round_trip(image: &RgbaImage) {
    let (w, h) = (image.width(), image.height());
    let n = (w * h) as usize;
    for q in [Quality::Fast, Quality::High] {
        let bc1 = ori_texture::encode_bc1(image, None, q).unwrap();
        assert_eq!(
            bc1.len(),
            w.div_ceil(4) as usize * h.div_ceil(4) as usize * 8
        );
        let decoded = decode_bc1(&bc1, w, h).unwrap();
        assert_eq!(decoded.len(), n);
        let bc4 = ori_texture::encode_bc4(&image.channel(0), w, h, q).unwrap();
        let values = decode_bc4(&bc4, w, h).unwrap();
        for (v, t) in values.iter().zip(image.data().chunks_exact(4)) {
            assert!((v * 255.0 - f32::from(t[0])).abs() < 40.0);
        }
        let bc5 = ori_texture::encode_bc5(&image.red_green(), w, h, q).unwrap();
        assert_eq!(decode_bc5(&bc5, w, h).unwrap().len(), n);
    }
}

fn gradient(w: u32, h: u32) -> RgbaImage {
    let data = (0..w * h)
        .flat_map(|i| {
            let (x, y) = (i % w, i / w);
            [
                (x * 37 % 256) as u8,
                (y * 53 % 256) as u8,
                ((x + y) * 11 % 256) as u8,
                255,
            ]
        })
        .collect();
    RgbaImage::new(w, h, data).unwrap()
}

#[test]
fn odd_and_tiny_sizes_are_padded() {
    for (w, h) in [(1, 1), (1, 7), (7, 1), (3, 5), (5, 3), (17, 9), (64, 63)] {
        round_trip(&gradient(w, h));
    }
}

#[test]
fn a_one_texel_image_round_trips_closely() {
    let image = RgbaImage::new(1, 1, vec![200, 100, 50, 255]).unwrap();
    let bc1 = ori_texture::encode_bc1(&image, None, Quality::High).unwrap();
    let px = decode_bc1(&bc1, 1, 1).unwrap()[0];
    for (c, want) in [200.0, 100.0, 50.0].into_iter().enumerate() {
        assert!((px[c] * 255.0 - want).abs() <= 2.0, "{px:?}");
    }
    let bc4 = ori_texture::encode_bc4(&[77], 1, 1, Quality::Fast).unwrap();
    assert_eq!(decode_bc4(&bc4, 1, 1).unwrap(), vec![77.0 / 255.0]);
}

#[test]
fn sixteen_bit_and_grey_pngs_are_converted() {
    let grey16 = ImageBuffer::from_fn(9, 5, |x, y| Luma([(x * 7000 + y * 300) as u16]));
    let img = load_png(&png_bytes(grey16)).unwrap();
    assert_eq!((img.width(), img.height()), (9, 5));
    // 16-bit 7000 is 8-bit 27; grey goes to R, G and B; alpha is opaque.
    assert_eq!(img.texel(1, 0), [27, 27, 27, 255]);
    round_trip(&img);

    let grey_alpha = ImageBuffer::from_fn(6, 6, |x, _| LumaA([(x * 40) as u8, 128]));
    let img = load_png(&png_bytes(grey_alpha)).unwrap();
    assert_eq!(img.texel(2, 3), [80, 80, 80, 128]);

    let rgb16 = ImageBuffer::from_fn(4, 3, |x, _| Rgb([65_535u16, (x * 20_000) as u16, 0]));
    let img = load_png(&png_bytes(rgb16)).unwrap();
    assert_eq!(img.texel(0, 0), [255, 0, 0, 255]);
    round_trip(&img);
}

#[test]
fn corrupt_pngs_are_errors() {
    let good = png_bytes(ImageBuffer::from_fn(8, 8, |x, y| {
        Rgb([x as u8, y as u8, 0])
    }));
    assert!(load_png(&good).is_ok());
    assert!(load_png(b"").is_err());
    assert!(load_png(b"GIF89a").is_err());
    for len in [8, 20, 33, good.len() / 2] {
        assert!(load_png(&good[..len]).is_err(), "cut at {len}");
    }
    // Cut inside the end marker, after all pixel data: decoding it whole is fine too.
    if let Ok(img) = load_png(&good[..good.len() - 1]) {
        assert_eq!(img, load_png(&good).unwrap());
    }
    // Flipped bytes: an error (bad CRC or data) or a valid image, never a panic.
    for at in 8..good.len() {
        let mut bad = good.clone();
        bad[at] ^= 0x5A;
        let _ = load_png(&bad);
    }
    // A header announcing a gigantic image is refused before allocating it.
    let mut huge = good.clone();
    huge[16..20].copy_from_slice(&1_000_000u32.to_be_bytes());
    assert!(load_png(&huge).is_err());
}

#[test]
fn mismatched_lengths_are_errors() {
    assert!(RgbaImage::new(0, 4, vec![]).is_err());
    assert!(RgbaImage::new(2, 2, vec![0; 15]).is_err());
    assert!(ori_texture::encode_bc4(&[0; 15], 4, 4, Quality::Fast).is_err());
    assert!(ori_texture::encode_bc4(&[], 0, 0, Quality::Fast).is_err());
    assert!(ori_texture::encode_bc5(&[0; 16], 4, 4, Quality::Fast).is_err());
    let image = gradient(4, 4);
    assert!(ori_texture::encode_bc1(&image, Some(&[true; 15]), Quality::Fast).is_err());
    let err = ori_texture::encode_bc4(&[0; 15], 4, 4, Quality::Fast).unwrap_err();
    assert!(err.to_string().contains("16"), "{err}");
}

#[test]
fn fully_masked_blocks_still_encode_their_colour() {
    // Empty texels everywhere: the block is encoded as if unmasked, not left black.
    let image = RgbaImage::new(4, 4, [90, 160, 30, 255].repeat(16)).unwrap();
    let bc1 = ori_texture::encode_bc1(&image, Some(&[false; 16]), Quality::High).unwrap();
    let px = decode_bc1(&bc1, 4, 4).unwrap()[5];
    assert!((px[1] * 255.0 - 160.0).abs() < 3.0, "{px:?}");
}

#[test]
fn masked_texels_do_not_pull_the_endpoints() {
    // Half the block is a smooth green ramp, the other half (empty) wild magenta.
    let mut data = Vec::new();
    let mut mask = Vec::new();
    for i in 0..16u8 {
        let empty = i % 2 == 1;
        data.extend(if empty {
            [255, 0, 255, 255]
        } else {
            [20, 100 + 8 * i, 40, 255]
        });
        mask.push(!empty);
    }
    let image = RgbaImage::new(4, 4, data).unwrap();
    let decoded = |m: Option<&[bool]>| {
        decode_bc1(
            &ori_texture::encode_bc1(&image, m, Quality::High).unwrap(),
            4,
            4,
        )
        .unwrap()
    };
    let err = |d: &[[f32; 4]]| -> f32 {
        (0..16)
            .filter(|&i| mask[i])
            .map(|i| {
                let t = image.texel(i as u32 % 4, i as u32 / 4);
                (0..3)
                    .map(|c| (d[i][c] * 255.0 - f32::from(t[c])).powi(2))
                    .sum::<f32>()
            })
            .sum()
    };
    let (plain, masked) = (err(&decoded(None)), err(&decoded(Some(&mask))));
    assert!(masked * 4.0 < plain, "masked {masked} vs unmasked {plain}");
}
