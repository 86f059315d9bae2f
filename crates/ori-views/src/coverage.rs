//! How many impostors sample each part of the surface (the ORI paper's Figure 2).

use ori_mesh::Mesh;
use ori_raster::{Frame, OrthoView, rasterize};
use rayon::prelude::*;

use crate::directions::{cross, evaluation_directions, sub};

/// Which impostors see which triangles, and the share of the visible surface sampled by
/// 0, 1, 2, ... impostors.
#[derive(Clone, Debug, PartialEq)]
pub struct SamplingCoverage {
    /// Per triangle: how many of the given directions' views see it (the colour of the
    /// paper's Figure 2).
    pub counts: Vec<u32>,
    /// Per triangle: whether it is on the visible surface, i.e. seen from at least one of the
    /// 320 evaluation directions at the same resolution. Triangles inside the object or in
    /// closed cavities are not, and are left out of the histogram.
    pub visible: Vec<bool>,
    /// Share of the visible surface area sampled by exactly `k` impostors (`k` = 0 to 9), and
    /// by 10 or more (last bin). Sums to 1, or is all zero when no visible triangle has area.
    pub histogram: [f64; 11],
    /// Total area of the visible triangles (mesh units squared).
    pub visible_area: f64,
}

impl SamplingCoverage {
    /// Share of the visible area seen by at least `k` impostors (1 for `k` = 0; `k` > 10 is
    /// taken as 10).
    pub fn share_at_least(&self, k: usize) -> f64 {
        self.histogram[k.min(10)..].iter().sum()
    }
}

/// The Figure-2 measurement: for each triangle of `mesh`, the number of `directions` whose
/// impostor sees it, at `resolution` (the bake resolution, normally 256), and the histogram of
/// the visible area over those counts.
///
/// Each view is framed like an impostor, the square bounding the object's projection
/// ([`OrthoView::fit`] with no margin, the `GUIDE.md` evaluation viewport; a bake's few texels
/// of margin change the scale by about 1%). Triangles of scanned meshes are about a pixel or
/// smaller, so "covers a pixel centre" would miss most of them. Instead a triangle counts as
/// seen when one of four probe points (its centroid, and the points halfway from the centroid
/// to each corner, so a large triangle half hidden at its centroid still counts) passes a
/// depth test against the view's height buffer; for the centroid: take the four
/// pixel centres around the centroid (the 2 x 2 block whose square contains it); the centroid
/// is seen when it is no more than one pixel width (in world units) below the lowest surface
/// found at those centres, or when all four are empty. On a visible, locally flat surface the
/// lowest of the four is at or below the centroid (a linear function over a square takes its
/// minimum at a corner), so visible points pass at any slope; a point hidden behind another
/// surface fails. The tolerance absorbs curvature and rounding. Empty centres are left out
/// rather than taken as infinitely far, so a back face just behind an outline does not count
/// (on a sphere no face turned more than about 1 degree away is counted); the price is that a
/// front face within a pixel of the outline and closer than about 6 degrees to edge-on may be
/// missed, where an impostor samples it poorly anyway. Geometry only, like the entropy:
/// alpha-tested holes are not cut.
///
/// Views are rasterized in parallel; counts are integer sums, so the result does not depend
/// on the thread count. A view that cannot be framed (a degenerate mesh, `resolution` 0) sees
/// nothing.
pub fn sampling_coverage(
    mesh: &Mesh,
    directions: &[[f64; 3]],
    resolution: u32,
) -> SamplingCoverage {
    let visible = visible_surface(mesh, resolution);
    sampling_coverage_with_visible(mesh, directions, resolution, visible)
}

/// Which triangles are on the visible surface: seen (as in [`sampling_coverage`]) from at
/// least one of the 320 evaluation directions at `resolution`. Computing it once lets several
/// direction sets be compared with [`sampling_coverage_with_visible`].
pub fn visible_surface(mesh: &Mesh, resolution: u32) -> Vec<bool> {
    seen_counts(mesh, &evaluation_directions(), resolution)
        .into_iter()
        .map(|c| c > 0)
        .collect()
}

