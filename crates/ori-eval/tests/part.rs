//! A part of a model (a hierarchy node) is measured in its own pixels: the parts of a split
//! model share out the model's pixels, and what a part shows through its cut is not its own.

mod common;

use ori_eval::{EvalParams, Evaluator, Whole};

#[test]
fn two_halves_share_out_the_whole_models_pixels() {
    let (mesh, set) = common::bunny();
    let [lo, hi] = common::bounds(mesh);
    let mid = (lo[0] + hi[0]) / 2.0;
    let boxes = [[lo, [mid, hi[1], hi[2]]], [[mid, lo[1], lo[2]], hi]];
    let halves = boxes.map(|[a, b]| ori_mesh::clip_to_box(mesh, a, b).unwrap());
    let params = EvalParams::default();
    let whole = Evaluator::new(mesh, set, &params).unwrap();
    let parts: Vec<Evaluator<'_>> = halves
        .iter()
        .zip(boxes)
        .map(|(half, clip)| {
            Evaluator::new(half, set, &params)
                .unwrap()
                .part_of(Some(Whole { mesh, clip }))
        })
        .collect();
    let plain: Vec<Evaluator<'_>> = halves
        .iter()
        .map(|half| Evaluator::new(half, set, &params).unwrap())
        .collect();
    for w in [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.577, 0.577, 0.577],
        [-0.4, 0.3, -0.866],
    ] {
        // One view of the whole model for all three.
        let view = whole.view(w).unwrap();
        let all = whole.mesh_coverage(&view);
        let [a, b] = [0, 1].map(|i| parts[i].mesh_coverage(&view));
        for (i, own) in [&a, &b].into_iter().enumerate() {
            let cut = plain[i].mesh_coverage(&view);
            assert_eq!(own.count_minus(&cut), 0, "{w:?}: own pixels are the part's");
        }
        let mut union = a.clone();
        union.union_with(&b);
        let (lost, extra) = (all.count_minus(&union), union.count_minus(&all));
        let shared = a.count() - a.count_minus(&b);
        eprintln!(
            "{w:?}: whole {}, halves {} + {} ({shared} shared), lost {lost}, extra {extra}",
            all.count(),
            a.count(),
            b.count()
        );
        // Only pixels whose centre falls on an edge of the cut may differ.
        assert!(lost + extra <= all.count() / 500, "{w:?}: {lost} + {extra}");
        assert!(
            shared <= all.count() / 100,
            "{w:?}: {shared} in both halves"
        );
    }
    // Looking into the low half's cut along +x: the pixels it shows through the cut (front
    // faces of the inside) are the high half's.
    let view = whole.view([1.0, 0.0, 0.0]).unwrap();
    let (own, cut) = (parts[0].mesh_coverage(&view), plain[0].mesh_coverage(&view));
    let high = parts[1].mesh_coverage(&view);
    let mut hidden = cut.clone();
    hidden.remove(&own);
    eprintln!(
        "low half from +x: {} pixels, {} hidden",
        cut.count(),
        hidden.count()
    );
    assert!(
        hidden.count() > cut.count() / 20,
        "{} of {}",
        hidden.count(),
        cut.count()
    );
    assert_eq!(hidden.count_minus(&high), 0);
}

/// A part's own pixels are found from the whole model's nearest surface exactly as the
/// rasterizer draws it: the evaluator draws the whole model in another triangle order and
/// skips the runs of triangles that project outside the part's pixels, which must change
/// nothing (a dense scan, and flowers whose alpha-tested petals let the surface behind show).
#[test]
fn a_parts_own_pixels_are_those_of_the_whole_models_raster() {
    let params = EvalParams::default();
    for model in [
        "stanford/dragon/dragon_res2_binary.ply",
        "gltf/GlassVaseFlowers/GlassVaseFlowers.glb",
    ] {
        let whole = common::load(model);
        let baker = ori_bake::Baker::new(&whole);
        let [lo, hi] = common::bounds(&whole);
        let mid: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        let (mut hidden_total, mut own_total) = (0, 0);
        // The low corner's octant and the high half along y.
        for clip in [[lo, mid], [[lo[0], mid[1], lo[2]], hi]] {
            let part = ori_mesh::clip_to_box(&whole, clip[0], clip[1]).expect("a part");
            let set = ori_bake::bake(
                &part,
                &[[0.0, 0.0, 1.0]],
                &ori_bake::BakeParams {
                    resolution: 16,
                    ..Default::default()
                },
            )
            .unwrap();
            let plain = Evaluator::new(&part, &set, &params).unwrap();
            let own = Evaluator::new(&part, &set, &params)
                .unwrap()
                .part_of(Some(Whole { mesh: &whole, clip }));
            // The box the evaluator keeps points in: grown by a millionth of its edge.
            let slack = 1e-6 * (0..3).map(|k| clip[1][k] - clip[0][k]).fold(0.0, f64::max);
            let inside = |p: [f64; 3]| {
                (0..3).all(|k| p[k] >= clip[0][k] - slack && p[k] <= clip[1][k] + slack)
            };
            for (k, w) in ori_views::held_out_directions(1)
                .iter()
                .step_by(150)
                .enumerate()
            {
                let s0 = [64, 157][k % 2];
                let view = ori_eval::eval_view(&part, *w, s0).unwrap();
                let cut = plain.mesh_coverage(&view);
                let (_, raster) = baker.bake_view(&view, 1).unwrap();
                let n = s0 as usize;
                let mut hidden = ori_eval::Mask::new(s0);
                for i in cut.ones() {
                    let (x, y) = ((i % n) as f64 + 0.5, (i / n) as f64 + 0.5);
                    let depth = view.depth_of_height(raster.height[i]);
                    if raster.tri[i] != ori_raster::EMPTY && !inside(view.unproject(x, y, depth)) {
                        hidden.set(i);
                    }
                }
                hidden_total += hidden.count();
                let mut expected = cut.clone();
                expected.remove(&hidden);
                own_total += expected.count();
                assert_eq!(
                    own.mesh_coverage(&view),
                    expected,
                    "{model}, box {clip:?}, direction {w:?}, {s0} px"
                );
            }
        }
        eprintln!("{model}: {own_total} own pixels, {hidden_total} hidden");
        assert!(
            hidden_total > own_total / 50,
            "{hidden_total} of {own_total}"
        );
    }
}
