//! Hostile input is normal input: end-to-end tests of `build-assets` on asset folders that try
//! to read outside the asset root, exhaust memory or time, or damage the cache and the output
//! folder. Each case sits beside a good asset, which must still build; each hostile build must
//! fail with exit 1, a message naming the model, the reference and the rule, and stay within
//! bounded memory (the children's peak resident size is checked) and time (a hang is killed).

mod common;

use std::fs;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::*;

/// The good asset every hostile folder keeps beside its hostile ones.
const GOOD: &str = "box-vertex-colors/BoxVertexColors.glb";

/// Long enough for any of these builds on a loaded two-core machine; a hang is killed then.
const HANG: Duration = Duration::from_secs(180);

/// Peak resident memory of any child this process has waited for, in bytes (Linux).
fn children_peak_rss() -> u64 {
    #[repr(C)]
    struct RUsage {
        utime: [i64; 2],
        stime: [i64; 2],
        maxrss: i64,
        rest: [i64; 13],
    }
    unsafe extern "C" {
        fn getrusage(who: i32, usage: *mut RUsage) -> i32;
    }
    const RUSAGE_CHILDREN: i32 = -1;
    let mut usage = RUsage {
        utime: [0; 2],
        stime: [0; 2],
        maxrss: 0,
        rest: [0; 13],
    };
    // SAFETY: getrusage writes one `struct rusage`, whose layout on 64-bit Linux this is.
    let rc = unsafe { getrusage(RUSAGE_CHILDREN, &mut usage) };
    assert_eq!(rc, 0);
    usage.maxrss as u64 * 1024
}

