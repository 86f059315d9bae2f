//! The HTML build report: written by every build, opened in headless Chromium (every picture
//! loads, no script error), re-made from a release by `cargo xtask report`.

mod common;

use std::fs;
use std::path::Path;
use std::process::Command;

use common::*;

/// Chromium, headless, as CI runs it (`.ci/run` installs Debian's `chromium`).
fn chromium(user_dir: &Path, args: &[&str], page: &Path) -> std::process::Output {
    Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
        ])
        .arg(format!("--user-data-dir={}", user_dir.display()))
        .args(args)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium must be installed (Debian package `chromium`; .ci/run installs it)")
}

#[test]
fn the_report_opens_in_a_browser_with_every_picture() {
    let p = Project::new(&["bunny", "box-vertex-colors", "glass-vase-flowers"]);
    let out = p.build_with_report(&[]);
    let t = ok(&out);
    assert!(t.contains("html report:"), "{t}");
    let index = p.path("out/report/index.html");
    let html = fs::read_to_string(&index).unwrap();
    for name in [
        "bunny/bunny_npm_lowres.obj",
        "box-vertex-colors/BoxVertexColors.glb",
        "glass-vase-flowers/GlassVaseFlowers.glb",
    ] {
        assert!(html.contains(name), "{name} missing from the report");
    }
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "network resource"
    );
    let figures: serde_json::Value =
        serde_json::from_slice(&fs::read(p.path("out/report/report.json")).unwrap()).unwrap();
    for a in figures["assets"].as_array().unwrap() {
        // Reference, ORI and error for four views, the worst view, two sampling pictures,
        // three contact sheets and the sphere.
        assert_eq!(a["pictures"].as_array().unwrap().len(), 19, "{a}");
        assert!(a["p_dif"].as_f64().unwrap() > 0.0, "{a}");
        assert_eq!(a["jobs"].as_array().unwrap().len(), 7);
    }

    // Every picture loads and no script fails: the page's own check, read from the DOM.
    let dom = chromium(
        &p.path("chromium-dom"),
        &["--virtual-time-budget=10000", "--dump-dom"],
        &index,
    );
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom.contains("data-check=\"images=57 failed=0 errors=0\""),
        "page check: {:?}",
        dom.split("data-check=")
            .nth(1)
            .map(|s| &s[..40.min(s.len())])
    );
    // A screenshot, to look at.
    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    let _ = fs::remove_file(&shot);
    chromium(
        &p.path("chromium-shot"),
        &[
            "--window-size=1400,2400",
            &format!("--screenshot={}", shot.display()),
        ],
        &index,
    );
    assert!(
        fs::metadata(&shot).unwrap().len() > 50_000,
        "{}",
        shot.display()
    );
}

#[test]
fn xtask_report_remakes_the_report_from_a_release() {
    let p = Project::new(&["box-vertex-colors"]);
    ok(&p.build_with_report(&[]));
    let index = p.path("out/report/index.html");
    let first = fs::read(&index).unwrap();
    fs::remove_dir_all(p.path("out/report")).unwrap();
    let remake = || {
        Command::new(EXE)
            .args(["report", "--config"])
            .arg(p.path("pipeline.toml"))
            .output()
            .unwrap()
    };
    let out = remake();
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(
        fs::read(&index).unwrap(),
        first,
        "the same report, byte for byte"
    );

    // A source edited since the build: figures stay, reference pictures go, and it says why.
    let model = p.path("assets/box-vertex-colors/BoxVertexColors.glb");
    let mut bytes = fs::read(&model).unwrap();
    bytes.extend_from_slice(&[0; 4]);
    fs::write(&model, bytes).unwrap();
    let out = remake();
    assert!(out.status.success(), "{}", text(&out));
    let html = fs::read_to_string(&index).unwrap();
    assert!(
        html.contains("changed since the package was built"),
        "{html}"
    );
    assert!(html.contains("maps-albedo.png") && !html.contains("front-mesh.png"));
}
