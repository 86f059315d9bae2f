//! Billboard clouds by hierarchical face clustering (seed 001, section 4.3): the triangles
//! are merged pairwise, cheapest first, into clusters each drawn as one textured plane.
//!
//! Merge cost (the paper's equation 3): a pair is rejected when a face of the merged cluster
//! would deviate more than 60 degrees from its plane (`MAX_NORMAL_DEG`) or when the plane's
//! rectangle would be mostly empty texels (`MAX_WASTE`); otherwise it costs its texture waste
//! plus `k * MAX_WASTE`, where `k` is the level of detail its geometric error falls in (0 up
//! to `finest`, then doubling), so that no merge of a coarser level is made before every
//! merge of the finer ones. Choices where the paper leaves room:
//! - Texture waste is the fraction of the plane's rectangle that the faces' projection leaves
//!   empty (lower is better, as equation 3 uses it).
//! - The plane and its rectangle come from the area-weighted second moments of the faces
//!   (principal component analysis): the normal is the axis of least variance, the
//!   rectangle's sides and the geometric error (half its thickness) are those of a uniform
//!   distribution with the same variances. The normal deviation is bounded with a normal cone
//!   per cluster. So every merge is evaluated in constant time.
//! - Closeness (the paper's generalised adjacency): triangles sharing a vertex, and the
//!   triangles nearest in Morton order of their centroids, which joins disconnected parts.
//! - Each cluster's texture is square (the paper fits its rectangle), baked orthographically
//!   along its normal at one texel density for all clusters, the largest whose textures and
//!   quads (`CARD_BYTES` each) fit the budget.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use std::sync::Arc;

use ori_bake::{BakeParams, Baker, Textures};
use ori_eval::Render;
use ori_mesh::Mesh;
use ori_raster::{Frame, OrthoView, dot, normalize};
use ori_relief::ReliefMap;
use rayon::prelude::*;

use crate::billboard::{PixelBox, quad_hits, texel_at, window_pixels, world_normal};
use crate::{Drawn, Primitive, Rival, RivalError, Technique, billboard_bytes, within_budget};

/// Largest angle between a face's normal and its cluster's plane.
const MAX_NORMAL_DEG: f64 = 60.0;
/// Largest fraction of empty texels in a cluster's rectangle.
const MAX_WASTE: f64 = 0.9;
/// Geometric error of the finest level, as a fraction of the bounding sphere's radius.
const FINEST: f64 = 0.005;
/// Neighbours in Morton order each triangle is close to, on either side.
const MORTON_WINDOW: usize = 4;
/// Geometry bytes of one card: four corners (position and UV as f32) and six 16-bit indices.
const CARD_BYTES: u64 = 4 * (12 + 8) + 6 * 2;
/// Triangles around one vertex beyond which only consecutive ones are joined.
const FAN_LIMIT: usize = 12;

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| a[k] + b[k])
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|c| c * s)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A cluster's area-weighted moments and normal cone.
#[derive(Clone, Copy, Debug)]
struct Moments {
    area: f64,
    /// Integral of x over the faces.
    first: [f64; 3],
    /// Integral of x x^T over the faces.
    second: [[f64; 3]; 3],
    /// Sum of area x unit normal.
    normal_sum: [f64; 3],
    cone_axis: [f64; 3],
    cone_angle: f64,
}

