//! Hierarchical ORIs (ORI paper, section 5). A single ORI is valid only up to its PLT; a
//! large model or scene is cut into a tree of cells, each carrying the ORI of the part of the
//! model inside it, and the runtime draws each part at the coarsest node that is still within
//! its PLT.
//!
//! - [`Cell`], [`Cell::bounding_cube`], [`split`] (octree, or kd at the median), [`Cell::inflated`]:
//!   what the build uses to cut the model (`ori_mesh::clip_to_box` does the cutting).
//! - [`traverse`]: the runtime rule, pre-order: a node whose ORI fits (PLT >= the projected
//!   size of its bounding sphere, `ori_plt::fits`) is drawn as that ORI; otherwise its
//!   children are visited; a leaf that does not fit is drawn as its mesh (the mixed
//!   representation of the relief-texture papers).
//!
//! # Invariants
//!
//! - Splits are exact partitions: children's cells tile the parent's cell (shared faces
//!   only), computed with `+ - * /` on `f64`, so the same on every machine.
//! - Traversal draws every part of the object exactly once: each root-to-leaf path holds
//!   exactly one drawn node (an ORI or a leaf mesh), and every ORI drawn fits.

#![warn(missing_docs)]

use ori_package::{HierarchyManifest, Manifest, SplitKind};

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Least corner.
    pub min: [f64; 3],
    /// Greatest corner.
    pub max: [f64; 3],
}

impl Cell {
    /// The cube centred on the bounding box of `points`, with its longest edge: the root cell
    /// of a hierarchy. `None` without points.
    pub fn bounding_cube(points: &[[f32; 3]]) -> Option<Cell> {
        let first = points.first()?.map(f64::from);
        let (mut lo, mut hi) = (first, first);
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(f64::from(p[k]));
                hi[k] = hi[k].max(f64::from(p[k]));
            }
        }
        let edge = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let half = edge / 2.0;
        let center: [f64; 3] = std::array::from_fn(|k| (lo[k] + hi[k]) / 2.0);
        Some(Cell {
            min: center.map(|c| c - half),
            max: center.map(|c| c + half),
        })
    }

    /// The longest edge.
    pub fn edge(&self) -> f64 {
        (0..3)
            .map(|k| self.max[k] - self.min[k])
            .fold(0.0, f64::max)
    }

    /// The cell grown by `by` on every side.
    pub fn inflated(&self, by: f64) -> Cell {
        Cell {
            min: self.min.map(|x| x - by),
            max: self.max.map(|x| x + by),
        }
    }

    /// `[min, max]`, as a package stores it.
    pub fn bounds(&self) -> [[f64; 3]; 2] {
        [self.min, self.max]
    }

    /// Whether `p` is inside (boundary included).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|k| p[k] >= self.min[k] && p[k] <= self.max[k])
    }
}

/// The children of `cell`: eight octants ([`SplitKind::Octree`]), or two halves across the
/// longest edge ([`SplitKind::Kd`], lowest axis on ties) at the median of the coordinates of
/// the `vertices` inside the cell along it (the midpoint when the median would leave a half
/// empty or the cell has no vertex). In a fixed order: octant bits x, y, z from least to most
/// significant; kd low half first.
pub fn split(cell: &Cell, kind: SplitKind, vertices: &[[f32; 3]]) -> Vec<Cell> {
    let mid: [f64; 3] = std::array::from_fn(|k| (cell.min[k] + cell.max[k]) / 2.0);
    match kind {
        SplitKind::Octree => (0..8)
            .map(|bits| {
                let mut c = *cell;
                for (k, &m) in mid.iter().enumerate() {
                    if bits >> k & 1 == 0 {
                        c.max[k] = m;
                    } else {
                        c.min[k] = m;
                    }
                }
                c
            })
            .collect(),
        SplitKind::Kd => {
            let axis = (0..3)
                .max_by(|&a, &b| {
                    let (ea, eb) = (cell.max[a] - cell.min[a], cell.max[b] - cell.min[b]);
                    ea.total_cmp(&eb).then(b.cmp(&a))
                })
                .unwrap_or(0);
            let mut coords: Vec<f64> = vertices
                .iter()
                .map(|p| p.map(f64::from))
                .filter(|&p| cell.contains(p))
                .map(|p| p[axis])
                .collect();
            coords.sort_by(f64::total_cmp);
            let at = match coords.get(coords.len() / 2) {
                Some(&m) if m > cell.min[axis] && m < cell.max[axis] => m,
                _ => mid[axis],
            };
            let (mut low, mut high) = (*cell, *cell);
            low.max[axis] = at;
            high.min[axis] = at;
            vec![low, high]
        }
    }
}

/// What the runtime draws for one node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visit {
    /// The node's ORI (its package, `ori_package::Hierarchy::nodes[i]`).
    Ori(usize),
    /// The node's part of the mesh (a leaf whose ORI is too coarse for its projected size):
    /// the model clipped to the node's cell.
    Mesh(usize),
}

impl Visit {
    /// The node visited.
    pub fn node(self) -> usize {
        match self {
            Visit::Ori(i) | Visit::Mesh(i) => i,
        }
    }
}

/// Whether an ORI (its package's manifest) may be drawn: `ori_plt::fits` with the projected
/// size of its bounding sphere (`projected_edge(center, radius)`, `None` when the sphere
/// reaches the camera: too large).
pub fn ori_fits(
    manifest: &Manifest,
    projected_edge: &dyn Fn([f64; 3], f64) -> Option<f64>,
) -> bool {
    let plt = ori_plt::Plt {
        s0: manifest.plt.s0,
        gc: manifest.plt.gc,
        worst_direction: None,
    };
    let sphere = &manifest.bounding_sphere;
    projected_edge(sphere.center, sphere.radius).is_some_and(|px| ori_plt::fits(&plt, px))
}

