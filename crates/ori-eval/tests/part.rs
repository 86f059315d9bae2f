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
