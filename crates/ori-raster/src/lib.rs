//! Orthographic frames and a deterministic CPU triangle rasterizer.
//!
//! Every image the pipeline makes of a mesh (item buffers for view planning, relief maps,
//! reference renders for evaluation) comes from [`rasterize`], so they all agree on framing,
//! pixel centres, fill rule and depth ties.
//!
//! The small geometric functions are `#[inline]`: other crates call them per pixel, and
//! without the hint (and without LTO) only the tiniest leaf functions are inlined across
//! crates.
//!
//! Conventions:
//! - A [`Frame`] (u, v, d) is right-handed (u x v = d); `d` points from the object towards the
//!   viewer. Image columns grow along `u`, rows grow along `-v` (row 0 is the top), pixel
//!   (i, j) has its centre at (i + 0.5, j + 0.5).
//! - Height `h = d . p`: larger is nearer the viewer. Relief depth is 0 at the near plane and 1
//!   at the far plane of an [`OrthoView`].
//! - Triangles are drawn whatever their winding (the first surface along the ray is what a
//!   relief map and a coverage test need). Pixel centres on an edge belong to the triangle on
//!   its top or left side, so a shared edge is drawn once. On equal heights the triangle with
//!   the lower index wins, so the result does not depend on anything but the input.

mod culling;

pub use culling::{Culling, InView};

/// A right-handed orthonormal frame (u, v, d), `d` towards the viewer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub u: [f64; 3],
    pub v: [f64; 3],
    pub d: [f64; 3],
}

/// Dot product.
#[inline]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a` scaled to unit length (zero stays zero).
#[inline]
pub fn normalize(a: [f64; 3]) -> [f64; 3] {
    let len = dot(a, a).sqrt();
    if len > 0.0 { a.map(|x| x / len) } else { a }
}

impl Frame {
    /// The frame of direction `d` (normalised here). `u` is horizontal: `up x d` with
    /// `up = +Y`, or `up = -Z` when `d` is within about 8 degrees of the Y axis, so that the
    /// frame never degenerates; `v = d x u`.
    pub fn from_direction(d: [f64; 3]) -> Frame {
        let d = normalize(d);
        let up = if d[1].abs() < 0.99 {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, -1.0]
        };
        let u = normalize(cross(up, d));
        let v = cross(d, u);
        Frame { u, v, d }
    }

    /// Coordinates of `p` in the frame: (u . p, v . p, d . p).
    #[inline]
    pub fn to_local(&self, p: [f64; 3]) -> [f64; 3] {
        [dot(self.u, p), dot(self.v, p), dot(self.d, p)]
    }

    /// World vector from frame coordinates.
    #[inline]
    pub fn to_world(&self, l: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|k| self.u[k] * l[0] + self.v[k] * l[1] + self.d[k] * l[2])
    }
}

/// An orthographic camera: a frame, the square window it sees on the (u, v) plane, the height
/// range that maps to relief depth [0, 1], and the image size in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoView {
    pub frame: Frame,
    /// (u, v) of the window centre.
    pub center: [f64; 2],
    /// Half the window edge, in world units.
    pub half_size: f64,
    /// Height (`d . p`) of depth 0: the plane nearest the viewer.
    pub near: f64,
    /// Height of depth 1: the far side of the object.
    pub far: f64,
    /// Pixels per edge.
    pub size: u32,
}

/// Why a view could not be fitted.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FitError(pub String);

impl std::fmt::Display for FitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FitError {}