impl Moments {
    fn triangle(p: [[f64; 3]; 3]) -> Option<Moments> {
        let n = cross(add(p[1], scale(p[0], -1.0)), add(p[2], scale(p[0], -1.0)));
        let twice = dot(n, n).sqrt();
        // Degenerate (or not finite): no plane to fit.
        if twice.is_nan() || twice <= 0.0 {
            return None;
        }
        let area = 0.5 * twice;
        let s = add(add(p[0], p[1]), p[2]);
        let mut second = [[0.0; 3]; 3];
        for (i, row) in second.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                let corners: f64 = p.iter().map(|c| c[i] * c[j]).sum();
                *v = area / 12.0 * (corners + s[i] * s[j]);
            }
        }
        let unit = scale(n, 1.0 / twice);
        Some(Moments {
            area,
            first: scale(s, area / 3.0),
            second,
            normal_sum: scale(unit, area),
            cone_axis: unit,
            cone_angle: 0.0,
        })
    }

    fn merge(&self, o: &Moments) -> Moments {
        let mut second = self.second;
        for (i, row) in second.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v += o.second[i][j];
            }
        }
        let (cone_axis, cone_angle) = merge_cones(
            (self.cone_axis, self.cone_angle),
            (o.cone_axis, o.cone_angle),
        );
        Moments {
            area: self.area + o.area,
            first: add(self.first, o.first),
            second,
            normal_sum: add(self.normal_sum, o.normal_sum),
            cone_axis,
            cone_angle,
        }
    }

    /// The plane of least variance: (unit normal facing the faces, centroid, variances in
    /// ascending order, the in-plane axes).
    fn plane(&self) -> Plane {
        let mean = scale(self.first, 1.0 / self.area);
        let mut cov = [[0.0; 3]; 3];
        for (i, row) in cov.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.second[i][j] / self.area - mean[i] * mean[j];
            }
        }
        let (values, vectors) = eigen(cov);
        let mut normal = vectors[0];
        if dot(normal, self.normal_sum) < 0.0 {
            normal = scale(normal, -1.0);
        }
        Plane {
            normal,
            centre: mean,
            variances: values.map(|v| v.max(0.0)),
        }
    }

    /// The merge cost (see the module), `None` when the merge is rejected.
    fn cost(&self, finest: f64) -> Option<f64> {
        let plane = self.plane();
        let deviation = ori_math::angle_between(plane.normal, self.cone_axis) + self.cone_angle;
        if deviation > MAX_NORMAL_DEG.to_radians() {
            return None;
        }
        let [thin, a, b] = plane.variances;
        let rectangle = 12.0 * (a * b).sqrt();
        let projected = dot(plane.normal, self.normal_sum).max(0.0);
        let waste = if rectangle > 0.0 {
            (1.0 - projected / rectangle).clamp(0.0, 1.0)
        } else {
            0.0
        };
        if waste > MAX_WASTE {
            return None;
        }
        let error = (3.0 * thin).sqrt();
        let mut level = 0u32;
        while error > finest * f64::from(1u32 << level.min(30)) && level < 60 {
            level += 1;
        }
        Some(waste + f64::from(level) * MAX_WASTE)
    }
}

struct Plane {
    normal: [f64; 3],
    centre: [f64; 3],
    variances: [f64; 3],
}

/// The smallest cone holding two cones (axis, half-angle in radians).
fn merge_cones(a: ([f64; 3], f64), b: ([f64; 3], f64)) -> ([f64; 3], f64) {
    let between = ori_math::angle_between(a.0, b.0);
    if between + b.1 <= a.1 {
        return a;
    }
    if between + a.1 <= b.1 {
        return b;
    }
    let angle = 0.5 * (a.1 + between + b.1);
    if angle >= std::f64::consts::PI || between <= 0.0 {
        return (a.0, angle.min(std::f64::consts::PI));
    }
    // Rotate a's axis towards b's by (angle - a.1) in their common plane.
    let t = angle - a.1;
    let (sin_between, _) = ori_math::sin_cos(between);
    let (sin_rest, _) = ori_math::sin_cos(between - t);
    let (sin_t, _) = ori_math::sin_cos(t);
    let axis = add(
        scale(a.0, sin_rest / sin_between),
        scale(b.0, sin_t / sin_between),
    );
    (normalize(axis), angle)
}

