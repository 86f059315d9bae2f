//! Selection on the Stanford scans: the quality it reaches, the same table for any thread
//! count, and the artifact's round trip.

use std::time::Instant;

use ori_bake::{BakeParams, ReliefSet};
use ori_mesh::Mesh;
use ori_select::{Rule, SelectParams, Selection, select};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

fn load(relative: &str) -> Mesh {
    let path = format!("{MODELS}/{relative}");
    ori_mesh::load_file(path.as_ref(), &Default::default())
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .mesh
}

/// The model, planned (n = 20, perturbed) and baked (256 x 256) with the defaults.
fn prepared(relative: &str) -> (Mesh, ReliefSet) {
    let mesh = load(relative);
    let plan = ori_views::plan_views(&mesh, &Default::default()).expect("plan");
    let set = ori_bake::bake(&mesh, &plan.directions, &BakeParams::default()).expect("bake");
    (mesh, set)
}

/// The model through every stage before selection at the pipeline's defaults: planned,
/// placed (`ori_place`, measured with the default selection) and baked. Also returns the
/// placement's worst view (pixels missed with all M closest impostors).
fn placed(relative: &str) -> (Mesh, ReliefSet, u32) {
    let mesh = load(relative);
    let plan = ori_views::plan_views(&mesh, &Default::default()).expect("plan");
    let select = SelectParams::default();
    let measure = ori_place::Measure {
        bake: &BakeParams::default(),
        eval: &select.eval_params(),
        closest: select.rule.m() as usize,
        goal_pixels: select.goal_pixels(),
        entropy_size: ori_views::ViewParams::default().item_buffer_size,
    };
    let placed = ori_place::place(&mesh, &plan, &measure, &Default::default()).expect("place");
    let set = ori_bake::bake(&mesh, &placed.plan.directions, &BakeParams::default()).expect("bake");
    (mesh, set, placed.worst_after)
}

/// Selection with the defaults (best:6, goal 0.2%, s0 = 256, 16 + 7 steps, wall threshold
/// 0.25) held to average and maximum coverage error and impostors per view.
fn holds(relative: &str, avg: f64, max: f64, impostors: f64) -> Selection {
    let (mesh, set, worst) = placed(relative);
    let started = Instant::now();
    let sel = select(&mesh, &set, &SelectParams::default()).expect("select");
    let s = sel.stats();
    eprintln!(
        "{relative}: min {:.3}% max {:.3}% avg {:.3}%, {:.2} impostors per view, {:?}, {:.2} s",
        s.min_percent,
        s.max_percent,
        s.avg_percent,
        s.avg_impostors,
        s.views_by_count,
        started.elapsed().as_secs_f64()
    );
    assert_eq!(sel.entries.len(), 320);
    assert!(
        s.avg_percent <= avg,
        "average {:.3}% > {avg}%",
        s.avg_percent
    );
    assert!(
        s.max_percent <= max,
        "maximum {:.3}% > {max}%",
        s.max_percent
    );
    assert!(
        s.avg_impostors <= impostors,
        "{:.2} impostors per view",
        s.avg_impostors
    );
    // The placement measured what the selection finds: no view is worse than the worst the
    // search saw, or than the goal where it stopped within it.
    let goal = SelectParams::default().goal_pixels();
    assert!(
        sel.missed().into_iter().max().unwrap() <= worst.max(goal),
        "placement saw {worst} pixels at worst"
    );
    sel
}

#[test]
fn bunny_quality() {
    // The paper's armadillo figures are 0.17 / 0.37 %, 2.9 impostors per view and PLT 270
    // with 256 x 256 maps. Measured with placement: 0.101 / 0.200 %, 2.33, PLT 500 (without
    // it the worst view, looking up through the holes in the scan's base, lost 1.573 %).
    // Held with about 10 % margin.
    let sel = holds("stanford/bunny/stanford-bunny.obj", 0.11, 0.22, 2.55);
    let plt = ori_plt::estimate(sel.s0, &sel.missed());
    assert!(plt.pixels() >= 450.0, "PLT {plt}");
}

#[test]
fn armadillo_quality() {
    // Measured with placement: 0.118 / 0.200 %, 2.65, PLT 500 (without it 0.130 / 0.362 %,
    // 2.72, PLT 277). Held with about 10 % margin.
    let sel = holds(
        "stanford/armadillo/armadillo_odedstein_remeshed.obj",
        0.13,
        0.22,
        2.9,
    );
    let plt = ori_plt::estimate(sel.s0, &sel.missed());
    assert!(plt.pixels() >= 450.0, "PLT {plt}");
}

#[test]
fn the_table_is_the_same_for_any_thread_count_and_round_trips() {
    let (mesh, set) = prepared("stanford/bunny/bunny_npm_lowres.obj");
    let params = SelectParams {
        rule: Rule::Best(4),
        ..SelectParams::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| select(&mesh, &set, &params))
            .expect("select")
            .encode()
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
    let sel = Selection::decode(&one).expect("decode");
    assert_eq!(sel.encode(), one);
    assert_eq!(sel.rule, Rule::Best(4));
    for e in &sel.entries {
        assert!(!e.impostors.is_empty() && e.impostors.len() <= 4);
    }
    // Each entry is ordered closest first and `lookup` finds a direction's own entry.
    let dirs = ori_views::evaluation_directions();
    for (d, e) in sel.entries.iter().enumerate() {
        let dots: Vec<f64> = e
            .impostors
            .iter()
            .map(|&i| {
                let v = set.maps[i as usize].view.frame.d;
                v[0] * dirs[d][0] + v[1] * dirs[d][1] + v[2] * dirs[d][2]
            })
            .collect();
        assert!(
            dots.windows(2).all(|p| p[0] >= p[1]),
            "direction {d}: {dots:?}"
        );
        assert_eq!(sel.lookup(dirs[d]), e);
    }
    // Damaged bytes are errors, never panics.
    for cut in [0, 7, 20, one.len() - 1] {
        assert!(Selection::decode(&one[..cut]).is_err());
    }
    let mut bad = one.clone();
    bad.push(0);
    assert!(Selection::decode(&bad).is_err());
}

#[test]
fn params_come_from_a_select_section() {
    let p: SelectParams = toml::from_str("rule = \"closest:3\"\ngoal_percent = 0.5").unwrap();
    assert_eq!(p.rule, Rule::Closest(3));
    assert_eq!(p.goal_pixels(), 327);
    assert_eq!(
        toml::from_str::<SelectParams>("").unwrap(),
        SelectParams::default()
    );
    assert_eq!(SelectParams::default().goal_pixels(), 131);
    let unknown = toml::from_str::<SelectParams>("rules = \"best:6\"").unwrap_err();
    assert!(unknown.to_string().contains("rules"), "{unknown}");
    for bad in ["best:0", "best:17", "closest:0", "nearest:2", "best"] {
        let e = toml::from_str::<SelectParams>(&format!("rule = \"{bad}\"")).unwrap_err();
        assert!(e.to_string().contains("select.rule"), "{bad}: {e}");
    }
    let too_far = SelectParams {
        goal_percent: 101.0,
        ..SelectParams::default()
    };
    assert!(too_far.validate().is_err());
}
