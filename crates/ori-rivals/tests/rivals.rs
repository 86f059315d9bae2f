//! Each rival technique on a scene it must draw (almost) exactly, seed 004's finding on real
//! scans, the byte budgets, and determinism.

#[path = "../../ori-views/tests/common/mod.rs"]
mod common;

use common::{cube, load, mesh, with_threads};
use ori_mesh::Mesh;
use ori_rivals::{
    BillboardCloud, Billboards, Octahedral, Projection, References, Relief, Rival, Rivals, Row,
    SimplifiedMesh, Sphere, Technique, relief_bytes, within_budget,
};

/// Random held-out directions (none of them a layout's own).
fn directions(count: usize) -> Vec<[f64; 3]> {
    ori_views::held_out_directions(ori_views::DEFAULT_HELD_OUT_SEED)[ori_views::HELD_OUT_REGULAR..]
        [..count]
        .to_vec()
}

fn row(mesh: &Mesh, rival: &dyn Rival, directions: &[[f64; 3]], s0: u32) -> Row {
    let rows = ori_rivals::compare(mesh, &[rival], directions, s0).unwrap();
    eprintln!("{rows:?}");
    rows.into_iter().next().unwrap()
}

/// A unit sphere, `rings` x `2 rings` quads, normals radial.
fn sphere(rings: u32) -> Mesh {
    let segments = 2 * rings;
    let mut positions = Vec::new();
    for i in 0..=rings {
        let theta = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        for j in 0..segments {
            let phi = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
            positions.push(
                [
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ]
                .map(|c| c as f32),
            );
        }
    }
    let at = |i: u32, j: u32| i * segments + j % segments;
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            // Counter-clockwise seen from outside.
            triangles.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            triangles.push([at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    let mut m = mesh(positions, triangles);
    m.normals = m.positions.clone();
    m
}

#[test]
fn a_relief_box_draws_an_axis_aligned_box_exactly() {
    let cube = cube();
    let maps = Relief::bake_box(&cube, relief_bytes(6 * 128 * 128)).unwrap();
    assert_eq!(maps.maps[0].size(), 128);
    let rival = Relief::relief_box(&cube, &maps).unwrap();
    let r = row(&cube, &rival, &directions(64), 128);
    // Only the pixel columns along some silhouette edges are lost (the nearest texel of the
    // side map's edge row misses them).
    assert!(r.coverage_error_avg_percent < 0.05, "{r:?}");
    assert!(r.coverage_error_max_percent < 1.0, "{r:?}");
    assert_eq!(r.inverse_coverage_avg_percent, 0.0, "{r:?}");
    assert!(r.depth_error_avg < 0.01, "{r:?}");
    assert!(r.drawn_per_view > 2.5 && r.drawn_per_view <= 3.0, "{r:?}");
}

#[test]
fn an_octahedral_impostor_draws_a_sphere_from_every_direction() {
    // Every frame of a sphere is the same disc, but the depth step moves a ray near the rim
    // onto the front of frames seen from the other side of it, off their disc: so the
    // frames must be close (24 x 24: about 8 degrees apart).
    let ball = sphere(24);
    let full = Octahedral::bake(&ball, Sphere::Full, 24, 64).unwrap();
    let r = row(&ball, &full, &directions(64), 128);
    assert!(r.coverage_error_avg_percent < 0.5, "{r:?}");
    assert!(r.coverage_error_max_percent < 1.5, "{r:?}");
    assert!(r.inverse_coverage_avg_percent < 2.0, "{r:?}");
    // The upper hemisphere's frames serve every view from above.
    let upper = Octahedral::bake(&ball, Sphere::Upper, 24, 64).unwrap();
    let above: Vec<[f64; 3]> = directions(128).into_iter().filter(|w| w[1] > 0.1).collect();
    let r = row(&ball, &upper, &above, 128);
    assert!(r.coverage_error_avg_percent < 0.5, "{r:?}");
    assert!(r.coverage_error_max_percent < 1.5, "{r:?}");
}

#[test]
fn an_octahedral_impostor_baked_for_some_views_draws_them_as_the_whole_one() {
    let ball = sphere(24);
    let whole = Octahedral::bake(&ball, Sphere::Full, 24, 32).unwrap();
    let seen = directions(8);
    let part = Octahedral::bake_for(&ball, Sphere::Full, 24, 32, &seen).unwrap();
    let depth_bits = |r: &ori_eval::Render| r.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
    for &w in &seen {
        let view = ori_eval::eval_view(&ball, w, 64).unwrap();
        let (a, b) = (
            whole.draw(&view).unwrap().render,
            part.draw(&view).unwrap().render,
        );
        assert_eq!(
            (&a.coverage, &a.albedo, &a.normal, depth_bits(&a)),
            (&b.coverage, &b.albedo, &b.normal, depth_bits(&b)),
            "{w:?}"
        );
    }
    // Most frames are left out: a view from elsewhere finds them missing, until completed.
    let elsewhere = ori_eval::eval_view(&ball, [0.0, -1.0, 0.0], 64).unwrap();
    assert!(part.draw(&elsewhere).is_err());
    let completed = part.complete(&ball).unwrap();
    assert_eq!(
        completed.draw(&elsewhere).unwrap().render.coverage,
        whole.draw(&elsewhere).unwrap().render.coverage
    );
}

#[test]
fn octahedral_maps_invert() {
    for w in directions(500) {
        let back = Sphere::Full.decode(Sphere::Full.encode(w));
        assert!(
            (0..3).all(|k| (back[k] - w[k]).abs() < 1e-9),
            "{w:?} {back:?}"
        );
        if w[1] >= 0.0 {
            let back = Sphere::Upper.decode(Sphere::Upper.encode(w));
            assert!(
                (0..3).all(|k| (back[k] - w[k]).abs() < 1e-9),
                "{w:?} {back:?}"
            );
        }
    }
}

/// A square of edge 2 through the origin, facing `d`.
fn quad_facing(d: [f64; 3]) -> Mesh {
    let f = ori_raster::Frame::from_direction(d);
    let corner = |a: f64, b: f64| f.to_world([a, b, 0.0]).map(|c| c as f32);
    let positions = vec![
        corner(-1.0, -1.0),
        corner(1.0, -1.0),
        corner(1.0, 1.0),
        corner(-1.0, 1.0),
    ];
    let mut m = mesh(positions, vec![[0, 1, 2], [0, 2, 3]]);
    m.normals = vec![d.map(|c| c as f32); 4];
    m
}

#[test]
fn billboards_draw_a_flat_quad_exactly_near_their_direction() {
    let d = ori_views::icosahedron_directions(1)[5];
    let quad = quad_facing(d);
    // Views up to about 6 degrees from the billboard's direction (the 80 directions are
    // about 24 degrees apart), all of which it is the nearest for.
    let f = ori_raster::Frame::from_direction(d);
    let views: Vec<[f64; 3]> = (0..16)
        .map(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / 16.0;
            let t = 0.1 * (1.0 + f64::from(k % 2)) / 2.0;
            ori_raster::normalize(f.to_world([t * a.cos(), t * a.sin(), 1.0]))
        })
        .collect();
    for projection in [
        Projection::Orthographic,
        Projection::Perspective(Default::default()),
    ] {
        let billboards = Billboards::bake(&quad, projection, 80, 256).unwrap();
        let r = row(&quad, &billboards, &views, 128);
        assert!(r.coverage_error_max_percent < 0.5, "{r:?}");
        assert!(r.inverse_coverage_avg_percent < 0.5, "{r:?}");
        assert!(r.depth_error_avg < 0.01, "{r:?}");
    }
}

#[test]
fn a_billboard_cloud_finds_the_planes_of_a_quad_and_of_a_box() {
    let quad = quad_facing(ori_views::icosahedron_directions(0)[3]);
    let clouds = BillboardCloud::bake_all(&quad, &[1], 200_000).unwrap();
    assert_eq!(clouds.len(), 1);
    assert_eq!(clouds[0].layout(), "1 planes from 2 triangles");
    // Its texture and its quad fill the budget.
    let bytes = clouds[0].bytes();
    assert!(
        bytes <= 200_000 && ori_rivals::within_budget(bytes, 200_000),
        "{bytes}"
    );
    // A box is six planes: merging its faces' triangles costs nothing, merging two faces
    // makes a plane as thick as the box, the coarsest level. Drawn with a depth test, the six
    // are the box from every direction.
    let cube = cube();
    let clouds = BillboardCloud::bake_all(&cube, &[6], 1_000_000).unwrap();
    assert_eq!(clouds[0].layout(), "6 planes from 12 triangles");
    let r = row(&cube, &clouds[0], &directions(64), 128);
    assert!(r.coverage_error_max_percent < 0.3, "{r:?}");
    assert!(r.inverse_coverage_avg_percent < 0.5, "{r:?}");
    assert!(r.depth_error_avg < 0.01, "{r:?}");
    // Drawn from both sides.
    assert_eq!(r.drawn_per_view, 6.0, "{r:?}");
}

/// Seed 004: at equal texel count, billboard textures baked with an orthographic camera give
/// a lower p_dif than perspective ones.
#[test]
fn orthographic_billboard_textures_beat_perspective_ones() {
    for model in [
        "stanford/bunny/stanford-bunny.obj",
        "stanford/dragon/dragon_res2_binary.ply",
    ] {
        let mesh = load(model);
        let views = directions(160);
        let ortho = Billboards::bake(&mesh, Projection::Orthographic, 80, 64).unwrap();
        let persp =
            Billboards::bake(&mesh, Projection::Perspective(Default::default()), 80, 64).unwrap();
        assert_eq!(ortho.bytes(), persp.bytes());
        let rows = ori_rivals::compare(&mesh, &[&ortho, &persp], &views, 128).unwrap();
        eprintln!("{model}: {rows:?}");
        assert!(rows[0].p_dif_avg < rows[1].p_dif_avg, "{model}: {rows:?}");
        assert!(
            rows[0].coverage_error_avg_percent < rows[1].coverage_error_avg_percent,
            "{model}: {rows:?}"
        );
    }
}

#[test]
fn a_simplified_mesh_fills_its_budget() {
    let bunny = load("stanford/bunny/stanford-bunny.obj");
    let budget = 400_000;
    let simplified = SimplifiedMesh::new(&bunny, budget).unwrap();
    assert!(simplified.bytes() <= budget, "{}", simplified.layout());
    assert!(
        within_budget(simplified.bytes(), budget),
        "{}",
        simplified.layout()
    );
    assert!(simplified.mesh().triangles.len() < bunny.triangles.len());
    let r = row(&bunny, &simplified, &directions(32), 128);
    assert!(r.coverage_error_avg_percent < 0.5, "{r:?}");
    assert_eq!(r.drawn_per_view, simplified.mesh().triangles.len() as f64);
    // A budget the whole mesh fits keeps it.
    let whole = SimplifiedMesh::new(&bunny, 4_000_000).unwrap();
    assert_eq!(whole.mesh(), &bunny);
}

#[test]
fn every_texture_layout_fits_the_budgets_within_five_percent() {
    for budget in [800_000, 1_600_000, 3_300_000] {
        let octahedral = Octahedral::layouts(budget);
        let billboards = Billboards::layouts(budget);
        assert!(!octahedral.is_empty() && !billboards.is_empty(), "{budget}");
        for (n, r) in octahedral {
            let bytes = relief_bytes((n * n) as u64 * u64::from(r) * u64::from(r));
            assert!(
                bytes <= budget && within_budget(bytes, budget),
                "{budget}: {n} {r}"
            );
        }
        for (count, r) in billboards {
            let bytes = ori_rivals::billboard_bytes(count as u64 * u64::from(r) * u64::from(r));
            assert!(
                bytes <= budget && within_budget(bytes, budget),
                "{budget}: {count} {r}"
            );
        }
    }
}

#[test]
fn a_comparison_is_the_same_on_one_and_two_threads() {
    let bunny = load("stanford/bunny/bunny_npm_lowres.obj");
    let run = || {
        let tuning = References::new(&bunny, &ori_rivals::tuning_directions(1)[..8], 64).unwrap();
        let rivals = Rivals::bake(&bunny, 300_000, &Technique::ALL, &tuning, &|_| ()).unwrap();
        let all = rivals.all(&bunny).unwrap();
        let refs: Vec<&dyn Rival> = all.iter().map(|r| r.as_ref() as &dyn Rival).collect();
        let rows = ori_rivals::compare(&bunny, &refs, &directions(24), 64).unwrap();
        serde_json::to_string(&rows).unwrap()
    };
    let one = with_threads(1, run);
    let two = with_threads(2, run);
    assert_eq!(one, two);
    let rows: Vec<Row> = serde_json::from_str(&one).unwrap();
    let names: Vec<Technique> = rows.iter().map(|r| r.technique).collect();
    assert_eq!(names, Technique::ALL[..7]);
    for r in rows.iter().filter(|r| r.technique.is_texture()) {
        assert!(within_budget(r.bytes, 300_000), "{r:?}");
    }
}
