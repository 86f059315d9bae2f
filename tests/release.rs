//! End-to-end tests of the release a build writes: packages and `release.json`, their
//! reproducibility (clean caches, thread counts, checkout paths, cold or cached), `verify`,
//! `--explode`, and which jobs each kind of edit re-runs.

mod common;

use std::fs;
use std::path::Path;
use std::process::Command;

use common::*;

fn verify(dir: &Path) -> std::process::Output {
    Command::new(EXE).arg("verify").arg(dir).output().unwrap()
}

#[test]
fn a_build_writes_valid_packages_and_a_release_index() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    ok(&p.build(&[]));
    let release: serde_json::Value =
        serde_json::from_slice(&fs::read(p.path("out/release.json")).unwrap()).unwrap();
    let assets = release["assets"].as_array().unwrap();
    let names: Vec<&str> = assets.iter().map(|a| a["name"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "box-vertex-colors/BoxVertexColors.glb",
            "bunny/bunny_npm_lowres.obj"
        ]
    );
    for a in assets {
        let bytes = fs::read(p.path("out").join(a["package"].as_str().unwrap())).unwrap();
        assert_eq!(a["bytes"], bytes.len());
        assert_eq!(a["blake3"], blake3::hash(&bytes).to_hex().as_str());
        let package = ori_package::read(&bytes).unwrap();
        let m = &package.manifest;
        assert_eq!(m.impostors.len(), 20);
        assert_eq!(m.selection.entries.len(), 320);
        assert_eq!(m.source.name, a["name"].as_str().unwrap());
        // The guide's budget: 2.5 bytes per texel (R8 + BC5 + BC1), plus KTX2 headers.
        let texels = 20 * u64::from(m.resolution) * u64::from(m.resolution);
        assert!(package.texture_bytes() >= texels * 5 / 2);
        assert!(package.texture_bytes() < texels * 5 / 2 + 20 * 3 * 1024);
        assert_eq!(a["texture_bytes"], package.texture_bytes());
        assert_eq!(a["plt"], m.plt.pixels);
        // The source hash is the model file's.
        let source = fs::read(p.path("assets").join(&m.source.name)).unwrap();
        assert_eq!(m.source.blake3, blake3::hash(&source).to_hex().as_str());
    }
    let out = verify(&p.path("out"));
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("2 package(s) verified"));
}

#[test]
fn the_release_is_byte_identical_however_it_is_built() {
    let samples = ["bunny", "box-vertex-colors", "glass-vase-flowers"];
    let a = Project::new(&samples);
    ok(&a.build(&["-j", "1"]));
    let reference = tree(&a.path("out"));
    assert_eq!(reference.len(), 4, "{:?}", reference.keys());

    // Fully cached, in a new process: the same folder (and nothing rewritten).
    let cached = a.build(&["-j", "2"]);
    assert_eq!(ran_all(&cached), [0; 8], "{}", text(&cached));
    same_release(&reference, &tree(&a.path("out")), "cached rebuild");

    // A clean cache, two threads, another checkout path.
    let b = Project::new(&samples);
    ok(&b.build(&["-j", "2"]));
    same_release(&reference, &tree(&b.path("out")), "clean cache, 2 threads");

    // Cold again from a clean cache with one thread, into a fresh output folder.
    fs::remove_dir_all(b.path("cache")).unwrap();
    fs::remove_dir_all(b.path("out")).unwrap();
    ok(&b.build(&["-j", "1"]));
    same_release(&reference, &tree(&b.path("out")), "clean cache, 1 thread");
}