impl OrthoView {
    /// The square view of `positions` along `frame`: the window is the bounding square of the
    /// projection, enlarged so that `margin_px` empty pixels surround it on a `size` image.
    pub fn fit(
        frame: Frame,
        positions: &[[f32; 3]],
        size: u32,
        margin_px: u32,
    ) -> Result<OrthoView, FitError> {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in positions {
            let l = frame.to_local(p.map(f64::from));
            for k in 0..3 {
                lo[k] = lo[k].min(l[k]);
                hi[k] = hi[k].max(l[k]);
            }
        }
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        if !(extent.is_finite() && (hi[2] - lo[2]).is_finite()) || positions.is_empty() {
            return Err(FitError(
                "coordinates too large to frame (the projected size overflows)".into(),
            ));
        }
        if extent <= 0.0 {
            return Err(FitError("the object has no extent in this view".into()));
        }
        if size <= 2 * margin_px {
            return Err(FitError(format!(
                "a {size} pixel image has no room inside a {margin_px} pixel margin"
            )));
        }
        let inner = f64::from(size - 2 * margin_px);
        let half_size = 0.5 * extent * f64::from(size) / inner;
        // A flat object (zero depth range) still gets a non-zero range, so depth is defined.
        let depth_pad = if hi[2] > lo[2] { 0.0 } else { extent * 1e-3 };
        Ok(OrthoView {
            frame,
            center: [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])],
            half_size,
            near: hi[2] + depth_pad,
            far: lo[2] - depth_pad,
            size,
        })
    }

    /// The same window and depth range at another resolution.
    pub fn with_size(&self, size: u32) -> OrthoView {
        OrthoView { size, ..*self }
    }

    /// Pixel coordinates (x right, y down, in pixels) and height of a world point.
    #[inline]
    pub fn project(&self, p: [f64; 3]) -> [f64; 3] {
        let l = self.frame.to_local(p);
        let scale = f64::from(self.size) / (2.0 * self.half_size);
        [
            (l[0] - self.center[0] + self.half_size) * scale,
            (self.center[1] + self.half_size - l[1]) * scale,
            l[2],
        ]
    }

    /// Relief depth in [0, 1] of a height.
    #[inline]
    pub fn depth_of_height(&self, h: f64) -> f64 {
        (self.near - h) / (self.near - self.far)
    }

    /// World position of the point at pixel coordinates (x, y) and relief depth `depth`.
    #[inline]
    pub fn unproject(&self, x: f64, y: f64, depth: f64) -> [f64; 3] {
        let scale = 2.0 * self.half_size / f64::from(self.size);
        let u = x * scale - self.half_size + self.center[0];
        let v = self.center[1] + self.half_size - y * scale;
        let h = self.near - depth * (self.near - self.far);
        self.frame.to_world([u, v, h])
    }
}

/// Marks an empty pixel in [`Raster::tri`].
pub const EMPTY: u32 = u32::MAX;

/// What the rasterizer saw at every pixel centre.
#[derive(Clone, Debug, PartialEq)]
pub struct Raster {
    pub size: u32,
    /// Height of the nearest surface, `f64::NEG_INFINITY` where empty.
    pub height: Vec<f64>,
    /// Index of the nearest triangle, or [`EMPTY`].
    pub tri: Vec<u32>,
    /// Barycentric weights of the triangle's three corners (in index order) at the pixel.
    pub bary: Vec<[f32; 3]>,
}

impl Raster {
    /// Number of covered pixels.
    pub fn covered(&self) -> usize {
        self.tri.iter().filter(|&&t| t != EMPTY).count()
    }
}

/// Alpha test for cut-out materials: called for every pixel a flagged triangle would cover,
/// with the triangle index and barycentrics; `false` makes the pixel a hole in that triangle.
pub struct AlphaTest<'a> {
    /// Which triangles need the test.
    pub masked: &'a [bool],
    pub keep: &'a (dyn Fn(u32, [f32; 3]) -> bool + Sync),
}

/// Draw `triangles` seen through `view`. Triangles `culling` marks single-sided are culled
/// where they face away from the viewer ([`faces_away`]); the others are drawn from both
/// sides.
pub fn rasterize(
    view: &OrthoView,
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    alpha: Option<&AlphaTest<'_>>,
    culling: Option<&Culling>,
) -> Raster {
    let mut out = rasterize_scales(view, positions, triangles, alpha, culling, None, &[1]);
    out.pop().expect("one scale, one raster")
}

/// Draw `triangles` through `view` at several resolutions of the same window, in one pass over
/// the triangles: raster `k` has `view.size * scales[k]` pixels per edge. Scales must be
/// powers of two, so that scaled screen coordinates are exact and each raster is
/// bit-identical to `rasterize(&view.with_size(view.size * scale), ..)`.
///
/// Where two triangles meet a pixel centre at the same height, the one drawn first keeps it;
/// `original`, when the triangles are a reordering of a mesh's (such as
/// `Mesh::spatial_order`, which draws faster), gives the index each had there, and the lower
/// one keeps it instead, so that the rasters are those of drawing in the original order
/// (with the indices of this order in [`Raster::tri`]).
///
/// # Panics
/// If a scale is not a power of two, or there are more than 32 (a programming error).
pub fn rasterize_scales(
    view: &OrthoView,
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    alpha: Option<&AlphaTest<'_>>,
    culling: Option<&Culling>,
    original: Option<&[u32]>,
    scales: &[u32],
) -> Vec<Raster> {
    let scene = Scene {
        view,
        positions,
        triangles,
        alpha,
        culling,
        original,
        scales,
    };
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 was detected just above.
        return unsafe { rasterize_avx2(scene) };
    }
    rasterize_portable(scene)
}

