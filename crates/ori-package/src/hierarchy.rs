//! Hierarchy packages (format version 2): a tree of cells over the object, each carrying a
//! complete single-ORI package (version 1) of the part of the model inside it (ORI paper,
//! section 5). Same header as version 1; the manifest describes the tree; the payload is the
//! node packages, each at the next aligned offset.

use serde::{Deserialize, Serialize};

use crate::layout::{assemble, check_packed, frame, place};
use crate::validate::{hash_hex, is_hash_hex};
use crate::{FORMAT_VERSION, HIERARCHY_FORMAT_VERSION, Package, PackageError, Source};

/// At most this many nodes (a depth-4 octree has 4,681).
pub const MAX_NODES: usize = 8192;

/// How cells are split.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SplitKind {
    /// Eight equal octants.
    Octree,
    /// Two halves across the cell's longest edge, at the median of the vertices inside.
    Kd,
}

/// The description of a hierarchy package; serialised as compact JSON in this field order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HierarchyManifest {
    /// Must equal [`HIERARCHY_FORMAT_VERSION`].
    pub format_version: u32,
    /// The program that wrote the package; non-empty.
    pub tool: String,
    /// The model; every node package names the same source.
    pub source: Source,
    /// How cells were split.
    pub split: SplitKind,
    /// The PLT (pixels) a node had to reach to stop being split.
    pub target_px: f64,
    /// The nodes: node 0 is the root; children come after their parent (the build writes
    /// them breadth first).
    pub nodes: Vec<HierarchyNode>,
}

/// One cell of the tree.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HierarchyNode {
    /// The cell, `[min, max]` in object space (before the inflation its mesh was clipped
    /// with); inside its parent's cell.
    pub bounds: [[f64; 3]; 2],
    /// Child node indices, each greater than this node's; empty for a leaf.
    pub children: Vec<u32>,
    /// Where this node's version-1 package lies in the file.
    pub package: PartRef,
}

impl HierarchyNode {
    /// A node whose package reference [`write_hierarchy`] fills.
    pub fn new(bounds: [[f64; 3]; 2], children: Vec<u32>) -> HierarchyNode {
        HierarchyNode {
            bounds,
            children,
            package: PartRef {
                offset: 0,
                length: 0,
                blake3: String::new(),
            },
        }
    }
}

/// A byte range of the file and its blake3.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartRef {
    /// From the start of the file; a multiple of [`crate::ALIGN`].
    pub offset: u64,
    /// In bytes.
    pub length: u64,
    /// 64 lowercase hex digits.
    pub blake3: String,
}

/// A hierarchy package as read: the tree and every node's package, all validated.
#[derive(Clone, Debug, PartialEq)]
pub struct Hierarchy {
    /// The tree, part references filled.
    pub manifest: HierarchyManifest,
    /// Node `i`'s package.
    pub nodes: Vec<Package>,
}

/// A package of either version, as [`read_any`] finds it.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyPackage {
    /// Version 1: one ORI.
    Single(Package),
    /// Version 2: a tree of ORIs.
    Hierarchy(Hierarchy),
}

impl AnyPackage {
    /// The package drawn for the whole object: the single ORI, or the hierarchy's root.
    pub fn root(&self) -> &Package {
        match self {
            AnyPackage::Single(p) => p,
            AnyPackage::Hierarchy(h) => &h.nodes[0],
        }
    }

    /// Bytes of texture data over every ORI it holds.
    pub fn texture_bytes(&self) -> u64 {
        match self {
            AnyPackage::Single(p) => p.texture_bytes(),
            AnyPackage::Hierarchy(h) => h.nodes.iter().map(Package::texture_bytes).sum(),
        }
    }
}

/// Reads a package of either version, with every check of [`crate::read`] or
/// [`read_hierarchy`].
pub fn read_any(bytes: &[u8]) -> Result<AnyPackage, PackageError> {
    match crate::read(bytes) {
        Err(PackageError::IsHierarchy) => read_hierarchy(bytes).map(AnyPackage::Hierarchy),
        other => other.map(AnyPackage::Single),
    }
}

fn manifest_json(m: &HierarchyManifest) -> Result<Vec<u8>, PackageError> {
    serde_json::to_vec(m).map_err(|e| PackageError::Manifest(e.to_string()))
}

/// Builds a hierarchy package from the tree and each node's version-1 package bytes (as
/// [`crate::write`] returns them). Every [`PartRef`] is filled here; the result goes through
/// [`read_hierarchy`]'s checks, so it always reads back. Deterministic.
pub fn write_hierarchy(
    manifest: &HierarchyManifest,
    node_packages: &[Vec<u8>],
) -> Result<Vec<u8>, PackageError> {
    if node_packages.len() != manifest.nodes.len() {
        return Err(PackageError::Manifest(format!(
            "{} nodes but {} node packages",
            manifest.nodes.len(),
            node_packages.len()
        )));
    }
    let mut m = manifest.clone();
    for (node, bytes) in m.nodes.iter_mut().zip(node_packages) {
        node.package.length = bytes.len() as u64;
        node.package.blake3 = hash_hex(bytes);
    }
    let lengths: Vec<u64> = m.nodes.iter().map(|n| n.package.length).collect();
    let (json, offsets, end) = place(&lengths, |offsets| {
        for (node, &offset) in m.nodes.iter_mut().zip(offsets) {
            node.package.offset = offset;
        }
        manifest_json(&m)
    })?;
    let parts = offsets
        .iter()
        .copied()
        .zip(node_packages.iter().map(Vec::as_slice));
    let bytes = assemble(HIERARCHY_FORMAT_VERSION, &json, parts, end)?;
    read_hierarchy(&bytes)?;
    Ok(bytes)
}

