//! `cargo xtask preview`: a package drawn by the wgpu renderer beside its mesh (runs on the
//! software Vulkan driver in CI).

mod common;

use std::process::Command;

use common::*;

#[test]
fn preview_draws_the_ori_the_mesh_and_their_difference() {
    let p = Project::new(&["bunny"]);
    ok(&p.build(&[]));
    let png = p.path("preview.png");
    let run = |extra: &[&str]| {
        Command::new(EXE)
            .arg("preview")
            .arg(p.path("out/bunny/bunny_npm_lowres.ori"))
            .arg("--config")
            .arg(p.path("pipeline.toml"))
            .args(["--size", "96", "--out"])
            .arg(&png)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run(&["--turntable", "2"]);
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    assert!(t.contains("adapter: "), "{t}");
    let img = image::open(&png).unwrap();
    // Three columns (ORI, mesh, difference), one row per direction.
    assert_eq!((img.width(), img.height()), (3 * 96, 2 * 96));
    // The ORI and the mesh agree but for a few pixels along the outline.
    for line in t.lines().filter(|l| l.starts_with("dir ")) {
        let number = |key: &str| -> f64 {
            line.split(key)
                .nth(1)
                .unwrap()
                .trim()
                .split([' ', ','])
                .next()
                .unwrap()
                .parse()
                .unwrap()
        };
        let (mesh, missed) = (number("mesh"), number("missed"));
        assert!(mesh > 1000.0 && missed < 0.02 * mesh, "{line}");
    }

    let out = run(&["--dir", "1,2"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).contains("expected three numbers"));
}