/// The arguments of [`rasterize_scales`].
#[derive(Clone, Copy)]
struct Scene<'a, 'b> {
    view: &'a OrthoView,
    positions: &'a [[f32; 3]],
    triangles: &'a [[u32; 3]],
    alpha: Option<&'a AlphaTest<'b>>,
    culling: Option<&'a Culling>,
    original: Option<&'a [u32]>,
    scales: &'a [u32],
}

/// [`rasterize_scales`] compiled for AVX2: the same operations (Rust never fuses a multiply
/// and an add), scheduled with wider registers, so the same rasters, a few percent sooner.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn rasterize_avx2(scene: Scene<'_, '_>) -> Vec<Raster> {
    rasterize_portable(scene)
}

/// [`rasterize_scales`] for any x86-64 (or other) processor.
#[inline(always)]
fn rasterize_portable(scene: Scene<'_, '_>) -> Vec<Raster> {
    let Scene {
        view,
        positions,
        triangles,
        alpha,
        culling,
        original,
        scales,
    } = scene;
    assert!(
        scales.iter().all(|s| s.is_power_of_two()),
        "scales must be powers of two"
    );
    let stride = scales.len();
    assert!(stride <= 32, "at most 32 scales");
    if stride == 0 {
        return Vec::new();
    }
    let mut outs: Vec<Raster> = scales
        .iter()
        .map(|&s| {
            let n = (view.size * s) as usize;
            Raster {
                size: view.size * s,
                height: vec![f64::NEG_INFINITY; n * n],
                tri: vec![EMPTY; n * n],
                bary: vec![[0.0; 3]; n * n],
            }
        })
        .collect();
    let finest = scales.iter().copied().max().unwrap_or(1);
    let fine_view = view.with_size(view.size * finest);
    let projected: Vec<[f64; 3]> = positions
        .iter()
        .map(|p| fine_view.project(p.map(f64::from)))
        .collect();
    // A first test from a small array: per corner and raster, the gap between pixel-centre
    // columns (and rows) it lies in. Most triangles of a dense scan cover no pixel centre, and
    // comparing three keys rejects them. Scaling by a power of two is exact, so the keys
    // are those of the scaled coordinates `draw` sees.
    let mut keys = vec![[0u32; 2]; positions.len() * stride];
    for (p, corner) in projected.iter().zip(keys.chunks_exact_mut(stride)) {
        for ((key, out), &scale) in corner.iter_mut().zip(&outs).zip(scales) {
            // Scaling by a power of two is exact: the same as dividing by `finest / scale`.
            let shrink = f64::from(scale) / f64::from(finest);
            *key = [0, 1].map(|k| centre_gap(p[k] * shrink, out.size));
        }
    }
    let away = culling.map(|c| c.in_view(view));
    for (t, tri) in triangles.iter().enumerate() {
        if away.as_ref().is_some_and(|a| a.surely_away(t)) {
            continue;
        }
        let corners = tri.map(|i| &keys[i as usize * stride..][..stride]);
        // Bit k: the triangle may cover a pixel centre of raster k.
        let mut candidate = 0u32;
        for k in 0..stride {
            if (0..2).all(|axis| !covers_no_centre(corners.map(|c| c[k][axis]))) {
                candidate |= 1 << k;
            }
        }
        if candidate == 0 {
            continue;
        }
        let exact = tri.map(|i| projected[i as usize]);
        let culled = culling.is_some_and(|c| c.single_sided(t));
        // Skipping here what `draw` would skip at every scale: a degenerate or (culled)
        // back-facing triangle keeps its area's sign and zero at every power-of-two scale.
        let area = edge(exact[0], exact[1], exact[2]);
        if area == 0.0 || (culled && area.is_finite() && faces_away(area)) {
            continue;
        }
        let masked = alpha.is_some_and(|al| al.masked.get(t).copied().unwrap_or(false));
        for (k, (out, &scale)) in outs.iter_mut().zip(scales).enumerate() {
            if candidate & (1 << k) == 0 {
                continue;
            }
            // Scaling by a power of two is exact: the same as dividing by `finest / scale`.
            let shrink = f64::from(scale) / f64::from(finest);
            let [a, b, c] = exact.map(|p: [f64; 3]| [p[0] * shrink, p[1] * shrink, p[2]]);
            let alpha = masked.then_some(alpha).flatten();
            draw(out, t, [a, b, c], alpha, culled, original);
        }
    }
    outs
}

