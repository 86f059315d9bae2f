//! Bit-identical output for any rayon thread count, on real data with odd sizes.

mod common;

use ori_texture::{Quality, RgbaImage};

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// Every encoder, every level, on the image (and its alpha as the mask).
fn encode_all(image: &RgbaImage) -> Vec<Vec<u8>> {
    let mask: Vec<bool> = image.data().chunks_exact(4).map(|t| t[3] >= 128).collect();
    let (w, h) = (image.width(), image.height());
    let mut out = Vec::new();
    for q in [Quality::Fast, Quality::High] {
        out.push(ori_texture::encode_bc1(image, None, q).unwrap());
        out.push(ori_texture::encode_bc1(image, Some(&mask), q).unwrap());
        out.push(ori_texture::encode_bc4(&image.channel(0), w, h, q).unwrap());
        out.push(ori_texture::encode_bc5(&image.red_green(), w, h, q).unwrap());
    }
    out
}

#[test]
fn one_and_four_threads_give_the_same_bytes() {
    // Alpha-tested leaves (mask) at an odd size, so padding is exercised too.
    let leaves = &common::glb_images("gltf/GlassVaseFlowers/GlassVaseFlowers.glb")[1];
    let image = leaves.crop(300, 200, 157, 123);
    let one = in_pool(1, || encode_all(&image));
    let four = in_pool(4, || encode_all(&image));
    assert_eq!(one, four);
    // And again: no hidden state between runs.
    assert_eq!(one, in_pool(3, || encode_all(&image)));
}
