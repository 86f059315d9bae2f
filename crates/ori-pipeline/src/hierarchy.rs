//! Hierarchical ORIs (`[hierarchy]`, ORI paper section 5): the shape of a tree and the steps
//! of the search that decides it by measuring node PLTs through the graph (`search.rs`); the
//! clip and hierarchy stages are in `stages/`.
//!
//! A tree starts as its root: the asset's ordinary chain (so a hierarchy whose root already
//! reaches the target costs nothing more than a single ORI). A node whose PLT is below
//! `target_px` and above `max_depth` is split (`ori_hierarchy::split`); each child's mesh is
//! the model clipped (`ori_mesh::clip_to_box`) to the child's cell grown by `inflate` of the
//! parent's edge; empty children are dropped; every other child gets its own chain (views,
//! bake, select, plt, compress, package), each job cached under its own key, so an edit that
//! changes only some cells' meshes rebuilds only those nodes' chains and the hierarchy job.

use ori_hierarchy::Cell;
use ori_package::SplitKind;
use serde::{Deserialize, Serialize};

/// `[hierarchy]`: build a tree of ORIs instead of one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HierarchyParams {
    /// Build a hierarchy (off by default: one ORI per asset).
    pub enabled: bool,
    /// "octree" (eight octants) or "kd" (two halves at the median vertex).
    pub split: SplitKind,
    /// Deepest level; the root is level 0 (0 to 4).
    pub max_depth: u32,
    /// A node whose PLT reaches this many pixels is not split.
    pub target_px: f64,
    /// A child's mesh is clipped to its cell grown by this fraction of the parent's edge.
    pub inflate: f64,
    /// A node at depth `d` is selected and placed with the asset's coverage-error goals times
    /// `goal_scale^d` (0.05 to 1).
    pub goal_scale: f64,
}

impl Default for HierarchyParams {
    fn default() -> Self {
        HierarchyParams {
            enabled: false,
            split: SplitKind::Octree,
            max_depth: 2,
            target_px: 256.0,
            inflate: 0.01,
            goal_scale: 0.5,
        }
    }
}

impl HierarchyParams {
    /// Check the values; the message names the key at fault.
    pub fn validate(&self) -> Result<(), String> {
        if self.max_depth > 4 {
            return Err(format!(
                "hierarchy.max_depth = {}: expected 0 to 4 (a depth-4 octree has up to 4,681 nodes)",
                self.max_depth
            ));
        }
        if !(self.target_px.is_finite() && self.target_px >= 1.0 && self.target_px <= 1e6) {
            return Err(format!(
                "hierarchy.target_px = {}: expected 1 to 1000000 pixels",
                self.target_px
            ));
        }
        if !(self.inflate.is_finite() && (0.0..=0.25).contains(&self.inflate)) {
            return Err(format!(
                "hierarchy.inflate = {}: expected 0 to 0.25 (a fraction of the parent's edge)",
                self.inflate
            ));
        }
        if !(self.goal_scale.is_finite() && (0.05..=1.0).contains(&self.goal_scale)) {
            return Err(format!(
                "hierarchy.goal_scale = {}: expected 0.05 to 1",
                self.goal_scale
            ));
        }
        Ok(())
    }

    /// The selection parameters of a node at `depth`: the asset's, with both coverage-error
    /// goals scaled by `goal_scale^depth`. The traversal draws a node only where the object is
    /// larger than its parent fits, and children held to their parent's goals measure below
    /// it in their own pixels, which ends the range where the parent's ends.
    pub fn node_select(
        &self,
        select: &ori_select::SelectParams,
        depth: u32,
    ) -> ori_select::SelectParams {
        let scale = (0..depth).fold(1.0, |s, _| s * self.goal_scale);
        ori_select::SelectParams {
            goal_percent: select.goal_percent * scale,
            edge_goal_percent: select.edge_goal_percent * scale,
            ..select.clone()
        }
    }

    /// The placement parameters of a node at `depth`: the asset's for the root; below it,
    /// every view must be drawable within the node's (scaled) goals, times `[place]
    /// goal_scale`, with all `most_drawn` (the rule's `M`) closest impostors rather than
    /// `[place] closest`. The scaled goals are often out of the closest few's reach, and
    /// placing for fewer than `M` leaves those views to the selection, which cannot move
    /// impostors.
    pub fn node_place(
        &self,
        place: &ori_place::PlaceParams,
        most_drawn: u32,
        depth: u32,
    ) -> ori_place::PlaceParams {
        if depth == 0 {
            return place.clone();
        }
        ori_place::PlaceParams {
            closest: most_drawn.clamp(1, ori_place::MAX_CLOSEST),
            ..place.clone()
        }
    }
}

/// One node of a decided tree.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedNode {
    /// The node's cell.
    pub cell: Cell,
    /// The box its mesh is clipped to (the cell, inflated); `None` for the root, whose mesh is
    /// the whole model.
    pub clip: Option<Cell>,
    /// Level: 0 for the root.
    pub depth: u32,
    /// Child node indices (greater than this node's).
    pub children: Vec<usize>,
}

/// A decided tree: node 0 is the root; children come after their parent (breadth first).
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedTree {
    pub nodes: Vec<PlannedNode>,
}

/// What the tree search needs measured for one node.
pub struct Measured {
    pub plt_px: f64,
    /// The node mesh's vertices, kept only for a kd split (its median).
    pub vertices: Vec<[f32; 3]>,
}

/// The next step of one tree's search: the cells to clip for the children of every node from
/// `from` on (the nodes measured last round) that needs splitting, as (parent, child cell,
/// clip box). `measured[i]` is `None` when node `i`'s chain failed: it is not split.
pub fn children_to_try(
    params: &HierarchyParams,
    tree: &PlannedTree,
    measured: &[Option<Measured>],
    from: usize,
) -> Vec<(usize, Cell, Cell)> {
    let mut out = Vec::new();
    for (i, node) in tree.nodes.iter().enumerate().skip(from) {
        let Some(m) = &measured[i] else { continue };
        if m.plt_px >= params.target_px || node.depth >= params.max_depth {
            continue;
        }
        let grow = params.inflate * node.cell.edge();
        for child in ori_hierarchy::split(&node.cell, params.split, &m.vertices) {
            out.push((i, child, child.inflated(grow)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_goals_scale_with_depth_and_the_root_keeps_the_assets() {
        let params = HierarchyParams::default();
        let select = ori_select::SelectParams::default();
        assert_eq!(params.node_select(&select, 0), select);
        let deep = params.node_select(&select, 2);
        assert_eq!(deep.goal_percent, select.goal_percent * 0.25);
        assert_eq!(deep.edge_goal_percent, select.edge_goal_percent * 0.25);
        assert_eq!((deep.rule, deep.s0), (select.rule, select.s0));
        assert!(deep.validate().is_ok());
        let place = ori_place::PlaceParams::default();
        assert_eq!(params.node_place(&place, 8, 0), place);
        assert_eq!(params.node_place(&place, 8, 1).closest, 8);
        assert_eq!(params.node_place(&place, 8, 1).max_moves, place.max_moves);
        // `closest:255` draws more than placement measures (at most 16).
        assert_eq!(params.node_place(&place, 255, 2).closest, 16);
        for bad in [0.0, 0.01, 1.5, f64::NAN] {
            let e = HierarchyParams {
                goal_scale: bad,
                ..params.clone()
            }
            .validate()
            .unwrap_err();
            assert!(e.contains("hierarchy.goal_scale"), "{e}");
        }
    }
}
