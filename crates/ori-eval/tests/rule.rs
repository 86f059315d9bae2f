//! The runtime rule on scenes whose answer is known.

mod common;

use ori_bake::{BakeParams, ReliefSet, bake};
use ori_eval::{EvalParams, Evaluator, Priority, Trace, compare, error_image};
use ori_mesh::{Material, Mesh};

fn quad(z: f32, half: f32, material: u32, first: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>, Vec<u32>) {
    let p = vec![
        [-half, -half, z],
        [half, -half, z],
        [half, half, z],
        [-half, half, z],
    ];
    let t = vec![[first, first + 1, first + 2], [first, first + 2, first + 3]];
    (p, t, vec![material; 2])
}

/// A plate of half-size 0.5 at height 1 above a floor of half-size 2 at height 0: the plate's
/// relief column hides a strip of floor that tilted views see.
fn plate_over_floor() -> Mesh {
    let (mut p, mut t, mut m) = quad(0.0, 2.0, 0, 0);
    let (p2, t2, m2) = quad(1.0, 0.5, 1, 4);
    p.extend(p2);
    t.extend(t2);
    m.extend(m2);
    let mut mesh = common::mesh(p, t);
    mesh.triangle_materials = m;
    let colour = |c: [f32; 3], name: &str| Material {
        name: name.into(),
        base_color_factor: [c[0], c[1], c[2], 1.0],
        ..Material::default()
    };
    mesh.materials = vec![
        colour([0.2, 0.2, 0.2], "floor"),
        colour([1.0, 0.0, 0.0], "plate"),
    ];
    mesh
}

fn tilted(deg: f64) -> [f64; 3] {
    let r = deg.to_radians();
    [r.sin(), 0.0, r.cos()]
}

fn baked(mesh: &Mesh, dirs: &[[f64; 3]]) -> ReliefSet {
    bake(mesh, dirs, &BakeParams::default()).expect("bake")
}

#[test]
fn a_flat_quad_seen_head_on_covers_exactly_its_pixels() {
    let (p, t, _) = quad(0.0, 1.0, 0, 0);
    let mesh = common::mesh(p, t);
    let set = baked(&mesh, &[[0.0, 0.0, 1.0]]);
    let ev = Evaluator::new(&mesh, &set, &EvalParams::default()).unwrap();
    let view = ev.view([0.0, 0.0, 1.0]).unwrap();
    let reference = ev.render_mesh(&view).unwrap();
    assert_eq!(
        reference.coverage.count(),
        256 * 256,
        "the quad fills its view"
    );
    let ori = ev.render_ori(&view, &[0]);
    let e = compare(&view, &reference, &ori);
    assert_eq!((e.missed, e.extra), (0, 0));
    assert!(e.p_dif < 1.0 && e.depth_error < 0.01, "{e:?}");
    assert_eq!(ev.impostor_mask(&view, 0, None), ori.coverage);
}

#[test]
fn vertical_wall_discard_removes_the_shadow_volume_of_a_step() {
    let mesh = plate_over_floor();
    let set = baked(&mesh, &[[0.0, 0.0, 1.0]]);
    let w = tilted(30.0);
    let run = |wall_threshold: f64| {
        let params = EvalParams {
            wall_threshold,
            ..EvalParams::default()
        };
        let ev = Evaluator::new(&mesh, &set, &params).unwrap();
        let view = ev.view(w).unwrap();
        let reference = ev.render_mesh(&view).unwrap();
        let ori = ev.render_ori(&view, &[0]);
        // Pixels where the ORI shows the plate's red but the mesh shows the grey floor.
        let red_on_floor = (0..256 * 256)
            .filter(|&i| {
                ori.coverage.get(i) && ori.albedo[i][1] < 50 && reference.albedo[i][1] > 50
            })
            .count();
        (compare(&view, &reference, &ori), red_on_floor)
    };
    // Without the test, the plate's column (down to the floor) is drawn over the strip of
    // floor the tilt reveals: covered, but red and at the plate's depth.
    let (kept, red_kept) = run(2.0);
    // With it, that strip is discarded: those pixels are missed, nothing wrong is drawn.
    let (discarded, red_discarded) = run(0.125);
    assert!(
        red_kept > 1000,
        "{red_kept} red pixels on the floor without the test"
    );
    assert!(
        red_discarded < 20,
        "{red_discarded} red pixels on the floor with the test"
    );
    assert!(
        discarded.missed > kept.missed + 1000,
        "{discarded:?} vs {kept:?}"
    );
    assert!(discarded.depth_error < kept.depth_error / 4.0);
    assert!(discarded.extra <= kept.extra);
}

