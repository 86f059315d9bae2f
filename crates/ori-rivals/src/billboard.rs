//! Billboards: flat textured quads. A baked relief map read as a flat texture (its depth used
//! only for coverage, or for one parallax step by the octahedral impostor), and the billboard
//! set of seed 004: one quad per direction of a view sphere, the nearest one drawn.

use ori_bake::BakeParams;
use ori_eval::Render;
use ori_mesh::Mesh;
use ori_raster::{OrthoView, dot};
use ori_relief::{EMPTY_DEPTH, ReliefMap};

use crate::perspective::PerspectiveCamera;
use crate::{Drawn, Primitive, Rival, RivalError, Technique, billboard_bytes, within_budget};

/// The non-empty texel of `map` at texel coordinates `(x, y)` (`OrthoView::project`'s).
pub(crate) fn texel_at(map: &ReliefMap, x: f64, y: f64) -> Option<usize> {
    let n = map.size() as usize;
    if !(x >= 0.0 && y >= 0.0) {
        return None;
    }
    // Non-negative here, so truncation is floor (`floor` is a library call on x86-64).
    let (i, j) = (x as usize, y as usize);
    if i >= n || j >= n {
        return None;
    }
    let t = j * n + i;
    (map.depth[t] != EMPTY_DEPTH).then_some(t)
}

/// Height (`d . p` along the map's direction) of the surface stored in texel `t`.
pub(crate) fn surface_height(map: &ReliefMap, t: usize) -> f64 {
    let v = &map.view;
    let depth = f64::from(map.depth[t]) / f64::from(ori_relief::MAX_DEPTH);
    v.near - depth * (v.near - v.far)
}

/// Unit world normal stored in texel `t`.
pub(crate) fn world_normal(map: &ReliefMap, t: usize) -> [f32; 3] {
    let l = ReliefMap::decode_normal(map.normal[t]);
    map.view.frame.to_world(l).map(|c| c as f32)
}

/// The ray of pixel `(x, y)` of `view`: a point on its near plane; rays run along
/// `-view.frame.d`.
fn pixel_origin(view: &OrthoView, x: usize, y: usize) -> [f64; 3] {
    view.unproject(x as f64 + 0.5, y as f64 + 0.5, 0.0)
}

/// Where the rays of a view's pixels meet a plane, as `N` values per pixel that are affine in
/// its column and row (texel coordinates of a map, heights along directions): taken from
/// their exact values at three pixels, so that each pixel costs three multiply-adds a value
/// instead of an unprojection, an intersection and a projection.
pub(crate) struct PlaneHits<const N: usize> {
    first: [f64; N],
    per_column: [f64; N],
    per_row: [f64; N],
}

impl<const N: usize> PlaneHits<N> {
    /// `values` of the point where the ray of each pixel of `view` meets the plane through
    /// `point` with normal `normal`; `None` when the rays run along the plane.
    pub fn new(
        view: &OrthoView,
        point: [f64; 3],
        normal: [f64; 3],
        values: impl Fn([f64; 3]) -> [f64; N],
    ) -> Option<PlaneHits<N>> {
        let w = view.frame.d;
        let last = view.size.max(2) as usize - 1;
        let at = |x, y| hit_plane(pixel_origin(view, x, y), w, point, normal).map(&values);
        let (first, right, down) = (at(0, 0)?, at(last, 0)?, at(0, last)?);
        let step = |to: [f64; N]| std::array::from_fn(|k| (to[k] - first[k]) / last as f64);
        Some(PlaneHits {
            first,
            per_column: step(right),
            per_row: step(down),
        })
    }

    #[inline]
    pub fn at(&self, x: usize, y: usize) -> [f64; N] {
        let (x, y) = (x as f64, y as f64);
        std::array::from_fn(|k| self.first[k] + x * self.per_column[k] + y * self.per_row[k])
    }
}

/// The texel coordinates in `map` and the height along `view`'s direction of where each
/// pixel's ray meets the plane through `point` perpendicular to the map's direction (a
/// billboard's quad).
pub(crate) fn quad_hits(
    view: &OrthoView,
    map: &ReliefMap,
    point: [f64; 3],
) -> Option<PlaneHits<3>> {
    let w = view.frame.d;
    PlaneHits::new(view, point, map.view.frame.d, |p| {
        let [x, y, _] = map.view.project(p);
        [x, y, dot(p, w)]
    })
}

