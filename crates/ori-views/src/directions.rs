//! Direction sets generated in code: icosahedron face centroids and their geodesic
//! subdivisions, and the six axes of the relief-texture box.
//!
//! Only `+ - * /` and `sqrt` are used, so every set is bit-identical on every machine.

/// The 12 icosahedron vertices `(0, ±1, ±phi)`, `(±1, ±phi, 0)`, `(±phi, 0, ±1)`, in this
/// order (signs `+` before `-`, first the first coordinate's sign, then the second's), not yet
/// normalised.
fn icosahedron_vertices() -> [[f64; 3]; 12] {
    let phi = 0.5 * (1.0 + 5f64.sqrt());
    let mut out = [[0.0; 3]; 12];
    let mut i = 0;
    for shape in 0..3 {
        for s1 in [1.0, -1.0] {
            for s2 in [1.0, -1.0] {
                out[i] = match shape {
                    0 => [0.0, s1, s2 * phi],
                    1 => [s1, s2 * phi, 0.0],
                    _ => [s1 * phi, 0.0, s2],
                };
                i += 1;
            }
        }
    }
    out
}

/// The 20 faces of the unit icosahedron as vertex triples, outward (counter-clockwise seen
/// from outside), in lexicographic order of their sorted vertex indices.
fn icosahedron_faces() -> Vec<[[f64; 3]; 3]> {
    let raw = icosahedron_vertices();
    let unit = raw.map(normalize);
    let mut faces = Vec::with_capacity(20);
    // Edges have squared length 4; the next-nearest vertices are at (2 phi)^2 ~ 10.5.
    let adjacent = |i: usize, j: usize| dist2(raw[i], raw[j]) < 5.0;
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if adjacent(i, j) && adjacent(j, k) && adjacent(i, k) {
                    let (a, b, c) = (unit[i], unit[j], unit[k]);
                    let outward = dot(cross(sub(b, a), sub(c, a)), add(add(a, b), c)) > 0.0;
                    faces.push(if outward { [a, b, c] } else { [a, c, b] });
                }
            }
        }
    }
    debug_assert_eq!(faces.len(), 20);
    faces
}

