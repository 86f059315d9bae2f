//! Viewpoint entropy, the three strategies, determinism, parameters and the plan artifact.

mod common;

use common::{cube, load, mesh, with_threads};
use ori_views::{
    Strategy, ViewError, ViewParams, ViewPlan, evaluation_directions, icosahedron_directions,
    plan_views, viewpoint_entropy,
};

const LOW_BUNNY: &str = "stanford/bunny/bunny_npm_lowres.obj";

fn params(strategy: Strategy) -> ViewParams {
    ViewParams {
        strategy,
        ..ViewParams::default()
    }
}

#[test]
fn entropy_prefers_the_view_that_shows_more_faces() {
    let cube = cube();
    let one_face = viewpoint_entropy(&cube, [0.0, 0.0, 1.0], 128).unwrap();
    let two_faces = viewpoint_entropy(&cube, [1.0, 0.0, 1.0], 128).unwrap();
    let three_faces = viewpoint_entropy(&cube, [1.0, 1.0, 1.0], 128).unwrap();
    assert!(
        one_face < two_faces && two_faces < three_faces,
        "{one_face} {two_faces} {three_faces}"
    );
    // One face, two triangles of equal area plus the background: at most log2(3) bits.
    assert!(one_face > 1.0 && one_face <= 3f64.log2(), "{one_face}");
}

#[test]
fn entropy_is_the_same_for_the_same_view() {
    let bunny = load(LOW_BUNNY);
    let d = [0.2, -0.4, 0.9];
    let a = viewpoint_entropy(&bunny, d, 128).unwrap();
    assert_eq!(
        a.to_bits(),
        viewpoint_entropy(&bunny, d, 128).unwrap().to_bits()
    );
    assert!(a.is_finite() && a > 0.0);
}

#[test]
fn regular_returns_the_icosahedron_and_its_entropies() {
    let bunny = load(LOW_BUNNY);
    let plan = plan_views(&bunny, &params(Strategy::Regular)).unwrap();
    assert_eq!(plan.strategy, Strategy::Regular);
    assert_eq!(plan.directions, icosahedron_directions(0));
    for (&d, &h) in plan.directions.iter().zip(&plan.entropies) {
        assert_eq!(h, viewpoint_entropy(&bunny, d, 128).unwrap());
    }
    let axes = ViewParams {
        count: 6,
        ..params(Strategy::Regular)
    };
    assert_eq!(plan_views(&bunny, &axes).unwrap().directions.len(), 6);
}

#[test]
fn perturbed_moves_at_most_the_radius_and_never_loses_entropy() {
    let bunny = load(LOW_BUNNY);
    let plan = plan_views(&bunny, &params(Strategy::Perturbed)).unwrap();
    let regular = icosahedron_directions(0);
    assert_eq!(plan.directions.len(), 20);
    let mut moved = 0;
    for ((&d, &h), &r) in plan.directions.iter().zip(&plan.entropies).zip(&regular) {
        let angle = ori_math::angle_between(d, r).to_degrees();
        assert!(angle <= 4.0 + 1e-9, "moved {angle} degrees");
        assert!(h >= viewpoint_entropy(&bunny, r, 128).unwrap());
        assert_eq!(h, viewpoint_entropy(&bunny, d, 128).unwrap());
        moved += usize::from(angle > 1e-9);
    }
    // Entropy is not flat over a 4 degree disc, so most directions do move.
    assert!(moved >= 10, "only {moved} of 20 moved");

    let still = ViewParams {
        search_radius_deg: 0.0,
        ..params(Strategy::Perturbed)
    };
    assert_eq!(plan_views(&bunny, &still).unwrap().directions, regular);
}

#[test]
fn minimal_takes_the_most_informative_evaluation_directions() {
    let bunny = load(LOW_BUNNY);
    let p = ViewParams {
        count: 12,
        ..params(Strategy::MinimalSampling)
    };
    let plan = plan_views(&bunny, &p).unwrap();
    let candidates = evaluation_directions();
    let mut all: Vec<(f64, usize)> = candidates
        .iter()
        .enumerate()
        .map(|(i, &d)| (viewpoint_entropy(&bunny, d, 128).unwrap(), i))
        .collect();
    all.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let expected: Vec<[f64; 3]> = all[..12].iter().map(|&(_, i)| candidates[i]).collect();
    assert_eq!(plan.directions, expected);
    assert_eq!(
        plan.entropies,
        all[..12].iter().map(|a| a.0).collect::<Vec<_>>()
    );
    assert!(plan.entropies.windows(2).all(|w| w[0] >= w[1]));
}

