//! The fast paths selection runs on give exactly what the full renders give.

mod common;

use ori_eval::{EvalParams, Evaluator, Mask, Simd, Trace, WallMap};
use ori_raster::{Culling, EMPTY, rasterize};

/// The rasterizer's coverage of `mesh` through `view`, culled (as the evaluator) or not.
fn raster_coverage(mesh: &ori_mesh::Mesh, view: &ori_raster::OrthoView, cull: bool) -> Mask {
    let culling = Culling::new(&mesh.positions, &mesh.triangles, mesh.single_sided());
    let r = rasterize(
        view,
        &mesh.positions,
        &mesh.triangles,
        None,
        cull.then_some(&culling),
    );
    let mut full = Mask::new(view.size);
    for (i, &t) in r.tri.iter().enumerate() {
        if t != EMPTY {
            full.set(i);
        }
    }
    full
}

#[test]
fn mesh_coverage_is_the_rasterizer_coverage() {
    let (mesh, set) = common::bunny();
    let ev = Evaluator::new(mesh, set, &EvalParams::default()).unwrap();
    for w in ori_views::evaluation_directions().iter().step_by(20) {
        let view = ev.view(*w).unwrap();
        assert_eq!(
            ev.mesh_coverage(&view),
            raster_coverage(mesh, &view, true),
            "direction {w:?}"
        );
    }
}

#[test]
fn impostor_masks_are_the_traced_coverage() {
    let (mesh, set) = common::bunny();
    for wall_threshold in [0.05, 0.125, 0.3] {
        let params = EvalParams {
            wall_threshold,
            ..EvalParams::default()
        };
        let ev = Evaluator::new(mesh, set, &params).unwrap();
        for w in ori_views::evaluation_directions().iter().step_by(53) {
            let view = ev.view(*w).unwrap();
            for &i in ev.facing(*w).iter().take(6) {
                let fast = ev.impostor_mask(&view, i, None);
                let layer = ev.layer(&view, i, None);
                assert_eq!(&fast, layer.mask(), "impostor {i}, direction {w:?}");
                let within = ev.mesh_coverage(&view);
                let restricted = ev.impostor_mask(&view, i, Some(&within));
                assert_eq!(restricted.count(), fast.count() - fast.count_minus(&within));
            }
        }
    }
}

#[test]
fn every_lane_width_gives_the_scalar_rule() {
    // Eight AVX lanes where the processor has AVX2 (with AVX-512's registers where it has
    // those), four SSE lanes otherwise: the same IEEE operations lane by lane. A choice the
    // processor lacks runs four lanes.
    #[cfg(target_arch = "x86_64")]
    eprintln!(
        "wide lanes here: avx2 {}, avx512vl {}",
        std::arch::is_x86_feature_detected!("avx2"),
        std::arch::is_x86_feature_detected!("avx512vl")
    );
    let (mesh, set) = common::bunny();
    let mut walls_traced = false;
    for wall_threshold in [0.05, 0.25] {
        let params = EvalParams {
            wall_threshold,
            ..EvalParams::default()
        };
        let ev = Evaluator::new(mesh, set, &params).unwrap();
        let march = params.march();
        for w in ori_views::evaluation_directions().iter().step_by(41) {
            let view = ev.view(*w).unwrap();
            for &i in ev.facing(*w).iter().take(6) {
                let map = &set.maps[i];
                let walls = WallMap::new(&map.depth, map.size(), march.threshold_codes());
                let rays = ev.rays(&view, i).unwrap();
                let [x0, x1, y0, y1] = rays.footprint(view.size);
                let pixels: Vec<(usize, u32, u32)> = (y0..y1)
                    .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                    .enumerate()
                    .map(|(k, (x, y))| (k, x, y))
                    .collect();
                let scalar: Vec<bool> = pixels
                    .iter()
                    .map(|&(_, x, y)| rays.covers(&map.depth, &walls, x, y))
                    .collect();
                let traces: Vec<Trace> = pixels
                    .iter()
                    .map(|&(_, x, y)| rays.trace(&map.depth, x, y))
                    .collect();
                for simd in [Simd::Widest, Simd::Avx512, Simd::Avx2, Simd::Four] {
                    let lanes = rays.clone().with_simd(simd);
                    let mut got = vec![None; pixels.len()];
                    lanes.covers_many(&map.depth, &walls, &pixels, |k, covered| {
                        assert!(
                            got[k].replace(covered).is_none(),
                            "pixel {k} answered twice"
                        );
                    });
                    let got: Vec<bool> = got.into_iter().map(|c| c.expect("answered")).collect();
                    assert_eq!(got, scalar, "{simd:?}, impostor {i}, direction {w:?}");
                    let mut got = vec![None; pixels.len()];
                    lanes.trace_many(&map.depth, &pixels, |k, trace| {
                        assert!(got[k].replace(trace).is_none(), "pixel {k} traced twice");
                    });
                    let got: Vec<Trace> = got.into_iter().map(|t| t.expect("traced")).collect();
                    assert_eq!(got, traces, "{simd:?}, impostor {i}, direction {w:?}");
                }
                assert!(scalar.contains(&true) && scalar.contains(&false));
                walls_traced |= traces.contains(&Trace::Wall);
            }
        }
    }
    assert!(walls_traced, "some rays end on walls");
}

