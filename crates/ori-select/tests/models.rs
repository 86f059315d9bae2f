//! Selection on a Stanford scan: the same table for any thread count, and the artifact's
//! round trip. (The quality the whole chain reaches is tested in ori-pipeline's `tests/ori.rs`.)

use ori_bake::{BakeParams, ReliefSet};
use ori_mesh::Mesh;
use ori_select::{
    MaskPlan, RegionShape, Rule, SelectParams, Selection, all_view_masks, select,
    select_from_masks, select_with,
};

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

#[test]
fn the_table_is_the_same_for_any_thread_count_and_round_trips() {
    let (mesh, set) = prepared("stanford/bunny/bunny_npm_lowres.obj");
    // Corners and edge midpoints only: the region grid's size does not change how work is
    // split and collected, and three selections at the default grid cost several times more.
    let params = SelectParams {
        rule: Rule::Best(4),
        region_steps: 2,
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
fn masks_traced_as_the_search_reads_them_choose_what_all_masks_choose() {
    let (mesh, set) = prepared("stanford/bunny/bunny_npm_lowres.obj");
    // The default rule and region grid, at a smaller s0 (the search's order is the same).
    let params = SelectParams {
        s0: 64,
        ..SelectParams::default()
    };
    let evaluator = ori_eval::Evaluator::new(&mesh, &set, &params.eval_params()).expect("eval");
    let plan = MaskPlan::new(&evaluator, &params);
    let masks = all_view_masks(&evaluator, &plan).expect("masks");
    let every = select_from_masks(&masks, &params, set.maps.len()).expect("select");
    assert_eq!(select_with(&evaluator, &params).expect("select"), every);
    assert!(every.entries.iter().any(|e| e.impostors.len() > 1));
    // The entries' own views are drawn at s0, their regions' at s0 * region_scale; masks
    // of another size are refused, not searched.
    assert_eq!(masks[plan.own_views - 1].reference.size(), 64);
    assert_eq!(masks[plan.own_views].reference.size(), 48);
    let full_size = SelectParams {
        region_scale: 1.0,
        ..params.clone()
    };
    let refused = select_from_masks(&masks, &full_size, set.maps.len()).unwrap_err();
    assert!(refused.to_string().contains("64 x 64"), "{refused}");
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
    for shape in [RegionShape::Cell, RegionShape::Triangle] {
        let written = toml::to_string(&SelectParams {
            region_shape: shape,
            ..SelectParams::default()
        })
        .unwrap();
        let name = written
            .lines()
            .find_map(|l| l.strip_prefix("region_shape = "))
            .unwrap()
            .trim_matches('"');
        assert_eq!(name.parse::<RegionShape>().unwrap(), shape, "{written}");
    }
    let e = "cells".parse::<RegionShape>().unwrap_err().to_string();
    assert!(e.contains("select.region_shape"), "{e}");
    let too_far = SelectParams {
        goal_percent: 101.0,
        ..SelectParams::default()
    };
    assert!(too_far.validate().is_err());
    for scale in ["0.0", "0.2", "1.01", "nan", "inf"] {
        let e = toml::from_str::<SelectParams>(&format!("region_scale = {scale}"))
            .map_err(|e| e.to_string())
            .and_then(|p| p.validate().map_err(|e| e.to_string()))
            .unwrap_err();
        assert!(e.contains("select.region_scale"), "{scale}: {e}");
    }
}

#[test]
fn the_held_out_measure_at_the_table_directions_is_the_table() {
    let (mesh, set) = prepared("stanford/bunny/bunny_npm_lowres.obj");
    let params = SelectParams {
        s0: 128,
        ..SelectParams::default()
    };
    let sel = select(&mesh, &set, &params).expect("select");
    let evaluator =
        ori_eval::Evaluator::new(&mesh, &set, &params.eval_params()).expect("evaluator");
    let subset = |w: [f64; 3]| {
        sel.lookup(w)
            .impostors
            .iter()
            .map(|&i| usize::from(i))
            .collect()
    };
    // Drawn at the table's own directions, the runtime rule misses what the table says.
    let table = ori_select::held_out(&evaluator, &ori_views::evaluation_directions(), &subset)
        .expect("held out");
    let expected: Vec<(u32, usize)> = sel
        .entries
        .iter()
        .map(|e| (e.missed, e.impostors.len()))
        .collect();
    assert_eq!(table.views, expected);
    assert_eq!(
        table.worst_missed(),
        sel.missed().into_iter().max().unwrap()
    );
    // Between them, every view draws its nearest entry's subset.
    let held = ori_select::held_out(
        &evaluator,
        &ori_views::held_out_directions(ori_views::DEFAULT_HELD_OUT_SEED),
        &subset,
    )
    .expect("held out");
    assert_eq!(held.views.len(), 3280);
    assert!(held.avg_impostors() > 1.0 && held.avg_impostors() <= 6.0);
}
