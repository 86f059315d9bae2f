//! `cargo bench -p ori-select --bench select`: selection + PLT at the defaults (n = 20,
//! 256 x 256 maps, s0 = 256, best:6), time per stage, median of 3, default thread pool, on
//! models of growing size. Planning and baking are done first and not timed.
//!
//! Stages: `masks` builds the evaluator and renders, for each of the 320 directions, the
//! mesh's coverage and the coverage masks of the 6 closest facing impostors; `select` runs
//! the subset search on them; `plt` reduces the errors to GC(s0) and the PLT.

use std::time::{Duration, Instant};

use ori_eval::Evaluator;
use ori_select::{SelectParams, all_view_masks, select_from_masks};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");
const RUNS: usize = 3;

fn median(mut t: Vec<Duration>) -> f64 {
    t.sort();
    t[t.len() / 2].as_secs_f64()
}

fn main() {
    let models = [
        "stanford/dragon/dragon_res4.ply",
        "stanford/bunny/bunny_npm_lowres.obj",
        "stanford/armadillo/armadillo_odedstein_remeshed.obj",
        "stanford/dragon/dragon_res3.ply",
        "stanford/bunny/stanford-bunny.obj",
        "stanford/dragon/dragon_res2_binary.ply",
    ];
    let params = SelectParams::default();
    println!(
        "selection ({}, goal {}%, s0 = {}) + PLT, {} threads, median of {RUNS}",
        params.rule,
        params.goal_percent,
        params.s0,
        rayon::current_num_threads()
    );
    println!(
        "{:<52} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6}",
        "model", "faces", "masks s", "select s", "plt s", "total s", "PLT"
    );
    let directions = ori_views::evaluation_directions();
    for rel in models {
        let path = format!("{MODELS}/{rel}");
        let mesh = match ori_mesh::load_file(path.as_ref(), &Default::default()) {
            Ok(loaded) => loaded.mesh,
            Err(e) => {
                println!("{rel}: skipped ({e})");
                continue;
            }
        };
        let plan = ori_views::plan_views(&mesh, &Default::default()).expect("plan");
        let set = ori_bake::bake(&mesh, &plan.directions, &Default::default()).expect("bake");
        let (mut tm, mut ts, mut tp, mut total) = (vec![], vec![], vec![], vec![]);
        let mut plt = None;
        for _ in 0..RUNS {
            let start = Instant::now();
            let evaluator = Evaluator::new(&mesh, &set, &params.eval_params()).expect("evaluator");
            let masks =
                all_view_masks(&evaluator, &directions, params.rule.m() as usize).expect("masks");
            tm.push(start.elapsed());
            let t = Instant::now();
            let sel = select_from_masks(&masks, &params, set.maps.len()).expect("select");
            ts.push(t.elapsed());
            let t = Instant::now();
            plt = Some(ori_plt::estimate(sel.s0, &sel.missed()));
            tp.push(t.elapsed());
            total.push(start.elapsed());
        }
        println!(
            "{rel:<52} {:>8} {:>8.3} {:>8.3} {:>8.4} {:>8.3} {:>6}",
            mesh.triangles.len(),
            median(tm),
            median(ts),
            median(tp),
            median(total),
            plt.expect("one run").to_string()
        );
    }
}
