//! Relief maps of real models: depth on the surface, colours where they belong, holes where
//! alpha says so, identical bytes for any thread count, bad geometry handled.

use std::path::{Path, PathBuf};

use ori_bake::{BakeParams, EMPTY_DEPTH, MAX_DEPTH, ReliefMap, bake};
use ori_mesh::{AlphaMode, LoadOptions, Mesh, load_file};

fn model(rel: &str) -> Mesh {
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/models")
        .join(rel);
    load_file(&path, &LoadOptions::default()).unwrap().mesh
}

/// The first surface along the ray through a texel centre, found independently of the
/// rasterizer: triangles binned by their pixel bounding box, exact barycentric tests, and
/// single-sided triangles culled by the sign of their world normal along the map direction.
struct RayCaster<'m> {
    mesh: &'m Mesh,
    single_sided: Vec<bool>,
    map: &'m ReliefMap,
    cells: Vec<Vec<u32>>,
    cell: usize,
    grid: usize,
}

const CELL: usize = 8;

impl<'m> RayCaster<'m> {
    fn new(mesh: &'m Mesh, map: &'m ReliefMap) -> Self {
        let n = map.size() as usize;
        let grid = n.div_ceil(CELL);
        let mut cells = vec![Vec::new(); grid * grid];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let p = tri.map(|i| map.view.project(mesh.positions[i as usize].map(f64::from)));
            let lo = |k: usize| p.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min);
            let hi = |k: usize| p.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max);
            let cx = |v: f64| ((v / CELL as f64).floor().max(0.0) as usize).min(grid - 1);
            for cy in cx(lo(1))..=cx(hi(1)) {
                for cxx in cx(lo(0))..=cx(hi(0)) {
                    cells[cy * grid + cxx].push(t as u32);
                }
            }
        }
        RayCaster {
            mesh,
            single_sided: mesh.single_sided(),
            map,
            cells,
            cell: CELL,
            grid,
        }
    }

    /// (height, triangle, barycentrics) of the nearest hit at pixel coordinates (x, y).
    fn cast(&self, x: f64, y: f64) -> Option<(f64, u32, [f64; 3])> {
        let c = (y as usize / self.cell).min(self.grid - 1) * self.grid
            + (x as usize / self.cell).min(self.grid - 1);
        let mut best: Option<(f64, u32, [f64; 3])> = None;
        for &t in &self.cells[c] {
            let n = ori_mesh::face_normal(&self.mesh.positions, self.mesh.triangles[t as usize]);
            let d = self.map.view.frame.d;
            let facing = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            if self.single_sided[t as usize] && facing <= 0.0 {
                continue;
            }
            let p = self.mesh.triangles[t as usize].map(|i| {
                self.map
                    .view
                    .project(self.mesh.positions[i as usize].map(f64::from))
            });
            let area = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
            if area == 0.0 {
                continue;
            }
            let w1 =
                ((x - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (y - p[0][1])) / area;
            let w2 =
                ((p[1][0] - p[0][0]) * (y - p[0][1]) - (x - p[0][0]) * (p[1][1] - p[0][1])) / area;
            let w0 = 1.0 - w1 - w2;
            let eps = -1e-9;
            if w0 < eps || w1 < eps || w2 < eps {
                continue;
            }
            let h = w0 * p[0][2] + w1 * p[1][2] + w2 * p[2][2];
            if best.is_none_or(|b| h > b.0) {
                best = Some((h, t, [w0, w1, w2]));
            }
        }
        best
    }
}

fn icosahedron() -> Vec<[f64; 3]> {
    ori_views::icosahedron_directions(0)
}

