//! Mesh coverage without the rest of a raster: the same pixels `ori_raster::rasterize` draws
//! (same projection, fill rule, alpha test and culling, operation for operation; only conservative
//! pre-tests added), computed as a union of triangles, so no depth test, heights or
//! barycentrics are needed and a triangle whose pixels are all covered already is skipped.
//! A test holds the two equal. Likewise the nearest heights alone (what a hierarchy node's
//! own pixels are found by), a maximum over triangles, for the pixels of a window only.

use ori_mesh::Mesh;
use ori_raster::{
    BEFORE_THE_FIRST, Culling, OrthoView, centre_box, centre_gap, covers_no_centre, dot,
    faces_away, row_span,
};

use crate::Mask;
use crate::reference::AlphaCut;

/// The mesh's triangles in a cache-friendly order ([`Mesh::spatial_order`], vertices
/// renumbered by [`Mesh::reordered`]), so that consecutive triangles read neighbouring
/// vertices. Coverage is a union, so the order does not change it; on a
/// 200k-triangle scan this halves the time, which went to fetching scattered vertices.
pub(crate) struct CoverageMesh {
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    /// Index of each triangle in the original mesh (for the alpha test).
    original: Vec<u32>,
    /// Which triangles are culled from behind (`Mesh::single_sided`).
    culling: Culling,
    /// The boxes of runs of [`CHUNK`] consecutive triangles, for [`heights`] to skip the runs
    /// that project outside the pixels it is asked for.
    chunks: Vec<Chunk>,
}

/// Triangles per [`Chunk`].
const CHUNK: usize = 64;

/// The bounding box of [`CHUNK`] consecutive triangles (neighbours on the Morton curve):
/// centre and half extents.
struct Chunk {
    center: [f64; 3],
    half: [f64; 3],
}

impl CoverageMesh {
    /// `single_sided`: [`Mesh::single_sided`], in the mesh's triangle order.
    pub fn new(mesh: &Mesh, single_sided: &[bool]) -> CoverageMesh {
        let order = mesh.spatial_order();
        let Mesh {
            positions,
            triangles,
            ..
        } = mesh.reordered(&order);
        let chunks = triangles
            .chunks(CHUNK)
            .map(|run| {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for &i in run.iter().flatten() {
                    let p = positions[i as usize];
                    for k in 0..3 {
                        lo[k] = lo[k].min(f64::from(p[k]));
                        hi[k] = hi[k].max(f64::from(p[k]));
                    }
                }
                Chunk {
                    center: std::array::from_fn(|k| 0.5 * (lo[k] + hi[k])),
                    half: std::array::from_fn(|k| 0.5 * (hi[k] - lo[k])),
                }
            })
            .collect();
        CoverageMesh {
            chunks,
            culling: Culling::new(
                &positions,
                &triangles,
                order.iter().map(|&t| single_sided[t as usize]).collect(),
            ),
            positions,
            triangles,
            original: order,
        }
    }
}

/// `OrthoView::project` without the depth, operation for operation, so that screen positions
/// are bit for bit the rasterizer's.
struct Screen {
    u: [f64; 3],
    v: [f64; 3],
    scale: f64,
    /// `center[0]`: `project` subtracts it and adds `half_size` in turn.
    cx: f64,
    half_size: f64,
    /// `center[1] + half_size`, as `project` computes it first.
    cy: f64,
}

impl Screen {
    fn new(view: &OrthoView) -> Screen {
        Screen {
            u: view.frame.u,
            v: view.frame.v,
            scale: f64::from(view.size) / (2.0 * view.half_size),
            cx: view.center[0],
            half_size: view.half_size,
            cy: view.center[1] + view.half_size,
        }
    }

    /// The column coordinate of a point whose `u . p` is `lu`.
    #[inline]
    fn x(&self, lu: f64) -> f64 {
        (lu - self.cx + self.half_size) * self.scale
    }

    /// The row coordinate of a point whose `v . p` is `lv`.
    #[inline]
    fn y(&self, lv: f64) -> f64 {
        (self.cy - lv) * self.scale
    }

    #[inline]
    fn xy(&self, p: [f64; 3]) -> [f64; 2] {
        [self.x(dot(self.u, p)), self.y(dot(self.v, p))]
    }
}

/// Per-vertex data of one view, reused between views (a fresh multi-megabyte buffer per
/// view costs page faults): the first test's column and row keys, read for every triangle,
/// apart from the exact screen positions, read for the few that pass it, so that the hot
/// array stays small in the cache.
#[derive(Default)]
struct Corners {
    keys: Vec<[u32; 2]>,
    exact: Vec<[f64; 2]>,
}

thread_local! {
    static CORNERS: std::cell::RefCell<Corners> = std::cell::RefCell::new(Corners::default());
}

