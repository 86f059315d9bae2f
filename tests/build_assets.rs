//! End-to-end tests of `cargo xtask build-assets` on copies of the built-in samples: reuse
//! across processes, precise invalidation, explanations, corruption recovery, concurrent
//! builders, bad input and bad configuration.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::Path;
use std::process::Command;

use common::*;

#[test]
fn cold_build_then_reuse_in_a_new_process() {
    let p = Project::new(&["bunny", "box-vertex-colors", "avocado"]);
    let first = p.build(&[]);
    ok(&first);
    assert_eq!(ran(&first, "ingest"), 3);
    let report = p.report();
    let bunny = asset(&report, "bunny/bunny_npm_lowres.obj");
    assert_eq!(bunny["mesh"]["vertices"], 1839);
    assert_eq!(bunny["mesh"]["triangles"], 3674);
    let avocado = asset(&report, "avocado/Avocado.gltf");
    assert_eq!(avocado["mesh"]["triangles"], 682);
    assert_eq!(
        asset(&report, "box-vertex-colors/BoxVertexColors.glb")["mesh"]["has_colors"],
        true
    );

    // A second process computes the same keys: nothing runs, same release bytes.
    let before = fs::read(p.path("out/release.json")).unwrap();
    let second = p.build(&[]);
    let t = ok(&second);
    assert_eq!(ran(&second, "ingest"), 0, "{t}");
    assert!(
        t.contains("[ingest] bunny/bunny_npm_lowres.obj: reused"),
        "{t}"
    );
    assert_eq!(fs::read(p.path("out/release.json")).unwrap(), before);
    assert!(
        p.report()["assets"][0]["jobs"]
            .as_array()
            .unwrap()
            .iter()
            .all(|j| j["status"] == "reused")
    );
}

#[test]
fn edits_rerun_exactly_what_they_touch_and_explain_why() {
    let p = Project::new(&["bunny", "box-vertex-colors", "avocado"]);
    ok(&p.build(&[]));

    // Touching a file without changing its bytes runs nothing.
    let bunny = p.path("assets/bunny/bunny_npm_lowres.obj");
    let f = fs::File::options().append(true).open(&bunny).unwrap();
    f.set_modified(std::time::SystemTime::now()).unwrap();
    drop(f);
    assert_eq!(ran(&p.build(&[]), "ingest"), 0);

    // Editing one model's bytes re-runs only its job.
    let mut obj = fs::read(&bunny).unwrap();
    obj.extend_from_slice(b"# edited\n");
    fs::write(&bunny, obj).unwrap();
    let out = p.build(&["--explain"]);
    let t = ok(&out);
    assert_eq!(ran(&out, "ingest"), 1, "{t}");
    // A comment changes the file but not the mesh: the cascade stops (early cutoff).
    assert_eq!((ran(&out, "views"), ran(&out, "bake")), (0, 0), "{t}");
    assert!(
        t.contains("[ingest] bunny/bunny_npm_lowres.obj: ran in")
            && t.contains("because new input: source changed"),
        "{t}"
    );

    // A referenced file (the base-colour texture) is an input; an unused one (the normal map)
    // is not.
    let normal_map = p.path("assets/avocado/Avocado_normal.png");
    let mut png = fs::read(&normal_map).unwrap();
    png.push(0);
    fs::write(&normal_map, &png).unwrap();
    assert_eq!(ran(&p.build(&[]), "ingest"), 0);
    let base = p.path("assets/avocado/Avocado_baseColor.png");
    let mut png = fs::read(&base).unwrap();
    png.push(0); // trailing bytes after IEND: same image, new content hash
    fs::write(&base, &png).unwrap();
    let out = p.build(&["--explain"]);
    let t = ok(&out);
    assert_eq!(ran(&out, "ingest"), 1, "{t}");
    assert!(
        t.contains("referenced file `Avocado_baseColor.png` changed"),
        "{t}"
    );

    // Moving a vertex changes the mesh: views and baking follow.
    let text = fs::read_to_string(&bunny).unwrap();
    let moved = text.replacen("\nv ", "\nv 0.001 0.002 0.003 # was: ", 1);
    fs::write(&bunny, moved).unwrap();
    let out = p.build(&[]);
    let t = ok(&out);
    assert_eq!(
        (ran(&out, "ingest"), ran(&out, "views"), ran(&out, "bake")),
        (1, 1, 1),
        "{t}"
    );

    // A bake parameter re-runs baking only, for every asset.
    p.config("[bake]\nresolution = 128\n");
    let out = p.build(&["--explain"]);
    let t = ok(&out);
    assert_eq!(
        (ran(&out, "ingest"), ran(&out, "views"), ran(&out, "bake")),
        (0, 0, 3),
        "{t}"
    );
    assert!(
        t.contains("parameters changed: resolution: 256 -> 128"),
        "{t}"
    );
    p.config("");

    // A parameter override re-runs only the assets it matches, and says which key changed.
    p.config("[[overrides]]\nassets = \"box-*/**\"\ningest.recompute_normals = true\n");
    let out = p.build(&["--explain"]);
    let t = ok(&out);
    assert_eq!(ran(&out, "ingest"), 1, "{t}");
    assert!(
        t.contains("[ingest] box-vertex-colors/BoxVertexColors.glb: ran in")
            && t.contains("parameters changed: recompute_normals: false -> true"),
        "{t}"
    );
}