/// The exact test and depth-tested write of one triangle (screen coordinates and heights).
/// Inlined into its caller, so that the AVX2 build compiles it for AVX2 too.
#[inline(always)]
fn draw(
    out: &mut Raster,
    t: usize,
    [a, b, c]: [[f64; 3]; 3],
    alpha: Option<&AlphaTest<'_>>,
    single_sided: bool,
    original: Option<&[u32]>,
) {
    let n = out.size as usize;
    let Some([x0, x1, y0, y1]) = centre_box([a, b, c].map(|p| [p[0], p[1]]), n) else {
        return;
    };
    let area = edge(a, b, c);
    if area == 0.0 || !area.is_finite() {
        return; // degenerate in this view
    }
    if single_sided && faces_away(area) {
        return;
    }
    // Orient counter-clockwise on screen; remember how to map weights back.
    let (p1, p2, swapped) = if area > 0.0 {
        (b, c, false)
    } else {
        (c, b, true)
    };
    let area = area.abs();
    // Top (horizontal, going right) and left (going up) edges own their pixels. Without a
    // branch: which way an edge goes is a coin toss the processor cannot predict.
    let owns = |from: [f64; 3], to: [f64; 3]| -> bool {
        let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
        ((dy == 0.0) & (dx > 0.0)) | (dy < 0.0)
    };
    let (bias0, bias1, bias2) = (owns(p1, p2), owns(p2, a), owns(a, p1));
    // Edge functions, with the row term hoisted: the same operations in the same order as
    // `edge(from, to, p)`, so the values are bit-identical to a direct evaluation.
    let edges = [(p1, p2, bias0), (p2, a, bias1), (a, p1, bias2)];
    let lines = edges.map(|(f, to, _)| ([f[0], f[1]], [to[0], to[1]]));
    for y in y0..=y1 {
        let py = y as f64 + 0.5;
        let rows = edges.map(|(f, to, _)| (to[0] - f[0]) * (py - f[1]));
        let Some((xa, xb)) = row_span(lines, rows, x0, x1) else {
            continue;
        };
        for x in xa..=xb {
            let px = x as f64 + 0.5;
            let w = std::array::from_fn::<f64, 3, _>(|k| {
                let (f, to, _) = edges[k];
                rows[k] - (to[1] - f[1]) * (px - f[0])
            });
            let inside = |k: usize| w[k] > 0.0 || (w[k] == 0.0 && edges[k].2);
            if !(inside(0) && inside(1) && inside(2)) {
                continue;
            }
            let [w0, w1, w2] = w;
            let (l0, l1, l2) = (w0 / area, w1 / area, w2 / area);
            let h = l0 * a[2] + l1 * p1[2] + l2 * p2[2];
            let i = y * n + x;
            let nearest = out.height[i];
            if h < nearest || (h == nearest && !first_at_a_tie(t, out.tri[i], original)) {
                continue;
            }
            let bary = if swapped {
                [l0 as f32, l2 as f32, l1 as f32]
            } else {
                [l0 as f32, l1 as f32, l2 as f32]
            };
            if let Some(al) = alpha
                && !(al.keep)(t as u32, bary)
            {
                continue;
            }
            out.height[i] = h;
            out.tri[i] = t as u32;
            out.bary[i] = bary;
        }
    }
}

/// Whether triangle `t` keeps a pixel centre that `held` (drawn before it) meets at the same
/// height: when it comes first in the original order ([`rasterize_scales`]).
#[inline]
fn first_at_a_tie(t: usize, held: u32, original: Option<&[u32]>) -> bool {
    original.is_some_and(|o| o[t] < o[held as usize])
}