pub(crate) fn coverage(
    view: &OrthoView,
    mesh: &CoverageMesh,
    alpha: Option<&AlphaCut<'_>>,
) -> Mask {
    CORNERS.with_borrow_mut(|corners| coverage_with(view, mesh, alpha, corners))
}

fn coverage_with(
    view: &OrthoView,
    mesh: &CoverageMesh,
    alpha: Option<&AlphaCut<'_>>,
    corners: &mut Corners,
) -> Mask {
    let n = view.size as usize;
    let mut mask = Mask::new(view.size);
    let screen = Screen::new(view);
    corners.exact.clear();
    corners
        .exact
        .extend(mesh.positions.iter().map(|p| screen.xy(p.map(f64::from))));
    // A first test cheaper than the exact one: a triangle whose three corners lie strictly
    // between the same two pixel-centre columns (or rows) covers no pixel centre.
    corners.keys.clear();
    let exact = &corners.exact;
    corners.keys.extend(
        exact
            .iter()
            .map(|s| [centre_gap(s[0], view.size), centre_gap(s[1], view.size)]),
    );
    let keys = &corners.keys;
    let away = mesh.culling.in_view(view);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        // On a closed scan about half the triangles face away: most are known to from the
        // view direction alone, before their corners are read.
        if away.surely_away(t) {
            continue;
        }
        let [ka, kb, kc] = tri.map(|i| keys[i as usize]);
        if (0..2).any(|k| covers_no_centre([ka[k], kb[k], kc[k]])) {
            continue;
        }
        // Culled and degenerate triangles first: on a closed scan about half the triangles
        // face away, and this is cheaper than the covered-box test below.
        let [a, b, c] = tri.map(|i| exact[i as usize]);
        let area = edge(a, b, c);
        if area == 0.0 || !area.is_finite() || (mesh.culling.single_sided(t) && faces_away(area)) {
            continue;
        }
        // With plain keys the candidate centres are columns min + 1 ..= max (likewise rows),
        // the box `draw` would compute: nothing to do when they are all covered already, the
        // common case on dense scans.
        let range = |k: usize| {
            let (p, q, r) = (ka[k], kb[k], kc[k]);
            (p < BEFORE_THE_FIRST && q < BEFORE_THE_FIRST && r < BEFORE_THE_FIRST)
                .then(|| (p.min(q).min(r) as usize + 1, p.max(q).max(r) as usize))
        };
        let known = range(0)
            .zip(range(1))
            .map(|((x0, x1), (y0, y1))| [x0, x1, y0, y1]);
        if known.is_some_and(|[x0, x1, y0, y1]| all_covered(&mask, n, x0, x1, y0, y1)) {
            continue;
        }
        let t = mesh.original[t] as usize;
        let masked = alpha.filter(|al| al.masked[t]);
        draw(&mut mask, t, [a, b, c], area, known, masked);
    }
    mask
}

/// Per-vertex data of one view for [`heights`], reused between views: screen position and
/// height, the first test's keys, and the view each vertex was last projected in (a vertex
/// is projected only when a triangle of a run that is not skipped reads it).
#[derive(Default)]
struct Projected {
    exact: Vec<[f64; 2]>,
    height: Vec<f64>,
    keys: Vec<[u32; 2]>,
    stamp: Vec<u32>,
    generation: u32,
}

thread_local! {
    static PROJECTED: std::cell::RefCell<Projected> = std::cell::RefCell::new(Projected::default());
}

/// The height (`d . p`) of the nearest surface at every pixel centre of `view`, bit for bit
/// the `height` of `ori_raster::rasterize` (same projection, fill rule, alpha test and
/// culling; `NEG_INFINITY` where nothing is drawn), at the pixels of `window`
/// (`[x0, x1, y0, y1]`, inclusive) only: outside it the value is `NEG_INFINITY`. The nearest
/// height is a maximum, so the triangle order does not change it, and runs of triangles whose
/// box projects outside the window are skipped whole.
pub(crate) fn heights(
    view: &OrthoView,
    mesh: &CoverageMesh,
    alpha: Option<&AlphaCut<'_>>,
    window: [usize; 4],
) -> Vec<f64> {
    PROJECTED.with_borrow_mut(|scratch| heights_with(view, mesh, alpha, window, scratch))
}