/// [`sampling_coverage`] with the visible surface given (from [`visible_surface`] at the same
/// resolution).
///
/// # Panics
/// When `visible` does not have one flag per triangle.
pub fn sampling_coverage_with_visible(
    mesh: &Mesh,
    directions: &[[f64; 3]],
    resolution: u32,
    visible: Vec<bool>,
) -> SamplingCoverage {
    assert_eq!(
        visible.len(),
        mesh.triangles.len(),
        "one visibility flag per triangle"
    );
    let counts = seen_counts(mesh, directions, resolution);
    let mut area_per_bin = [0.0f64; 11];
    let mut visible_area = 0.0;
    // Sequential, in triangle order: a fixed summation order.
    for ((tri, &count), _) in mesh
        .triangles
        .iter()
        .zip(&counts)
        .zip(&visible)
        .filter(|(_, v)| **v)
    {
        let [a, b, c] = tri.map(|i| mesh.positions[i as usize].map(f64::from));
        let n = cross(sub(b, a), sub(c, a));
        let area = 0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        area_per_bin[(count as usize).min(10)] += area;
        visible_area += area;
    }
    let histogram = if visible_area > 0.0 {
        area_per_bin.map(|a| a / visible_area)
    } else {
        [0.0; 11]
    };
    SamplingCoverage {
        counts,
        visible,
        histogram,
        visible_area,
    }
}

/// Per triangle, the number of `directions` whose view sees it (its centroid, or one of the
/// points halfway from the centroid to a corner: a wide triangle whose centroid alone is
/// hidden, behind the seed of a cut avocado say, is still seen).
fn seen_counts(mesh: &Mesh, directions: &[[f64; 3]], resolution: u32) -> Vec<u32> {
    let probes: Vec<[[f64; 3]; 4]> = mesh
        .triangles
        .iter()
        .map(|tri| {
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize].map(f64::from));
            let g: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
            let half = |p: [f64; 3]| std::array::from_fn(|k| 0.5 * (g[k] + p[k]));
            [g, half(a), half(b), half(c)]
        })
        .collect();
    let zeros = || vec![0u32; mesh.triangles.len()];
    directions
        .par_iter()
        .fold(zeros, |mut counts, &d| {
            if let Ok(view) =
                OrthoView::fit(Frame::from_direction(d), &mesh.positions, resolution, 0)
            {
                add_seen(mesh, &probes, &view, &mut counts);
            }
            counts
        })
        .reduce(zeros, |mut a, b| {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
            a
        })
}

/// Add 1 to the count of every triangle `view` sees at one of its probe points (the test is
/// described at [`sampling_coverage`]).
fn add_seen(mesh: &Mesh, probes: &[[[f64; 3]; 4]], view: &OrthoView, counts: &mut [u32]) {
    let raster = rasterize(view, &mesh.positions, &mesh.triangles, None, None);
    let n = view.size as i64;
    let tolerance = 2.0 * view.half_size / f64::from(view.size);
    let height = |x: i64, y: i64| {
        if (0..n).contains(&x) && (0..n).contains(&y) {
            raster.height[(y * n + x) as usize]
        } else {
            f64::NEG_INFINITY
        }
    };
    let seen = |c: [f64; 3]| {
        let [x, y, h] = view.project(c);
        // The pixel centres (i + 0.5, j + 0.5) around (x, y).
        let (i, j) = ((x - 0.5).floor() as i64, (y - 0.5).floor() as i64);
        // Lowest covered height around; +inf (seen) when all four are empty.
        let lowest = [
            height(i, j),
            height(i + 1, j),
            height(i, j + 1),
            height(i + 1, j + 1),
        ]
        .into_iter()
        .filter(|h| *h > f64::NEG_INFINITY)
        .fold(f64::INFINITY, f64::min);
        lowest == f64::INFINITY || h >= lowest - tolerance
    };
    for (count, p) in counts.iter_mut().zip(probes) {
        if p.iter().any(|&c| seen(c)) {
            *count += 1;
        }
    }
}
