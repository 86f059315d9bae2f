//! KTX2: our writer's files read back by our reader and by the `ktx2` crate (format, sizes,
//! levels, Data Format Descriptor), level alignment, and a reader that never panics or
//! over-allocates on truncated, corrupted or hostile files.

mod common;

use ori_texture::{Ktx2, Quality, RgbaImage, VkFormat};

/// A real albedo crop and its box-filtered half-size levels down to 1 x 1.
fn mip_chain(image: &RgbaImage) -> Vec<RgbaImage> {
    let mut levels = vec![image.clone()];
    while levels
        .last()
        .is_some_and(|l| l.width() > 1 || l.height() > 1)
    {
        let prev = levels.last().unwrap();
        let (w, h) = ((prev.width() / 2).max(1), (prev.height() / 2).max(1));
        let mut data = Vec::with_capacity((w * h * 4) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0u32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let t = prev.texel(
                        (2 * x + dx).min(prev.width() - 1),
                        (2 * y + dy).min(prev.height() - 1),
                    );
                    for c in 0..4 {
                        sum[c] += u32::from(t[c]);
                    }
                }
                data.extend(sum.map(|s| ((s + 2) / 4) as u8));
            }
        }
        levels.push(RgbaImage::new(w, h, data).unwrap());
    }
    levels
}

fn albedo() -> RgbaImage {
    common::opaque(&common::png("gltf/Avocado/glTF/Avocado_baseColor.png").crop(512, 512, 40, 24))
}

/// Every format, as a texture of real data with a full mip chain.
fn textures() -> Vec<Ktx2> {
    let levels = mip_chain(&albedo());
    let (w, h) = (levels[0].width(), levels[0].height());
    let each = |f: &dyn Fn(&RgbaImage) -> Vec<u8>| levels.iter().map(f).collect::<Vec<_>>();
    let bc1 = each(&|l| ori_texture::encode_bc1(l, None, Quality::Fast).unwrap());
    vec![
        Ktx2::new(VkFormat::Bc1RgbSrgb, w, h, bc1.clone()).unwrap(),
        Ktx2::new(VkFormat::Bc1RgbUnorm, w, h, bc1).unwrap(),
        Ktx2::new(
            VkFormat::Bc4Unorm,
            w,
            h,
            each(&|l| {
                ori_texture::encode_bc4(&l.channel(0), l.width(), l.height(), Quality::Fast)
                    .unwrap()
            }),
        )
        .unwrap(),
        Ktx2::new(
            VkFormat::Bc5Unorm,
            w,
            h,
            each(&|l| {
                ori_texture::encode_bc5(&l.red_green(), l.width(), l.height(), Quality::Fast)
                    .unwrap()
            }),
        )
        .unwrap(),
        Ktx2::new(VkFormat::R8Unorm, w, h, each(&|l| l.channel(1))).unwrap(),
        // A single level is the common case.
        Ktx2::new(VkFormat::R8Unorm, 3, 1, vec![vec![1, 2, 3]]).unwrap(),
    ]
}

fn ktx2_format(f: VkFormat) -> ktx2::Format {
    match f {
        VkFormat::R8Unorm => ktx2::Format::R8_UNORM,
        VkFormat::Bc1RgbUnorm => ktx2::Format::BC1_RGB_UNORM_BLOCK,
        VkFormat::Bc1RgbSrgb => ktx2::Format::BC1_RGB_SRGB_BLOCK,
        VkFormat::Bc4Unorm => ktx2::Format::BC4_UNORM_BLOCK,
        VkFormat::Bc5Unorm => ktx2::Format::BC5_UNORM_BLOCK,
    }
}

#[test]
fn our_reader_returns_what_was_written() {
    for tex in textures() {
        let bytes = tex.to_bytes();
        assert_eq!(Ktx2::from_bytes(&bytes).unwrap(), tex, "{:?}", tex.format());
        // The writer is a pure function of the texture.
        assert_eq!(tex.to_bytes(), bytes);
    }
}

#[test]
fn the_ktx2_crate_reads_our_files() {
    for tex in textures() {
        let bytes = tex.to_bytes();
        let reader = ktx2::Reader::new(&bytes[..]).unwrap();
        let header = reader.header();
        let format = ktx2_format(tex.format());
        assert_eq!(header.format, Some(format));
        assert_eq!(format.value(), tex.format().value());
        assert_eq!(
            (header.pixel_width, header.pixel_height),
            (tex.width(), tex.height())
        );
        assert_eq!(
            (header.pixel_depth, header.layer_count, header.face_count),
            (0, 0, 1)
        );
        assert_eq!(header.level_count as usize, tex.levels().len());
        assert_eq!(header.supercompression_scheme, None);
        assert_eq!(header.type_size, 1);
        let levels: Vec<_> = reader.levels().collect();
        for (got, want) in levels.iter().zip(tex.levels()) {
            assert_eq!(got.data, &want[..]);
            assert_eq!(got.uncompressed_byte_length, want.len() as u64);
        }
        // The spec has the value NUL-terminated.
        assert_eq!(reader.writer(), Some("ori-texture\0"));

        // The Data Format Descriptor is the one the format calls for.
        let (expected, _) = ktx2::dfd::Basic::from_format(format).unwrap();
        assert_eq!(reader.basic_dfd(), Some(&expected), "{format:?}");
        assert_eq!(reader.dfd_blocks().len(), 1);
        let (model, transfer) = match tex.format() {
            VkFormat::Bc1RgbSrgb => (ktx2::ColorModel::BC1A, ktx2::TransferFunction::SRGB),
            VkFormat::Bc1RgbUnorm => (ktx2::ColorModel::BC1A, ktx2::TransferFunction::Linear),
            VkFormat::Bc4Unorm => (ktx2::ColorModel::BC4, ktx2::TransferFunction::Linear),
            VkFormat::Bc5Unorm => (ktx2::ColorModel::BC5, ktx2::TransferFunction::Linear),
            VkFormat::R8Unorm => (ktx2::ColorModel::RGBSDA, ktx2::TransferFunction::Linear),
        };
        assert_eq!(reader.color_model(), Some(model));
        assert_eq!(reader.transfer_function(), Some(transfer));
        assert_eq!(reader.color_primaries(), Some(ktx2::ColorPrimaries::BT709));
        assert_eq!(reader.is_alpha_premultiplied(), Some(false));
    }
}

