//! `cargo bench -p ori-views --bench views`: `plan_views` per strategy on the Stanford scans
//! (2 rayon threads, median of 5), and the ORI paper's Figure-2 table (share of the visible
//! surface sampled by 0, 1, ... 10+ impostors) per strategy for the bunny and the armadillo.
//!
//! For the dev-profile time (what tests and `cargo xtask` run), see
//! `cargo run -p ori-views --example plan_timing`.

use std::time::{Duration, Instant};

use ori_views::{
    Strategy, ViewParams, plan_views, sampling_coverage_with_visible, visible_surface,
};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");
const STRATEGIES: [Strategy; 3] = [
    Strategy::Regular,
    Strategy::MinimalSampling,
    Strategy::Perturbed,
];
/// Bake resolution at which Figure 2 is measured.
const RESOLUTION: u32 = 256;

fn main() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("thread pool");
    let models = [
        ("bunny", "stanford/bunny/stanford-bunny.obj", true),
        (
            "armadillo",
            "stanford/armadillo/armadillo_odedstein_remeshed.obj",
            true,
        ),
        ("dragon", "stanford/dragon/dragon_res2_binary.ply", false),
    ];
    for (name, path, figure2) in models {
        let path = format!("{MODELS}/{path}");
        let mesh = match ori_mesh::load_file(path.as_ref(), &Default::default()) {
            Ok(loaded) => loaded.mesh,
            Err(e) => {
                println!("{name}: skipped ({e})");
                continue;
            }
        };
        println!("\n{name}: {} triangles", mesh.triangles.len());
        let mut plans = Vec::new();
        for strategy in STRATEGIES {
            let params = ViewParams {
                strategy,
                ..ViewParams::default()
            };
            let mut times: Vec<Duration> = Vec::new();
            let mut plan = None;
            for _ in 0..5 {
                let start = Instant::now();
                plan = Some(pool.install(|| plan_views(&mesh, &params)).expect("plan"));
                times.push(start.elapsed());
            }
            times.sort();
            let plan = plan.expect("five runs");
            let mean = plan.entropies.iter().sum::<f64>() / plan.entropies.len() as f64;
            println!(
                "  plan_views {:<9} median {:>8.1} ms (min {:.1}, max {:.1}), mean entropy {mean:.3} bits",
                strategy.name(),
                ms(times[2]),
                ms(times[0]),
                ms(times[4]),
            );
            plans.push(plan);
        }
        if !figure2 {
            continue;
        }
        let start = Instant::now();
        let visible = pool.install(|| visible_surface(&mesh, RESOLUTION));
        println!(
            "  Figure 2 at {RESOLUTION} px ({} of {} triangles visible, {:.0} ms), % of visible area sampled by k impostors:",
            visible.iter().filter(|&&v| v).count(),
            visible.len(),
            ms(start.elapsed())
        );
        println!(
            "  {:<9} {}    >=1 %  mean k",
            "k",
            (0..=10)
                .map(|k| format!("{:>5}", if k == 10 { "10+".into() } else { k.to_string() }))
                .collect::<String>()
        );
        for plan in &plans {
            let c = pool.install(|| {
                sampling_coverage_with_visible(&mesh, &plan.directions, RESOLUTION, visible.clone())
            });
            // Area-weighted mean number of impostors (counts above 10 as they are).
            let mut sum = 0.0;
            let mut area = 0.0;
            for (t, tri) in mesh
                .triangles
                .iter()
                .enumerate()
                .filter(|&(t, _)| c.visible[t])
            {
                let [a, b, d] = tri.map(|i| mesh.positions[i as usize].map(f64::from));
                let (e, f) = (
                    [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                    [d[0] - a[0], d[1] - a[1], d[2] - a[2]],
                );
                let n = [
                    e[1] * f[2] - e[2] * f[1],
                    e[2] * f[0] - e[0] * f[2],
                    e[0] * f[1] - e[1] * f[0],
                ];
                let w = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                sum += w * f64::from(c.counts[t]);
                area += w;
            }
            println!(
                "  {:<9} {}  {:>7.3}  {:>6.2}",
                plan.strategy.name(),
                c.histogram
                    .iter()
                    .map(|h| format!("{:>5.1}", 100.0 * h))
                    .collect::<String>(),
                100.0 * c.share_at_least(1),
                sum / area
            );
        }
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