/// The pixels of `x0..=x1` in one row whose centres can pass the three edge tests of a
/// triangle, or `None` when none can. `edges` are (from, to) in screen space and `rows` their
/// row terms `(to.x - from.x) * (py - from.y)`. The span is conservative (a pixel and a relative
/// margin beyond the rounded bounds) and the exact tests still decide every pixel inside it, so
/// it changes no result; it only makes a thin triangle cost its area rather than its bounding
/// box (a fan of a many-cornered polygon is thousands of long slivers). Rows of a few pixels
/// are returned whole: there the exact tests cost less than the span's divisions.
#[inline]
pub fn row_span(
    edges: [([f64; 2], [f64; 2]); 3],
    rows: [f64; 3],
    x0: usize,
    x1: usize,
) -> Option<(usize, usize)> {
    if x1 < x0 + 4 {
        return Some((x0, x1));
    }
    let (mut lo, mut hi) = (x0 as f64, x1 as f64);
    for ((from, to), row) in edges.into_iter().zip(rows) {
        let dy = to[1] - from[1];
        if dy == 0.0 {
            // The edge function is `row` along the whole row.
            if row < 0.0 {
                return None;
            }
            continue;
        }
        // w(px) = row - dy * (px - from.x) >= 0, with px = x + 0.5.
        let bound = from[0] + row / dy - 0.5;
        if !bound.is_finite() {
            continue;
        }
        let margin = 1.0 + 1e-7 * (from[0].abs() + (row / dy).abs());
        if dy > 0.0 {
            hi = hi.min(bound + margin);
        } else {
            lo = lo.max(bound - margin);
        }
    }
    if lo > hi || hi < 0.0 {
        return None;
    }
    let first = ceil_nonneg(lo).max(x0);
    let last = (hi as usize).min(x1);
    (first <= last).then_some((first, last))
}

/// The [`centre_gap`] of a coordinate on a pixel-centre line (or NaN): it matches no other.
pub const ON_A_CENTRE: u32 = u32::MAX;
/// The [`centre_gap`] of a coordinate before the first pixel centre.
pub const BEFORE_THE_FIRST: u32 = u32::MAX - 1;

/// Which gap between the `n` pixel centres `i + 0.5` a screen coordinate `v` lies in: `k`
/// strictly between centres `k` and `k + 1` (`n - 1` past the last), [`BEFORE_THE_FIRST`],
/// or [`ON_A_CENTRE`]. Plain gaps are below `n`.
#[inline]
pub fn centre_gap(v: f64, n: u32) -> u32 {
    let c = v - 0.5;
    if c < 0.0 {
        return BEFORE_THE_FIRST;
    }
    if c > f64::from(n.saturating_sub(1)) {
        return n.saturating_sub(1);
    }
    if c >= 0.0 {
        let k = c as u32;
        if f64::from(k) != c {
            return k;
        }
    }
    ON_A_CENTRE
}

/// Whether a triangle whose corners lie in the centre gaps `gaps` (along one axis) lies
/// between the same two centre lines, so that it covers no pixel centre (exact, not only
/// conservative).
#[inline]
pub fn covers_no_centre([a, b, c]: [u32; 3]) -> bool {
    a == b && b == c && a != ON_A_CENTRE
}

/// The pixels `[x0, x1, y0, y1]` (inclusive) of an `n` x `n` image whose centres `i + 0.5`
/// lie in the bounding box of screen points `corners`; `None` when there are none (off the
/// image, or not finite).
#[inline]
pub fn centre_box(corners: [[f64; 2]; 3], n: usize) -> Option<[usize; 4]> {
    let [a, b, c] = corners;
    let max = n as f64;
    let min_x = a[0].min(b[0]).min(c[0]);
    let max_x = a[0].max(b[0]).max(c[0]);
    let min_y = a[1].min(b[1]).min(c[1]);
    let max_y = a[1].max(b[1]).max(c[1]);
    if !(max_x >= 0.5 && max_y >= 0.5 && min_x <= max - 0.5 && min_y <= max - 0.5) {
        return None;
    }
    // The values are >= 0 here, so truncation is floor (`floor`/`ceil` are library calls on
    // baseline x86-64).
    let x0 = ceil_nonneg(min_x - 0.5);
    let x1 = ((max_x - 0.5) as usize).min(n - 1);
    let y0 = ceil_nonneg(min_y - 0.5);
    let y1 = ((max_y - 0.5) as usize).min(n - 1);
    (x0 <= x1 && y0 <= y1).then_some([x0, x1, y0, y1])
}

/// `ceil(v)` for the pixel range, 0 for negative `v`.
#[inline]
fn ceil_nonneg(v: f64) -> usize {
    if v <= 0.0 {
        return 0;
    }
    let t = v as usize;
    if (t as f64) < v { t + 1 } else { t }
}