#[test]
fn an_unchanged_asset_comes_from_the_asset_memo_and_a_damaged_memo_costs_a_warning() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    ok(&p.build(&[]));
    let release = tree(&p.path("out"));
    let report = report_text(&p, "out");
    // Without the jobs' action entries the memo still knows both assets: nothing runs.
    fs::remove_dir_all(p.path("cache/ac")).unwrap();
    let out = p.build(&[]);
    let t = ok(&out);
    assert_eq!(ran_all(&out), [0; 8], "{t}");
    assert!(
        t.contains("[plt] bunny/bunny_npm_lowres.obj: reused"),
        "{t}"
    );
    same_release(&tree(&p.path("out")), &release, "from the memo");
    assert_eq!(report_text(&p, "out"), report);

    // A package the release must copy again is read from the cache first: a damaged one (of
    // the right size) sends its asset through the graph, which makes it again.
    let entry = |name: &str| {
        let index: serde_json::Value =
            serde_json::from_slice(&fs::read(p.path("out/release.json")).unwrap()).unwrap();
        let e = index["assets"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == name);
        let e = e.unwrap().clone();
        (
            e["package"].as_str().unwrap().to_string(),
            e["blake3"].as_str().unwrap().to_string(),
        )
    };
    let (package, hash) = entry("bunny/bunny_npm_lowres.obj");
    let blob = p.path(&format!("cache/cas/{}/{hash}", &hash[..2]));
    let mut bytes = fs::read(&blob).unwrap();
    bytes[100] ^= 1;
    fs::write(&blob, bytes).unwrap();
    fs::remove_file(p.path("out").join(&package)).unwrap();
    let out = p.build(&[]);
    let t = ok(&out);
    assert_eq!(ran(&out, "package"), 1, "{t}");
    same_release(&tree(&p.path("out")), &release, "damaged package blob");
    // The same when the release must read it to check it, though its file is in place.
    let (_, hash) = entry("box-vertex-colors/BoxVertexColors.glb");
    let blob = p.path(&format!("cache/cas/{}/{hash}", &hash[..2]));
    let mut bytes = fs::read(&blob).unwrap();
    bytes[100] ^= 1;
    fs::write(&blob, bytes).unwrap();
    fs::remove_dir_all(p.path("cache/release-checks")).unwrap();
    let out = p.build(&[]);
    let t = ok(&out);
    assert_eq!(ran(&out, "package"), 1, "{t}");
    same_release(
        &tree(&p.path("out")),
        &release,
        "damaged package blob, check unknown",
    );

    // A damaged memo: one warning, and every asset goes through the graph.
    for shard in fs::read_dir(p.path("cache/asset-memo")).unwrap() {
        fs::write(shard.unwrap().path(), b"{ damaged").unwrap();
    }
    let out = p.build(&[]);
    let t = ok(&out);
    assert!(t.contains("warning") && t.contains("asset-memo"), "{t}");
    same_release(&tree(&p.path("out")), &release, "damaged memo");
    assert_eq!(report_text(&p, "out"), report);
    assert_eq!(ran_all(&p.build(&[])), [0; 8]);
}