/// Spherical triangles of the icosahedron subdivided `subdivisions` times. Each step splits a
/// triangle `(a, b, c)` into `(a, ab, ca)`, `(ab, b, bc)`, `(ca, bc, c)`, `(ab, bc, ca)` with
/// edge midpoints pushed out to the unit sphere, so triangle `j` of one level lies inside
/// triangle `j / 4` of the level before.
pub(crate) fn geodesic_triangles(subdivisions: u32) -> Vec<[[f64; 3]; 3]> {
    let mut faces = icosahedron_faces();
    for _ in 0..subdivisions {
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (midpoint(a, b), midpoint(b, c), midpoint(c, a));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    faces
}

/// Unit directions towards the face centroids of the icosahedron subdivided `subdivisions`
/// times: 20 x 4^subdivisions of them (0: 20, 1: 80, 2: 320, 3: 1280, 4: 5120).
///
/// Subdivision is geodesic: every triangle is split in four at its edge midpoints, which are
/// pushed out to the unit sphere. Order: the 20 icosahedron faces in a fixed order, then each
/// face's four children in turn, so direction `j` of one level lies inside the spherical
/// triangle of direction `j / 4` of the level before. Deterministic and bit-identical on
/// every machine. The set is centrally symmetric (for each direction its opposite is in it).
///
/// # Panics
/// When `subdivisions > 8` (1.3 million directions), which is surely a mistake.
pub fn icosahedron_directions(subdivisions: u32) -> Vec<[f64; 3]> {
    assert!(
        subdivisions <= 8,
        "icosahedron_directions: {subdivisions} subdivisions is too many (at most 8)"
    );
    geodesic_triangles(subdivisions)
        .iter()
        .map(|&[a, b, c]| normalize(add(add(a, b), c)))
        .collect()
}

/// The six axis directions `+X, -X, +Y, -Y, +Z, -Z`: the faces of the relief-texture box
/// (Oliveira et al., as used in `papers/mixed-polygons-relief-textures.txt`).
pub fn axis_directions() -> [[f64; 3]; 6] {
    [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ]
}

/// How many regular directions [`held_out_directions`] starts with (`icosahedron_directions(3)`).
pub const HELD_OUT_REGULAR: usize = REGULAR_COUNTS[4];
/// How many seeded random directions [`held_out_directions`] adds to the regular ones.
pub const HELD_OUT_RANDOM: usize = 2000;

/// The seed of the held-out directions unless one is asked for.
pub const DEFAULT_HELD_OUT_SEED: u64 = 1;

/// Directions that no stage chooses anything at, for measuring quality where the runtime
/// draws: the 1280 of `icosahedron_directions(3)` (none is a table direction, but a quarter
/// of them, each table triangle's middle child, lie within 0.0051 degrees of one), then
/// [`HELD_OUT_RANDOM`] directions uniform on the sphere drawn from `seed` (SplitMix64, then
/// `z` uniform in `[-1, 1)` and the azimuth uniform, with `ori_math::sin_cos` and `sqrt`, so
/// the set is bit-identical on every machine).
pub fn held_out_directions(seed: u64) -> Vec<[f64; 3]> {
    let mut state = seed;
    let mut next = || {
        // SplitMix64 (Steele, Lea, Flood 2014); the top 53 bits as a fraction in [0, 1).
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut directions = icosahedron_directions(3);
    for _ in 0..HELD_OUT_RANDOM {
        let z = 1.0 - 2.0 * next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (sin, cos) = ori_math::sin_cos(std::f64::consts::TAU * next());
        directions.push([r * cos, r * sin, z]);
    }
    directions
}

/// The 320 evaluation and selection directions of `GUIDE.md`: the icosahedron subdivided
/// twice, `icosahedron_directions(2)`.
pub fn evaluation_directions() -> Vec<[f64; 3]> {
    icosahedron_directions(2)
}

/// The directions around each evaluation direction that the runtime serves from its table
/// entry (the lookup picks the nearest entry, so each entry serves about its spherical
/// triangle): a grid over the triangle with `steps` steps along each edge. The error of a
/// fixed subset changes smoothly but not linearly over a triangle (on the Stanford bunny it
/// peaked between a corner and the centre, where corners and edge midpoints did not look),
/// so a finer grid leaves less to chance between its points. None of the samples is a
/// held-out direction (those are the centroids of the next subdivision's triangles, or
/// random) or an evaluation direction.
#[derive(Clone, Debug, PartialEq)]
pub struct EvaluationRegions {
    /// Each grid point once (neighbouring triangles share corners and edge points), in order
    /// of first use by the evaluation directions.
    pub samples: Vec<[f64; 3]>,
    /// For evaluation direction `i`: its three corners, then the other grid points of its
    /// triangle, as indices into `samples`.
    pub of_direction: Vec<Vec<usize>>,
}

/// [`EvaluationRegions`] of [`evaluation_directions`], `steps` (at least 1) steps along each
/// edge. For triangle `(a, b, c)`: the corners `a, b, c`, then `normalize((i a + j b) + k c)`
/// for `i` from `steps - 1` down to 0 and `j` from `steps - i` down to 0, `k = steps - i - j`,
/// the corners and the centre (the evaluation direction itself) left out. With 2 steps: 162
/// corners and 480 edge midpoints; with 4: 162 corners, 1440 edge points and 960 inner points.
pub fn evaluation_regions(steps: usize) -> EvaluationRegions {
    let steps = steps.max(1);
    let mut samples = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut of_direction = Vec::new();
    for [a, b, c] in geodesic_triangles(2) {
        let mut points = vec![a, b, c];
        for i in (0..steps).rev() {
            for j in (0..=steps - i).rev() {
                let k = steps - i - j;
                if j == steps || k == steps || (i == j && j == k) {
                    continue;
                }
                // Integer weights; a zero weight adds exact zeros, so the neighbouring
                // triangle computes an edge point with equal bits.
                let [wi, wj, wk] = [i, j, k].map(|w| w as f64);
                points.push(normalize(add(
                    add(scale(a, wi), scale(b, wj)),
                    scale(c, wk),
                )));
            }
        }
        let indices = points
            .iter()
            .map(|p| {
                *index.entry(p.map(f64::to_bits)).or_insert_with(|| {
                    samples.push(*p);
                    samples.len() - 1
                })
            })
            .collect();
        of_direction.push(indices);
    }
    EvaluationRegions {
        samples,
        of_direction,
    }
}

impl EvaluationRegions {
    /// These regions made the cells the runtime serves from each entry (it draws a direction
    /// with its nearest entry): where the triangles are not regular a cell reaches a little
    /// past its triangle, so each entry's cell corners (`cell_corners`) are added (unless
    /// within [`SAME_DIRECTION`] of a sample it has), and parts of a triangle belong to a
    /// neighbour's cell, so each entry then keeps only the samples it serves or nearly
    /// serves: `dot(p, own) >= max over entries of dot(p, entry) - CELL_MARGIN`. Samples no
    /// entry keeps are dropped, the rest renumbered in order of first use.
    pub fn to_cells(mut self) -> EvaluationRegions {
        let directions = evaluation_directions();
        let corners = cell_corners();
        let mut added: Vec<Option<usize>> = vec![None; corners.corners.len()];
        for (entry, of_entry) in corners.of_direction.iter().enumerate() {
            for &c in of_entry {
                let v = corners.corners[c];
                let samples = &self.samples;
                let known = self.of_direction[entry]
                    .iter()
                    .any(|&s| 1.0 - dot(samples[s], v) < SAME_DIRECTION);
                if known {
                    continue;
                }
                let index = *added[c].get_or_insert_with(|| {
                    self.samples.push(v);
                    self.samples.len() - 1
                });
                self.of_direction[entry].push(index);
            }
        }
        let nearest: Vec<f64> = self
            .samples
            .iter()
            .map(|&p| nearest_dot(&directions, p))
            .collect();
        let mut renumbered: Vec<Option<usize>> = vec![None; self.samples.len()];
        let mut samples = Vec::new();
        for (entry, of_entry) in self.of_direction.iter_mut().enumerate() {
            of_entry
                .retain(|&s| dot(self.samples[s], directions[entry]) >= nearest[s] - CELL_MARGIN);
            for s in of_entry.iter_mut() {
                *s = *renumbered[*s].get_or_insert_with(|| {
                    samples.push(self.samples[*s]);
                    samples.len() - 1
                });
            }
        }
        self.samples = samples;
        self
    }
}

/// How far into a neighbour's cell an entry's region reaches, in `dot`: about 0.9 degrees
/// past the edge between two neighbouring cells, a third of the grid's step at the default
/// 6 steps. Without it the samples on a shared edge serve one side only, and the errors
/// between grid points near an edge go unmeasured on the other.
pub(crate) const CELL_MARGIN: f64 = 0.003;

/// The largest `dot(p, d)` over `directions`.
fn nearest_dot(directions: &[[f64; 3]], p: [f64; 3]) -> f64 {
    directions
        .iter()
        .map(|&d| dot(p, d))
        .fold(f64::MIN, f64::max)
}

/// Two unit directions closer than this in `1 - dot` are one corner (about 1.4e-6 radians;
/// the same corner computed from different triples differs by rounding only).
const SAME_DIRECTION: f64 = 1e-12;

/// The corners of the cells of [`evaluation_directions`] on the sphere (each direction's
/// cell: the directions nearer to it than to any other), and which entries meet at each.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CellCorners {
    /// Each corner once, in order of discovery.
    pub(crate) corners: Vec<[f64; 3]>,
    /// For evaluation direction `i`: the corners of its cell, as indices into `corners`.
    pub(crate) of_direction: Vec<Vec<usize>>,
}

/// [`CellCorners`] of the evaluation directions `t`: for `a < b < c` with the three pairwise
/// `dot > 0.9`, `v = normalize(cross(b - a, c - a))`, negated if `dot(v, a) < 0`; kept if no
/// direction has `dot(v, d) > dot(v, a) + 1e-9` (no entry nearer) and no kept corner is the
/// same direction ([`SAME_DIRECTION`]). Each corner belongs to every entry `d` with
/// `dot(v, d) >= max_d dot(v, d) - 1e-9` (three, or more where more cells meet).
pub(crate) fn cell_corners() -> CellCorners {
    const NEAR: f64 = 0.9;
    const TIE: f64 = 1e-9;
    let t = evaluation_directions();
    let near: Vec<Vec<usize>> = (0..t.len())
        .map(|a| {
            (a + 1..t.len())
                .filter(|&b| dot(t[a], t[b]) > NEAR)
                .collect()
        })
        .collect();
    // Each corner with its `nearest_dot`, which also decides its entries below.
    let mut corners: Vec<([f64; 3], f64)> = Vec::new();
    for (a, after_a) in near.iter().enumerate() {
        for (i, &b) in after_a.iter().enumerate() {
            for &c in &after_a[i + 1..] {
                if dot(t[b], t[c]) <= NEAR {
                    continue;
                }
                let mut v = normalize(cross(sub(t[b], t[a]), sub(t[c], t[a])));
                if dot(v, t[a]) < 0.0 {
                    v = v.map(|x| -x);
                }
                let nearest = nearest_dot(&t, v);
                if nearest > dot(v, t[a]) + TIE
                    || corners
                        .iter()
                        .any(|&(k, _)| 1.0 - dot(k, v) < SAME_DIRECTION)
                {
                    continue;
                }
                corners.push((v, nearest));
            }
        }
    }
    let mut of_direction = vec![Vec::new(); t.len()];
    for (k, &(v, nearest)) in corners.iter().enumerate() {
        for (entry, &d) in t.iter().enumerate() {
            if dot(v, d) >= nearest - TIE {
                of_direction[entry].push(k);
            }
        }
    }
    CellCorners {
        corners: corners.into_iter().map(|(v, _)| v).collect(),
        of_direction,
    }
}

/// The 162 corners of the evaluation triangles, in order of first use: the directions
/// farthest from every evaluation direction, where the runtime's nearest entry serves a view
/// least well.
pub fn evaluation_corners() -> Vec<[f64; 3]> {
    evaluation_regions(1).samples
}

/// Sizes of the regularly spaced sets: the axis box, then the icosahedron levels 0 to 4.
pub(crate) const REGULAR_COUNTS: [usize; 6] = [6, 20, 80, 320, 1280, 5120];

/// The regularly spaced set of `count` directions, if there is one.
pub(crate) fn regular_directions(count: usize) -> Option<Vec<[f64; 3]>> {
    match count {
        6 => Some(axis_directions().to_vec()),
        _ => (0..5)
            .find(|&level| 20 << (2 * level) == count)
            .map(icosahedron_directions),
    }
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = sub(a, b);
    dot(d, d)
}

pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let len = dot(a, a).sqrt();
    a.map(|x| x / len)
}