/// Whether a triangle whose screen corners `a, b, c` (in winding order) have
/// `edge(a, b, c) == area` shows its back to the viewer. The frame (u, v, d) is right-handed
/// and the screen's y runs down (along -v), so a triangle whose normal `(b - a) x (c - a)`
/// points towards the viewer (`. d > 0`) turns clockwise on the image: negative area.
#[inline]
pub fn faces_away(area: f64) -> bool {
    area > 0.0
}

/// Twice the signed area of (a, b, p) on screen (y down): positive when p is to the left of
/// a -> b as seen on the image.
fn edge(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        // A unit square in the XY plane at z = 0, as two triangles sharing a diagonal.
        (
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    /// The unit square [0, 1]^2 seen from +Z at 8 x 8 pixels, depths -1 to 3.
    fn unit_square_view() -> OrthoView {
        OrthoView {
            frame: Frame::from_direction([0.0, 0.0, 1.0]),
            center: [0.5, 0.5],
            half_size: 0.5,
            near: 3.0,
            far: -1.0,
            size: 8,
        }
    }

    #[test]
    fn frames_are_right_handed_and_orthonormal() {
        for d in [
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.3, -0.2, 0.9],
        ] {
            let f = Frame::from_direction(d);
            let c = cross(f.u, f.v);
            assert!(c.iter().zip(f.d).all(|(a, b)| (a - b).abs() < 1e-12));
            assert!(dot(f.u, f.v).abs() < 1e-12 && (dot(f.u, f.u) - 1.0).abs() < 1e-12);
        }
        let f = Frame::from_direction([0.0, 0.0, 1.0]);
        assert_eq!((f.u, f.v), ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]));
    }

    #[test]
    fn square_covers_every_pixel_once_with_no_cracks() {
        let (p, t) = quad();
        let view = OrthoView::fit(Frame::from_direction([0.0, 0.0, 1.0]), &p, 16, 0).unwrap();
        let r = rasterize(&view, &p, &t, None, None);
        assert_eq!(r.covered(), 256);
        // Both triangles drew something; the diagonal is split between them.
        assert!(r.tri.contains(&0) && r.tri.contains(&1));
        // Barycentrics reproduce the pixel position.
        let i = 3 * 16 + 12; // row 3 (near the top, v high), column 12
        let tri = t[r.tri[i] as usize];
        let b = r.bary[i];
        let x: f32 = (0..3).map(|k| b[k] * p[tri[k] as usize][0]).sum();
        let y: f32 = (0..3).map(|k| b[k] * p[tri[k] as usize][1]).sum();
        assert!((x - 12.5 / 16.0).abs() < 1e-6 && (y - (1.0 - 3.5 / 16.0)).abs() < 1e-6);
    }

    #[test]
    fn nearest_surface_wins_and_ties_go_to_the_lower_index() {
        let (mut p, mut t) = quad();
        p.extend([[0.0, 0.0, 0.5], [1.0, 0.0, 0.5], [1.0, 1.0, 0.5]]);
        t.push([4, 5, 6]);
        t.push([0, 1, 2]); // duplicate of triangle 0
        let view = OrthoView::fit(Frame::from_direction([0.0, 0.0, 1.0]), &p, 8, 0).unwrap();
        let r = rasterize(&view, &p, &t, None, None);
        assert!(
            r.tri.iter().all(|&x| x != 3),
            "the duplicate never wins a tie"
        );
        assert!(r.tri.contains(&2));
        assert!((view.depth_of_height(0.5)).abs() < 1e-12);
        // From below the far triangle is hidden.
        let view = OrthoView::fit(Frame::from_direction([0.0, 0.0, -1.0]), &p, 8, 0).unwrap();
        assert!(!rasterize(&view, &p, &t, None, None).tri.contains(&2));
    }

    #[test]
    fn several_scales_in_one_pass_equal_separate_passes() {
        // A fan of thin, overlapping, oddly placed triangles.
        let mut p = Vec::new();
        let mut t = Vec::new();
        let mut x = 0.123f32;
        for i in 0..200u32 {
            x = (x * 3.7 + 0.31).fract();
            let y = (x * 7.1).fract();
            let z = (x * 13.3).fract();
            p.push([x, y, z]);
            if i >= 2 {
                t.push([i - 2, i - 1, i]);
            }
        }
        // A sliver through the centres of coarse row 3 that passes between fine centres.
        let base = p.len() as u32;
        let v = 1.0 - 3.5 / 8.0;
        p.extend([
            [0.0, v - 1e-5, 2.0],
            [1.0, v - 1e-5, 2.0],
            [0.5, v + 1e-5, 2.0],
        ]);
        t.push([base, base + 1, base + 2]);
        let view = unit_square_view();
        let both = rasterize_scales(&view, &p, &t, None, None, None, &[1, 4]);
        assert!(
            both[0].tri.contains(&(t.len() as u32 - 1)),
            "the sliver is drawn"
        );
        assert!(
            !both[1].tri.contains(&(t.len() as u32 - 1)),
            "and misses every fine centre"
        );
        assert_eq!(both[0], rasterize(&view, &p, &t, None, None));
        assert_eq!(
            both[1],
            rasterize(&view.with_size(8 * 4), &p, &t, None, None)
        );
    }

    /// A seeded xorshift generator: `next(k)` is in `0..k`.
    fn xorshift(mut state: u64) -> impl FnMut(u64) -> u64 {
        move |k| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % k
        }
    }

    #[test]
    fn another_order_with_the_original_indices_draws_the_same_rasters() {
        // Overlapping flat triangles at two heights, so that many pixel centres are met at
        // the same height by several triangles (ties), drawn in reverse order.
        let view = unit_square_view();
        let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
        let (mut p, mut t) = (Vec::new(), Vec::new());
        for i in 0..400u32 {
            let z = if next(2) == 0 { 0.5 } else { 1.5 };
            for _ in 0..3 {
                p.push([next(65) as f32 / 64.0, next(65) as f32 / 64.0, z]);
            }
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let scales = [1, 4];
        let drawn = rasterize_scales(&view, &p, &t, None, None, None, &scales);
        let original: Vec<u32> = (0..t.len() as u32).rev().collect();
        let reversed: Vec<[u32; 3]> = original.iter().map(|&k| t[k as usize]).collect();
        let named = |rasters: Vec<Raster>| -> Vec<Raster> {
            rasters
                .into_iter()
                .map(|mut r| {
                    for k in r.tri.iter_mut().filter(|k| **k != EMPTY) {
                        *k = original[*k as usize];
                    }
                    r
                })
                .collect()
        };
        let again = rasterize_scales(&view, &p, &reversed, None, None, Some(&original), &scales);
        assert_eq!(named(again), drawn);
        // Without the original indices the other order keeps other triangles at the ties.
        let other = rasterize_scales(&view, &p, &reversed, None, None, None, &scales);
        assert_ne!(named(other), drawn);
    }

    #[test]
    fn first_tests_and_early_culling_change_no_pixel() {
        // Small triangles with corners on, beside and between pixel centres (eighth-pixel
        // steps at the coarse scale, half-pixel steps at the finest), some off the image, half
        // of them single-sided: each raster must equal the exact test alone (`draw` on every
        // triangle).
        let view = unit_square_view();
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
        let (mut p, mut t) = (Vec::new(), Vec::new());
        for i in 0..3000u32 {
            let x = (next(80) as f32 - 8.0) / 64.0;
            let y = (next(80) as f32 - 8.0) / 64.0;
            for _ in 0..3 {
                let dx = (next(9) as f32 - 4.0) / 64.0;
                let dy = (next(9) as f32 - 4.0) / 64.0;
                p.push([x + dx, 1.0 - (y + dy), next(8) as f32 / 8.0]);
            }
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let single: Vec<bool> = (0..t.len()).map(|i| i % 2 == 0).collect();
        let culling = Culling::new(&p, &t, single.clone());
        let scales = [1, 2, 4];
        let fast = rasterize_scales(&view, &p, &t, None, Some(&culling), None, &scales);
        let fine = view.with_size(8 * 4);
        for (raster, scale) in fast.iter().zip(scales) {
            let size = 8 * scale;
            let n = size as usize * size as usize;
            let mut exact = Raster {
                size,
                height: vec![f64::NEG_INFINITY; n],
                tri: vec![EMPTY; n],
                bary: vec![[0.0; 3]; n],
            };
            let down = f64::from(4 / scale);
            for (i, tri) in t.iter().enumerate() {
                let [a, b, c] = tri.map(|v| {
                    let q = fine.project(p[v as usize].map(f64::from));
                    [q[0] / down, q[1] / down, q[2]]
                });
                draw(&mut exact, i, [a, b, c], None, single[i], None);
            }
            assert!(exact.covered() > 0);
            assert_eq!(*raster, exact, "scale {scale}");
        }
    }

    #[test]
    fn the_avx2_build_draws_what_the_portable_build_draws() {
        // Overlapping small triangles at a few heights (ties), some single-sided, drawn in a
        // shuffled order with their original indices, at three scales.
        let view = unit_square_view();
        let mut next = xorshift(0x1234_5678_9abc_def1u64);
        let (mut p, mut t) = (Vec::new(), Vec::new());
        for i in 0..3000u32 {
            let (x, y) = (next(70) as f32 / 64.0, next(70) as f32 / 64.0);
            let z = next(3) as f32 / 4.0;
            for _ in 0..3 {
                let dx = (next(17) as f32 - 8.0) / 256.0;
                let dy = (next(17) as f32 - 8.0) / 256.0;
                p.push([x + dx, y + dy, z + next(2) as f32 / 64.0]);
            }
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let single: Vec<bool> = (0..t.len()).map(|i| i % 3 == 0).collect();
        let original: Vec<u32> = (0..t.len() as u32).map(|i| (i * 7919) % 3000).collect();
        let (culling, original) = (Some(&Culling::new(&p, &t, single)), Some(&original[..]));
        let scales = [1, 2, 4];
        let dispatched = rasterize_scales(&view, &p, &t, None, culling, original, &scales);
        let portable = rasterize_portable(Scene {
            view: &view,
            positions: &p,
            triangles: &t,
            alpha: None,
            culling,
            original,
            scales: &scales,
        });
        assert!(dispatched.iter().all(|r| r.covered() > 0));
        assert_eq!(dispatched, portable);
    }

    #[test]
    fn single_sided_triangles_are_culled_from_behind() {
        // The quad winds counter-clockwise around +Z: it faces a viewer on the +Z side.
        let (p, t) = quad();
        let single = Culling::new(&p, &t, vec![true, false]);
        for (d, drawn) in [
            ([0.0, 0.0, 1.0], [true, true]),
            ([0.0, 0.0, -1.0], [false, true]),
        ] {
            let view = OrthoView::fit(Frame::from_direction(d), &p, 8, 0).unwrap();
            let r = rasterize(&view, &p, &t, None, Some(&single));
            for (tri, drawn) in drawn.into_iter().enumerate() {
                assert_eq!(
                    r.tri.contains(&(tri as u32)),
                    drawn,
                    "triangle {tri} from {d:?}"
                );
            }
            let both = rasterize_scales(&view, &p, &t, None, Some(&single), None, &[1, 2]);
            assert_eq!(both[0], r);
        }
        // The rule agrees with the world normal for an oblique view.
        let d = normalize([0.3, -0.4, 0.8]);
        let view = OrthoView::fit(Frame::from_direction(d), &p, 8, 0).unwrap();
        let a = view.project([0.0, 0.0, 0.0]);
        let b = view.project([1.0, 0.0, 0.0]);
        let c = view.project([1.0, 1.0, 0.0]);
        assert!(!faces_away(edge(a, b, c)));
        assert!(faces_away(edge(a, c, b)));
    }

    #[test]
    fn alpha_test_cuts_holes() {
        let (p, t) = quad();
        let view = OrthoView::fit(Frame::from_direction([0.0, 0.0, 1.0]), &p, 8, 0).unwrap();
        let keep = |tri: u32, _b: [f32; 3]| tri == 1;
        let masked = [true, true];
        let r = rasterize(
            &view,
            &p,
            &t,
            Some(&AlphaTest {
                masked: &masked,
                keep: &keep,
            }),
            None,
        );
        assert!(r.covered() > 0 && !r.tri.contains(&0));
    }

    #[test]
    fn unproject_inverts_project() {
        let (p, _) = quad();
        let view = OrthoView::fit(Frame::from_direction([0.2, 0.5, 0.8]), &p, 64, 2).unwrap();
        let w = [0.3, 0.7, 0.0];
        let s = view.project(w);
        let back = view.unproject(s[0], s[1], view.depth_of_height(s[2]));
        for k in 0..3 {
            assert!((back[k] - w[k]).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_extents_are_errors() {
        let f = Frame::from_direction([0.0, 0.0, 1.0]);
        assert!(OrthoView::fit(f, &[[1.0, 1.0, 1.0]; 3], 8, 0).is_err());
        assert!(OrthoView::fit(f, &[[f32::MAX, 0.0, 0.0], [-f32::MAX, 0.0, 0.0]], 8, 0).is_ok());
        assert!(OrthoView::fit(f, &[], 8, 0).is_err());
    }
}