#[test]
fn dry_run_changes_nothing() {
    let p = Project::new(&["bunny"]);
    let out = p.build(&["--dry-run"]);
    let t = ok(&out);
    assert!(t.contains("would run because new job"), "{t}");
    assert!(t.contains("dry run of 1 assets: 8 job(s) would run"), "{t}");
    assert!(!p.path("out/report.json").exists());
    assert!(!p.path("cache/ac").exists());
}

#[test]
fn corrupt_cache_entries_are_reported_and_rebuilt() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    ok(&p.build(&[]));
    let good = report_text(&p, "out");
    // Damage every blob: truncate the big ones, flip a byte in the small ones.
    for shard in fs::read_dir(p.path("cache/cas")).unwrap() {
        for blob in fs::read_dir(shard.unwrap().path()).unwrap() {
            let path = blob.unwrap().path();
            let mut bytes = fs::read(&path).unwrap();
            if bytes.len() > 4096 {
                bytes.truncate(bytes.len() / 2);
            } else {
                bytes[1] ^= 1;
            }
            fs::write(&path, bytes).unwrap();
        }
    }
    let out = p.build(&[]);
    let t = ok(&out);
    assert!(
        t.contains("corrupt cache entry") || t.contains("re-running stage"),
        "{t}"
    );
    assert_eq!(report_text(&p, "out"), good);
    // And the cache is whole again.
    assert_eq!(ran(&p.build(&[]), "ingest"), 0);
}

#[test]
fn two_builders_share_one_cache_at_the_same_time() {
    let p = Project::new(&["bunny", "box-vertex-colors", "avocado"]);
    let spawn = |out: &str| {
        Command::new(EXE)
            .args(["build-assets", "--config"])
            .arg(p.path("pipeline.toml"))
            .arg("--out")
            .arg(p.path(out))
            .env("CI", "1")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn("out-a"), spawn("out-b"));
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    ok(&a);
    ok(&b);
    assert_eq!(report_text(&p, "out-a"), report_text(&p, "out-b"));
    // Whatever interleaving happened, the cache they left is complete and valid.
    let third = p.build(&[]);
    ok(&third);
    assert_eq!(ran(&third, "ingest"), 0);
}

#[test]
fn thread_count_does_not_change_outputs() {
    let p = Project::new(&["bunny", "box-vertex-colors", "avocado"]);
    ok(&p.build(&[
        "-j",
        "1",
        "--out",
        p.path("one").to_str().unwrap(),
        "--cache",
        p.path("c1").to_str().unwrap(),
    ]));
    ok(&p.build(&[
        "-j",
        "2",
        "--out",
        p.path("two").to_str().unwrap(),
        "--cache",
        p.path("c2").to_str().unwrap(),
    ]));
    assert_eq!(report_text(&p, "one"), report_text(&p, "two"));
}

#[test]
fn a_broken_model_fails_alone_with_a_clear_message() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    let glb = fs::read(shared_models().join("gltf/Duck/Duck.glb")).unwrap();
    fs::create_dir_all(p.path("assets/broken")).unwrap();
    fs::write(p.path("assets/broken/duck.glb"), &glb[..glb.len() / 3]).unwrap();
    let out = p.build(&[]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{t}");
    assert!(
        t.contains("error: [ingest] broken/duck.glb:") && t.contains("duck.glb:"),
        "{t}"
    );
    let report = p.report();
    assert_eq!(asset(&report, "broken/duck.glb")["status"], "failed");
    assert_eq!(asset(&report, "bunny/bunny_npm_lowres.obj")["status"], "ok");
}

