//! End-to-end tests of the remote cache against a real nginx WebDAV server on 127.0.0.1
//! (Debian's `nginx-light`; `.ci/run` installs it, and without it these tests fail), and of
//! sharded builds assembled from the cache.

mod common;
#[path = "../xtask/src/nginx.rs"]
mod nginx;

use std::fs;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::*;
use nginx::Nginx;

const SAMPLES: [&str; 3] = ["bunny", "box-vertex-colors", "glass-vase-flowers"];

fn server() -> Nginx {
    Nginx::start().unwrap_or_else(|e| panic!("cannot start the test's nginx: {e}"))
}

/// A project using the server's `cache` folder in `mode`.
fn project(samples: &[&str], url: &str, mode: &str) -> Project {
    let p = Project::new(samples);
    p.config(&remote(url, mode));
    p
}

fn remote(url: &str, mode: &str) -> String {
    format!("[cache.remote]\nurl = \"{url}\"\nmode = \"{mode}\"\ntimeout_s = 5\n")
}

/// Build with its own local cache and output folder (`cache-NAME`, `out-NAME`).
fn build_as(p: &Project, name: &str, extra: &[&str]) -> Output {
    let (cache, out) = (
        p.path(&format!("cache-{name}")),
        p.path(&format!("out-{name}")),
    );
    let mut args = vec![
        "--cache",
        cache.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    p.build(&args)
}

/// Every file under `dir`, recursively.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = fs::read_dir(&d) else {
            continue;
        };
        for e in entries {
            let path = e.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Every blob on the server hashes to its name (blake3 hex); every action entry's checksum
/// holds. Returns (blobs, entries).
fn check_server(server: &Nginx) -> (usize, usize) {
    check_server_names(server, |bytes| blake3::hash(bytes).to_hex().to_string())
}

/// [`check_server`] with blobs named by `name_of` their bytes.
fn check_server_names(server: &Nginx, name_of: impl Fn(&[u8]) -> String) -> (usize, usize) {
    let base = server.root().join("cache");
    let (mut blobs, mut entries) = (0, 0);
    for path in files(&base) {
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        let bytes = fs::read(&path).unwrap();
        match path
            .parent()
            .unwrap()
            .file_name()
            .unwrap()
            .to_str()
            .unwrap()
        {
            "cas" => {
                assert_eq!(name_of(&bytes), name, "{path:?}");
                blobs += 1;
            }
            "ac" => {
                check_entry(bytes, &format!("{path:?}"));
                entries += 1;
            }
            other => panic!("unexpected file {path:?} in {other}"),
        }
    }
    (blobs, entries)
}

/// The megabytes a remote line says were downloaded and uploaded.
fn megabytes_moved(line: &str) -> (f64, f64) {
    let mb: Vec<f64> = line
        .split(" MB")
        .filter_map(|part| part.rsplit(' ').next()?.parse().ok())
        .collect();
    assert_eq!(mb.len(), 2, "{line}");
    (mb[0], mb[1])
}

/// The bytes of the packages in a release folder.
fn package_bytes(out: &Path) -> u64 {
    files(out)
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "ori"))
        .map(|f| fs::metadata(f).unwrap().len())
        .sum()
}

#[test]
fn a_builder_with_an_empty_cache_downloads_the_packages_and_runs_nothing() {
    let s = server();
    let p = project(&SAMPLES, &s.url("cache"), "read-write");
    let cold = build_as(&p, "a", &[]);
    ok(&cold);
    assert_eq!(ran_all(&cold), [3; 8], "{}", text(&cold));
    assert!(
        remote_line(&cold).contains("uploaded 24 entries"),
        "{}",
        text(&cold)
    );
    let (blobs, entries) = check_server(&s);
    assert_eq!(entries, 24);
    assert!(blobs > 21, "{blobs}");

    let warm = build_as(&p, "b", &[]);
    let t = ok(&warm);
    assert_eq!(ran_all(&warm), [0; 8], "{t}");
    let line = remote_line(&warm);
    assert!(
        line.contains("downloaded 24 entries") && line.contains("uploaded 0 entries"),
        "{line}"
    );
    // Only what the release reads moves: the packages (and the small summaries the report
    // reads), not the intermediate results the cold build uploaded.
    let (downloaded, _) = megabytes_moved(&line);
    let (_, uploaded) = megabytes_moved(&remote_line(&cold));
    let packages = package_bytes(&p.path("out-b")) as f64 / 1e6;
    assert!(
        downloaded >= packages && downloaded < packages * 1.05 + 0.1,
        "{line}; packages {packages} MB"
    );
    assert!(uploaded > 3.0 * downloaded, "{uploaded} MB uploaded");
    assert!(remote_warnings(&warm).is_empty(), "{t}");
    same_release(
        &tree(&p.path("out-a")),
        &tree(&p.path("out-b")),
        "downloaded from the remote cache",
    );

    // The local cache holds every entry and what the release reads: a rebuild asks the
    // server nothing.
    let requests = s.access_log().lines().count();
    let again = build_as(&p, "b", &[]);
    assert_eq!(ran_all(&again), [0; 8]);
    assert_eq!(s.access_log().lines().count(), requests);
}