/// Midpoint of the arc between unit vectors `a` and `b` (symmetric in `a`, `b`, bit for bit,
/// so neighbouring triangles share their new vertices exactly).
fn midpoint(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    normalize(add(a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether unit vector `p` lies inside the spherical triangle `(a, b, c)` (outward).
    fn inside(p: [f64; 3], [a, b, c]: [[f64; 3]; 3]) -> bool {
        let eps = -1e-12;
        dot(cross(a, b), p) > eps && dot(cross(b, c), p) > eps && dot(cross(c, a), p) > eps
    }

    #[test]
    fn children_lie_inside_their_parent() {
        for level in 0..3 {
            let parents = geodesic_triangles(level);
            let children = icosahedron_directions(level + 1);
            for (j, &child) in children.iter().enumerate() {
                assert!(
                    inside(child, parents[j / 4]),
                    "level {level}, direction {j}"
                );
            }
        }
    }

    #[test]
    fn faces_are_outward_and_equilateral() {
        let faces = icosahedron_faces();
        for [a, b, c] in faces {
            assert!(dot(cross(sub(b, a), sub(c, a)), a) > 0.0);
            let e = dist2(a, b);
            assert!((dist2(b, c) - e).abs() < 1e-12 && (dist2(c, a) - e).abs() < 1e-12);
        }
    }

    #[test]
    fn regions_are_grids_over_the_triangles_of_the_evaluation_directions() {
        let directions = evaluation_directions();
        let triangles = geodesic_triangles(2);
        let held_out = held_out_directions(DEFAULT_HELD_OUT_SEED);
        let corners = evaluation_corners();
        assert_eq!(corners.len(), 162);
        for steps in [1, 2, 3, 4, 5, 6] {
            let regions = evaluation_regions(steps);
            // Euler: 162 vertices and 480 edges of the 320 triangles; each sample once.
            let inner = (steps - 1) * steps.saturating_sub(2) / 2 - usize::from(steps % 3 == 0);
            assert_eq!(
                regions.samples.len(),
                162 + (steps - 1) * 480 + inner * 320,
                "{steps} steps"
            );
            assert_eq!(regions.of_direction.len(), directions.len());
            for (i, samples) in regions.of_direction.iter().enumerate() {
                assert_eq!(samples.len(), 3 + 3 * (steps - 1) + inner);
                for s in &samples[..3] {
                    assert!(corners.contains(&regions.samples[*s]));
                }
                for &s in samples {
                    let p = regions.samples[s];
                    // In the triangle, and nearer to its own direction than to any entry
                    // outside the neighbouring triangles.
                    assert!(inside(p, triangles[i]), "direction {i}");
                    let own = dot(p, directions[i]);
                    let beaten = directions
                        .iter()
                        .filter(|&&d| dot(p, d) > own + 1e-9)
                        .count();
                    assert!(
                        beaten <= 5,
                        "direction {i}, sample {s}: {beaten} nearer entries"
                    );
                    assert!(!held_out.contains(&p) && !directions.contains(&p));
                }
            }
        }
    }

    #[test]
    fn cell_corners_are_equidistant_from_their_entries_and_reach_past_the_triangles() {
        let directions = evaluation_directions();
        let triangles = geodesic_triangles(2);
        let cells = cell_corners();
        let mut outside = 0;
        for (i, of_entry) in cells.of_direction.iter().enumerate() {
            // A cell of this near-regular tiling has five to nine corners (a pentagon or
            // hexagon, or a hexagon whose near-cocircular corners split in two).
            assert!((5..=9).contains(&of_entry.len()), "entry {i}: {of_entry:?}");
            for &k in of_entry {
                let v = cells.corners[k];
                let own = dot(v, directions[i]);
                assert!(
                    own >= nearest_dot(&directions, v) - 1e-9,
                    "entry {i}, corner {k}"
                );
                outside += usize::from(!inside(v, triangles[i]));
            }
        }
        for k in 0..cells.corners.len() {
            let entries = cells.of_direction.iter().filter(|c| c.contains(&k)).count();
            assert!(entries >= 3, "corner {k}: {entries} entries");
        }
        assert!(outside > 0, "no cell corner outside its entry's triangle");
    }

    #[test]
    fn cell_regions_hold_what_each_entry_serves_and_nothing_far_past_it() {
        let directions = evaluation_directions();
        let held_out = held_out_directions(DEFAULT_HELD_OUT_SEED);
        for steps in [2, 6] {
            let grid = evaluation_regions(steps);
            let cells = evaluation_regions(steps).to_cells();
            let mut used = vec![false; cells.samples.len()];
            for (entry, samples) in cells.of_direction.iter().enumerate() {
                for (j, &a) in samples.iter().enumerate() {
                    used[a] = true;
                    let p = cells.samples[a];
                    let nearest = nearest_dot(&directions, p);
                    assert!(dot(p, directions[entry]) >= nearest - CELL_MARGIN);
                    assert!(!held_out.contains(&p) && !directions.contains(&p));
                    for &b in &samples[j + 1..] {
                        assert!(1.0 - dot(p, cells.samples[b]) >= SAME_DIRECTION);
                    }
                }
                // The grid's samples an entry serves stay in its region.
                for &g in &grid.of_direction[entry] {
                    let p = grid.samples[g];
                    if dot(p, directions[entry]) >= nearest_dot(&directions, p) - 1e-9 {
                        assert!(samples.iter().any(|&s| cells.samples[s] == p));
                    }
                }
            }
            assert!(
                used.iter().all(|&u| u),
                "{steps} steps: a sample no entry measures"
            );
            // Every direction is served: each held-out direction's nearest entry has a sample
            // (or its own direction) within a grid step (a level-2 edge is about 0.2775
            // radians) of it.
            let step = (0.2775 / steps as f64).cos();
            for &h in &held_out {
                let entry = (0..directions.len())
                    .max_by(|&a, &b| dot(h, directions[a]).total_cmp(&dot(h, directions[b])))
                    .unwrap();
                let near = dot(h, directions[entry]) > step
                    || cells.of_direction[entry]
                        .iter()
                        .any(|&s| dot(h, cells.samples[s]) > step);
                assert!(
                    near,
                    "{steps} steps: held-out {h:?} far from entry {entry}'s samples"
                );
            }
        }
    }

    #[test]
    fn regular_sets_exist_for_the_listed_counts_only() {
        for n in REGULAR_COUNTS {
            assert_eq!(regular_directions(n).map(|d| d.len()), Some(n));
        }
        for n in [0, 1, 5, 7, 19, 21, 40, 20480] {
            assert!(regular_directions(n).is_none(), "{n}");
        }
    }
}