#[test]
fn configuration_errors_name_the_file_and_the_key() {
    let p = Project::new(&["bunny"]);
    p.config("[ingest]\nrecompute_normal = true\n");
    let out = p.build(&[]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("pipeline.toml") && t.contains("unknown field `recompute_normal`"),
        "{t}"
    );
    assert!(t.contains("recompute_normals"), "{t}");
    assert!(
        !p.path("out").exists(),
        "nothing written on a configuration error"
    );

    p.config("");
    let out = Command::new(EXE)
        .args(["build-assets", "--config"])
        .arg(p.path("pipeline.toml"))
        .arg("--assets")
        .arg(p.path("nowhere"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).contains("nowhere") && text(&out).contains("does not exist"));
}

#[test]
fn dump_maps_writes_a_picture_of_every_map() {
    let p = Project::new(&["bunny"]);
    let dir = p.path("maps");
    ok(&p.build(&["--dump-maps", dir.to_str().unwrap()]));
    let folder = dir.join("bunny/bunny_npm_lowres.obj");
    let mut names: Vec<String> = fs::read_dir(&folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names.len(), 60, "{names:?}");
    assert_eq!(names[0], "map-00-albedo.png");
    let png = fs::read(folder.join("map-19-depth.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn placement_moves_impostors_the_same_way_for_any_thread_count() {
    // The search on (64 x 64 maps, s0 = 64 views keep it quick): it moves impostors, the
    // bake follows the placed plan, and the release does not depend on the thread count.
    let p = Project::new(&["bunny"]);
    p.config("[place]\nmax_moves = 4\n[bake]\nresolution = 64\n");
    let build = |j: &str, dir: &str| {
        let out = p.build(&[
            "-j",
            j,
            "--out",
            p.path(dir).to_str().unwrap(),
            "--cache",
            p.path(&format!("cache-{dir}")).to_str().unwrap(),
        ]);
        ok(&out);
        assert_eq!(ran(&out, "place"), 1, "{}", text(&out));
        tree(&p.path(dir))
    };
    let one = build("1", "one");
    assert_eq!(one, build("2", "two"));
    // Turning the search off changes the plan, so the package differs.
    p.config("[place]\nmax_moves = 0\n[bake]\nresolution = 64\n");
    assert_ne!(one, build("2", "off"));
}

#[test]
fn a_bc4_package_carries_the_table_and_plt_of_the_depth_it_ships() {
    // BC4 depth is lossy: the table and the PLT must be those of the decoded codes a runtime
    // reads, not of the baked ones.
    let p = Project::new(&["bunny"]);
    p.config("[bake]\nresolution = 32\n[compress]\ndepth = \"bc4\"\n");
    ok(&p.build(&[]));
    let package =
        ori_package::read(&fs::read(p.path("out/bunny/bunny_npm_lowres.ori")).unwrap()).unwrap();
    let set = ori_report::relief_set(&package).unwrap();
    let mesh = ori_mesh::load_file(
        &p.path("assets/bunny/bunny_npm_lowres.obj"),
        &Default::default(),
    )
    .unwrap()
    .mesh;
    let select: ori_select::SelectParams =
        serde_json::from_value(package.manifest.params["select"].clone()).unwrap();
    let evaluator = ori_eval::Evaluator::new(&mesh, &set, &select.eval_params()).unwrap();
    let selection = ori_select::select_with(&evaluator, &select).unwrap();
    let stored = &package.manifest.selection.entries;
    let differing = (0..320)
        .filter(|&i| {
            let e = &selection.entries[i];
            (&e.impostors, e.missed) != (&stored[i].impostors, stored[i].missed)
        })
        .count();
    assert_eq!(
        differing, 0,
        "{differing} of 320 entries differ from the decoded depth's"
    );
    let held_out = ori_select::held_out(
        &evaluator,
        &ori_views::held_out_directions(ori_views::DEFAULT_HELD_OUT_SEED),
        &|w| {
            let entry = selection.lookup(w);
            entry.impostors.iter().map(|&i| usize::from(i)).collect()
        },
    )
    .unwrap();
    assert_eq!(package.manifest.plt.gc, held_out.worst_missed());
}

#[test]
fn an_asset_that_misses_the_quality_gate_is_reported_and_the_build_exits_3() {
    let p = Project::new(&["bunny", "box-vertex-colors"]);
    let (bunny, boxes) = (
        "bunny/bunny_npm_lowres.obj",
        "box-vertex-colors/BoxVertexColors.glb",
    );
    let gate = "[gate]\nmax_texture_bytes = 1000\n\
                [[overrides]]\nassets = \"box-*/**\"\ngate.max_texture_bytes = 100000000\n";
    p.config(gate);
    let out = p.build_with_report(&[]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(3), "{t}");
    assert!(
        t.contains(&format!("error: quality gate: {bunny}: "))
            && t.contains("more than gate.max_texture_bytes = 1000")
            && t.contains("1 asset(s) missed the quality gate"),
        "{t}"
    );
    assert!(!t.contains(&format!("quality gate: {boxes}")), "{t}");
    let report = p.report();
    let missed = asset(&report, bunny)["gate"].as_array().unwrap();
    assert_eq!(missed.len(), 1, "{report}");
    assert!(asset(&report, boxes).get("gate").is_none());
    // The release is written all the same, and the HTML report says what was missed.
    let verified = Command::new(EXE)
        .arg("verify")
        .arg(p.path("out"))
        .output()
        .unwrap();
    assert!(verified.status.success(), "{}", text(&verified));
    let index = fs::read_to_string(p.path("out/report/index.html")).unwrap();
    assert!(
        index.contains("1 missed the quality gate") && index.contains("quality gate: "),
        "the report names the miss"
    );

    // Unchanged assets (from the asset memo) are held to the gate too.
    let out = p.build(&[]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out));
    assert_eq!(ran_all(&out), [0; 8]);

    // The gate is in no job's key: changing it runs nothing.
    p.config("[gate]\nmin_plt_px = 1\nmax_coverage_error_percent = 100\n");
    let out = p.build(&[]);
    ok(&out);
    assert_eq!(ran_all(&out), [0; 8]);
    assert!(p.report()["assets"][0].get("gate").is_none());

    p.config("[gate]\nmin_plt_px = -1\n");
    let out = p.build(&[]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("pipeline.toml") && t.contains("gate.min_plt_px"),
        "{t}"
    );
}

/// docs/EVENTS.md's tables: each event's fields, with their type and whether they may be
/// absent.
fn events_schema() -> BTreeMap<String, Vec<(String, String, bool)>> {
    let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/EVENTS.md");
    let text = fs::read_to_string(doc).unwrap();
    let mut schema: BTreeMap<String, Vec<(String, String, bool)>> = BTreeMap::new();
    let mut current = None;
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("### `") {
            let name = name.trim_end_matches('`').to_string();
            schema.insert(name.clone(), Vec::new());
            current = Some(name);
        } else if let (Some(event), true) = (&current, line.starts_with("| `")) {
            let cells: Vec<&str> = line.split('|').map(str::trim).collect();
            let field = cells[1].trim_matches('`').to_string();
            let optional = cells[2].ends_with(", optional");
            let ty = cells[2].trim_end_matches(", optional").to_string();
            schema.get_mut(event).unwrap().push((field, ty, optional));
        }
    }
    assert!(schema.len() >= 6, "{schema:?}");
    schema
}