/// Where the ray from `o` along `-w` meets the plane through `c` with normal `d` (`None`
/// when the ray runs along the plane).
fn hit_plane(o: [f64; 3], w: [f64; 3], c: [f64; 3], d: [f64; 3]) -> Option<[f64; 3]> {
    let wd = dot(w, d);
    if wd.abs() < 1e-9 {
        return None;
    }
    let t = (dot(o, d) - dot(c, d)) / wd;
    Some(std::array::from_fn(|k| o[k] - t * w[k]))
}

/// A rectangle of pixels, `x0..x1` by `y0..y1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct PixelBox {
    pub x0: usize,
    pub x1: usize,
    pub y0: usize,
    pub y1: usize,
}

impl PixelBox {
    pub fn empty() -> PixelBox {
        PixelBox {
            x0: usize::MAX,
            x1: 0,
            y0: usize::MAX,
            y1: 0,
        }
    }

    pub fn union(self, o: PixelBox) -> PixelBox {
        PixelBox {
            x0: self.x0.min(o.x0),
            x1: self.x1.max(o.x1),
            y0: self.y0.min(o.y0),
            y1: self.y1.max(o.y1),
        }
    }

    /// All of an `n` x `n` image.
    pub fn whole(n: usize) -> PixelBox {
        PixelBox {
            x0: 0,
            x1: n,
            y0: 0,
            y1: n,
        }
    }

    /// The texels of `map` that hold a surface (empty when none does).
    pub fn occupied(map: &ReliefMap) -> PixelBox {
        let n = map.size() as usize;
        let mut b = PixelBox::empty();
        for (row, depths) in map.depth.chunks_exact(n.max(1)).enumerate() {
            let (Some(first), Some(last)) = (
                depths.iter().position(|&d| d != EMPTY_DEPTH),
                depths.iter().rposition(|&d| d != EMPTY_DEPTH),
            ) else {
                continue;
            };
            b = b.union(PixelBox {
                x0: first,
                x1: last + 1,
                y0: row,
                y1: row + 1,
            });
        }
        b
    }

    fn is_empty(self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    /// Each pixel inside, row by row: column, row and index in an image `size` wide.
    pub fn pixels(self, size: u32) -> impl Iterator<Item = (usize, usize, usize)> {
        let n = size as usize;
        (self.y0..self.y1).flat_map(move |y| (self.x0..self.x1).map(move |x| (x, y, y * n + x)))
    }
}

/// The pixels of `view` whose rays meet the texels `texels` of `map` laid on the plane through
/// `point` perpendicular to the map's direction: outside them none of those texels is read
/// there (bounding box of the texels' corners, widened by a pixel). `PixelBox::whole` gives
/// the map's whole window; `PixelBox::occupied` its surface, where only that can be drawn.
pub(crate) fn window_pixels(
    view: &OrthoView,
    map: &ReliefMap,
    point: [f64; 3],
    texels: PixelBox,
) -> PixelBox {
    if texels.is_empty() {
        return PixelBox::empty();
    }
    let (v, f) = (&map.view, &map.view.frame);
    let h = dot(point, f.d);
    let step = 2.0 * v.half_size / f64::from(v.size);
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for (tx, ty) in [
        (texels.x0, texels.y0),
        (texels.x1, texels.y0),
        (texels.x0, texels.y1),
        (texels.x1, texels.y1),
    ] {
        // Texel column `tx` starts at u = centre - half + tx * step; rows run down along -v.
        let corner = f.to_world([
            v.center[0] - v.half_size + tx as f64 * step,
            v.center[1] + v.half_size - ty as f64 * step,
            h,
        ]);
        let [x, y, _] = view.project(corner);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    let n = view.size as usize;
    let clamp = |c: f64| {
        if c.is_nan() {
            0
        } else {
            (c.max(0.0) as usize).min(n)
        }
    };
    PixelBox {
        x0: clamp(x0.floor() - 1.0),
        x1: clamp(x1.ceil() + 1.0),
        y0: clamp(y0.floor() - 1.0),
        y1: clamp(y1.ceil() + 1.0),
    }
}

/// How a billboard set's textures were seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    Orthographic,
    Perspective(PerspectiveCamera),
}

/// View-aligned billboards: one texture per direction of an icosahedral view sphere, drawn as
/// a quad through the bounding sphere's centre perpendicular to its direction; a view draws
/// the quad of the nearest direction (seed 004; seed 002's sphere-vertex images).
pub struct Billboards {
    projection: Projection,
    maps: Vec<ReliefMap>,
    centre: [f64; 3],
}

impl Billboards {
    /// `count` billboards (20 x 4^k: the face centres of the icosahedron subdivided k times)
    /// of `resolution` x `resolution` texels.
    pub fn bake(
        mesh: &Mesh,
        projection: Projection,
        count: usize,
        resolution: u32,
    ) -> Result<Billboards, RivalError> {
        let technique = match projection {
            Projection::Orthographic => Technique::BillboardsOrthographic,
            Projection::Perspective(_) => Technique::BillboardsPerspective,
        };
        let bad = |reason: String| RivalError::Bake {
            technique: technique.name(),
            reason,
        };
        let subdivisions = (0..=4)
            .find(|&s| 20usize << (2 * s) == count)
            .ok_or_else(|| bad(format!("{count} billboards: 20, 80, 320, 1280 or 5120")))?;
        let directions = ori_views::icosahedron_directions(subdivisions);
        let params = BakeParams {
            resolution,
            ..BakeParams::default()
        };
        let (centre, radius) = crate::bounding_sphere(mesh, technique)?;
        let maps = match projection {
            Projection::Orthographic => {
                ori_bake::bake_any_resolution(mesh, &directions, &params)
                    .map_err(|e| bad(e.to_string()))?
                    .maps
            }
            Projection::Perspective(camera) => {
                camera.bake(mesh, centre, radius, &directions, &params)?
            }
        };
        Ok(Billboards {
            projection,
            maps,
            centre,
        })
    }