#[test]
fn edits_rerun_exactly_the_stages_they_touch() {
    let p = Project::new(&["bunny", "box-vertex-colors", "avocado"]);
    ok(&p.build(&[]));

    // Touching a file without changing its bytes runs nothing.
    let bunny = p.path("assets/bunny/bunny_npm_lowres.obj");
    let f = fs::File::options().append(true).open(&bunny).unwrap();
    f.set_modified(std::time::SystemTime::now()).unwrap();
    drop(f);
    let out = p.build(&[]);
    assert_eq!(ran_all(&out), [0; 8], "{}", text(&out));

    // A comment changes the file, not the mesh: ingest runs, and packaging records the new
    // source hash; everything between is reused.
    let mut obj = fs::read(&bunny).unwrap();
    obj.extend_from_slice(b"# edited\n");
    fs::write(&bunny, obj).unwrap();
    let out = p.build(&["--explain"]);
    assert_eq!(ran_all(&out), [1, 0, 0, 0, 0, 0, 0, 1], "{}", text(&out));

    // Moving a vertex changes that asset's mesh: all of its jobs, no other asset's.
    let moved =
        fs::read_to_string(&bunny)
            .unwrap()
            .replacen("\nv ", "\nv 0.001 0.002 0.003 # was: ", 1);
    fs::write(&bunny, moved).unwrap();
    let out = p.build(&[]);
    assert_eq!(ran_all(&out), [1; 8], "{}", text(&out));

    // A compression parameter: compression and packaging, every asset.
    p.config("[compress]\nquality = \"fast\"\n");
    let out = p.build(&["--explain"]);
    let t = ok(&out);
    assert_eq!(ran_all(&out), [0, 0, 0, 0, 0, 0, 3, 3], "{t}");
    assert!(
        t.contains("[compress] bunny/bunny_npm_lowres.obj: ran in")
            && t.contains("parameters changed: quality: \"high\" -> \"fast\""),
        "{t}"
    );

    // The selection's region grid: selection, the PLT and packaging; placement measures
    // neither the grid nor its goal, so it is reused.
    p.config(
        "[compress]\nquality = \"fast\"\n[[overrides]]\nassets = \"**\"\nselect.region_steps = 3\n",
    );
    let out = p.build(&["--explain"]);
    let t = ok(&out);
    assert_eq!(ran_all(&out), [0, 0, 0, 0, 3, 3, 0, 3], "{t}");
    assert!(t.contains("region_steps: 2 -> 3"), "{t}");

    // The impostor count: views, baking and everything after them.
    p.config("[compress]\nquality = \"fast\"\n[views]\ncount = 6\n");
    let out = p.build(&["--explain"]);
    let t = ok(&out);
    assert_eq!(ran_all(&out), [0, 3, 3, 3, 3, 3, 3, 3], "{t}");
    assert!(t.contains("parameters changed: count: 20 -> 6"), "{t}");
    let release = tree(&p.path("out"));
    let package = ori_package::read(&release["bunny/bunny_npm_lowres.ori"]).unwrap();
    assert_eq!(package.manifest.impostors.len(), 6);
}

#[test]
fn verify_names_every_mismatch() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    ok(&p.build(&[]));
    let out_dir = p.path("out");

    // One flipped byte in a texture: the hash differs and the package no longer reads.
    let bunny = out_dir.join("bunny/bunny_npm_lowres.ori");
    let mut bytes = fs::read(&bunny).unwrap();
    let last = bytes.len() - 100;
    bytes[last] ^= 0x40;
    fs::write(&bunny, &bytes).unwrap();
    // A package nobody listed, and a listed one gone.
    fs::write(out_dir.join("stray.ori"), b"not a package").unwrap();
    fs::remove_file(out_dir.join("box-vertex-colors/BoxVertexColors.ori")).unwrap();

    let out = verify(&out_dir);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(
        t.contains("bunny_npm_lowres.ori: invalid package")
            && t.contains("BoxVertexColors.ori: cannot read")
            && t.contains("stray.ori: not listed in release.json")
            && t.contains("3 mismatch(es)"),
        "{t}"
    );

    // A rebuild repairs what it wrote: the damaged package is rewritten, the missing one
    // written again. The stray one is not the builder's: left alone, with a warning.
    let t = ok(&p.build(&[]));
    assert!(
        t.contains("1 .ori file(s) this builder did not write were left alone (stray.ori)"),
        "{t}"
    );
    assert_eq!(
        fs::read(out_dir.join("stray.ori")).unwrap(),
        b"not a package"
    );
    let t = text(&verify(&out_dir));
    assert!(
        t.contains("stray.ori: not listed") && t.contains("1 mismatch(es)"),
        "{t}"
    );
    fs::remove_file(out_dir.join("stray.ori")).unwrap();
    let out = verify(&out_dir);
    assert!(out.status.success(), "{}", text(&out));

    // A missing index is an error, not a pass.
    fs::remove_file(out_dir.join("release.json")).unwrap();
    let out = verify(&out_dir);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out).contains("release.json: cannot read"));
}

