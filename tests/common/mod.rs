//! What the end-to-end tests share: temporary projects built with the `xtask` binary, and
//! readers for its summary and report.
#![allow(dead_code)] // each test file uses a part

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

pub const EXE: &str = env!("CARGO_BIN_EXE_xtask");

pub fn samples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples")
}

pub fn shared_models() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/models")
}

/// Selection measured on 64 x 64 views instead of 256 x 256, and each entry's region at its
/// corners and edge midpoints only: twenty times less tracing, the same stages and artifacts.
/// (Quality at the defaults is tested in ori-pipeline's `tests/ori.rs`.)
pub const FAST: &str = "[select]\ns0 = 64\nregion_steps = 2\n";

/// Placement off, unless a test's own configuration has a `[place]` table: the search bakes
/// 340 candidate maps per asset. (`ori-place` tests the search, `build_assets.rs` the stage.)
pub const NO_PLACEMENT: &str = "[place]\nmax_moves = 0\n";

/// A temporary project: `assets/` with copies of some samples, a `pipeline.toml`, and the
/// cache and output inside.
pub struct Project {
    pub dir: tempfile::TempDir,
}

impl Project {
    pub fn new(sample_folders: &[&str]) -> Project {
        let dir = tempfile::tempdir().unwrap();
        for folder in sample_folders {
            copy_dir(
                &samples().join(folder),
                &dir.path().join("assets").join(folder),
            );
        }
        let p = Project { dir };
        p.config("");
        p
    }

    pub fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }

    pub fn config(&self, extra: &str) {
        let place = if extra.contains("[place]") {
            ""
        } else {
            NO_PLACEMENT
        };
        fs::write(
            self.path("pipeline.toml"),
            format!("[assets]\nroot = \"assets\"\n[output]\ndir = \"out\"\n[cache]\ndir = \"cache\"\n{FAST}{place}{extra}"),
        )
        .unwrap();
    }

    /// Build without the HTML report (`tests/report.rs` tests it), to keep tests quick.
    pub fn build(&self, args: &[&str]) -> Output {
        let mut all = vec!["--no-report"];
        all.extend_from_slice(args);
        self.build_with_report(&all)
    }

    pub fn build_with_report(&self, args: &[&str]) -> Output {
        Command::new(EXE)
            .arg("build-assets")
            .arg("--config")
            .arg(self.path("pipeline.toml"))
            .args(args)
            .env("CI", "1")
            .output()
            .unwrap()
    }

    pub fn report(&self) -> Value {
        serde_json::from_slice(&fs::read(self.path("out/report.json")).unwrap()).unwrap()
    }
}

pub fn copy_dir(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    for entry in fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
    }
}

pub fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The `ran` column of the summary line for `stage`.
pub fn ran(out: &Output, stage: &str) -> usize {
    summary_column(out, stage, 1)
}

/// Column `column` (0 is the stage's name) of the summary line for `stage`.
pub fn summary_column(out: &Output, stage: &str, column: usize) -> usize {
    let t = text(out);
    t.lines()
        .find(|l| l.split_whitespace().next() == Some(stage))
        .and_then(|l| l.split_whitespace().nth(column))
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no summary line for {stage}:\n{t}"))
}

/// The report as text, without each asset's `jobs` (which log this build's runs and times),
/// so a mismatch prints readably.
pub fn report_text(p: &Project, out: &str) -> String {
    let mut report: Value =
        serde_json::from_slice(&fs::read(p.path(out).join("report.json")).unwrap()).unwrap();
    for asset in report["assets"].as_array_mut().unwrap() {
        asset.as_object_mut().unwrap().remove("jobs");
    }
    serde_json::to_string_pretty(&report).unwrap()
}

pub fn ok(out: &Output) -> String {
    assert!(out.status.success(), "build failed:\n{}", text(out));
    text(out)
}

pub fn asset<'a>(report: &'a Value, name: &str) -> &'a Value {
    report["assets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["name"] == name)
        .unwrap_or_else(|| panic!("{name} not in report: {report}"))
}

/// The stages, in pipeline order.
pub const STAGES: [&str; 8] = [
    "ingest", "views", "place", "bake", "select", "plt", "compress", "package",
];

/// How many jobs of each stage ran, in pipeline order.
pub fn ran_all(out: &std::process::Output) -> [usize; 8] {
    STAGES.map(|s| ran(out, s))
}

/// Every file of the release under `dir` (packages and `release.json`; the report logs one
/// build), relative path to bytes.
pub fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if name == "report.json" || name == "report" {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path
                    .strip_prefix(dir)
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                out.insert(rel, fs::read(&path).unwrap());
            }
        }
    }
    out
}

/// Asserts two release folders are the same, naming the first file that differs.
pub fn same_release(a: &BTreeMap<String, Vec<u8>>, b: &BTreeMap<String, Vec<u8>>, what: &str) {
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "{what}: different files"
    );
    for (k, v) in a {
        assert!(v == &b[k], "{what}: {k} differs");
    }
}

/// The summary's remote-cache line.
pub fn remote_line(out: &Output) -> String {
    let t = text(out);
    t.lines()
        .find(|l| l.starts_with("remote cache "))
        .unwrap_or_else(|| panic!("no remote cache line:\n{t}"))
        .to_string()
}

/// Warning lines about the remote cache.
pub fn remote_warnings(out: &Output) -> Vec<String> {
    text(out)
        .lines()
        .filter(|l| l.starts_with("warning: remote cache"))
        .map(String::from)
        .collect()
}

/// An action entry as a remote cache holds it: a checksum line (blake3 of the JSON), then the
/// JSON; panics naming `what` when the checksum does not hold.
pub fn check_entry(bytes: Vec<u8>, what: &str) {
    let text = String::from_utf8(bytes).unwrap();
    let (check, json) = text.split_once('\n').unwrap();
    let json = json.strip_suffix('\n').unwrap();
    assert_eq!(
        blake3::hash(json.as_bytes()).to_hex().as_str(),
        check,
        "{what}"
    );
}

/// Headless Chromium, as CI runs it (`.ci/run` installs Debian's `chromium`), opening
/// `file://{page}{query}` with `args` after the common flags.
pub fn chromium(user_dir: &Path, args: &[&str], page: &Path, query: &str) -> Output {
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
        .arg(format!("file://{}{query}", page.display()))
        .output()
        .expect("chromium must be installed (Debian package `chromium`; .ci/run installs it)")
}