/// Eigenvalues (ascending) and unit eigenvectors of a symmetric 3 x 3 matrix, by cyclic
/// Jacobi rotations (only `+ - * /` and `sqrt`: the same on every machine).
fn eigen(mut m: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        let off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
        if off <= 1e-30 * (m[0][0] * m[0][0] + m[1][1] * m[1][1] + m[2][2] * m[2][2]) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if m[p][q] == 0.0 {
                continue;
            }
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in m.iter_mut() {
                let (mkp, mkq) = (row[p], row[q]);
                row[p] = c * mkp - s * mkq;
                row[q] = s * mkp + c * mkq;
            }
            let (rp, rq) = (m[p], m[q]);
            m[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
            m[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| m[a][a].total_cmp(&m[b][b]));
    let values = order.map(|i| m[i][i]);
    let vectors = order.map(|i| normalize([v[0][i], v[1][i], v[2][i]]));
    (values, vectors)
}

/// Pairs of triangles that may merge (see the module), each once, `a < b`.
fn closeness(mesh: &Mesh, faces: &[u32]) -> Vec<(u32, u32)> {
    let mut pairs = Vec::new();
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
    for (slot, &t) in faces.iter().enumerate() {
        for &v in &mesh.triangles[t as usize] {
            around[v as usize].push(slot as u32);
        }
    }
    for fan in &around {
        if fan.len() <= FAN_LIMIT {
            for (i, &a) in fan.iter().enumerate() {
                for &b in &fan[i + 1..] {
                    pairs.push((a.min(b), a.max(b)));
                }
            }
        } else {
            for w in fan.windows(2) {
                pairs.push((w[0].min(w[1]), w[0].max(w[1])));
            }
        }
    }
    let (lo, hi) = mesh.bounds();
    let cell = |c: f64, k: usize| -> u64 {
        let span = f64::from(hi[k]) - f64::from(lo[k]);
        let t = if span > 0.0 {
            (c - f64::from(lo[k])) / span
        } else {
            0.0
        };
        (t.clamp(0.0, 1.0) * 1023.0) as u64
    };
    let mut order: Vec<(u64, u32)> = faces
        .iter()
        .enumerate()
        .map(|(slot, &t)| {
            let tri = mesh.triangles[t as usize];
            let mut code = 0u64;
            for k in 0..3 {
                let c = tri
                    .iter()
                    .map(|&i| f64::from(mesh.positions[i as usize][k]))
                    .sum::<f64>()
                    / 3.0;
                let v = cell(c, k);
                for bit in 0..10 {
                    code |= ((v >> bit) & 1) << (3 * bit + k);
                }
            }
            (code, slot as u32)
        })
        .collect();
    order.sort_unstable();
    for (i, &(_, a)) in order.iter().enumerate() {
        for &(_, b) in order.iter().skip(i + 1).take(MORTON_WINDOW) {
            pairs.push((a.min(b), a.max(b)));
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// A cluster: its triangles and their moments (about the bounding sphere's centre).
type Cluster = (Vec<u32>, Moments);

/// The clusters when `targets` (descending) clusters are left, or when no merge is allowed
/// any more (a snapshot per target, none repeated); `centre` and `radius` are the model's
/// bounding sphere's. Moments are taken about the centre, so that a model far from the
/// origin keeps the precision of its thin variances.
fn cluster(mesh: &Mesh, centre: [f64; 3], radius: f64, targets: &[usize]) -> Vec<Vec<Cluster>> {
    let finest = FINEST * radius;
    let mut faces = Vec::new();
    let mut moments: Vec<Option<Moments>> = Vec::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let p = tri.map(|i| {
            let q = mesh.positions[i as usize];
            std::array::from_fn(|k| f64::from(q[k]) - centre[k])
        });
        if let Some(m) = Moments::triangle(p) {
            faces.push(t as u32);
            moments.push(Some(m));
        }
    }
    let n = faces.len();
    let mut members: Vec<Vec<u32>> = faces.iter().map(|&t| vec![t]).collect();
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut version = vec![0u32; n];
    let mut heap = BinaryHeap::new();
    let push = |heap: &mut BinaryHeap<_>, m: &Moments, a: u32, b: u32, va: u32, vb: u32| {
        if let Some(cost) = m.cost(finest) {
            let cost: f64 = cost;
            heap.push(Reverse((cost.to_bits(), a, b, va, vb)));
        }
    };
    for (a, b) in closeness(mesh, &faces) {
        neighbours[a as usize].push(b);
        neighbours[b as usize].push(a);
        let merged = moments[a as usize]
            .as_ref()
            .expect("live")
            .merge(moments[b as usize].as_ref().expect("live"));
        push(&mut heap, &merged, a, b, 0, 0);
    }
    let mut live = n;
    let mut out = Vec::new();
    let mut targets = targets.iter().copied().peekable();
    let snapshot = |members: &Vec<Vec<u32>>, moments: &Vec<Option<Moments>>| -> Vec<Cluster> {
        members
            .iter()
            .zip(moments)
            .filter_map(|(m, s)| s.map(|s| (m.clone(), s)))
            .collect()
    };
    let mut last = usize::MAX;
    // Merges leave stale pairs behind, skipped when popped; once they are most of the heap
    // they are dropped, so that it stays small enough to pop from quickly. The least pair
    // still valid is the same either way.
    let mut compacted = heap.len();
    while let Some(&target) = targets.peek() {
        if heap.len() > 2 * compacted.max(1024) {
            heap.retain(|Reverse((_, a, b, va, vb))| {
                let (a, b) = (*a as usize, *b as usize);
                version[a] == *va
                    && version[b] == *vb
                    && moments[a].is_some()
                    && moments[b].is_some()
            });
            compacted = heap.len();
        }
        if live <= target {
            if live != last {
                out.push(snapshot(&members, &moments));
                last = live;
            }
            targets.next();
            continue;
        }
        let Some(Reverse((_, a, b, va, vb))) = heap.pop() else {
            // No merge allowed: what is left is the last snapshot.
            if live != last {
                out.push(snapshot(&members, &moments));
            }
            break;
        };
        let (a, b) = (a as usize, b as usize);
        if version[a] != va || version[b] != vb || moments[a].is_none() || moments[b].is_none() {
            continue;
        }
        let merged = moments[a].expect("live").merge(&moments[b].expect("live"));
        moments[a] = Some(merged);
        moments[b] = None;
        let taken = std::mem::take(&mut members[b]);
        members[a].extend(taken);
        version[a] += 1;
        live -= 1;
        let mut around = std::mem::take(&mut neighbours[a]);
        around.extend(std::mem::take(&mut neighbours[b]));
        around.retain(|&c| c as usize != a && c as usize != b);
        around.sort_unstable();
        around.dedup();
        for &c in &around {
            let list = &mut neighbours[c as usize];
            list.retain(|&x| x as usize != b);
            if !list.contains(&(a as u32)) {
                list.push(a as u32);
            }
            let m = merged.merge(moments[c as usize].as_ref().expect("live"));
            let (lo, hi) = ((a as u32).min(c), (a as u32).max(c));
            push(
                &mut heap,
                &m,
                lo,
                hi,
                version[lo as usize],
                version[hi as usize],
            );
        }
        neighbours[a] = around;
    }
    out
}

/// One plane of the cloud: its texture (baked along its normal) and where the plane lies.
/// Drawn from both sides, as billboard clouds are: a face can look at the viewer while its
/// cluster's plane looks away (up to 60 degrees apart), so culling planes from behind loses
/// much of every silhouette.
struct Card {
    map: ReliefMap,
    /// A point of the plane.
    centre: [f64; 3],
    /// The texels of `map` that hold a surface: only pixels that see them can be drawn.
    occupied: PixelBox,
}

/// A billboard cloud.
pub struct BillboardCloud {
    cards: Vec<Card>,
    triangles: usize,
}

/// `scratch` (with the model's materials) made the cluster's triangles alone.
fn submesh_into(mesh: &Mesh, triangles: &[u32], scratch: &mut Mesh) {
    let corners: Vec<u32> = triangles
        .iter()
        .flat_map(|&t| mesh.triangles[t as usize])
        .collect();
    let order: Vec<usize> = triangles.iter().map(|&t| t as usize).collect();
    crate::simplified::compact_into(mesh, &corners, &order, scratch);
}

impl BillboardCloud {
    /// The cloud of the clusters left at each of `counts` (descending), each with textures
    /// filling `budget`; layouts whose textures cannot fill it within 5 % are left out.
    pub fn bake_all(
        mesh: &Mesh,
        counts: &[usize],
        budget: u64,
    ) -> Result<Vec<BillboardCloud>, RivalError> {
        let bad = |reason: String| RivalError::Bake {
            technique: Technique::BillboardCloud.name(),
            reason,
        };
        let mut clouds = Vec::new();
        let textures = Arc::new(Textures::new(mesh));
        let (centre, radius) = crate::bounding_sphere(mesh, Technique::BillboardCloud)?;
        let snapshots = cluster(mesh, centre, radius, counts);
        if snapshots.iter().all(|s| s.is_empty()) {
            return Err(bad("no triangle has an area".into()));
        }
        for clusters in snapshots {
            // Per cluster: its frame, a point of its plane, and the side of its texture's
            // window. Its sub-mesh is made in a scratch mesh per worker while its card is
            // baked with the model's decoded textures, so that neither memory nor time goes
            // to copies of the textures.
            let planes: Vec<(&[u32], Frame, [f64; 3], f64)> = clusters
                .iter()
                .map(|(members, moments)| {
                    let plane = moments.plane();
                    let frame = Frame::from_direction(plane.normal);
                    let corners: Vec<[f32; 3]> = members
                        .iter()
                        .flat_map(|&t| mesh.triangles[t as usize])
                        .map(|v| mesh.positions[v as usize])
                        .collect();
                    let side = OrthoView::fit(frame, &corners, 8, 0)
                        .map(|v| 2.0 * v.half_size)
                        .unwrap_or(0.0);
                    (members.as_slice(), frame, add(plane.centre, centre), side)
                })
                .collect();
            // The largest texel density (texels per unit length) whose textures fit.
            let edge = |density: f64, side: f64| -> u32 {
                let texels = (side * density).ceil() as u64 + 2;
                (texels.div_ceil(4) * 4).clamp(8, 1024) as u32
            };
            let bytes = |density: f64| -> u64 {
                let texels = planes
                    .iter()
                    .map(|p| u64::from(edge(density, p.3)).pow(2))
                    .sum();
                billboard_bytes(texels) + CARD_BYTES * planes.len() as u64
            };
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            while bytes(hi) <= budget && hi < 1e12 {
                hi *= 2.0;
            }
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if bytes(mid) <= budget {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            if !(bytes(lo) <= budget && within_budget(bytes(lo), budget)) {
                continue;
            }
            let cards = planes
                .par_iter()
                // At most 64 scratch meshes per cloud, however the work is split.
                .with_min_len(planes.len().div_ceil(64).max(1))
                .map_init(
                    // The model's textures are read decoded, from `textures`.
                    || crate::simplified::materials_only(mesh),
                    |scratch, (members, frame, centre, side)| {
                        let params = BakeParams {
                            resolution: edge(lo, *side),
                            supersample: 2,
                            margin: 1,
                        };
                        submesh_into(mesh, members, scratch);
                        let mut set = Baker::with_textures(scratch, textures.clone())
                            .bake_any_resolution(&[frame.d], &params)
                            .map_err(|e| bad(e.to_string()))?;
                        let map = set.maps.pop().expect("one direction, one map");
                        Ok(Card {
                            occupied: PixelBox::occupied(&map),
                            map,
                            centre: *centre,
                        })
                    },
                )
                .collect::<Result<Vec<_>, RivalError>>()?;
            clouds.push(BillboardCloud {
                cards,
                triangles: mesh.triangles.len(),
            });
        }
        Ok(clouds)
    }

    /// Cloud sizes tried for a budget.
    pub const COUNTS: [usize; 4] = [4096, 2048, 1024, 512];
}

impl Rival for BillboardCloud {
    fn technique(&self) -> Technique {
        Technique::BillboardCloud
    }

    fn bytes(&self) -> u64 {
        let texels = self
            .cards
            .iter()
            .map(|c| u64::from(c.map.size()).pow(2))
            .sum();
        billboard_bytes(texels) + CARD_BYTES * self.cards.len() as u64
    }

    fn layout(&self) -> String {
        format!(
            "{} planes from {} triangles",
            self.cards.len(),
            self.triangles
        )
    }

    fn primitive(&self) -> Primitive {
        Primitive::Quads
    }

    fn draw(&self, view: &OrthoView) -> Result<Drawn, RivalError> {
        let w = view.frame.d;
        let mut render = Render::empty(view.size);
        let mut nearest = vec![f64::NEG_INFINITY; view.size as usize * view.size as usize];
        let mut drawn = 0;
        for card in &self.cards {
            let f = &card.map.view.frame;
            // Drawn from both sides (billboard clouds are not culled), lit from the side seen.
            let facing = dot(f.d, w);
            if facing == 0.0 {
                continue;
            }
            let side = if facing > 0.0 { 1.0 } else { -1.0 };
            drawn += 1;
            let Some(hits) = quad_hits(view, &card.map, card.centre) else {
                continue;
            };
            let window = window_pixels(view, &card.map, card.centre, card.occupied);
            for (x, y, i) in window.pixels(view.size) {
                let [tx, ty, height] = hits.at(x, y);
                let Some(t) = texel_at(&card.map, tx, ty) else {
                    continue;
                };
                if height <= nearest[i] {
                    continue;
                }
                nearest[i] = height;
                render.coverage.set(i);
                render.depth[i] = view.depth_of_height(height) as f32;
                render.albedo[i] = card.map.albedo[t];
                render.normal[i] = world_normal(&card.map, t).map(|c| side * c);
            }
        }
        Ok(Drawn {
            render,
            count: drawn,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_drawn_over_its_occupied_texels_draws_what_its_whole_window_draws() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/models/stanford/bunny/bunny_npm_lowres.obj"
        );
        let mesh = ori_mesh::load_file(path.as_ref(), &Default::default())
            .unwrap()
            .mesh;
        // Small textures seen at 512 pixels: a texel spans pixels, so a box a texel short of
        // the surface would miss some (checked to fail that way).
        let cloud = BillboardCloud::bake_all(&mesh, &[256], 60_000)
            .unwrap()
            .pop()
            .unwrap();
        let whole = BillboardCloud {
            cards: cloud
                .cards
                .iter()
                .map(|c| Card {
                    map: c.map.clone(),
                    centre: c.centre,
                    occupied: PixelBox::whole(c.map.size() as usize),
                })
                .collect(),
            triangles: cloud.triangles,
        };
        let area = |b: PixelBox| (b.x1.saturating_sub(b.x0)) * (b.y1.saturating_sub(b.y0));
        let occupied: usize = cloud.cards.iter().map(|c| area(c.occupied)).sum();
        let windows: usize = whole.cards.iter().map(|c| area(c.occupied)).sum();
        assert!(
            occupied * 10 < windows * 9,
            "{occupied} of {windows} texels"
        );
        let directions = ori_views::held_out_directions(ori_views::DEFAULT_HELD_OUT_SEED);
        for &w in directions.iter().step_by(97) {
            let view = ori_eval::eval_view(&mesh, w, 512).unwrap();
            let [tight, all] = [&cloud, &whole].map(|c| c.draw(&view).unwrap().render);
            assert!(tight.coverage.count() > 0);
            // Bit for bit (depth is NaN where nothing is drawn, and NaN != NaN).
            let bits = |r: &Render| -> Vec<u32> { r.depth.iter().map(|d| d.to_bits()).collect() };
            assert!(
                tight.coverage == all.coverage && bits(&tight) == bits(&all),
                "{w:?}"
            );
            assert!(
                tight.albedo == all.albedo && tight.normal == all.normal,
                "{w:?}"
            );
        }
    }
}