    /// The layouts that fit `budget` within 5 %: (count, resolution) for each view-sphere
    /// size whose textures are at least 16 texels wide.
    pub fn layouts(budget: u64) -> Vec<(usize, u32)> {
        [20usize, 80, 320, 1280]
            .into_iter()
            .filter_map(|count| {
                let r = crate::edge_for(budget, count as u64, 4, billboard_bytes)?;
                let bytes = billboard_bytes(count as u64 * u64::from(r) * u64::from(r));
                (r >= 16 && within_budget(bytes, budget)).then_some((count, r))
            })
            .collect()
    }

    fn nearest(&self, w: [f64; 3]) -> usize {
        let mut best = 0;
        for (i, m) in self.maps.iter().enumerate() {
            if dot(m.view.frame.d, w) > dot(self.maps[best].view.frame.d, w) {
                best = i;
            }
        }
        best
    }
}

impl Rival for Billboards {
    fn technique(&self) -> Technique {
        match self.projection {
            Projection::Orthographic => Technique::BillboardsOrthographic,
            Projection::Perspective(_) => Technique::BillboardsPerspective,
        }
    }

    fn bytes(&self) -> u64 {
        billboard_bytes(self.maps.iter().map(|m| u64::from(m.size()).pow(2)).sum())
    }

    fn layout(&self) -> String {
        let r = self.maps[0].size();
        let seen = match self.projection {
            Projection::Orthographic => "orthographic".to_string(),
            Projection::Perspective(c) => c.describe(),
        };
        format!("{} billboards of {r} x {r}, {seen}", self.maps.len())
    }

    fn primitive(&self) -> Primitive {
        Primitive::Quads
    }

    fn draw(&self, view: &OrthoView) -> Result<Drawn, RivalError> {
        let w = view.frame.d;
        let map = &self.maps[self.nearest(w)];
        let mut render = Render::empty(view.size);
        let whole = PixelBox::whole(map.size() as usize);
        let Some(hits) = quad_hits(view, map, self.centre) else {
            return Ok(Drawn { render, count: 1 });
        };
        for (x, y, i) in window_pixels(view, map, self.centre, whole).pixels(view.size) {
            let [tx, ty, height] = hits.at(x, y);
            let Some(t) = texel_at(map, tx, ty) else {
                continue;
            };
            render.coverage.set(i);
            render.depth[i] = view.depth_of_height(height) as f32;
            render.albedo[i] = map.albedo[t];
            render.normal[i] = world_normal(map, t);
        }
        Ok(Drawn { render, count: 1 })
    }
}