/// With `digest = "sha256"` every blob on the server is named by the sha256 of its bytes, as
/// bazel-remote requires, and builders find every result by those names.
#[test]
fn sha256_digests_name_every_blob_as_bazel_remote_requires() {
    use sha2::Digest as _;
    let s = server();
    let sha256 = format!(
        "{}digest = \"sha256\"\n",
        remote(&s.url("cache"), "read-write")
    );
    let p = Project::new(&SAMPLES[..2]);
    p.config(&sha256);
    let cold = build_as(&p, "a", &[]);
    let t = ok(&cold);
    assert!(
        remote_line(&cold).contains("(read-write, sha256 names)"),
        "{t}"
    );
    let hex = |bytes: &[u8]| {
        sha2::Sha256::digest(bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    let (blobs, entries) = check_server_names(&s, hex);
    assert!(
        blobs > 10 && entries == 16,
        "{blobs} blobs, {entries} entries"
    );

    let warm = build_as(&p, "b", &[]);
    let t = ok(&warm);
    assert_eq!(ran_all(&warm), [0; 8], "{t}");
    same_release(&tree(&p.path("out-a")), &tree(&p.path("out-b")), "sha256");
    // A job that runs fetches its lazily kept inputs by their sha256 names.
    p.config(&format!("{sha256}[compress]\nquality = \"fast\"\n"));
    let out = build_as(&p, "b", &[]);
    let t = ok(&out);
    assert_eq!((ran(&out, "compress"), ran(&out, "bake")), (2, 0), "{t}");
    assert!(remote_warnings(&out).is_empty(), "{t}");
    check_server_names(&s, hex);
}

/// A job that runs on a builder that took its inputs' entries from the server (but not their
/// bytes) fetches them then; with the server gone, the jobs that made them run again.
#[test]
fn results_fetched_lazily_are_fetched_or_made_again_when_a_job_needs_them() {
    let mut s = server();
    let p = project(&SAMPLES[..2], &s.url("cache"), "read-write");
    ok(&build_as(&p, "a", &[]));
    ok(&build_as(&p, "b", &[]));

    // A texture setting: the compress and package jobs run, reading the bake's maps, which
    // machine b never downloaded.
    p.config(&format!(
        "{}[compress]\nquality = \"fast\"\n",
        remote(&s.url("cache"), "read-write")
    ));
    let out = build_as(&p, "b", &[]);
    let t = ok(&out);
    assert_eq!(ran(&out, "compress"), 2, "{t}");
    assert_eq!((ran(&out, "bake"), ran(&out, "ingest")), (0, 0), "{t}");
    assert!(remote_warnings(&out).is_empty(), "{t}");
    let (downloaded, _) = megabytes_moved(&remote_line(&out));
    assert!(downloaded > 1.0, "the maps were fetched: {t}");
    ok(&build_as(&p, "a", &[]));
    same_release(&tree(&p.path("out-a")), &tree(&p.path("out-b")), "fetched");

    // The server gone: a PLT setting re-runs the PLT jobs, whose inputs machine b never
    // fetched; the jobs that made them run again here, and the release is still right.
    s.stop();
    p.config(&format!(
        "{}[compress]\nquality = \"fast\"\n[plt]\nheld_out_seed = 2\n",
        remote(&s.url("cache"), "read-write")
    ));
    let out = build_as(&p, "b", &[]);
    let t = ok(&out);
    assert_eq!(ran(&out, "plt"), 2, "{t}");
    assert_eq!(remote_warnings(&out).len(), 1, "{t}");
    assert!(t.contains("re-running stage"), "{t}");
    let plain = Project::new(&SAMPLES[..2]);
    plain.config("[compress]\nquality = \"fast\"\n[plt]\nheld_out_seed = 2\n");
    ok(&plain.build(&[]));
    same_release(
        &tree(&plain.path("out")),
        &tree(&p.path("out-b")),
        "made again",
    );
}

#[test]
fn a_server_that_stops_mid_build_leaves_one_warning_and_a_local_build() {
    let mut s = server();
    let p = project(&SAMPLES, &s.url("cache"), "read-write");
    let child = Command::new(EXE)
        .args(["build-assets", "--no-report", "-j", "1", "--config"])
        .arg(p.path("pipeline.toml"))
        .env("CI", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Stop the server as soon as the first action entry is uploaded.
    let deadline = Instant::now() + Duration::from_secs(60);
    while files(&s.root().join("cache/ac")).is_empty() {
        assert!(Instant::now() < deadline, "nothing uploaded in 60 s");
        std::thread::sleep(Duration::from_millis(5));
    }
    s.stop();
    let out = child.wait_with_output().unwrap();
    let t = ok(&out);
    assert_eq!(ran_all(&out), [3; 8], "{t}");
    let warnings = remote_warnings(&out);
    assert_eq!(warnings.len(), 1, "{t}");
    assert!(warnings[0].contains("is unavailable"), "{t}");
    assert!(
        remote_line(&out).contains("unavailable during the build"),
        "{t}"
    );

    // A server gone before the build: the same, and the release is the same as without it.
    let cold = build_as(&p, "b", &[]);
    assert_eq!(remote_warnings(&cold).len(), 1, "{}", text(&cold));
    assert_eq!(ran_all(&cold), [3; 8]);
    same_release(
        &tree(&p.path("out")),
        &tree(&p.path("out-b")),
        "server down",
    );
}

#[test]
fn a_server_that_never_answers_times_out_once() {
    // Accepts connections (the kernel does) and never answers.
    let silent = TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://{}/cache", silent.local_addr().unwrap());
    let p = Project::new(&["box-vertex-colors"]);
    p.config(&remote(&url, "read-write").replace("timeout_s = 5", "timeout_s = 1"));
    let started = Instant::now();
    let out = p.build(&[]);
    let t = ok(&out);
    assert_eq!(ran_all(&out), [1; 8], "{t}");
    let warnings = remote_warnings(&out);
    assert_eq!(warnings.len(), 1, "{t}");
    assert!(warnings[0].contains("no answer within 1 s"), "{t}");
    // One timeout per worker at most (two cores), not one per request.
    assert!(started.elapsed() < Duration::from_secs(30), "{t}");
}

#[test]
fn damaged_bytes_on_the_server_are_a_miss_and_are_repaired() {
    let s = server();
    let p = project(&SAMPLES, &s.url("cache"), "read-write");
    ok(&build_as(&p, "a", &[]));
    // Damage the bunny's package blob on the server: same length, one byte changed.
    let release: serde_json::Value =
        serde_json::from_slice(&fs::read(p.path("out-a/release.json")).unwrap()).unwrap();
    let bunny = release["assets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["name"] == "bunny/bunny_npm_lowres.obj")
        .unwrap();
    let blob = s
        .root()
        .join("cache/cas")
        .join(bunny["blake3"].as_str().unwrap());
    let mut bytes = fs::read(&blob).unwrap();
    bytes[100] ^= 0x20;
    fs::write(&blob, &bytes).unwrap();

    let out = build_as(&p, "b", &[]);
    let t = ok(&out);
    // Only the damaged job ran again; the package is right.
    assert_eq!(ran_all(&out), [0, 0, 0, 0, 0, 0, 0, 1], "{t}");
    let warnings = remote_warnings(&out);
    assert_eq!(warnings.len(), 1, "{t}");
    assert!(warnings[0].contains("is damaged"), "{t}");
    same_release(
        &tree(&p.path("out-a")),
        &tree(&p.path("out-b")),
        "damaged blob",
    );
    // Read-write: the rebuilt blob replaced the damaged copy.
    check_server(&s);
}

#[test]
fn concurrent_uploads_of_the_same_results_both_succeed() {
    let s = server();
    let p = project(&SAMPLES[..2], &s.url("cache"), "read-write");
    let spawn = |name: &str| {
        Command::new(EXE)
            .args(["build-assets", "--no-report", "-j", "1", "--config"])
            .arg(p.path("pipeline.toml"))
            .arg("--cache")
            .arg(p.path(&format!("cache-{name}")))
            .arg("--out")
            .arg(p.path(&format!("out-{name}")))
            .env("CI", "1")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn("a"), spawn("b"));
    for out in [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()] {
        let t = ok(&out);
        assert!(remote_warnings(&out).is_empty(), "{t}");
    }
    let (_, entries) = check_server(&s);
    assert_eq!(entries, 16);
    same_release(&tree(&p.path("out-a")), &tree(&p.path("out-b")), "a and b");

    let c = build_as(&p, "c", &[]);
    assert_eq!(ran_all(&c), [0; 8], "{}", text(&c));
    same_release(
        &tree(&p.path("out-a")),
        &tree(&p.path("out-c")),
        "from the server",
    );
}

#[test]
fn read_only_mode_never_uploads() {
    let s = server();
    let p = project(&["box-vertex-colors"], &s.url("cache"), "read-only");
    let out = p.build(&[]);
    let t = ok(&out);
    assert_eq!(ran_all(&out), [1; 8], "{t}");
    assert!(remote_line(&out).contains("(read-only)"), "{t}");
    assert!(
        remote_line(&out).contains("uploaded 0 entries, 0 blobs"),
        "{t}"
    );
    assert_eq!(files(&s.root()), Vec::<PathBuf>::new());
    let log = s.access_log();
    assert!(log.contains("\"GET /cache/ac/"), "{log}");
    assert!(!log.contains("\"PUT "), "{log}");
}

#[test]
fn bad_remote_settings_stop_the_build_naming_the_key() {
    let p = Project::new(&["box-vertex-colors"]);
    p.config("[cache.remote]\nurl = \"https://cache.example\"\n");
    let out = p.build(&[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).contains("[cache.remote] url"), "{}", text(&out));
    p.config("[cache.remote]\nurl = \"http://127.0.0.1:9\"\ntoken_env = \"ORI_NO_SUCH_TOKEN\"\n");
    let out = p.build(&[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out).contains("token_env = \"ORI_NO_SUCH_TOKEN\""),
        "{}",
        text(&out)
    );
}

#[test]
fn three_shards_then_assemble_give_the_single_machine_release() {
    let samples = [
        "bunny",
        "box-vertex-colors",
        "glass-vase-flowers",
        "avocado",
    ];
    let s = server();
    let p = project(&samples, &s.url("cache"), "read-write");

    // The reference: one machine, no remote cache.
    let single = Project::new(&samples);
    ok(&single.build(&[]));
    let reference = tree(&single.path("out"));

    let assemble = |name: &str| {
        Command::new(EXE)
            .args(["assemble", "--no-report", "--config"])
            .arg(p.path("pipeline.toml"))
            .arg("--cache")
            .arg(p.path(&format!("cache-{name}")))
            .arg("--out")
            .arg(p.path(&format!("out-{name}")))
            .env("CI", "1")
            .output()
            .unwrap()
    };
    let mut built = 0;
    for k in 1..=3 {
        let shard = format!("{k}/3");
        let out = build_as(&p, &format!("shard{k}"), &["--shard", &shard]);
        let t = ok(&out);
        let line = t
            .lines()
            .find(|l| l.starts_with(&format!("shard {shard}: ")))
            .unwrap_or_else(|| panic!("{t}"));
        built += ran(&out, "ingest");
        assert!(line.contains("of 4 assets; no release written"), "{t}");
        assert!(!p.path(&format!("out-shard{k}/release.json")).exists());
        if k == 2 {
            // Not every shard is built yet: assemble names what is missing, writes nothing.
            let out = assemble("early");
            let t = text(&out);
            assert_eq!(out.status.code(), Some(1), "{t}");
            assert!(t.contains("not fully in the cache"), "{t}");
            assert!(t.contains("is not in the cache"), "{t}");
            assert!(!p.path("out-early/release.json").exists());
        }
    }
    assert_eq!(built, 4, "every asset in exactly one shard");

    // A fresh machine assembles from the remote cache without running any stage.
    let out = assemble("final");
    let t = ok(&out);
    assert_eq!(ran_all(&out), [0; 8], "{t}");
    same_release(&reference, &tree(&p.path("out-final")), "assembled");
    assert!(p.path("out-final/report.json").exists());

    let bad = build_as(&p, "x", &["--shard", "4/3"]);
    assert_eq!(bad.status.code(), Some(2), "{}", text(&bad));
}
