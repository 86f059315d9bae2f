//! The `ori` command as a user meets it: installed with `cargo install`, run from a folder the
//! repository knows nothing about; its `--help` texts, error messages and exit statuses held
//! to snapshots in tests/snapshots/cli/ (`ORI_UPDATE_SNAPSHOTS=1` rewrites them after a
//! deliberate change; review the diff).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const ORI: &str = env!("CARGO_BIN_EXE_ori");

fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn copy_dir(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    for entry in fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
    }
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Runs `ori` in `dir`.
fn ori(exe: &Path, dir: &Path, args: &[&str]) -> Output {
    Command::new(exe)
        .args(args)
        .current_dir(dir)
        .env("CI", "1")
        .output()
        .unwrap()
}

/// The configuration `ori init` wrote, with selection measured on 64 x 64 views and no
/// placement search, to keep the test quick (the same stages and artifacts).
fn lighten(config: &Path) {
    let mut text = fs::read_to_string(config).unwrap();
    for (default, light) in [
        ("\ns0 = 256\n", "\ns0 = 64\n"),
        ("\nmax_moves = 32\n", "\nmax_moves = 0\n"),
    ] {
        assert!(text.contains(default), "the template's {default:?} moved");
        text = text.replacen(default, light, 1);
    }
    fs::write(config, text).unwrap();
}

#[test]
fn installed_ori_initialises_and_builds_a_folder_it_has_never_seen() {
    let temp = tempfile::tempdir().unwrap();
    let root = temp.path().join("root");
    // The tests' own target folder and profile: the installed binary is built from the
    // artifacts `cargo test` compiled, not from scratch.
    let target = Path::new(env!("CARGO_TARGET_TMPDIR")).parent().unwrap();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let install = Command::new(cargo)
        .args(["install", "--locked", "--offline", "--debug", "--path"])
        .arg(repository().join("crates/ori-cli"))
        .arg("--root")
        .arg(&root)
        .env("CARGO_TARGET_DIR", target)
        .output()
        .unwrap();
    assert!(install.status.success(), "{}", text(&install));
    let exe = root
        .join("bin")
        .join(format!("ori{}", std::env::consts::EXE_SUFFIX));

    let project = temp.path().join("project");
    fs::create_dir_all(&project).unwrap();
    let version = ori(&exe, &project, &["--version"]);
    let version = String::from_utf8(version.stdout).unwrap();
    let hash = version.trim().rsplit(['(', ')']).nth(1).unwrap_or("");
    assert!(
        version.starts_with(&format!("ori {} (", env!("CARGO_PKG_VERSION")))
            && hash.len() == 40
            && hash.bytes().all(|b| b.is_ascii_hexdigit()),
        "{version}"
    );

    let init = ori(&exe, &project, &["init"]);
    assert!(init.status.success(), "{}", text(&init));
    let again = ori(&exe, &project, &["init"]);
    assert_eq!(again.status.code(), Some(2), "{}", text(&again));
    lighten(&project.join("pipeline.toml"));
    for sample in ["box-vertex-colors", "bunny"] {
        copy_dir(
            &repository().join("samples").join(sample),
            &project.join("assets").join(sample),
        );
    }

    let build = ori(&exe, &project, &["build", "--no-report"]);
    assert!(build.status.success(), "{}", text(&build));
    let out = project.join("target/ori-out");
    for package in [
        "box-vertex-colors/BoxVertexColors.ori",
        "bunny/bunny_npm_lowres.ori",
    ] {
        assert!(out.join(package).is_file(), "{package}: {}", text(&build));
    }
    let verify = ori(&exe, &project, &["verify", "target/ori-out"]);
    assert!(verify.status.success(), "{}", text(&verify));
    assert_eq!(
        String::from_utf8_lossy(&verify.stdout).trim(),
        "2 package(s) verified in target/ori-out"
    );
    // From another folder, the configuration's paths still resolve against its own folder.
    let elsewhere = ori(
        &exe,
        temp.path(),
        &["build", "--no-report", "--config", "project/pipeline.toml"],
    );
    assert!(elsewhere.status.success(), "{}", text(&elsewhere));
    let t = text(&elsewhere);
    assert!(
        t.contains("2 assets built") && !t.contains(": ran in"),
        "nothing to redo: {t}"
    );
}

