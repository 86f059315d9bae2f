//! The HTML build report: written by every build, opened in headless Chromium (every picture
//! loads, no script error), re-made from a release by `cargo xtask report`.

mod common;

use std::fs;
use std::path::Path;
use std::process::Command;

use common::*;

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
        assert_eq!(a["jobs"].as_array().unwrap().len(), 8);
    }

    // Every picture loads and no script fails: the page's own check, read from the DOM.
    let dom = chromium(
        &p.path("chromium-dom"),
        &["--virtual-time-budget=10000", "--dump-dom"],
        &index,
        "",
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
        "",
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

/// The picture folder of each asset in `out/report/report.json`, by asset name.
fn picture_folders(p: &Project) -> Vec<(String, String)> {
    let figures: serde_json::Value =
        serde_json::from_slice(&fs::read(p.path("out/report/report.json")).unwrap()).unwrap();
    figures["assets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            let first = a["pictures"][0][1].as_str().unwrap();
            let folder = first.split('/').next().unwrap().to_string();
            (a["name"].as_str().unwrap().to_string(), folder)
        })
        .collect()
}

#[test]
fn a_rebuild_redraws_only_the_pictures_of_what_changed() {
    let p = Project::new(&["box-vertex-colors", "bunny"]);
    ok(&p.build_with_report(&[]));
    let folders = picture_folders(&p);
    assert_eq!(folders.len(), 2);
    let modified = |folder: &str| {
        fs::metadata(p.path(&format!("out/report/{folder}/front-ori.png")))
            .unwrap()
            .modified()
            .unwrap()
    };
    let before: Vec<_> = folders.iter().map(|(_, f)| modified(f)).collect();
    let stamp =
        |folder: &str| fs::read(p.path(&format!("out/report/{folder}/pictures.json"))).unwrap();
    let stamps: Vec<_> = folders.iter().map(|(_, f)| stamp(f)).collect();

    // Move one vertex of the bunny.
    let model = p.path("assets/bunny/bunny_npm_lowres.obj");
    let text = fs::read_to_string(&model).unwrap();
    fs::write(
        &model,
        text.replacen("\nv ", "\nv 0.001 0.002 0.003 # was: ", 1),
    )
    .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    ok(&p.build_with_report(&[]));
    assert_eq!(picture_folders(&p), folders);
    for (k, (name, folder)) in folders.iter().enumerate() {
        let redrawn = modified(folder) != before[k];
        let edited = name.starts_with("bunny/");
        assert_eq!(redrawn, edited, "{name}: redrawn {redrawn}");
        assert_eq!(stamp(folder) != stamps[k], edited, "{name}: stamp");
    }
    let html = fs::read_to_string(p.path("out/report/index.html")).unwrap();
    assert!(html.contains("front-ori.png") && !html.contains("changed since"));

    // An asset added before the others in the table: their pictures stay where they are,
    // undrawn; removed again, its pictures go with it.
    let after_edit: Vec<_> = folders.iter().map(|(_, f)| modified(f)).collect();
    common::copy_dir(
        &p.path("assets/box-vertex-colors"),
        &p.path("assets/a-first"),
    );
    ok(&p.build_with_report(&[]));
    let with_added = picture_folders(&p);
    assert_eq!(with_added.len(), 3);
    assert_eq!(with_added[0].0, "a-first/BoxVertexColors.glb");
    assert_eq!(&with_added[1..], folders.as_slice());
    let still: Vec<_> = folders.iter().map(|(_, f)| modified(f)).collect();
    assert_eq!(
        still, after_edit,
        "pictures redrawn after an asset was added"
    );
    fs::remove_dir_all(p.path("assets/a-first")).unwrap();
    ok(&p.build_with_report(&[]));
    assert_eq!(picture_folders(&p), folders);
    assert!(!p.path(&format!("out/report/{}", with_added[0].1)).exists());
}

#[test]
fn with_compare_enabled_the_report_ranks_each_ori_among_its_rivals() {
    let p = Project::new(&["box-vertex-colors"]);
    p.config("[compare]\nenabled = true\ndirections = 8\n");
    ok(&p.build_with_report(&[]));
    let summary: serde_json::Value =
        serde_json::from_slice(&fs::read(p.path("out/report/report.json")).unwrap()).unwrap();
    let rows = summary["assets"][0]["comparison"].as_array().unwrap();
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r["technique"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "octahedral",
            "hemi-octahedral",
            "billboards-orthographic",
            "billboards-perspective",
            "relief-box",
            "billboard-cloud",
            "simplified-mesh",
            "ori"
        ]
    );
    // The ORI's row is measured on its package: 20 maps of 256 x 256 at 2.5 bytes a texel.
    assert_eq!(rows[7]["bytes"], 20 * 256 * 256 * 5 / 2);
    let index = p.path("out/report/index.html");
    let html = fs::read_to_string(&index).unwrap();
    assert!(html.contains("Rivals at equal bytes") && html.contains("billboard-cloud"));

    // Turned off again, the section goes (the pictures' stamp names the comparison).
    p.config("");
    let out = Command::new(EXE)
        .args(["report", "--config"])
        .arg(p.path("pipeline.toml"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let html = fs::read_to_string(&index).unwrap();
    assert!(!html.contains("Rivals at equal bytes"));
}