#[test]
fn facing_order_priority_and_the_error_picture() {
    let mesh = plate_over_floor();
    let dirs = [tilted(-40.0), tilted(10.0), tilted(100.0), tilted(180.0)];
    let set = baked(&mesh, &dirs);
    for priority in [Priority::ClosestDirection, Priority::BiasedDepth] {
        let params = EvalParams {
            priority,
            ..EvalParams::default()
        };
        let ev = Evaluator::new(&mesh, &set, &params).unwrap();
        let w = [0.0, 0.0, 1.0];
        // d . w > 0 only; closest first.
        assert_eq!(ev.facing(w), [1, 0]);
        let view = ev.view(w).unwrap();
        assert!(
            ev.rays(&view, 3).is_none(),
            "a back-facing impostor draws nothing"
        );
        let ori = ev.render_ori(&view, &[1, 0]);
        let layers = [ev.layer(&view, 1, None), ev.layer(&view, 0, None)];
        for i in 0..256 * 256 {
            let (a, b) = (layers[0].mask().get(i), layers[1].mask().get(i));
            assert_eq!(ori.coverage.get(i), a || b);
            if priority == Priority::ClosestDirection && a {
                assert_eq!(ori.source[i], 1, "the closest impostor wins where it draws");
            }
        }
        let reference = ev.render_mesh(&view).unwrap();
        let e = compare(&view, &reference, &ori);
        let rgb = error_image(&view, &reference, &ori);
        let count = |c: [u8; 3]| rgb.chunks_exact(3).filter(|p| *p == c).count() as u32;
        assert_eq!(count([255, 0, 0]), e.missed);
        assert_eq!(count([0, 0, 255]), e.extra);
    }
}

#[test]
fn traces_follow_the_rule_at_single_pixels() {
    let (p, t, _) = quad(0.0, 1.0, 0, 0);
    let mesh = common::mesh(p, t);
    let set = baked(&mesh, &[[0.0, 0.0, 1.0]]);
    let ev = Evaluator::new(&mesh, &set, &EvalParams::default()).unwrap();
    let view = ev.view(tilted(20.0)).unwrap();
    let rays = ev.rays(&view, 0).unwrap();
    let depth = &set.maps[0].depth;
    // The centre pixel hits the quad at mid depth (a flat object's depth range is padded
    // symmetrically), the texel under the quad's centre.
    match rays.trace(depth, 128, 128) {
        Trace::Hit { z, texel } => {
            assert!((z - 127.0).abs() < 1.0, "{z}");
            assert_eq!(set.maps[0].depth[texel as usize], 127);
            assert!((rays.eval_depth(128, 128, z) - 0.5).abs() < 0.01);
        }
        other => panic!("{other:?}"),
    }
    // The footprint bounds every pixel the impostor draws, and skips some it cannot.
    let [x0, x1, y0, y1] = rays.footprint(256);
    let drawn = ev.impostor_mask(&view, 0, None);
    assert!(drawn.count() > 0 && (x1 - x0) * (y1 - y0) < 256 * 256);
    for i in drawn.ones() {
        let (x, y) = ((i % 256) as u32, (i / 256) as u32);
        assert!(x >= x0 && x < x1 && y >= y0 && y < y1);
    }
    let everywhere = (0..256u32).flat_map(|y| (0..256u32).map(move |x| (x, y)));
    let hits = everywhere
        .filter(|&(x, y)| matches!(rays.trace(depth, x, y), Trace::Hit { .. }))
        .count();
    assert_eq!(hits as u32, drawn.count());
}

#[test]
fn params_deserialize_and_validate() {
    let p: EvalParams =
        toml::from_str("wall_threshold = 0.25\npriority = \"biased-depth\"").unwrap();
    assert_eq!(p.wall_threshold, 0.25);
    assert_eq!(p.priority, Priority::BiasedDepth);
    assert_eq!(p.linear_steps, 16);
    assert!(toml::from_str::<EvalParams>("wall = 0.25").is_err());
    for bad in [
        EvalParams {
            linear_steps: 0,
            ..EvalParams::default()
        },
        EvalParams {
            wall_threshold: f64::NAN,
            ..EvalParams::default()
        },
        EvalParams {
            s0: 4,
            ..EvalParams::default()
        },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
}