#[test]
fn levels_are_aligned_and_stored_smallest_first() {
    for tex in textures() {
        let bytes = tex.to_bytes();
        let align = match tex.format() {
            VkFormat::R8Unorm => 4,
            VkFormat::Bc5Unorm => 16,
            _ => 8,
        };
        let offsets: Vec<u64> = (0..tex.levels().len())
            .map(|l| u64::from_le_bytes(bytes[80 + 24 * l..88 + 24 * l].try_into().unwrap()))
            .collect();
        for (l, &o) in offsets.iter().enumerate() {
            assert_eq!(o % align, 0, "{:?} level {l}", tex.format());
            if l > 0 {
                assert!(
                    o < offsets[l - 1],
                    "level {l} should come before level {}",
                    l - 1
                );
            }
        }
        // The largest level ends the file.
        assert_eq!(offsets[0] as usize + tex.levels()[0].len(), bytes.len());
    }
}

#[test]
fn mismatched_levels_are_refused() {
    assert!(Ktx2::new(VkFormat::Bc1RgbSrgb, 4, 4, vec![vec![0; 16]]).is_err());
    assert!(Ktx2::new(VkFormat::Bc1RgbSrgb, 4, 4, vec![]).is_err());
    assert!(Ktx2::new(VkFormat::Bc1RgbSrgb, 0, 4, vec![vec![]]).is_err());
    // 5 x 5 has three levels (5, 2, 1); a fourth is too many.
    let l = |n| vec![0u8; n];
    assert!(Ktx2::new(VkFormat::R8Unorm, 5, 5, vec![l(25), l(4), l(1)]).is_ok());
    assert!(Ktx2::new(VkFormat::R8Unorm, 5, 5, vec![l(25), l(4), l(1), l(1)]).is_err());
    assert!(Ktx2::new(VkFormat::R8Unorm, 5, 5, vec![l(25), l(5)]).is_err());
}

#[test]
fn truncated_files_are_errors() {
    for tex in textures() {
        let bytes = tex.to_bytes();
        for len in 0..bytes.len() {
            assert!(
                Ktx2::from_bytes(&bytes[..len]).is_err(),
                "{:?} cut at {len}",
                tex.format()
            );
        }
    }
}

#[test]
fn corrupted_files_never_panic() {
    let bytes = textures()[0].to_bytes();
    // Deterministic pseudo-random corruptions of the header, index and DFD.
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for _ in 0..20_000 {
        let mut b = bytes.clone();
        for _ in 0..1 + next() % 4 {
            let at = (next() % 200) as usize % b.len();
            b[at] = next() as u8;
        }
        // Errors or a texture whose sizes are consistent: never a panic.
        if let Ok(tex) = Ktx2::from_bytes(&b) {
            assert!(!tex.levels().is_empty());
        }
    }
}

#[test]
fn hostile_sizes_are_refused_without_allocating() {
    let mut bytes = Ktx2::new(VkFormat::R8Unorm, 4, 4, vec![vec![7; 16]])
        .unwrap()
        .to_bytes();
    let put = |b: &mut Vec<u8>, at: usize, v: u32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    // A 65536 x 65536 image whose level index still says 16 bytes.
    let mut huge = bytes.clone();
    put(&mut huge, 20, 65_536);
    put(&mut huge, 24, 65_536);
    assert!(Ktx2::from_bytes(&huge).is_err());
    // Every level count up to u32::MAX.
    for count in [2, 3, 32, 33, u32::MAX] {
        let mut b = bytes.clone();
        put(&mut b, 40, count);
        assert!(Ktx2::from_bytes(&b).is_err(), "{count} levels");
    }
    // Offsets and lengths near the top of u64.
    for value in [u64::MAX, u64::MAX - 8, 1 << 40] {
        let mut b = bytes.clone();
        b[80..88].copy_from_slice(&value.to_le_bytes());
        assert!(Ktx2::from_bytes(&b).is_err());
        let mut b = bytes.clone();
        b[88..96].copy_from_slice(&value.to_le_bytes());
        assert!(Ktx2::from_bytes(&b).is_err());
    }
    // A DFD that claims to be larger than the file.
    put(&mut bytes, 52, u32::MAX);
    assert!(Ktx2::from_bytes(&bytes).is_err());
    // Unsupported formats, supercompression, arrays and cube maps.
    let base = Ktx2::new(VkFormat::R8Unorm, 4, 4, vec![vec![7; 16]])
        .unwrap()
        .to_bytes();
    for (at, value) in [(12, 37), (44, 2), (32, 6), (36, 6), (28, 4), (16, 4)] {
        let mut b = base.clone();
        put(&mut b, at, value);
        assert!(Ktx2::from_bytes(&b).is_err(), "field at {at} = {value}");
    }
    // A DFD that disagrees with the format (R8 file relabelled as BC1 sRGB).
    let mut b = base.clone();
    put(&mut b, 12, 132);
    assert!(Ktx2::from_bytes(&b).is_err());
}
