//! A part of a larger model (a hierarchy node: the model clipped to a box) is measured in its
//! own pixels: those where the whole model's nearest surface lies inside the box. Elsewhere the
//! rest of the model is in front (a neighbouring node draws there), and what the part shows
//! through its cuts (the model's inside) is never seen.

use ori_mesh::Mesh;
use ori_raster::{EMPTY, OrthoView};

use crate::Mask;
use crate::reference::{AlphaCut, raster};

/// The model a part was clipped from, and the box it was clipped to (`[min, max]`).
#[derive(Clone, Copy, Debug)]
pub struct Whole<'a> {
    pub mesh: &'a Mesh,
    pub clip: [[f64; 3]; 2],
}

/// [`Whole`] with what drawing it needs.
pub(crate) struct WholeModel<'a> {
    mesh: &'a Mesh,
    /// The clip box grown by a millionth of its edge: points on its faces belong to the part
    /// (its mesh was cut there).
    own: [[f64; 3]; 2],
    alpha: Option<AlphaCut<'a>>,
    single_sided: Vec<bool>,
}

impl<'a> WholeModel<'a> {
    pub fn new(whole: Whole<'a>) -> WholeModel<'a> {
        let [lo, hi] = whole.clip;
        let slack = 1e-6 * (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        WholeModel {
            mesh: whole.mesh,
            own: [lo.map(|c| c - slack), hi.map(|c| c + slack)],
            alpha: AlphaCut::new(whole.mesh),
            single_sided: whole.mesh.single_sided(),
        }
    }

    /// The pixels of `part` where the whole model's nearest surface lies outside the box.
    pub fn in_front(&self, view: &OrthoView, part: &Mask) -> Mask {
        let r = raster(self.mesh, self.alpha.as_ref(), &self.single_sided, view);
        let [lo, hi] = self.own;
        let inside = |p: [f64; 3]| (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]);
        let n = view.size as usize;
        let mut out = Mask::new(view.size);
        for i in part.ones() {
            if r.tri[i] == EMPTY {
                continue;
            }
            let (x, y) = ((i % n) as f64 + 0.5, (i / n) as f64 + 0.5);
            if !inside(view.unproject(x, y, view.depth_of_height(r.height[i]))) {
                out.set(i);
            }
        }
        out
    }
}