#[test]
fn every_bunny_texel_lies_on_the_surface_within_half_a_depth_step() {
    let mesh = model("stanford/bunny/stanford-bunny.obj");
    let set = bake(&mesh, &icosahedron(), &BakeParams::default()).unwrap();
    assert_eq!(set.maps.len(), 20);
    let mut checked = 0;
    for (m, map) in set.maps.iter().enumerate() {
        let caster = RayCaster::new(&mesh, map);
        let n = map.size() as usize;
        let step = map.view.near - map.view.far;
        for y in 0..n {
            for x in 0..n {
                let code = map.depth[y * n + x];
                if code == EMPTY_DEPTH {
                    continue;
                }
                // An edge texel (centre off the mesh) holds the nearest of its 2 x 2
                // sub-samples that hit.
                let centre = caster.cast(x as f64 + 0.5, y as f64 + 0.5).map(|c| c.0);
                let edge = || {
                    [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)]
                        .iter()
                        .filter_map(|&(dx, dy)| caster.cast(x as f64 + dx, y as f64 + dy))
                        .map(|c| c.0)
                        .reduce(f64::max)
                };
                let h = centre
                    .or_else(edge)
                    .unwrap_or_else(|| panic!("map {m} texel ({x}, {y}) is not on the mesh"));
                let exact = map.view.depth_of_height(h);
                let stored = f64::from(code) / f64::from(MAX_DEPTH);
                let err = (exact - stored).abs() * f64::from(MAX_DEPTH);
                assert!(
                    err <= 0.5 + 1e-6,
                    "map {m} texel ({x}, {y}): {err} depth steps off (range {step})"
                );
                checked += 1;
            }
        }
        assert!(
            map.covered() > n * n / 5,
            "map {m} covers {} texels",
            map.covered()
        );
    }
    assert!(checked > 20 * 10_000);
}

fn srgb_encode(l: f64) -> f64 {
    ori_math::linear_to_srgb(l) * 255.0
}

#[test]
fn duck_texture_lands_where_it_should() {
    let mesh = model("gltf/Duck/Duck.glb");
    let tex = &mesh.textures[0];
    // One texel per texture texel or finer, so the comparison with the texel under the exact
    // hit point is meaningful (filtering aside).
    let params = BakeParams {
        resolution: 512,
        supersample: 1,
        margin: 2,
    };
    let set = bake(&mesh, &ori_views::axis_directions(), &params).unwrap();
    let uvs = mesh.uvs.as_ref().unwrap();
    let mut diffs = Vec::new();
    for map in &set.maps {
        let caster = RayCaster::new(&mesh, map);
        let n = map.size() as usize;
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let interior = (0..3).all(|dy| {
                    (0..3).all(|dx| map.depth[(y + dy - 1) * n + x + dx - 1] != EMPTY_DEPTH)
                });
                if !interior {
                    continue;
                }
                let Some((_, t, b)) = caster.cast(x as f64 + 0.5, y as f64 + 0.5) else {
                    continue;
                };
                let tri = mesh.triangles[t as usize];
                let uv = (0..2)
                    .map(|k| {
                        (0..3)
                            .map(|c| b[c] * f64::from(uvs[tri[c] as usize][k]))
                            .sum::<f64>()
                    })
                    .collect::<Vec<_>>();
                let tx = ((uv[0].rem_euclid(1.0) * tex.width as f64) as usize)
                    .min(tex.width as usize - 1);
                let ty = ((uv[1].rem_euclid(1.0) * tex.height as f64) as usize)
                    .min(tex.height as usize - 1);
                let texel = &tex.rgba8[(ty * tex.width as usize + tx) * 4..][..3];
                let baked = map.albedo[y * n + x];
                let d: f64 = (0..3)
                    .map(|k| (f64::from(baked[k]) - f64::from(texel[k])).abs())
                    .sum::<f64>()
                    / 3.0;
                diffs.push(d);
            }
        }
    }
    diffs.sort_by(f64::total_cmp);
    let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
    let p90 = diffs[diffs.len() * 9 / 10];
    assert!(diffs.len() > 50_000, "{} interior texels", diffs.len());
    assert!(
        mean < 6.0 && p90 < 12.0,
        "mean {mean:.2}, p90 {p90:.2} (of 255)"
    );
}

