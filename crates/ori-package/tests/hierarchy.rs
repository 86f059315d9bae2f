//! Hierarchy packages (format version 2): round trip, the tree's rules, damage detection.

mod common;

use common::sample;
use ori_package::{
    ALIGN, AnyPackage, HierarchyManifest, HierarchyNode, PackageError, SplitKind, read, read_any,
    read_hierarchy, write, write_hierarchy,
};

/// A root and two children, each with a (different) package of the sample's source.
fn tree() -> (HierarchyManifest, Vec<Vec<u8>>) {
    let packages: Vec<Vec<u8>> = (1..=3)
        .map(|n| {
            let (m, t) = sample(n, ori_package::TextureFormat::R8);
            write(&m, &t).unwrap()
        })
        .collect();
    let source = read(&packages[0]).unwrap().manifest.source;
    let manifest = HierarchyManifest {
        format_version: 2,
        tool: "ori-package tests".into(),
        source,
        split: SplitKind::Kd,
        target_px: 512.0,
        nodes: vec![
            HierarchyNode::new([[0.0; 3], [2.0, 1.0, 1.0]], vec![1, 2]),
            HierarchyNode::new([[0.0; 3], [1.0, 1.0, 1.0]], vec![]),
            HierarchyNode::new([[1.0, 0.0, 0.0], [2.0, 1.0, 1.0]], vec![]),
        ],
    };
    (manifest, packages)
}

#[test]
fn round_trip_keeps_every_node_package() {
    let (m, packages) = tree();
    let bytes = write_hierarchy(&m, &packages).unwrap();
    assert_eq!(
        write_hierarchy(&m, &packages).unwrap(),
        bytes,
        "deterministic"
    );
    let h = read_hierarchy(&bytes).unwrap();
    assert_eq!(h.nodes.len(), 3);
    for (i, node) in h.manifest.nodes.iter().enumerate() {
        let r = &node.package;
        assert_eq!(r.offset % ALIGN, 0);
        let slice = &bytes[r.offset as usize..(r.offset + r.length) as usize];
        assert_eq!(slice, &packages[i][..]);
        assert_eq!(h.nodes[i], read(&packages[i]).unwrap());
    }
    assert!(matches!(read(&bytes), Err(PackageError::IsHierarchy)));
    assert!(matches!(read_any(&bytes), Ok(AnyPackage::Hierarchy(_))));
    assert!(matches!(read_any(&packages[0]), Ok(AnyPackage::Single(_))));
}

#[test]
fn trees_that_break_the_rules_are_refused() {
    let (m, packages) = tree();
    let refused = |edit: &dyn Fn(&mut HierarchyManifest), want: &str| {
        let mut bad = m.clone();
        edit(&mut bad);
        let e = write_hierarchy(&bad, &packages).unwrap_err().to_string();
        assert!(e.contains(want), "{want:?} not in {e:?}");
    };
    refused(&|t| t.nodes[0].children = vec![1], "node 2 has no parent");
    refused(&|t| t.nodes[1].children = vec![0], "out of order");
    refused(&|t| t.nodes[2].bounds[1][0] = 3.0, "leave its parent");
    refused(&|t| t.nodes[1].bounds[0][1] = 2.0, "not a box");
    refused(&|t| t.nodes[1].bounds[0][1] = f64::NAN, "JSON");
    refused(&|t| t.target_px = 0.0, "target_px");
    refused(&|t| t.source.name = "other.obj".into(), "names source");
    let mut short = m.clone();
    short.nodes.pop();
    assert!(write_hierarchy(&short, &packages).is_err());
}

#[test]
fn a_damaged_node_is_named() {
    let (m, packages) = tree();
    let bytes = write_hierarchy(&m, &packages).unwrap();
    let h = read_hierarchy(&bytes).unwrap();
    let r = &h.manifest.nodes[2].package;
    let mut bad = bytes.clone();
    bad[(r.offset + r.length / 2) as usize] ^= 1;
    let e = read_hierarchy(&bad).unwrap_err().to_string();
    assert!(e.contains("node 2 package is corrupt"), "{e}");
    // Cut short, or with bytes after the last node.
    assert!(read_hierarchy(&bytes[..bytes.len() - 1]).is_err());
    let mut long = bytes.clone();
    long.push(0);
    assert!(
        read_hierarchy(&long)
            .unwrap_err()
            .to_string()
            .contains("trailing")
    );
}

#[test]
fn mutated_hierarchies_never_panic() {
    let (m, packages) = tree();
    let bytes = write_hierarchy(&m, &packages).unwrap();
    let mut rng = common::XorShift(0x9e37_79b9_7f4a_7c15);
    for _ in 0..300 {
        let mut b = bytes.clone();
        for _ in 0..1 + rng.below(4) {
            let at = rng.below(b.len() as u64) as usize;
            b[at] = rng.next() as u8;
        }
        let cut = b.len() - rng.below(64) as usize;
        let _ = read_any(&b[..cut]);
        let _ = read_any(&b);
    }
}