/// The runtime traversal, pre-order from the root: a node that fits ([`ori_fits`]) is drawn
/// as its ORI; otherwise its children are visited in order; a leaf that does not fit is drawn
/// as its mesh. `node(i)` is node `i`'s package manifest; `projected_edge(center, radius)`
/// the edge in pixels of the square bounding the sphere's projection
/// (`ori_plt::sphere_projected_edge` for a perspective camera, `ori_plt::ortho_sphere_edge`
/// for an orthographic one), `None` when unbounded.
pub fn traverse<'m>(
    tree: &HierarchyManifest,
    node: impl Fn(usize) -> &'m Manifest,
    projected_edge: &dyn Fn([f64; 3], f64) -> Option<f64>,
) -> Vec<Visit> {
    let mut out = Vec::new();
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let children = &tree.nodes[i].children;
        if ori_fits(node(i), projected_edge) {
            out.push(Visit::Ori(i));
        } else if children.is_empty() {
            out.push(Visit::Mesh(i));
        } else {
            stack.extend(children.iter().rev().map(|&c| c as usize));
        }
    }
    out
}

/// The range of a tree: the largest on-screen size of the root (the projected edge of its
/// bounding sphere, in pixels, orthographic camera) at which [`traverse`] draws no leaf mesh.
/// `node(i)` is node `i`'s (PLT in pixels, bounding-sphere radius). Under an orthographic
/// camera a node's projected size is the root's times `radius / root radius`, so node `i`
/// fits up to a root size of `plt * root radius / radius`, and a node draws no leaf mesh up to
/// the larger of that and the smallest such size among its children.
pub fn leafless_size(tree: &HierarchyManifest, node: impl Fn(usize) -> (f64, f64)) -> f64 {
    let root_radius = node(0).1;
    let mut size = vec![0.0; tree.nodes.len()];
    // Children come after their parent: from the last node back, a node's children are done.
    for i in (0..tree.nodes.len()).rev() {
        let (plt, radius) = node(i);
        let own = plt * root_radius / radius;
        let children = tree.nodes[i].children.iter().map(|&c| size[c as usize]);
        size[i] = children.reduce(f64::min).map_or(own, |c: f64| c.max(own));
    }
    size[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn volume(c: &Cell) -> f64 {
        (0..3).map(|k| c.max[k] - c.min[k]).product()
    }

    #[test]
    fn octants_and_kd_halves_tile_the_cell() {
        let cube = Cell::bounding_cube(&[[0.0, 0.0, 0.0], [2.0, 1.0, 0.5]]).unwrap();
        assert_eq!(cube.min, [0.0, -0.5, -0.75]);
        assert_eq!(cube.edge(), 2.0);
        let octants = split(&cube, SplitKind::Octree, &[]);
        assert_eq!(octants.len(), 8);
        assert_eq!(octants.iter().map(volume).sum::<f64>(), volume(&cube));
        assert_eq!(octants[5].min, [1.0, -0.5, 0.25]);
        // kd: vertices bunched at x < 0.5 move the cut there.
        let verts = [
            [0.1, 0.0, 0.0],
            [0.2, 0.0, 0.0],
            [0.3, 0.0, 0.0],
            [1.9, 0.0, 0.0],
        ];
        let halves = split(&cube, SplitKind::Kd, &verts);
        assert_eq!(halves[0].max[0], f64::from(0.3f32));
        assert_eq!(halves[1].min[0], halves[0].max[0]);
        assert_eq!(volume(&halves[0]) + volume(&halves[1]), volume(&cube));
        // No vertex: the midpoint.
        assert_eq!(split(&cube, SplitKind::Kd, &[])[0].max[0], 1.0);
    }

    #[test]
    fn leafless_size_is_where_the_first_leaf_mesh_appears() {
        let unit = [[0.0; 3], [1.0; 3]];
        // Root 0 (PLT 300, radius 2) -> 1 (inner: PLT 100, radius 1) and 2 (leaf: PLT 200,
        // radius 1); 1 -> leaves 3 (PLT 150, radius 0.5) and 4 (PLT 400, radius 0.5).
        let children = [vec![1, 2], vec![3, 4], vec![], vec![], vec![]];
        let tree = HierarchyManifest {
            format_version: ori_package::HIERARCHY_FORMAT_VERSION,
            tool: "test".into(),
            source: ori_package::Source {
                name: "m.obj".into(),
                blake3: "0".repeat(64),
            },
            split: SplitKind::Kd,
            target_px: 256.0,
            nodes: children
                .into_iter()
                .map(|c| ori_package::HierarchyNode::new(unit, c))
                .collect(),
        };
        let nodes = [
            (300.0, 2.0),
            (100.0, 1.0),
            (200.0, 1.0),
            (150.0, 0.5),
            (400.0, 0.5),
        ];
        // Node 1 fits up to a root size of 200; its leaves up to 600 and 1600, so node 1's
        // part holds to 600, node 2 to 400: the root's range is 400 (node 2's mesh next).
        assert_eq!(leafless_size(&tree, |i| nodes[i]), 400.0);
        // A root that fits further than its children: its own PLT.
        let nodes = [
            (900.0, 2.0),
            (100.0, 1.0),
            (200.0, 1.0),
            (150.0, 0.5),
            (400.0, 0.5),
        ];
        assert_eq!(leafless_size(&tree, |i| nodes[i]), 900.0);
    }
}