#[test]
fn box_vertex_colours_land_where_they_should() {
    let mesh = model("gltf/BoxVertexColors/BoxVertexColors.glb");
    let colors = mesh.colors.as_ref().unwrap();
    let set = bake(
        &mesh,
        &ori_views::icosahedron_directions(0),
        &BakeParams::default(),
    )
    .unwrap();
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for map in &set.maps {
        let caster = RayCaster::new(&mesh, map);
        let n = map.size() as usize;
        for y in 2..n - 2 {
            for x in 2..n - 2 {
                let interior = (0..5).all(|dy| {
                    (0..5).all(|dx| map.depth[(y + dy - 2) * n + x + dx - 2] != EMPTY_DEPTH)
                });
                if !interior {
                    continue;
                }
                let (_, t, b) = caster.cast(x as f64 + 0.5, y as f64 + 0.5).unwrap();
                let tri = mesh.triangles[t as usize];
                for (k, &baked) in map.albedo[y * n + x].iter().enumerate() {
                    let lin: f64 = (0..3)
                        .map(|c| b[c] * f64::from(colors[tri[c] as usize][k]))
                        .sum();
                    worst = worst.max((srgb_encode(lin) - f64::from(baked)).abs());
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 100_000);
    // Supersampling averages a texel's footprint, and the box's colours vary smoothly.
    assert!(worst <= 4.0, "worst channel error {worst:.2} of 255");
}

#[test]
fn alpha_tested_leaves_bake_with_holes() {
    let mesh = model("gltf/GlassVaseFlowers/GlassVaseFlowers.glb");
    assert!(
        mesh.materials
            .iter()
            .any(|m| m.alpha_mode == AlphaMode::Mask)
    );
    let mut opaque = mesh.clone();
    for m in &mut opaque.materials {
        m.alpha_mode = AlphaMode::Opaque;
    }
    let dirs = icosahedron();
    let params = BakeParams::default();
    let cut = bake(&mesh, &dirs, &params).unwrap();
    let solid = bake(&opaque, &dirs, &params).unwrap();
    let mut fewer = 0;
    for (c, s) in cut.maps.iter().zip(&solid.maps) {
        for (a, b) in c.depth.iter().zip(&s.depth) {
            assert!(
                !(*b == EMPTY_DEPTH && *a != EMPTY_DEPTH),
                "a hole can only remove surface"
            );
        }
        // The cut-out leaves are a small part of the bouquet's outline: about 150 to 300
        // texels of each 256 x 256 view.
        if s.covered() >= c.covered() + 100 {
            fewer += 1;
        }
    }
    assert_eq!(fewer, 20, "only {fewer} of 20 views show holes");
}

#[test]
fn output_is_identical_for_any_thread_count() {
    let mesh = model("gltf/Duck/Duck.glb");
    let dirs = icosahedron();
    let params = BakeParams {
        resolution: 128,
        ..BakeParams::default()
    };
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bake(&mesh, &dirs, &params).unwrap().encode())
    };
    let one = run(1);
    assert_eq!(one, run(3));
    let decoded = ori_bake::ReliefSet::decode(&one).unwrap();
    assert_eq!(decoded.encode(), one);
    for n in [0, 7, one.len() / 2, one.len() - 1] {
        assert!(ori_bake::ReliefSet::decode(&one[..n]).is_err());
    }
}

fn tetrahedron(scale: f32) -> Mesh {
    let p = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let positions: Vec<[f32; 3]> = p.iter().map(|v: &[f32; 3]| v.map(|c| c * scale)).collect();
    let triangles = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3], [0, 0, 1]];
    let normals = ori_mesh::angle_weighted_normals(&positions, &triangles);
    Mesh {
        positions,
        normals,
        uvs: None,
        colors: None,
        triangle_materials: vec![0; triangles.len()],
        triangles,
        materials: vec![ori_mesh::Material::default()],
        textures: vec![],
    }
}

#[test]
fn bad_geometry_bakes_or_fails_clearly_never_nan() {
    let dirs = icosahedron();
    let params = BakeParams {
        resolution: 32,
        ..BakeParams::default()
    };
    // Degenerate triangle (the last one), tiny and huge coordinates: all bake.
    for scale in [1.0, 1e-30, 1e30] {
        let set = bake(&tetrahedron(scale), &dirs, &params).unwrap();
        for map in &set.maps {
            assert!(map.covered() > 0, "scale {scale}");
            assert!(map.view.half_size.is_finite() && map.view.half_size > 0.0);
        }
    }
    // Inverted normals give the same baked normals: the seen side is what counts.
    let mut inverted = tetrahedron(1.0);
    for n in &mut inverted.normals {
        *n = n.map(|c| -c);
    }
    let a = bake(&tetrahedron(1.0), &dirs, &params).unwrap();
    let b = bake(&inverted, &dirs, &params).unwrap();
    assert_eq!(a, b);
    // A mesh with no extent cannot be framed: a clear error, not NaN.
    let mut point = tetrahedron(1.0);
    point.positions = vec![[2.0, 2.0, 2.0]; 4];
    let e = bake(&point, &dirs, &params).unwrap_err().to_string();
    assert!(e.contains("no extent"), "{e}");
}