#[test]
fn plans_are_bit_identical_for_any_thread_count() {
    let bunny = load(LOW_BUNNY);
    for strategy in [
        Strategy::Regular,
        Strategy::MinimalSampling,
        Strategy::Perturbed,
    ] {
        let one = with_threads(1, || plan_views(&bunny, &params(strategy)).unwrap());
        let two = with_threads(2, || plan_views(&bunny, &params(strategy)).unwrap());
        let three = with_threads(3, || plan_views(&bunny, &params(strategy)).unwrap());
        assert_eq!(one.encode(), two.encode(), "{strategy:?}");
        assert_eq!(one.encode(), three.encode(), "{strategy:?}");
    }
}

#[test]
fn a_plan_round_trips_through_its_bytes() {
    let bunny = load(LOW_BUNNY);
    let plan = plan_views(&bunny, &ViewParams::default()).unwrap();
    let bytes = plan.encode();
    assert_eq!(ViewPlan::decode(&bytes).unwrap(), plan);
    assert!(matches!(
        ViewPlan::decode(&bytes[1..]),
        Err(ViewError::Decode(_))
    ));
}

#[test]
fn params_deserialize_from_a_views_section() {
    #[derive(serde::Deserialize)]
    struct File {
        views: ViewParams,
    }
    let parse = |s: &str| toml::from_str::<File>(s).map(|f| f.views);
    assert_eq!(parse("[views]").unwrap(), ViewParams::default());
    let p = parse(
        "[views]\nstrategy = \"minimal\"\ncount = 12\nitem_buffer_size = 256\nsearch_radius_deg = 2.5",
    )
    .unwrap();
    assert_eq!(
        p,
        ViewParams {
            strategy: Strategy::MinimalSampling,
            count: 12,
            item_buffer_size: 256,
            search_radius_deg: 2.5,
        }
    );
    for name in ["regular", "minimal", "perturbed"] {
        let p = parse(&format!("[views]\nstrategy = \"{name}\"")).unwrap();
        assert_eq!(p.strategy.name(), name);
    }
    assert_eq!(ViewParams::default().strategy, Strategy::Perturbed);
    assert!(parse("[views]\ncuont = 20").is_err());
    assert!(parse("[views]\nstrategy = \"random\"").is_err());
}

#[test]
fn bad_params_are_clear_errors() {
    let bunny = load(LOW_BUNNY);
    let err = |p: ViewParams| match plan_views(&bunny, &p) {
        Err(ViewError::Params(msg)) => msg,
        other => panic!("expected a parameter error, got {other:?}"),
    };
    let msg = err(ViewParams {
        count: 12,
        ..ViewParams::default()
    });
    assert!(
        msg.contains("views.count = 12") && msg.contains("6, 20, 80, 320, 1280 or 5120"),
        "{msg}"
    );
    assert!(
        err(ViewParams {
            count: 321,
            ..params(Strategy::MinimalSampling)
        })
        .contains("1 to 320")
    );
    assert!(
        err(ViewParams {
            count: 0,
            ..params(Strategy::MinimalSampling)
        })
        .contains("views.count")
    );
    assert!(
        err(ViewParams {
            item_buffer_size: 8,
            ..ViewParams::default()
        })
        .contains("views.item_buffer_size")
    );
    assert!(
        err(ViewParams {
            search_radius_deg: f64::NAN,
            ..ViewParams::default()
        })
        .contains("views.search_radius_deg")
    );
}

#[test]
fn a_mesh_without_extent_is_an_error() {
    let point = mesh(vec![[1.0, 2.0, 3.0]; 3], vec![[0, 1, 2]]);
    let e = plan_views(&point, &ViewParams::default()).unwrap_err();
    assert!(matches!(e, ViewError::Mesh(_)), "{e}");
    assert!(e.to_string().contains("no extent"), "{e}");
}
