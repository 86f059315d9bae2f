//! Time `plan_views` in the profile this is built with (by default dev, the profile tests and
//! `cargo xtask` use): `cargo run -p ori-views --example plan_timing [-- MODEL STRATEGY THREADS]`.
//! Defaults: the Stanford dragon (res2), strategy "perturbed", 2 threads; median of 5 runs.

use std::time::Instant;

use ori_views::{Strategy, ViewParams, plan_views};

fn main() {
    let mut args = std::env::args().skip(1);
    let model = args.next().unwrap_or_else(|| {
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/models/stanford/dragon/dragon_res2_binary.ply"
        )
        .into()
    });
    let strategy = match args.next().as_deref() {
        None | Some("perturbed") => Strategy::Perturbed,
        Some("regular") => Strategy::Regular,
        Some("minimal") => Strategy::MinimalSampling,
        Some(other) => panic!("unknown strategy {other:?} (regular, minimal or perturbed)"),
    };
    let threads = args.next().map_or(2, |t| t.parse().expect("thread count"));
    let mesh = ori_mesh::load_file(model.as_ref(), &Default::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .mesh;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let params = ViewParams {
        strategy,
        ..ViewParams::default()
    };
    let mut times: Vec<f64> = (0..5)
        .map(|_| {
            let start = Instant::now();
            pool.install(|| plan_views(&mesh, &params)).expect("plan");
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    println!(
        "{model}: {} triangles, {} with {threads} threads: median {:.1} ms (min {:.1}, max {:.1})",
        mesh.triangles.len(),
        strategy.name(),
        times[2],
        times[0],
        times[4]
    );
}