fn heights_with(
    view: &OrthoView,
    mesh: &CoverageMesh,
    alpha: Option<&AlphaCut<'_>>,
    window: [usize; 4],
    scratch: &mut Projected,
) -> Vec<f64> {
    let n = view.size as usize;
    let mut out = vec![f64::NEG_INFINITY; n * n];
    let [wx0, wx1, wy0, wy1] = window;
    if wx0 > wx1 || wy0 > wy1 || wx1 >= n || wy1 >= n {
        return out;
    }
    let vertices = mesh.positions.len();
    if scratch.stamp.len() != vertices {
        scratch.stamp = vec![0; vertices];
        scratch.exact.resize(vertices, [0.0; 2]);
        scratch.height.resize(vertices, 0.0);
        scratch.keys.resize(vertices, [0; 2]);
        scratch.generation = 0;
    }
    scratch.generation = scratch.generation.wrapping_add(1);
    if scratch.generation == 0 {
        scratch.stamp.fill(0);
        scratch.generation = 1;
    }
    let generation = scratch.generation;
    let (frame, screen) = (view.frame, Screen::new(view));
    // A run is skipped when its box lies more than a pixel beyond the window's outer pixel
    // centres (the margin dwarfs any rounding; a NaN skips nothing).
    let (left, right) = (wx0 as f64 - 0.5, wx1 as f64 + 1.5);
    let (top, bottom) = (wy0 as f64 - 0.5, wy1 as f64 + 1.5);
    let extent = |axis: [f64; 3], half: [f64; 3]| {
        axis[0].abs() * half[0] + axis[1].abs() * half[1] + axis[2].abs() * half[2]
    };
    let away = mesh.culling.in_view(view);
    let runs = mesh.triangles.chunks(CHUNK).zip(&mesh.chunks);
    for (k, (run, chunk)) in runs.enumerate() {
        let (lu, hu) = (dot(frame.u, chunk.center), extent(frame.u, chunk.half));
        let (lv, hv) = (dot(frame.v, chunk.center), extent(frame.v, chunk.half));
        if screen.x(lu + hu) < left
            || screen.x(lu - hu) > right
            || screen.y(lv - hv) < top
            || screen.y(lv + hv) > bottom
        {
            continue;
        }
        for (t, tri) in (k * CHUNK..).zip(run) {
            if away.surely_away(t) {
                continue;
            }
            for &i in tri {
                let i = i as usize;
                if scratch.stamp[i] == generation {
                    continue;
                }
                let p = mesh.positions[i].map(f64::from);
                let xy = screen.xy(p);
                scratch.exact[i] = xy;
                scratch.height[i] = dot(frame.d, p);
                scratch.keys[i] = xy.map(|c| centre_gap(c, view.size));
                scratch.stamp[i] = generation;
            }
            let [ka, kb, kc] = tri.map(|i| scratch.keys[i as usize]);
            if (0..2).any(|k| covers_no_centre([ka[k], kb[k], kc[k]])) {
                continue;
            }
            let [a, b, c] = tri.map(|i| scratch.exact[i as usize]);
            let area = edge(a, b, c);
            if area == 0.0
                || !area.is_finite()
                || (mesh.culling.single_sided(t) && faces_away(area))
            {
                continue;
            }
            let h = tri.map(|i| scratch.height[i as usize]);
            let t = mesh.original[t] as usize;
            let masked = alpha.filter(|al| al.masked[t]);
            draw_height(&mut out, n, window, t, [a, b, c], h, area, masked);
        }
    }
    out
}

/// `ori_raster`'s exact inside test and depth-tested write of one triangle, heights only,
/// at the pixels of `window`; `area` is `edge(a, b, c)`, non-zero and finite, of a triangle
/// not culled, and `h` its corners' heights.
#[allow(clippy::too_many_arguments)]
fn draw_height(
    out: &mut [f64],
    n: usize,
    [wx0, wx1, wy0, wy1]: [usize; 4],
    t: usize,
    corners: [[f64; 2]; 3],
    [ha, hb, hc]: [f64; 3],
    area: f64,
    alpha: Option<&AlphaCut<'_>>,
) {
    let Some([x0, x1, y0, y1]) = centre_box(corners, n) else {
        return;
    };
    let (x0, x1, y0, y1) = (x0.max(wx0), x1.min(wx1), y0.max(wy0), y1.min(wy1));
    if x0 > x1 || y0 > y1 {
        return;
    }
    let tri = Triangle::new(corners, area);
    let lines = tri.lines();
    let (h1, h2) = if tri.swapped { (hc, hb) } else { (hb, hc) };
    for y in y0..=y1 {
        let rows = tri.rows(y);
        let Some((xa, xb)) = row_span(lines, rows, x0, x1) else {
            continue;
        };
        for x in xa..=xb {
            let Some(w) = tri.inside(rows, x) else {
                continue;
            };
            let [l0, l1, l2] = tri.weights(w);
            let height = l0 * ha + l1 * h1 + l2 * h2;
            let i = y * n + x;
            if height <= out[i] {
                continue;
            }
            if alpha.is_some_and(|alpha| !alpha.keeps(t as u32, tri.bary(w))) {
                continue;
            }
            out[i] = height;
        }
    }
}