/// Run `build-assets` on the project, killing it past [`HANG`]; prints its time.
fn build(p: &Project, args: &[&str]) -> Output {
    let start = Instant::now();
    let mut child = Command::new(EXE)
        .arg("build-assets")
        .arg("--config")
        .arg(p.path("pipeline.toml"))
        .arg("--no-report")
        .args(args)
        .env("CI", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > HANG {
            child.kill().unwrap();
            panic!("build-assets {args:?} ran past {HANG:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    eprintln!(
        "build-assets {args:?}: {:.2} s, exit {:?}",
        start.elapsed().as_secs_f64(),
        out.status.code()
    );
    out
}

/// A project holding the good asset and whatever the test adds under `assets/`.
fn project() -> Project {
    Project::new(&["box-vertex-colors"])
}

/// The build failed with exit 1, the good asset was built, every asset in `hostile` failed
/// with an error containing each of its phrases, and memory stayed bounded.
fn assert_refused(p: &Project, out: &Output, hostile: &[(&str, &[&str])]) {
    let t = text(out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(
        p.path("out/box-vertex-colors/BoxVertexColors.ori")
            .is_file(),
        "{t}"
    );
    let report = p.report();
    assert_eq!(asset(&report, GOOD)["status"], "ok", "{t}");
    for (name, phrases) in hostile {
        let a = asset(&report, name);
        assert_eq!(a["status"], "failed", "{name}: {t}");
        let error = a["error"].as_str().unwrap_or_default();
        for phrase in *phrases {
            assert!(error.contains(phrase), "{name}: `{phrase}` not in: {error}");
        }
        let package = release_package(name);
        assert!(!p.path("out").join(package).exists(), "{name} was packaged");
    }
    assert!(
        t.contains(&format!(" assets built, {} failed", hostile.len())),
        "the summary counts failed assets apart: {t}"
    );
    let peak = children_peak_rss();
    eprintln!(
        "peak resident memory of the builds so far: {} MiB",
        peak >> 20
    );
    assert!(peak < 2 << 30, "peak resident memory {peak} bytes");
}

fn release_package(name: &str) -> String {
    let stem = name.rsplit_once('.').map_or(name, |(s, _)| s);
    format!("{stem}.ori")
}

/// The Avocado glTF (external buffer and texture) copied to `assets/<folder>/`, with its
/// buffer URI replaced by `buffer_uri`.
fn avocado_with_buffer(p: &Project, folder: &str, buffer_uri: &str) {
    let dir = p.path("assets").join(folder);
    copy_dir(&samples().join("avocado"), &dir);
    let gltf = fs::read_to_string(dir.join("Avocado.gltf")).unwrap();
    let uri = serde_json::to_string(buffer_uri).unwrap();
    let gltf = gltf.replace("\"Avocado.bin\"", &uri);
    fs::write(dir.join("Avocado.gltf"), gltf).unwrap();
}

/// The small bunny OBJ copied to `assets/<folder>/bunny.obj` with `header` lines first.
fn bunny_with(p: &Project, folder: &str, header: &str) {
    let dir = p.path("assets").join(folder);
    fs::create_dir_all(&dir).unwrap();
    let obj = fs::read(samples().join("bunny/bunny_npm_lowres.obj")).unwrap();
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend_from_slice(&obj);
    fs::write(dir.join("bunny.obj"), bytes).unwrap();
}

#[test]
fn references_outside_the_asset_root_are_refused() {
    let p = project();
    // Real, loadable files outside the root (in the test's temp dir).
    fs::copy(samples().join("avocado/Avocado.bin"), p.path("outside.bin")).unwrap();
    fs::write(p.path("outside.mtl"), "newmtl m\nKd 1 0 0\n").unwrap();
    fs::copy(
        samples().join("avocado/Avocado_baseColor.png"),
        p.path("outside.png"),
    )
    .unwrap();
    let outside_abs = p.path("outside.bin").to_string_lossy().into_owned();
    avocado_with_buffer(&p, "absolute", &outside_abs);
    avocado_with_buffer(&p, "climbs", "../../outside.bin");
    avocado_with_buffer(&p, "encoded", "..%2F..%2Foutside.bin");
    avocado_with_buffer(&p, "linked", "link.bin");
    std::os::unix::fs::symlink(p.path("outside.bin"), p.path("assets/linked/link.bin")).unwrap();
    bunny_with(&p, "mtllib", "mtllib ../../outside.mtl\nusemtl m\n");
    bunny_with(&p, "map-kd", "mtllib m.mtl\nusemtl m\n");
    fs::write(
        p.path("assets/map-kd/m.mtl"),
        "newmtl m\nmap_Kd ../../outside.png\n",
    )
    .unwrap();
    // Climbing out and back in stays inside: allowed.
    avocado_with_buffer(&p, "inside", "../inside/Avocado.bin");

    let out = build(&p, &[]);
    let rule = "resolves outside the asset root";
    assert_refused(
        &p,
        &out,
        &[
            ("absolute/Avocado.gltf", &[&outside_abs, rule]),
            ("climbs/Avocado.gltf", &["`../../outside.bin`", rule]),
            ("encoded/Avocado.gltf", &["..%2F..%2Foutside.bin", rule]),
            ("linked/Avocado.gltf", &["`link.bin`", rule]),
            (
                "mtllib/bunny.obj",
                &["mtllib/bunny.obj", "../../outside.mtl", rule],
            ),
            ("map-kd/bunny.obj", &["m.mtl", "../../outside.png", rule]),
        ],
    );
    assert_eq!(asset(&p.report(), "inside/Avocado.gltf")["status"], "ok");
    // Nothing derived from the outside files was published.
    for name in ["absolute", "climbs", "encoded", "linked"] {
        let a = asset(&p.report(), &format!("{name}/Avocado.gltf")).clone();
        assert!(a["mesh"].is_null() && a["quality"].is_null(), "{a}");
    }
}

#[test]
fn devices_fifos_and_oversized_files_are_refused_without_blocking() {
    let p = project();
    p.config("[limits]\nmax_file_mb = 1\n");
    avocado_with_buffer(&p, "zero", "zero.bin");
    std::os::unix::fs::symlink("/dev/zero", p.path("assets/zero/zero.bin")).unwrap();
    avocado_with_buffer(&p, "fifo", "pipe.bin");
    let fifo = p.path("assets/fifo/pipe.bin");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    avocado_with_buffer(&p, "big", "big.bin");
    // A sparse file: 2 MiB claimed, nothing written.
    fs::File::create(p.path("assets/big/big.bin"))
        .unwrap()
        .set_len(2 << 20)
        .unwrap();

    let out = build(&p, &[]);
    assert_refused(
        &p,
        &out,
        &[
            (
                "zero/Avocado.gltf",
                &["`zero.bin`", "outside the asset root"],
            ),
            ("fifo/Avocado.gltf", &["`pipe.bin`", "not a regular file"]),
            (
                "big/Avocado.gltf",
                &["`big.bin`", "2097152 bytes", "[limits] max_file_mb"],
            ),
        ],
    );
}

#[test]
fn textures_past_the_pixel_limits_fail_before_decoding() {
    let p = project();
    // 9000 x 9000 grey: 81 M pixels, past the default 8192 x 8192, a few hundred KB on disk.
    let dir = p.path("assets/huge");
    fs::create_dir_all(&dir).unwrap();
    let grey = image::GrayImage::new(9000, 9000);
    grey.save(dir.join("huge.png")).unwrap();
    assert!(fs::metadata(dir.join("huge.png")).unwrap().len() < 1 << 20);
    let obj = fs::read(samples().join("bunny/bunny_npm_lowres.obj")).unwrap();
    let mut bytes = b"mtllib m.mtl\nusemtl m\n".to_vec();
    bytes.extend_from_slice(&obj);
    fs::write(dir.join("bunny.obj"), bytes).unwrap();
    fs::write(dir.join("m.mtl"), "newmtl m\nmap_Kd huge.png\n").unwrap();

    let out = build(&p, &[]);
    assert_refused(
        &p,
        &out,
        &[(
            "huge/bunny.obj",
            &["huge.png", "9000 x 9000", "[limits] max_texture_pixels"],
        )],
    );

    // The limit is a setting: a real model's texture over a lowered limit fails the same way.
    let q = project();
    q.config("[limits]\nmax_texture_pixels = 1000000\n");
    copy_dir(&samples().join("avocado"), &q.path("assets/avocado"));
    let out = build(&q, &[]);
    assert_refused(
        &q,
        &out,
        &[(
            "avocado/Avocado.gltf",
            &["Avocado_baseColor.png", "[limits] max_texture_pixels"],
        )],
    );
}

/// One OBJ face over `corners` points: a star (alternating radii, so the fan's triangles are
/// long slivers that overlap), or a convex disk.
fn polygon(path: &Path, corners: usize, star: bool) {
    let mut f = std::io::BufWriter::new(fs::File::create(path).unwrap());
    for i in 0..corners {
        let a = i as f64 / corners as f64 * std::f64::consts::TAU;
        let r = if star && i % 2 == 1 { 0.3 } else { 1.0 };
        writeln!(f, "v {} {} 0", r * a.cos(), r * a.sin()).unwrap();
    }
    write!(f, "f").unwrap();
    for i in 1..=corners {
        write!(f, " {i}").unwrap();
    }
    writeln!(f).unwrap();
}

#[test]
fn many_cornered_polygons_fail_fast_unless_they_are_ordinary_geometry() {
    let p = project();
    fs::create_dir_all(p.path("assets/polygon")).unwrap();
    polygon(&p.path("assets/polygon/million.obj"), 1_000_000, true);
    // Under the corner limit, but thousands of overlapping slivers: every image of it would
    // cost thousands of times an ordinary mesh's.
    polygon(&p.path("assets/polygon/star.obj"), 4000, true);
    let out = build(&p, &[]);
    assert_refused(
        &p,
        &out,
        &[
            (
                "polygon/million.obj",
                &["million.obj", "line 1000001", "[limits] max_face_corners"],
            ),
            (
                "polygon/star.obj",
                &[
                    "star.obj",
                    "depth complexity",
                    "[limits] max_depth_complexity",
                ],
            ),
        ],
    );

    // A convex polygon of as many corners is ordinary geometry.
    let q = project();
    fs::create_dir_all(q.path("assets/polygon")).unwrap();
    polygon(&q.path("assets/polygon/disk.obj"), 4000, false);
    ok(&build(&q, &[]));
}

#[test]
fn thousands_of_threads_are_clamped_to_the_cores() {
    let p = project();
    let out = build(&p, &["-j", "5000"]);
    let t = ok(&out);
    assert!(
        t.contains("warning: -j 5000 is more than this machine's"),
        "{t}"
    );
}

#[test]
fn a_lying_stat_memo_is_detected_dropped_and_never_trusted() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    let bunny = p.path("assets/bunny/bunny_npm_lowres.obj");
    let boxes = p.path("assets/box-vertex-colors/BoxVertexColors.glb");
    // The memo keeps files whose change time is older than its racy window (2 s).
    std::thread::sleep(Duration::from_millis(2100));
    ok(&build(&p, &[]));
    let memo_path = p.path("cache/stat-memo.json");
    let memo = fs::read_to_string(&memo_path).unwrap();
    let hash = |bytes: &[u8]| blake3::hash(bytes).to_hex().to_string();
    let (bunny_hash, box_hash) = (
        hash(&fs::read(&bunny).unwrap()),
        hash(&fs::read(&boxes).unwrap()),
    );
    assert!(
        memo.contains(&bunny_hash) && memo.contains(&box_hash),
        "{memo}"
    );

    // Swap the two assets' hashes: each entry now names the other's content.
    let swapped = memo
        .replace(&bunny_hash, "SWAP")
        .replace(&box_hash, &bunny_hash)
        .replace("SWAP", &box_hash);
    fs::write(&memo_path, swapped).unwrap();
    let out = build(&p, &[]);
    let t = ok(&out);
    assert!(
        t.contains("stat memo") && t.contains("2 damaged or mismatched entries dropped"),
        "{t}"
    );
    let source_of = |package: &str| -> String {
        let bytes = fs::read(p.path("out").join(package)).unwrap();
        let package = ori_package::read(&bytes).unwrap();
        package.manifest.source.blake3
    };
    assert_eq!(source_of("bunny/bunny_npm_lowres.ori"), bunny_hash);
    assert_eq!(source_of("box-vertex-colors/BoxVertexColors.ori"), box_hash);

    // One digit changed: reported once, rehashed, never a failure, nothing lost.
    let memo = fs::read_to_string(&memo_path).unwrap();
    let digit = if bunny_hash.starts_with('0') {
        "1"
    } else {
        "0"
    };
    let damaged = memo.replacen(&bunny_hash, &format!("{digit}{}", &bunny_hash[1..]), 1);
    assert_ne!(damaged, memo);
    fs::write(&memo_path, damaged).unwrap();
    for round in 0..2 {
        let out = build(&p, &[]);
        let t = ok(&out);
        assert_eq!(t.contains("damaged or mismatched"), round == 0, "{t}");
        assert!(p.path("out/bunny/bunny_npm_lowres.ori").is_file());
    }
    let verify = Command::new(EXE)
        .arg("verify")
        .arg(p.path("out"))
        .output()
        .unwrap();
    assert!(verify.status.success(), "{}", text(&verify));
}

#[test]
fn the_builder_removes_only_packages_it_wrote() {
    let p = Project::new(&["box-vertex-colors", "bunny"]);
    // --out is a folder that holds other releases and loose packages.
    let theirs = [
        "theirs.ori",
        "other-release/a.ori",
        "other-release/deep/b.ori",
    ];
    for file in theirs {
        let path = p.path("out").join(file);
        fs::create_dir_all(path.parent().unwrap()).unwrap();
        fs::write(&path, b"someone else's").unwrap();
    }
    fs::write(p.path("out/other-release/release.json"), b"{}").unwrap();
    let t = ok(&build(&p, &[]));
    assert!(t.contains("did not write were left alone"), "{t}");
    // Our stale package goes (its asset is gone); theirs stay.
    fs::remove_dir_all(p.path("assets/bunny")).unwrap();
    ok(&build(&p, &[]));
    assert!(!p.path("out/bunny/bunny_npm_lowres.ori").exists());
    for file in theirs {
        assert_eq!(
            fs::read(p.path("out").join(file)).unwrap(),
            b"someone else's"
        );
    }
    // A release.json that names files elsewhere cannot make the builder remove them.
    fs::write(p.path("victim.ori"), b"keep").unwrap();
    let index = p.path("out/release.json");
    let mut release: serde_json::Value =
        serde_json::from_slice(&fs::read(&index).unwrap()).unwrap();
    release["assets"][0]["package"] = "../victim.ori".into();
    fs::write(&index, serde_json::to_vec(&release).unwrap()).unwrap();
    ok(&build(&p, &[]));
    assert_eq!(fs::read(p.path("victim.ori")).unwrap(), b"keep");
}

#[test]
fn a_cache_entry_replaced_by_a_folder_is_damage_not_a_failure() {
    let p = project();
    ok(&build(&p, &[]));
    let mut replaced = 0;
    for entry in walkdir::WalkDir::new(p.path("cache/ac")) {
        let entry = entry.unwrap();
        if entry.file_type().is_file() && replaced < 3 {
            fs::remove_file(entry.path()).unwrap();
            fs::create_dir_all(entry.path().join("x")).unwrap();
            replaced += 1;
        }
    }
    let blob = walkdir::WalkDir::new(p.path("cache/cas"))
        .into_iter()
        .filter_map(Result::ok)
        .find(|e| e.file_type().is_file())
        .unwrap();
    fs::remove_file(blob.path()).unwrap();
    fs::create_dir_all(blob.path()).unwrap();
    for _ in 0..2 {
        let t = ok(&build(&p, &[]));
        assert!(
            p.path("out/box-vertex-colors/BoxVertexColors.ori")
                .is_file(),
            "{t}"
        );
    }
}

#[test]
fn configuration_type_errors_name_the_key_line_and_column() {
    let p = project();
    p.config("[views]\ncount = 20\n[bake]\nmargin = -1\n");
    let out = build(&p, &[]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("line 15, column 10: `bake.margin`: invalid value: integer `-1`"),
        "{t}"
    );

    p.config("[[overrides]]\nassets = \"**\"\nselect.s0 = \"big\"\n");
    let out = build(&p, &[]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("line 14, column 13: `overrides[0].select.s0`"),
        "{t}"
    );
}

#[test]
fn overrides_that_conflict_together_are_a_configuration_error() {
    let p = project();
    p.config(
        "[[overrides]]\nassets = \"**\"\nviews.strategy = \"minimal\"\nviews.count = 7\n\
         [[overrides]]\nassets = \"box-vertex-colors/**\"\nviews.strategy = \"regular\"\n",
    );
    let out = build(&p, &[]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("asset box-vertex-colors/BoxVertexColors.glb")
            && t.contains("conflict together")
            && t.contains("views.count = 7"),
        "{t}"
    );
    assert!(!t.contains("panicked"), "{t}");
    assert!(
        !p.path("out").exists() && !p.path("cache").exists(),
        "nothing written"
    );
}

#[test]
fn output_errors_exit_1_and_a_dry_run_writes_nothing() {
    let p = project();
    fs::write(p.path("out-file"), b"not a folder").unwrap();
    let out = build(&p, &["--out", p.path("out-file").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));

    let q = project();
    let out = build(&q, &["--dry-run"]);
    ok(&out);
    assert!(
        !q.path("cache/stat-memo.json").exists(),
        "a dry run wrote the stat memo"
    );
    assert!(!q.path("out").exists());
}

#[test]
fn report_and_verify_reject_wrong_packages() {
    let p = Project::new(&["box-vertex-colors", "bunny"]);
    ok(&build(&p, &[]));
    let a = p.path("out/bunny/bunny_npm_lowres.ori");
    let b = p.path("out/box-vertex-colors/BoxVertexColors.ori");
    let report = |p: &Project| {
        Command::new(EXE)
            .arg("report")
            .arg(p.path("out"))
            .arg("--config")
            .arg(p.path("pipeline.toml"))
            .output()
            .unwrap()
    };
    let verify = |p: &Project| {
        Command::new(EXE)
            .arg("verify")
            .arg(p.path("out"))
            .output()
            .unwrap()
    };

    // Two packages swapped, release.json's hashes and sizes made to match: only the embedded
    // source names tell.
    let (bytes_a, bytes_b) = (fs::read(&a).unwrap(), fs::read(&b).unwrap());
    fs::write(&a, &bytes_b).unwrap();
    fs::write(&b, &bytes_a).unwrap();
    let index = p.path("out/release.json");
    let mut release: serde_json::Value =
        serde_json::from_slice(&fs::read(&index).unwrap()).unwrap();
    let entries = release["assets"].as_array_mut().unwrap();
    for key in ["blake3", "bytes", "plt", "plt_at_least", "texture_bytes"] {
        let first = entries[0][key].clone();
        entries[0][key] = entries[1][key].clone();
        entries[1][key] = first;
    }
    fs::write(&index, serde_json::to_vec_pretty(&release).unwrap()).unwrap();
    let out = verify(&p);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(
        t.contains("built from `box-vertex-colors/BoxVertexColors.glb`"),
        "{t}"
    );

    // A corrupt package: the report says so and exits 1.
    let q = Project::new(&["box-vertex-colors"]);
    ok(&build(&q, &[]));
    let package = q.path("out/box-vertex-colors/BoxVertexColors.ori");
    let mut bytes = fs::read(&package).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x40;
    fs::write(&package, bytes).unwrap();
    let out = report(&q);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(t.contains("BoxVertexColors.ori"), "{t}");
}