/// Reads a hierarchy package and checks everything: the header, the manifest (schema,
/// canonical form, the tree's rules), the layout of the node packages, each one's blake3, and
/// each node package with every check of [`crate::read`] (same source as the hierarchy).
/// Never panics, and never allocates more than a small multiple of `bytes.len()`.
pub fn read_hierarchy(bytes: &[u8]) -> Result<Hierarchy, PackageError> {
    let (version, json, payload) = frame(bytes)?;
    if version != HIERARCHY_FORMAT_VERSION {
        return Err(PackageError::Manifest(format!(
            "format version {version} is not a hierarchy (version {HIERARCHY_FORMAT_VERSION})"
        )));
    }
    let manifest: HierarchyManifest = serde_json::from_slice(json)
        .map_err(|e| PackageError::Manifest(format!("not valid hierarchy manifest JSON: {e}")))?;
    if manifest_json(&manifest)? != json {
        return Err(PackageError::Manifest(
            "not in canonical form (compact serde_json output, fields in schema order)".into(),
        ));
    }
    check_tree(&manifest).map_err(PackageError::Manifest)?;
    check_packed(
        bytes,
        payload,
        manifest.nodes.iter().enumerate().map(|(i, n)| {
            (
                format!("node {i} package"),
                n.package.offset,
                n.package.length,
            )
        }),
    )?;
    let mut nodes = Vec::with_capacity(manifest.nodes.len());
    for (i, node) in manifest.nodes.iter().enumerate() {
        let r = &node.package;
        // Within the file: checked by `check_packed`.
        let data = &bytes[r.offset as usize..(r.offset + r.length) as usize];
        if hash_hex(data) != r.blake3 {
            return Err(PackageError::Manifest(format!(
                "node {i} package is corrupt: its blake3 does not match the manifest"
            )));
        }
        let package = crate::read(data)
            .map_err(|e| PackageError::Manifest(format!("node {i} package: {e}")))?;
        if package.manifest.source != manifest.source {
            return Err(PackageError::Manifest(format!(
                "node {i} package names source {:?}, the hierarchy {:?}",
                package.manifest.source.name, manifest.source.name
            )));
        }
        nodes.push(package);
    }
    Ok(Hierarchy { manifest, nodes })
}

/// The manifest's own rules (everything but the node packages' bytes).
fn check_tree(m: &HierarchyManifest) -> Result<(), String> {
    if m.format_version != HIERARCHY_FORMAT_VERSION {
        return Err(format!(
            "format_version is {}, expected {HIERARCHY_FORMAT_VERSION}",
            m.format_version
        ));
    }
    if m.tool.is_empty() {
        return Err("tool is empty".into());
    }
    // `source` is checked through the nodes: each node package's is validated and must equal it.
    if !(m.target_px.is_finite() && m.target_px > 0.0) {
        return Err(format!("target_px {} is not positive", m.target_px));
    }
    if m.nodes.is_empty() || m.nodes.len() > MAX_NODES {
        return Err(format!(
            "{} nodes; a hierarchy has 1 to {MAX_NODES}",
            m.nodes.len()
        ));
    }
    let mut parent = vec![None; m.nodes.len()];
    for (i, node) in m.nodes.iter().enumerate() {
        let [lo, hi] = node.bounds;
        if !lo.iter().chain(&hi).all(|x| x.is_finite()) || (0..3).any(|k| lo[k] > hi[k]) {
            return Err(format!("node {i}: bounds {:?} are not a box", node.bounds));
        }
        if !is_hash_hex(&node.package.blake3) {
            return Err(format!("node {i}: package blake3 is not 64 lowercase hex"));
        }
        for &c in &node.children {
            let c = c as usize;
            if c <= i || c >= m.nodes.len() {
                return Err(format!(
                    "node {i}: child {c} out of order (children come after their parent, \
                     below {})",
                    m.nodes.len()
                ));
            }
            if parent[c].is_some() {
                return Err(format!("node {c} has two parents"));
            }
            parent[c] = Some(i);
            let [clo, chi] = m.nodes[c].bounds;
            if (0..3).any(|k| clo[k] < lo[k] || chi[k] > hi[k]) {
                return Err(format!("node {c}'s bounds leave its parent {i}'s"));
            }
        }
    }
    if let Some(orphan) = (1..m.nodes.len()).find(|&i| parent[i].is_none()) {
        return Err(format!("node {orphan} has no parent"));
    }
    Ok(())
}

// Version 1 must stay below version 2: `frame` accepts both, `read` tells them apart.
const _: () = assert!(FORMAT_VERSION < HIERARCHY_FORMAT_VERSION);