/// Every line of `stdout` parsed and held to the schema.
fn events_of(out: &std::process::Output) -> Vec<serde_json::Value> {
    let schema = events_schema();
    let stdout = String::from_utf8(out.stdout.clone()).unwrap();
    let events: Vec<serde_json::Value> = stdout
        .lines()
        .map(|line| serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}")))
        .collect();
    for event in &events {
        let object = event.as_object().unwrap();
        let name = object["event"].as_str().unwrap();
        let fields = schema
            .get(name)
            .unwrap_or_else(|| panic!("undocumented event {event}"));
        for (key, value) in object.iter().filter(|(k, _)| *k != "event") {
            let (_, ty, _) = fields
                .iter()
                .find(|(f, _, _)| f == key)
                .unwrap_or_else(|| panic!("undocumented field {key} in {event}"));
            let fits = match ty.as_str() {
                "string" => value.is_string(),
                "number" => value.is_number(),
                "integer" => value.is_u64() || value.is_i64(),
                "boolean" => value.is_boolean(),
                "array of string" => value
                    .as_array()
                    .is_some_and(|a| a.iter().all(serde_json::Value::is_string)),
                other => panic!("unknown type {other} in docs/EVENTS.md"),
            };
            assert!(fits, "{key} is not a {ty} in {event}");
        }
        for (field, _, optional) in fields {
            assert!(
                *optional || object.contains_key(field),
                "{field} missing: {event}"
            );
        }
    }
    events
}

