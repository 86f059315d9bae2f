//! A part of a larger model (a hierarchy node: the model clipped to a box) is measured in its
//! own pixels: those where the whole model's nearest surface lies inside the box. Elsewhere the
//! rest of the model is in front (a neighbouring node draws there), and what the part shows
//! through its cuts (the model's inside) is never seen.

use ori_mesh::Mesh;
use ori_raster::OrthoView;

use crate::Mask;
use crate::coverage::{CoverageMesh, heights};
use crate::reference::AlphaCut;

/// The model a part was clipped from, and the box it was clipped to (`[min, max]`).
#[derive(Clone, Copy, Debug)]
pub struct Whole<'a> {
    pub mesh: &'a Mesh,
    pub clip: [[f64; 3]; 2],
}

/// [`Whole`] with what drawing it needs.
pub(crate) struct WholeModel<'a> {
    mesh: CoverageMesh,
    /// The clip box grown by a millionth of its edge: points on its faces belong to the part
    /// (its mesh was cut there).
    own: [[f64; 3]; 2],
    alpha: Option<AlphaCut<'a>>,
}

impl<'a> WholeModel<'a> {
    pub fn new(whole: Whole<'a>) -> WholeModel<'a> {
        let [lo, hi] = whole.clip;
        let slack = 1e-6 * (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        WholeModel {
            mesh: CoverageMesh::new(whole.mesh, &whole.mesh.single_sided()),
            own: [lo.map(|c| c - slack), hi.map(|c| c + slack)],
            alpha: AlphaCut::new(whole.mesh),
        }
    }

    /// The pixels of `part` where the whole model's nearest surface lies outside the box.
    pub fn in_front(&self, view: &OrthoView, part: &Mask) -> Mask {
        let n = view.size as usize;
        let mut out = Mask::new(view.size);
        // The part's pixels are all the whole model's heights are needed at.
        let Some(window) = part.bounds() else {
            return out;
        };
        let height = heights(view, &self.mesh, self.alpha.as_ref(), window);
        let [lo, hi] = self.own;
        let inside = |p: [f64; 3]| (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]);
        for i in part.ones() {
            if height[i] == f64::NEG_INFINITY {
                continue;
            }
            let (x, y) = ((i % n) as f64 + 0.5, (i / n) as f64 + 0.5);
            if !inside(view.unproject(x, y, view.depth_of_height(height[i]))) {
                out.set(i);
            }
        }
        out
    }
}