/// A triangle set up for `ori_raster`'s exact inside test, operation for operation:
/// counter-clockwise on screen, with the top-left rule's edge ownership.
struct Triangle {
    /// (from, to, owns its pixel centres) per edge.
    edges: [([f64; 2], [f64; 2], bool); 3],
    /// The absolute area (twice the screen area).
    area: f64,
    /// Whether the last two corners were swapped to turn counter-clockwise.
    swapped: bool,
}

impl Triangle {
    /// `area`: `edge(a, b, c)`, non-zero and finite.
    #[inline]
    fn new([a, b, c]: [[f64; 2]; 3], area: f64) -> Triangle {
        let (p1, p2, swapped) = if area > 0.0 {
            (b, c, false)
        } else {
            (c, b, true)
        };
        // Top (horizontal, going right) and left (going up) edges own their pixels.
        let owns = |from: [f64; 2], to: [f64; 2]| -> bool {
            let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
            (dy == 0.0 && dx > 0.0) || dy < 0.0
        };
        Triangle {
            edges: [
                (p1, p2, owns(p1, p2)),
                (p2, a, owns(p2, a)),
                (a, p1, owns(a, p1)),
            ],
            area: area.abs(),
            swapped,
        }
    }

    #[inline]
    fn lines(&self) -> [([f64; 2], [f64; 2]); 3] {
        self.edges.map(|(f, to, _)| (f, to))
    }

    /// The edge functions' row terms at pixel row `y`.
    #[inline]
    fn rows(&self, y: usize) -> [f64; 3] {
        let py = y as f64 + 0.5;
        self.edges.map(|(f, to, _)| (to[0] - f[0]) * (py - f[1]))
    }

    /// The edge functions at the centre of pixel `x` of the row, when it is inside.
    #[inline]
    fn inside(&self, rows: [f64; 3], x: usize) -> Option<[f64; 3]> {
        let px = x as f64 + 0.5;
        let w = std::array::from_fn::<f64, 3, _>(|k| {
            let (f, to, _) = self.edges[k];
            rows[k] - (to[1] - f[1]) * (px - f[0])
        });
        let inside = |k: usize| w[k] > 0.0 || (w[k] == 0.0 && self.edges[k].2);
        (inside(0) && inside(1) && inside(2)).then_some(w)
    }

    /// The weights of the counter-clockwise corners (the first, then the two in set-up order).
    #[inline]
    fn weights(&self, w: [f64; 3]) -> [f64; 3] {
        w.map(|w| w / self.area)
    }

    /// Barycentric weights in the triangle's own corner order, as the alpha test takes them.
    #[inline]
    fn bary(&self, w: [f64; 3]) -> [f32; 3] {
        let [l0, l1, l2] = self.weights(w);
        if self.swapped {
            [l0 as f32, l2 as f32, l1 as f32]
        } else {
            [l0 as f32, l1 as f32, l2 as f32]
        }
    }
}

/// Whether every pixel of `[x0, x1] x [y0, y1]` (inclusive) is in `mask` (edge `n`).
#[inline]
fn all_covered(mask: &Mask, n: usize, x0: usize, x1: usize, y0: usize, y1: usize) -> bool {
    for y in y0..=y1 {
        for x in x0..=x1 {
            if !mask.get(y * n + x) {
                return false;
            }
        }
    }
    true
}

fn edge(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// `ori_raster`'s exact inside test of one triangle, setting the covered pixels; `area` is
/// `edge(a, b, c)`, non-zero and finite, of a triangle not culled. `known`: its box of pixel
/// centres `[x0, x1, y0, y1]`, when the caller has found it and that it is not all covered.
fn draw(
    mask: &mut Mask,
    t: usize,
    [a, b, c]: [[f64; 2]; 3],
    area: f64,
    known: Option<[usize; 4]>,
    alpha: Option<&AlphaCut<'_>>,
) {
    let n = mask.size() as usize;
    let [x0, x1, y0, y1] = match known {
        Some(found) => found,
        // Nothing to add where every pixel of the box is covered already.
        None => match centre_box([a, b, c], n) {
            Some([x0, x1, y0, y1]) if !all_covered(mask, n, x0, x1, y0, y1) => [x0, x1, y0, y1],
            _ => return,
        },
    };
    let tri = Triangle::new([a, b, c], area);
    let lines = tri.lines();
    for y in y0..=y1 {
        let rows = tri.rows(y);
        let Some((xa, xb)) = row_span(lines, rows, x0, x1) else {
            continue;
        };
        for x in xa..=xb {
            let i = y * n + x;
            if mask.get(i) {
                continue;
            }
            let Some(w) = tri.inside(rows, x) else {
                continue;
            };
            if alpha.is_some_and(|alpha| !alpha.keeps(t as u32, tri.bary(w))) {
                continue;
            }
            mask.set(i);
        }
    }
}
