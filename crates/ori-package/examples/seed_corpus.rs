//! Writes small valid packages to seed the fuzzer's corpus:
//! `cargo run -p ori-package --example seed_corpus -- crates/ori-package/fuzz/corpus/read`.

#[path = "../tests/common/mod.rs"]
mod common;

use ori_package::{TextureFormat, write};

fn main() {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "crates/ori-package/fuzz/corpus/read".into());
    std::fs::create_dir_all(&dir).expect("create the corpus directory");
    // The smallest resolution keeps seeds small (the manifest's 320 entries dominate).
    let seeds = [
        (
            "r8-1",
            common::manifest(1, 4, TextureFormat::R8),
            1,
            TextureFormat::R8,
        ),
        (
            "bc4-2",
            common::manifest(2, 4, TextureFormat::Bc4),
            2,
            TextureFormat::Bc4,
        ),
    ];
    for (name, manifest, n, depth) in seeds {
        let textures: Vec<_> = (0..n).map(|i| common::textures(4, i, depth)).collect();
        let bytes = write(&manifest, &textures).expect("a valid seed package");
        let path = std::path::Path::new(&dir).join(format!("seed-{name}.ori"));
        std::fs::write(&path, &bytes).expect("write the seed");
        println!("{} ({} bytes)", path.display(), bytes.len());
    }
}
