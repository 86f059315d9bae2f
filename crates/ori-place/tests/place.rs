//! The placement search on a real scan: it lowers what it promises to lower, it is the same
//! for any thread count, and it leaves the plan alone when told to.

use ori_bake::BakeParams;
use ori_eval::EvalParams;
use ori_mesh::Mesh;
use ori_place::{Measure, PlaceParams, Placement, place};
use ori_views::ViewPlan;

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

fn bunny() -> (Mesh, ViewPlan) {
    let path = format!("{MODELS}/stanford/bunny/bunny_npm_lowres.obj");
    let mesh = ori_mesh::load_file(path.as_ref(), &Default::default())
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .mesh;
    let plan = ori_views::plan_views(&mesh, &Default::default()).expect("plan");
    (mesh, plan)
}

/// Placement measured on 128 x 128 views with 64 x 64 maps (the defaults' rule, goal
/// 0.2 %), to keep the test quick; `threads` rayon threads.
fn placed(mesh: &Mesh, plan: &ViewPlan, params: &PlaceParams, threads: usize) -> Placement {
    let bake = BakeParams {
        resolution: 64,
        ..Default::default()
    };
    let eval = EvalParams {
        s0: 128,
        ..Default::default()
    };
    let measure = Measure {
        bake: &bake,
        eval: &eval,
        closest: 6,
        goal_pixels: (0.002 * 128.0 * 128.0) as u32,
        entropy_size: 128,
        whole: None,
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool")
        .install(|| place(mesh, plan, &measure, params))
        .expect("place")
}

#[test]
fn placement_lowers_the_worst_view_the_same_way_for_any_thread_count() {
    let (mesh, plan) = bunny();
    let params = PlaceParams::default();
    let one = placed(&mesh, &plan, &params, 1);
    eprintln!(
        "{} moves, worst view {} -> {} pixels",
        one.moves, one.worst_before, one.worst_after
    );
    assert!(one.moves > 0, "the perturbed plan is not already the best");
    assert!(one.worst_after < one.worst_before);
    assert_eq!(one.plan.directions.len(), plan.directions.len());
    assert_eq!(one.plan.strategy, plan.strategy);
    // A moved impostor sits on an evaluation direction; the others are untouched.
    let evaluation = ori_views::evaluation_directions();
    let mut moved = 0;
    for (new, old) in one.plan.directions.iter().zip(&plan.directions) {
        if new != old {
            assert!(evaluation.contains(new));
            moved += 1;
        }
    }
    assert!(moved > 0 && moved as u32 <= one.moves);
    for (i, (h, d)) in one
        .plan
        .entropies
        .iter()
        .zip(&one.plan.directions)
        .enumerate()
    {
        assert!(
            h.is_finite() && *h > 0.0,
            "impostor {i} at {d:?}: entropy {h}"
        );
    }
    let two = placed(&mesh, &plan, &params, 2);
    assert_eq!(one.plan.encode(), two.plan.encode());
    assert_eq!(one, two);
}

#[test]
fn a_move_budget_is_kept_and_zero_keeps_the_plan() {
    let (mesh, plan) = bunny();
    let one_move = PlaceParams {
        max_moves: 1,
        ..Default::default()
    };
    let p = placed(&mesh, &plan, &one_move, 2);
    assert_eq!(p.moves, 1);
    let changed = p
        .plan
        .directions
        .iter()
        .zip(&plan.directions)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(changed, 1);
    let off = PlaceParams {
        max_moves: 0,
        ..Default::default()
    };
    let p = placed(&mesh, &plan, &off, 2);
    assert_eq!((p.moves, &p.plan), (0, &plan));
}

#[test]
fn bad_parameters_are_errors_that_name_the_key() {
    let (mesh, plan) = bunny();
    let bad = [
        (
            PlaceParams {
                max_moves: 1001,
                ..Default::default()
            },
            "place.max_moves",
        ),
        (
            PlaceParams {
                step_deg: 1.0,
                ..Default::default()
            },
            "place.step_deg",
        ),
        (
            PlaceParams {
                goal_scale: 0.0,
                ..Default::default()
            },
            "place.goal_scale",
        ),
    ];
    for (params, key) in bad {
        let measure = Measure {
            bake: &BakeParams::default(),
            eval: &EvalParams::default(),
            closest: 6,
            goal_pixels: 131,
            entropy_size: 128,
            whole: None,
        };
        let err = place(&mesh, &plan, &measure, &params).unwrap_err();
        assert!(err.to_string().contains(key), "{err}");
    }
}

#[test]
fn params_come_from_a_place_section() {
    let p: PlaceParams = toml::from_str("max_moves = 8").unwrap();
    assert_eq!(
        p,
        PlaceParams {
            max_moves: 8,
            ..Default::default()
        }
    );
    assert!(toml::from_str::<PlaceParams>("moves = 8").is_err());
}
