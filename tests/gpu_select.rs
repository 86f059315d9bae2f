//! `build-assets --backend gpu`: selection measured with the wgpu renderer (the software
//! Vulkan driver in CI) gives the CPU evaluator's table, under its own cache keys.

mod common;

use std::fs;

use common::*;

fn measured_by(p: &Project) -> String {
    let bytes = fs::read(p.path("out/bunny/bunny_npm_lowres.ori")).unwrap();
    ori_package::read(&bytes).unwrap().manifest.plt.measured_by
}

fn selection_of(p: &Project) -> Vec<(Vec<u16>, u32)> {
    let bytes = fs::read(p.path("out/bunny/bunny_npm_lowres.ori")).unwrap();
    let package = ori_package::read(&bytes).unwrap();
    package
        .manifest
        .selection
        .entries
        .iter()
        .map(|e| (e.impostors.clone(), e.missed))
        .collect()
}

#[test]
fn gpu_selection_matches_the_cpu_and_is_cached_apart() {
    let p = Project::new(&["bunny"]);
    ok(&p.build(&[]));
    let cpu = selection_of(&p);
    assert!(
        measured_by(&p).starts_with("cpu evaluator ("),
        "{}",
        measured_by(&p)
    );

    let out = p.build(&["--backend", "gpu", "--explain"]);
    let t = ok(&out);
    assert!(t.contains("selection backend: gpu on "), "{t}");
    // Only selection and what follows it run; the parameters name the device.
    assert_eq!(ran(&out, "bake"), 0, "{t}");
    assert_eq!(ran(&out, "select"), 1, "{t}");
    assert!(t.contains("backend: (unset) -> \"gpu\""), "{t}");
    let gpu = selection_of(&p);
    let differing = cpu.iter().zip(&gpu).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} of 320 directions differ");
    // The package says what measured it.
    let by = measured_by(&p);
    assert!(by.starts_with("wgpu renderer on "), "{by}");

    // Each backend's results are cached under their own keys.
    assert_eq!(ran(&p.build(&["--backend", "gpu"]), "select"), 0);
    assert_eq!(ran(&p.build(&[]), "select"), 0);
}
