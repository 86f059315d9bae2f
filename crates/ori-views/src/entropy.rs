//! Viewpoint entropy (Vázquez, Feixas, Sbert, Heidrich 2003) from an orthographic item buffer.

use ori_mesh::Mesh;
use ori_raster::{Frame, OrthoView, rasterize};

use crate::ViewError;
use crate::directions::{dot, sub};

/// The sphere every item buffer is framed on: the centre of the axis-aligned bounds and the
/// largest distance from it to a vertex. Not the smallest enclosing sphere, but it does not
/// depend on the direction, which is what makes entropies of different directions comparable.
#[derive(Clone, Copy, Debug)]
pub struct BoundingSphere {
    pub center: [f64; 3],
    pub radius: f64,
}

impl BoundingSphere {
    pub fn of(mesh: &Mesh) -> Result<BoundingSphere, ViewError> {
        let (lo, hi) = mesh.bounds();
        let center: [f64; 3] = std::array::from_fn(|k| 0.5 * (f64::from(lo[k]) + f64::from(hi[k])));
        let r2 = mesh
            .positions
            .iter()
            .map(|p| {
                let d = sub(p.map(f64::from), center);
                dot(d, d)
            })
            .fold(0.0, f64::max);
        let radius = r2.sqrt();
        // Far below f32 resolution of any real model; also catches an empty mesh (radius 0).
        if !(radius.is_finite() && radius > 1e-30) {
            return Err(ViewError::Mesh(format!(
                "the mesh has no extent to look at (bounding radius {radius})"
            )));
        }
        Ok(BoundingSphere { center, radius })
    }

    /// The item-buffer view along `direction`: the square window circumscribing the sphere's
    /// projection, so every direction sees the object at the same scale and the background
    /// term means the same thing for all of them.
    pub fn view(&self, direction: [f64; 3], size: u32) -> OrthoView {
        let frame = Frame::from_direction(direction);
        let c = frame.to_local(self.center);
        OrthoView {
            frame,
            center: [c[0], c[1]],
            half_size: self.radius,
            near: c[2] + self.radius,
            far: c[2] - self.radius,
            size,
        }
    }
}

/// Viewpoint entropy of `mesh` seen along `direction` (towards the viewer), from a
/// `size` x `size` item buffer framed on the mesh's bounding sphere.
///
/// `H = -sum_i (A_i / A_t) log2(A_i / A_t)` over the triangles visible in the item buffer and
/// the background (`A_0`), with `A_i` the pixel count of face `i` and `A_t = size^2`. Higher
/// means more faces seen in more even proportions. Geometry only: alpha-tested holes are not
/// cut, a hole changes which faces are seen but hardly how many. Uses the portable `log2`, so
/// the value is bit-identical on every machine. `size` is 1 to 4096.
pub fn viewpoint_entropy(mesh: &Mesh, direction: [f64; 3], size: u32) -> Result<f64, ViewError> {
    if !(1..=4096).contains(&size) {
        return Err(ViewError::Params(format!(
            "item buffer size {size} is out of range (1 to 4096 pixels)"
        )));
    }
    let sphere = BoundingSphere::of(mesh)?;
    Ok(entropy_in(mesh, &sphere, direction, size))
}

pub(crate) fn entropy_in(
    mesh: &Mesh,
    sphere: &BoundingSphere,
    direction: [f64; 3],
    size: u32,
) -> f64 {
    let view = sphere.view(direction, size);
    let raster = rasterize(&view, &mesh.positions, &mesh.triangles, None, None);
    entropy_of_item_buffer(raster.tri)
}

/// Entropy of the distribution of pixels over item ids (the background,
/// [`ori_raster::EMPTY`], is one more id). Written as `log2 A_t - (1 / A_t) sum_i A_i log2 A_i`
/// and summed over the distinct counts in increasing order, so it takes one logarithm per
/// distinct count and the summation order is fixed.
pub(crate) fn entropy_of_item_buffer(mut ids: Vec<u32>) -> f64 {
    let total = ids.len();
    if total == 0 {
        return 0.0;
    }
    ids.sort_unstable();
    let mut counts: Vec<u32> = ids
        .chunk_by(|a, b| a == b)
        .map(|run| run.len() as u32)
        .collect();
    counts.sort_unstable();
    let mut sum = 0.0;
    for run in counts.chunk_by(|a, b| a == b) {
        let c = run[0];
        // Counts of 1 add 1 log2 1 = 0.
        if c > 1 {
            sum += (run.len() as f64 * f64::from(c)) * ori_math::log2(f64::from(c));
        }
    }
    let total = total as f64;
    // Rounding may leave -1 ulp for an image of one id.
    (ori_math::log2(total) - sum / total).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ori_raster::EMPTY;

    #[test]
    fn entropy_of_known_distributions() {
        assert_eq!(entropy_of_item_buffer(vec![7; 16]), 0.0);
        assert!((entropy_of_item_buffer(vec![1, 2, 3, 4]) - 2.0).abs() < 1e-15);
        // p = (1/2, 1/4, 1/4): H = 1.5 bits.
        let h = entropy_of_item_buffer(vec![EMPTY, 5, EMPTY, 9]);
        assert!((h - 1.5).abs() < 1e-15, "{h}");
        assert_eq!(entropy_of_item_buffer(Vec::new()), 0.0);
    }
}