#[test]
fn alpha_tested_coverage_is_the_baked_coverage() {
    let mesh = common::load("vegetation/fern_02/fern_02.glb");
    assert!(
        mesh.materials
            .iter()
            .any(|m| m.alpha_mode == ori_mesh::AlphaMode::Mask),
        "the fern is alpha-tested"
    );
    // One impostor is enough to build an evaluator; the reference is what matters here.
    let params = ori_bake::BakeParams {
        resolution: 128,
        supersample: 1,
        margin: 0,
    };
    let dirs = ori_views::evaluation_directions();
    let set = ori_bake::bake(&mesh, &dirs[..1], &params).unwrap();
    let ev = Evaluator::new(
        &mesh,
        &set,
        &EvalParams {
            s0: 128,
            ..EvalParams::default()
        },
    )
    .unwrap();
    for w in dirs.iter().step_by(40) {
        let view = ev.view(*w).unwrap();
        let baked = ori_bake::bake(&mesh, &[*w], &params).unwrap();
        let mut expected = Mask::new(128);
        for (i, &d) in baked.maps[0].depth.iter().enumerate() {
            if d != ori_bake::EMPTY_DEPTH {
                expected.set(i);
            }
        }
        assert_eq!(ev.mesh_coverage(&view), expected, "direction {w:?}");
    }
}

#[test]
fn culling_leaves_out_the_inside_seen_through_a_cut() {
    // The bunny cut in half across x: from +x one looks into the cut and sees the inside of
    // the far half's shell (back faces, culled: the bunny is single-sided); from -x the
    // outside. The fast path culls exactly as the rasterizer does.
    let (mesh, set) = common::bunny();
    let [lo, hi] = common::bounds(mesh);
    let mid = (lo[0] + hi[0]) / 2.0;
    let half = ori_mesh::clip_to_box(mesh, lo, [mid, hi[1], hi[2]]).unwrap();
    let ev = Evaluator::new(&half, set, &EvalParams::default()).unwrap();
    let count = |w: [f64; 3]| {
        let view = ev.view(w).unwrap();
        let culled = ev.mesh_coverage(&view);
        assert_eq!(culled, raster_coverage(&half, &view, true), "{w:?}");
        let both_sides = raster_coverage(&half, &view, false);
        assert_eq!(
            culled.count_minus(&both_sides),
            0,
            "culling only removes pixels"
        );
        (both_sides.count(), culled.count())
    };
    let (all, front) = count([1.0, 0.0, 0.0]);
    assert!(
        front < all * 9 / 10,
        "looking into the cut: {front} of {all}"
    );
    let (all, front) = count([-1.0, 0.0, 0.0]);
    assert!(front > all * 99 / 100, "from outside: {front} of {all}");
}

#[test]
fn an_ori_traces_each_impostor_only_where_those_before_it_draw_nothing() {
    // The closest direction wins, so the image is that of every layer traced in full.
    let (mesh, set) = common::bunny();
    let ev = Evaluator::new(mesh, set, &EvalParams::default()).unwrap();
    let mut later = 0;
    for w in ori_views::evaluation_directions().iter().step_by(40) {
        let view = ev.view(*w).unwrap();
        let subset: Vec<usize> = ev.facing(*w).into_iter().take(3).collect();
        let full: Vec<_> = subset.iter().map(|&i| ev.layer(&view, i, None)).collect();
        let refs: Vec<_> = full.iter().collect();
        let ori = ev.render_ori(&view, &subset);
        let all = ev.compose(&view, &refs);
        // Bit for bit (empty pixels' depth is NaN).
        let bits = |r: &ori_eval::Render| r.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            (
                &ori.coverage,
                &ori.source,
                &ori.albedo,
                &ori.normal,
                bits(&ori)
            ),
            (
                &all.coverage,
                &all.source,
                &all.albedo,
                &all.normal,
                bits(&all)
            ),
            "direction {w:?}"
        );
        later += ori
            .coverage
            .ones()
            .filter(|&i| usize::from(ori.source[i]) != subset[0])
            .count();
    }
    assert!(later > 0, "later impostors draw somewhere");
}

#[test]
fn a_full_mask_holds_every_pixel_and_no_more() {
    for size in [1, 7, 8, 256] {
        let full = Mask::full(size);
        assert_eq!(full.count(), size * size);
        let mut every = Mask::new(size);
        for i in 0..(size * size) as usize {
            every.set(i);
        }
        assert_eq!(full, every);
    }
}