/// Compares `actual` with the snapshot file `name`, or rewrites it when asked to.
fn snapshot(name: &str, actual: &str) {
    let path = repository().join("tests/snapshots/cli").join(name);
    if std::env::var_os("ORI_UPDATE_SNAPSHOTS").is_some() {
        fs::create_dir_all(path.parent().unwrap()).unwrap();
        fs::write(&path, actual).unwrap();
        return;
    }
    let expected = fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (ORI_UPDATE_SNAPSHOTS=1 writes it)", path.display()));
    assert!(
        expected == actual,
        "{} differs (ORI_UPDATE_SNAPSHOTS=1 rewrites it):\n--- expected\n{expected}\n--- actual\n{actual}",
        path.display()
    );
}

#[test]
fn help_texts_match_their_snapshots() {
    let here = std::env::temp_dir();
    let mut all = String::new();
    let commands = [
        "",
        "build",
        "assemble",
        "verify",
        "report",
        "preview",
        "compress-texture",
        "eval-table",
        "compare",
        "init",
    ];
    for command in commands {
        let args: Vec<&str> = command.split_whitespace().chain(["--help"]).collect();
        let out = ori(Path::new(ORI), &here, &args);
        assert!(out.status.success(), "{}", text(&out));
        all.push_str(&format!(
            "$ ori {}\n{}\n",
            args.join(" "),
            String::from_utf8_lossy(&out.stdout)
        ));
    }
    snapshot("help.txt", &all);
}

/// Every exit status with the messages that come with it, on a small project: what a CI
/// script or a person reads.
#[test]
fn exit_statuses_and_error_messages_match_their_snapshot() {
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path();
    copy_dir(
        &repository().join("samples/box-vertex-colors"),
        &dir.join("assets/box"),
    );
    let base = "[assets]\nroot = \"assets\"\n[output]\ndir = \"out\"\n[cache]\ndir = \"cache\"\n\
                [select]\ns0 = 64\n[place]\nmax_moves = 0\n";
    fs::write(dir.join("pipeline.toml"), base).unwrap();
    let mut log = String::new();
    let mut run = |what: &str, args: &[&str]| -> i32 {
        let out = ori(Path::new(ORI), dir, args);
        let code = out.status.code().unwrap_or(-1);
        // Only standard error: standard output holds progress and timings.
        let stderr =
            String::from_utf8_lossy(&out.stderr).replace(&*dir.to_string_lossy(), "<project>");
        log.push_str(&format!(
            "# {what}\n$ ori {}\nexit status {code}\n{stderr}\n",
            args.join(" ")
        ));
        code
    };

    assert_eq!(run("a clean build", &["build", "-q", "--no-report"]), 0);
    assert_eq!(run("the release checked", &["verify", "out"]), 0);

    let package = dir.join("out/box/BoxVertexColors.ori");
    let mut bytes = fs::read(&package).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x40;
    fs::write(&package, bytes).unwrap();
    assert_eq!(run("a damaged package", &["verify", "out"]), 1);

    fs::write(dir.join("assets/box/broken.glb"), b"glTF\x02\x00\x00\x00").unwrap();
    assert_eq!(
        run(
            "a model that cannot be read",
            &["build", "-q", "--no-report"]
        ),
        1
    );
    fs::remove_file(dir.join("assets/box/broken.glb")).unwrap();

    fs::write(
        dir.join("pipeline.toml"),
        format!("{base}[gate]\nmin_plt_px = 100000\nmax_texture_bytes = 1000\n"),
    )
    .unwrap();
    assert_eq!(
        run("an asset below its gate", &["build", "-q", "--no-report"]),
        3
    );

    fs::write(
        dir.join("pipeline.toml"),
        format!("{base}[bake]\nresolutoin = 128\n"),
    )
    .unwrap();
    assert_eq!(run("a misspelt key", &["build", "-q"]), 2);
    fs::write(
        dir.join("pipeline.toml"),
        format!("{base}[bake]\nresolution = \"big\"\n"),
    )
    .unwrap();
    assert_eq!(run("a value of the wrong type", &["build", "-q"]), 2);
    fs::write(dir.join("pipeline.toml"), format!("{base}[bake\n")).unwrap();
    assert_eq!(run("broken TOML", &["build", "-q"]), 2);
    assert_eq!(
        run(
            "no such configuration",
            &["build", "--config", "missing.toml"]
        ),
        2
    );
    assert_eq!(run("a wrong flag", &["build", "--jobs", "many"]), 2);
    assert_eq!(run("a configuration already there", &["init"]), 2);

    snapshot("exit-statuses.txt", &log);
}
