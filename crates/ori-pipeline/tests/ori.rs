//! The whole chain (`ori::build_ori`: views, place, bake, select, plt) on the Stanford scans
//! at the pipeline's defaults: the quality it reaches.

use ori_mesh::Mesh;
use ori_pipeline::ori::{Ori, OriParams, build_ori};
use ori_select::SelectParams;

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

fn load(relative: &str) -> Mesh {
    let path = format!("{MODELS}/{relative}");
    ori_mesh::load_file(path.as_ref(), &Default::default())
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .mesh
}

/// The model through every step at the pipeline's defaults: planned, placed (measured with
/// the default selection), baked, selected and its PLT measured.
fn built(relative: &str) -> Ori {
    let mesh = load(relative);
    build_ori(&mesh, &OriParams::default()).unwrap_or_else(|e| panic!("{relative}: {e}"))
}

/// Selection with the defaults (best:6, goal 0.2%, s0 = 256, 16 + 7 steps, wall threshold
/// 0.25) held to average and maximum coverage error and impostors per view.
fn holds(relative: &str, avg: f64, max: f64, impostors: f64) -> Ori {
    let ori = built(relative);
    let (sel, worst) = (&ori.selection, ori.maps.placement.worst_after);
    let s = sel.stats();
    eprintln!(
        "{relative}: min {:.3}% max {:.3}% avg {:.3}%, {:.2} impostors per view, {:?}, {:.2} s",
        s.min_percent,
        s.max_percent,
        s.avg_percent,
        s.avg_impostors,
        s.views_by_count,
        ori.maps.times.select.as_secs_f64()
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
    // The PLT step reads the same table.
    assert_eq!(ori.plt, ori_plt::estimate(sel.s0, &sel.missed()));
    ori
}

#[test]
fn bunny_quality() {
    // The paper's armadillo figures are 0.17 / 0.37 %, 2.9 impostors per view and PLT 270
    // with 256 x 256 maps. Measured with placement: 0.101 / 0.200 %, 2.33, PLT 500 (without
    // it the worst view, looking up through the holes in the scan's base, lost 1.573 %).
    // Held with about 10 % margin.
    let plt = holds("stanford/bunny/stanford-bunny.obj", 0.11, 0.22, 2.55).plt;
    assert!(plt.pixels() >= 450.0, "PLT {plt}");
}

#[test]
fn armadillo_quality() {
    // Measured with placement: 0.118 / 0.200 %, 2.65, PLT 500 (without it 0.130 / 0.362 %,
    // 2.72, PLT 277). Held with about 10 % margin.
    let plt = holds(
        "stanford/armadillo/armadillo_odedstein_remeshed.obj",
        0.13,
        0.22,
        2.9,
    )
    .plt;
    assert!(plt.pixels() >= 450.0, "PLT {plt}");
}
