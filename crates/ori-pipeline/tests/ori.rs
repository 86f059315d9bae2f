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

/// Selection with the defaults (best:8, goal 0.2%, s0 = 256, 16 + 7 steps, wall threshold
/// 0.25) held, at the held-out directions (drawn as the runtime draws them, the nearest
/// entry's subset), to average and maximum coverage error and impostors per view.
fn holds(relative: &str, avg: f64, max: f64, impostors: f64) -> Ori {
    let ori = built(relative);
    let (sel, worst) = (&ori.selection, ori.maps.placement.worst_after);
    let s = sel.stats();
    let h = &ori.held_out;
    eprintln!(
        "{relative}: held-out max {:.3}% avg {:.3}%, {:.2} impostors per view; table max \
         {:.3}% avg {:.3}%, {:.2} impostors per view, {:?}; select {:.2} s",
        h.max_percent(),
        h.avg_percent(),
        h.avg_impostors(),
        s.max_percent,
        s.avg_percent,
        s.avg_impostors,
        s.views_by_count,
        ori.maps.times.select.as_secs_f64()
    );
    assert_eq!(sel.entries.len(), 320);
    assert_eq!(h.views.len(), 3280);
    assert!(
        h.avg_percent() <= avg,
        "held-out average {:.3}% > {avg}%",
        h.avg_percent()
    );
    assert!(
        h.max_percent() <= max,
        "held-out maximum {:.3}% > {max}%",
        h.max_percent()
    );
    assert!(
        h.avg_impostors() <= impostors,
        "{:.2} impostors per held-out view",
        h.avg_impostors()
    );
    // At its own directions every entry reaches the goal, where placement made it reachable.
    let goal = SelectParams::default().goal_pixels();
    assert!(
        sel.missed().into_iter().max().unwrap() <= worst.max(goal),
        "placement saw {worst} pixels at worst"
    );
    // The PLT is the held-out measure's.
    assert_eq!(ori.plt, ori_plt::estimate(sel.s0, &h.missed()));
    ori
}

/// Held-out average %, maximum %, impostors per view and the PLT's lower bound, held to
/// issue 21's targets (0.12 %, 0.30 %, 3.0 per view).
const BUNNY: (f64, f64, f64, f64) = (0.12, 0.30, 3.0, 330.0);
const ARMADILLO: (f64, f64, f64, f64) = (0.12, 0.30, 3.0, 330.0);

#[test]
fn bunny_quality() {
    // The paper's armadillo figures are 0.17 / 0.37 %, 2.9 impostors per view and PLT 270
    // with 256 x 256 maps, measured at its table's own directions only.
    let plt = holds(
        "stanford/bunny/stanford-bunny.obj",
        BUNNY.0,
        BUNNY.1,
        BUNNY.2,
    )
    .plt;
    assert!(plt.pixels() >= BUNNY.3, "PLT {plt}");
}

#[test]
fn armadillo_quality() {
    let plt = holds(
        "stanford/armadillo/armadillo_odedstein_remeshed.obj",
        ARMADILLO.0,
        ARMADILLO.1,
        ARMADILLO.2,
    )
    .plt;
    assert!(plt.pixels() >= ARMADILLO.3, "PLT {plt}");
}
