//! The decoders against hand-made blocks laid out as the D3D10 block-compression
//! specification describes them, in both modes of BC1 and of BC4.

use ori_texture::decode::{bc4_palette, decode_bc1_block, decode_bc4_block};
use ori_texture::{Quality, RgbaImage, decode_bc1, decode_bc4, decode_bc5};

/// A BC1 block from its two RGB565 words and 16 two-bit codes (texel 0 first).
fn bc1_block(c0: u16, c1: u16, codes: [u32; 16]) -> [u8; 8] {
    let bits = codes
        .iter()
        .enumerate()
        .fold(0u32, |b, (i, &c)| b | c << (2 * i));
    let mut out = [0u8; 8];
    out[..2].copy_from_slice(&c0.to_le_bytes());
    out[2..4].copy_from_slice(&c1.to_le_bytes());
    out[4..].copy_from_slice(&bits.to_le_bytes());
    out
}

/// A BC4 block from its endpoints and 16 three-bit codes (texel 0 first).
fn bc4_block(r0: u8, r1: u8, codes: [u64; 16]) -> [u8; 8] {
    let bits = codes
        .iter()
        .enumerate()
        .fold(0u64, |b, (i, &c)| b | c << (3 * i));
    let mut out = [0u8; 8];
    out[0] = r0;
    out[1] = r1;
    out[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
    out
}

fn close(a: [f32; 4], b: [f32; 4]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
}

const CODES: [u32; 16] = [0, 1, 2, 3, 3, 2, 1, 0, 0, 0, 0, 0, 3, 3, 3, 3];

#[test]
fn bc1_four_colour_mode() {
    // c0 = pure red (31, 0, 0) > c1 = (0, 32, 31): four opaque colours.
    let c1 = (32 << 5) | 31;
    let texels = decode_bc1_block(&bc1_block(0xF800, c1, CODES));
    let g = 32.0 / 63.0;
    let expected = [
        [1.0, 0.0, 0.0, 1.0],
        [0.0, g, 1.0, 1.0],
        [2.0 / 3.0, g / 3.0, 1.0 / 3.0, 1.0],
        [1.0 / 3.0, 2.0 * g / 3.0, 2.0 / 3.0, 1.0],
    ];
    for (i, &code) in CODES.iter().enumerate() {
        assert!(
            close(texels[i], expected[code as usize]),
            "texel {i}: {:?}",
            texels[i]
        );
    }
}

#[test]
fn bc1_three_colour_mode_with_transparent_black() {
    // c0 <= c1: colours c0, c1, their midpoint, and transparent black.
    let texels = decode_bc1_block(&bc1_block(0x001F, 0xF800, CODES));
    let expected = [
        [0.0, 0.0, 1.0, 1.0],
        [1.0, 0.0, 0.0, 1.0],
        [0.5, 0.0, 0.5, 1.0],
        [0.0, 0.0, 0.0, 0.0],
    ];
    for (i, &code) in CODES.iter().enumerate() {
        assert!(
            close(texels[i], expected[code as usize]),
            "texel {i}: {:?}",
            texels[i]
        );
    }
    // Equal endpoints are the 3-colour mode too.
    let same = decode_bc1_block(&bc1_block(0x7BEF, 0x7BEF, [3; 16]));
    assert_eq!(same[0], [0.0; 4]);
}

#[test]
fn bc4_eight_value_mode() {
    let codes: [u64; 16] = std::array::from_fn(|i| (i % 8) as u64);
    let values = decode_bc4_block(&bc4_block(200, 100, codes));
    let (a, b) = (200.0 / 255.0, 100.0 / 255.0);
    let mut expected = vec![a, b];
    expected.extend((1..=6).map(|i| ((7 - i) as f32 * a + i as f32 * b) / 7.0));
    for (i, v) in values.iter().enumerate() {
        assert!((v - expected[i % 8]).abs() < 1e-6, "texel {i}: {v}");
    }
    assert_eq!(bc4_palette(200, 100)[2], (6.0 * a + b) / 7.0);
}

#[test]
fn bc4_six_value_mode_with_zero_and_one() {
    let codes: [u64; 16] = std::array::from_fn(|i| (7 - i % 8) as u64);
    let values = decode_bc4_block(&bc4_block(100, 200, codes));
    let (a, b) = (100.0 / 255.0, 200.0 / 255.0);
    let mut expected = vec![a, b];
    expected.extend((1..=4).map(|i| ((5 - i) as f32 * a + i as f32 * b) / 5.0));
    expected.extend([0.0, 1.0]);
    for (i, v) in values.iter().enumerate() {
        assert!((v - expected[7 - i % 8]).abs() < 1e-6, "texel {i}: {v}");
    }
}

#[test]
fn bc5_is_two_bc4_blocks_red_then_green() {
    let mut block = [0u8; 16];
    block[..8].copy_from_slice(&bc4_block(255, 0, [0; 16]));
    block[8..].copy_from_slice(&bc4_block(0, 255, [7; 16]));
    let decoded = decode_bc5(&block, 4, 4).unwrap();
    assert!(decoded.iter().all(|&p| p == [1.0, 1.0]));
}

#[test]
fn image_decoders_drop_padding_and_check_sizes() {
    // 5 x 3 texels: 2 x 1 blocks; texel (4, 0) is texel 0 of the second block.
    let mut data = Vec::new();
    data.extend_from_slice(&bc4_block(0, 0, [0; 16]));
    data.extend_from_slice(&bc4_block(255, 255, [0; 16]));
    let values = decode_bc4(&data, 5, 3).unwrap();
    assert_eq!(values.len(), 15);
    assert_eq!(values[3], 0.0);
    assert_eq!(values[4], 1.0);
    assert_eq!(values[14], 1.0);
    assert!(decode_bc4(&data, 9, 3).is_err());
    assert!(decode_bc4(&data, 0, 3).is_err());
    assert!(decode_bc1(&data[..7], 4, 4).is_err());
}

#[test]
fn encoder_emits_only_four_colour_blocks() {
    // A ramp with noise: every block has two or more colours.
    let data: Vec<u8> = (0..64 * 64)
        .flat_map(|i| {
            let (x, y) = (i % 64, i / 64);
            [
                (x * 4) as u8,
                (y * 4) as u8,
                ((x * 7 + y * 13) % 256) as u8,
                255,
            ]
        })
        .collect();
    let image = RgbaImage::new(64, 64, data).unwrap();
    for quality in [Quality::Fast, Quality::High] {
        let blocks = ori_texture::encode_bc1(&image, None, quality).unwrap();
        for b in blocks.chunks_exact(8) {
            let (c0, c1) = (
                u16::from_le_bytes([b[0], b[1]]),
                u16::from_le_bytes([b[2], b[3]]),
            );
            let codes = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
            assert!(c0 > c1 || (c0 == c1 && codes == 0), "{b:?}");
        }
    }
}
