//! Writes small valid packages to seed the fuzzer's corpus:
//! `cargo run -p ori-package --example seed_corpus -- crates/ori-package/fuzz/corpus/read`.

#[path = "../tests/common/mod.rs"]
mod common;

use ori_package::{
    HierarchyManifest, HierarchyNode, SplitKind, TextureFormat, write, write_hierarchy,
};

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
    let mut packages = Vec::new();
    let save = |name: &str, bytes: &[u8]| {
        let path = std::path::Path::new(&dir).join(format!("seed-{name}.ori"));
        std::fs::write(&path, bytes).expect("write the seed");
        println!("{} ({} bytes)", path.display(), bytes.len());
    };
    for (name, manifest, n, depth) in seeds {
        let textures: Vec<_> = (0..n).map(|i| common::textures(4, i, depth)).collect();
        let bytes = write(&manifest, &textures).expect("a valid seed package");
        save(name, &bytes);
        packages.push((manifest.source.clone(), bytes));
    }
    // A version-2 hierarchy: a root and one child, the two packages above as their nodes.
    let tree = HierarchyManifest {
        format_version: ori_package::HIERARCHY_FORMAT_VERSION,
        tool: "ori-package seed".into(),
        source: packages[0].0.clone(),
        split: SplitKind::Octree,
        target_px: 256.0,
        nodes: vec![
            HierarchyNode::new([[0.0; 3], [1.0; 3]], vec![1]),
            HierarchyNode::new([[0.0; 3], [0.5; 3]], vec![]),
        ],
    };
    let nodes: Vec<Vec<u8>> = packages.into_iter().map(|(_, b)| b).collect();
    save(
        "hierarchy-2",
        &write_hierarchy(&tree, &nodes).expect("a valid seed hierarchy"),
    );
}