#[test]
fn removed_assets_leave_no_package_behind() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    ok(&p.build(&[]));
    assert!(p.path("out/bunny/bunny_npm_lowres.ori").exists());
    fs::remove_dir_all(p.path("assets/bunny")).unwrap();
    ok(&p.build(&[]));
    assert!(!p.path("out/bunny/bunny_npm_lowres.ori").exists());
    let out = verify(&p.path("out"));
    assert!(
        text(&out).contains("1 package(s) verified"),
        "{}",
        text(&out)
    );
}

#[test]
fn explode_writes_an_inspectable_folder() {
    let p = Project::new(&["box-vertex-colors"]);
    let out = p.build(&["--explode", p.path("exploded").to_str().unwrap()]);
    ok(&out);
    let dir = p.path("exploded/box-vertex-colors/BoxVertexColors");
    let manifest: serde_json::Value =
        serde_json::from_slice(&fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["impostors"].as_array().unwrap().len(), 20);
    for i in [0, 19] {
        for map in ["depth", "normal", "albedo"] {
            for ext in ["ktx2", "png"] {
                let f = dir.join(format!("impostor-{i:02}-{map}.{ext}"));
                assert!(fs::metadata(&f).unwrap().len() > 0, "{}", f.display());
            }
        }
    }
}

#[test]
fn auto_resolution_picks_the_smallest_that_reaches_the_target_and_caches_each_try() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    p.config(
        "[bake]\nresolution = \"auto\"\n[plt]\ntarget_px = 60\nmin_resolution = 32\nmax_resolution = 256\n",
    );
    let out = p.build(&[]);
    ok(&out);
    let report = p.report();
    let release = tree(&p.path("out"));
    for a in report["assets"].as_array().unwrap() {
        let chosen = a["resolution"].as_u64().unwrap();
        let auto = &a["auto_resolution"];
        let tried: Vec<(u64, f64)> = auto["tried"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| (t[0].as_u64().unwrap(), t[1].as_f64().unwrap()))
            .collect();
        let plt = |r: u64| tried.iter().find(|t| t.0 == r).map(|t| t.1);
        assert_eq!(
            tried[0].0, 128,
            "first guess: the power of two nearest 2 x target"
        );
        if auto["reached"] == true {
            assert!(plt(chosen).unwrap() >= 60.0, "{a}");
            assert!(chosen == 32 || plt(chosen / 2).unwrap() < 60.0, "{a}");
        } else {
            assert!(tried.iter().all(|t| t.1 < 60.0), "{a}");
        }
        let name = a["name"].as_str().unwrap();
        let package =
            ori_package::read(&release[&name.replace(".obj", ".ori").replace(".glb", ".ori")])
                .unwrap();
        assert_eq!(u64::from(package.manifest.resolution), chosen);
        assert_eq!(package.manifest.params["bake"]["resolution_auto"], true);
    }
    // Every resolution tried is cached: a second build runs nothing.
    let again = p.build(&[]);
    assert_eq!(ran_all(&again), [0; 8], "{}", text(&again));
}

#[test]
fn a_rebuild_repairs_a_tampered_package_and_ignores_a_damaged_release_memo() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    ok(&p.build(&[]));
    let clean = tree(&p.path("out"));
    // Once the memo knows the release, a no-op build still catches a package changed in place
    // (same size, other bytes).
    ok(&p.build(&[]));
    let package = p.path("out/bunny/bunny_npm_lowres.ori");
    let mut bytes = fs::read(&package).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0xff;
    fs::write(&package, &bytes).unwrap();
    assert!(!verify(&p.path("out")).status.success());
    let out = p.build(&[]);
    ok(&out);
    assert_eq!(ran(&out, "package"), 0, "{}", text(&out));
    same_release(&clean, &tree(&p.path("out")), "after repairing a package");
    // A damaged memo of checks is checked again, not believed.
    for shard in fs::read_dir(p.path("cache/release-checks")).unwrap() {
        let shard = shard.unwrap().path();
        let mut memo = fs::read(&shard).unwrap();
        let middle = memo.len() / 2;
        memo[middle] ^= 1;
        fs::write(&shard, memo).unwrap();
    }
    fs::write(p.path("cache/release-stat-memo.json"), b"not json").unwrap();
    fs::remove_file(&package).unwrap();
    ok(&p.build(&[]));
    same_release(&clean, &tree(&p.path("out")), "after damaging the memo");
    assert!(verify(&p.path("out")).status.success());
}