#[test]
fn json_events_follow_docs_events_md() {
    let p = Project::new(&["box-vertex-colors"]);
    fs::create_dir_all(p.path("assets/odd")).unwrap();
    fs::write(
        p.path("assets/odd/tetra.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nzz 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    let glb = fs::read(shared_models().join("gltf/Duck/Duck.glb")).unwrap();
    fs::create_dir_all(p.path("assets/broken")).unwrap();
    fs::write(p.path("assets/broken/duck.glb"), &glb[..glb.len() / 3]).unwrap();
    p.config("[gate]\nmax_texture_bytes = 1\n");
    let out = p.build(&["--message-format", "json"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let events = events_of(&out);
    let named = |name: &str| -> Vec<&serde_json::Value> {
        events.iter().filter(|e| e["event"] == name).collect()
    };
    assert_eq!(events[0]["event"], "plan");
    let last = events.last().unwrap();
    assert_eq!(last["event"], "build-finished");
    assert_eq!(last["exit_status"], 1);
    assert_eq!(last["assets"], 3);
    assert_eq!(last["failed_assets"], 1);
    assert_eq!(named("build-finished").len(), 1);
    let outcomes: BTreeSet<&str> = named("job-finished")
        .iter()
        .map(|e| e["outcome"].as_str().unwrap())
        .collect();
    assert!(
        ["ran", "failed", "skipped"]
            .iter()
            .all(|o| outcomes.contains(o)),
        "{outcomes:?}"
    );
    // Every job that runs starts and finishes; one skipped after an upstream failure only
    // finishes.
    let skipped = named("job-finished")
        .iter()
        .filter(|e| e["outcome"] == "skipped")
        .count();
    assert_eq!(
        named("job-started").len(),
        named("job-finished").len() - skipped
    );
    assert!(
        named("warning").iter().any(|w| w["asset"] == "odd/tetra.obj"
            && w["message"].as_str().unwrap().contains("zz")),
        "{events:?}"
    );
    let finished = named("asset-finished");
    assert_eq!(finished.len(), 3);
    let boxes = finished
        .iter()
        .find(|e| e["asset"] == "box-vertex-colors/BoxVertexColors.glb")
        .unwrap();
    assert!(boxes["plt"].as_f64().unwrap() > 0.0 && boxes["texture_bytes"].as_u64().unwrap() > 1);
    assert_eq!(boxes["gate"].as_array().unwrap().len(), 1, "{boxes}");
    // The person's lines went to standard error.
    assert!(String::from_utf8_lossy(&out.stderr).contains("stage "));

    // Unchanged assets: every job reused, none started.
    let out = p.build(&["--message-format", "json"]);
    let events = events_of(&out);
    let finished: Vec<&serde_json::Value> = events
        .iter()
        .filter(|e| e["event"] == "job-finished" && e["asset"] != "broken/duck.glb")
        .collect();
    assert!(finished.len() >= 16 && finished.iter().all(|e| e["outcome"] == "reused"));

    // A wrong configuration: no build, and the stream still ends with its status.
    p.config("[gate]\nmin_plt_px = -1\n");
    let out = p.build(&["--message-format", "json"]);
    assert_eq!(out.status.code(), Some(2));
    let events = events_of(&out);
    assert_eq!(events.len(), 1);
    assert_eq!(events[0]["exit_status"], 2);
    assert!(
        events[0]["error"]
            .as_str()
            .unwrap()
            .contains("gate.min_plt_px")
    );
}
