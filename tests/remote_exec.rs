//! End-to-end tests of remote execution on a real farm: PostgreSQL, a BuildGrid server and
//! workers (`xtask reapi-worker`, the same binary as the builder) on 127.0.0.1
//! (`xtask/src/buildgrid.rs`). `.ci/run` installs BuildGrid in `target/buildgrid-venv` and
//! Debian's PostgreSQL; without them these tests fail, saying how to install them.

#[path = "../xtask/src/buildgrid.rs"]
mod buildgrid;
mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use buildgrid::BuildGrid;
use common::*;

/// A glTF whose buffer and images are files of their own (sent to the farm as its loader asks
/// for them), and a binary glTF.
const SAMPLES: [&str; 2] = ["avocado", "box-vertex-colors"];
/// Every stage of a build without hierarchies.
const STAGES: [&str; 8] = [
    "ingest", "views", "place", "bake", "select", "plt", "compress", "package",
];

fn farm(workers: usize) -> BuildGrid {
    let mut farm =
        BuildGrid::start().unwrap_or_else(|e| panic!("cannot start the test's BuildGrid: {e}"));
    for _ in 0..workers {
        farm.add_worker(Path::new(EXE)).unwrap();
    }
    farm
}

/// A build of the project with cache `cache-NAME` and output `out-NAME`, on `farm` if given.
fn build_command(p: &Project, name: &str, farm: Option<&BuildGrid>) -> Command {
    build_command_with(p, "pipeline.toml", name, farm)
}

/// `build_command` with the project's configuration file `config`.
fn build_command_with(p: &Project, config: &str, name: &str, farm: Option<&BuildGrid>) -> Command {
    let mut command = Command::new(EXE);
    command
        .args(["build-assets", "--no-report", "--config"])
        .arg(p.path(config))
        .arg("--cache")
        .arg(p.path(&format!("cache-{name}")))
        .arg("--out")
        .arg(p.path(&format!("out-{name}")))
        .env("CI", "1");
    if let Some(farm) = farm {
        command.args(["--remote-exec", &farm.url]);
    }
    command
}

fn build(p: &Project, name: &str, farm: Option<&BuildGrid>) -> Output {
    build_command(p, name, farm).output().unwrap()
}

/// A build of the project on `farm` (`farm`), started, its output piped.
fn spawn_farm_build(p: &Project, farm: &BuildGrid) -> std::process::Child {
    build_command(p, "farm", Some(farm))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// The jobs of all stages that ran on the farm.
fn remote_jobs(out: &Output) -> usize {
    STAGES.iter().map(|s| remote(out, s)).sum()
}

/// The `remote` column of the summary line for `stage` (after `ran`).
fn remote(out: &Output, stage: &str) -> usize {
    summary_column(out, stage, 2)
}

/// Wait for a build, calling `on_line` with each line it prints as it prints it; its output,
/// and everything it printed.
fn watch(mut child: std::process::Child, mut on_line: impl FnMut(&str)) -> (Output, String) {
    let (send, receive) = std::sync::mpsc::channel::<String>();
    let readers: Vec<_> = [
        Box::new(child.stdout.take().unwrap()) as Box<dyn std::io::Read + Send>,
        Box::new(child.stderr.take().unwrap()),
    ]
    .into_iter()
    .map(|stream| {
        let send = send.clone();
        std::thread::spawn(move || {
            for line in std::io::BufRead::lines(std::io::BufReader::new(stream)) {
                let _ = send.send(line.unwrap_or_default());
            }
        })
    })
    .collect();
    drop(send);
    let mut log = String::new();
    for line in receive {
        on_line(&line);
        log.push_str(&line);
        log.push('\n');
    }
    for reader in readers {
        reader.join().unwrap();
    }
    let status = child.wait().unwrap();
    let out = Output {
        status,
        stdout: log.clone().into_bytes(),
        stderr: Vec::new(),
    };
    (out, log)
}

fn execution_line(out: &Output) -> String {
    let t = text(out);
    t.lines()
        .find(|l| l.starts_with("remote execution "))
        .unwrap_or_else(|| panic!("no remote execution line:\n{t}"))
        .to_string()
}

/// Whether the build's remote execution line says that all of its `jobs` ran on `farm`.
fn all_ran_there(out: &Output, farm: &BuildGrid, jobs: usize) -> bool {
    let all = format!("remote execution {}: {jobs} job(s) ran there (", farm.url);
    execution_line(out).starts_with(&all)
}

/// The lines of `log` that warn that remote execution stopped.
fn execution_warnings(log: &str) -> Vec<&str> {
    log.lines()
        .filter(|l| l.starts_with("warning: remote execution "))
        .collect()
}

/// Build the project here (`local`), and check that it makes the release `out-NAME` holds.
fn same_as_a_local_build(p: &Project, name: &str, what: &str) {
    ok(&build(p, "local", None));
    same_release(
        &tree(&p.path(&format!("out-{name}"))),
        &tree(&p.path("out-local")),
        what,
    );
}

#[test]
fn a_farm_builds_the_samples_as_this_machine_does_and_a_rebuild_runs_nothing() {
    let p = Project::new(&SAMPLES);
    let farm = farm(2);
    let out = build(&p, "farm", Some(&farm));
    let log = ok(&out);
    for stage in STAGES {
        assert_eq!(ran(&out, stage), 2, "{stage}:\n{log}");
        assert_eq!(remote(&out, stage), 2, "{stage} ran here:\n{log}");
    }
    assert!(all_ran_there(&out, &farm, 16), "{log}");
    assert!(!log.contains("warning"), "{log}");
    same_as_a_local_build(&p, "farm", "farm and local builds");

    let again = build(&p, "farm", Some(&farm));
    let log = ok(&again);
    assert_eq!(ran_all(&again), [0; 8], "{log}");
    assert!(
        execution_line(&again).ends_with(": 0 job(s) ran there"),
        "{log}"
    );
}

#[test]
fn a_farm_that_goes_away_leaves_the_rest_of_the_build_to_this_machine() {
    let p = Project::new(&SAMPLES);
    let mut farm = farm(1);
    let child = spawn_farm_build(&p, &farm);
    // Kill the server once the builder has a job back from the farm.
    let (out, log) = watch(child, |line| {
        if line.contains("ran remotely") {
            farm.kill_server();
        }
    });
    ok(&out);
    let warnings = execution_warnings(&log);
    assert_eq!(warnings.len(), 1, "{log}");
    assert!(
        warnings[0].ends_with("the remaining jobs run here"),
        "{log}"
    );
    assert!(
        execution_line(&out).contains("unavailable during the build, the rest was built here"),
        "{log}"
    );
    assert!((1..16).contains(&remote_jobs(&out)), "{log}");

    same_as_a_local_build(&p, "farm", "half-farm and local builds");
}

#[test]
fn a_job_whose_worker_dies_runs_again_on_another() {
    let p = Project::new(&SAMPLES);
    let mut farm = farm(2);
    let child = spawn_farm_build(&p, &farm);
    // The first lease a worker starts: kill that worker while it runs it.
    let started = Instant::now();
    let (victim, lease) = loop {
        let running = (0..2).find_map(|n| {
            let log = farm.worker_log(n);
            let lease = log
                .lines()
                .find_map(|l| l.strip_suffix(": running"))?
                .to_string();
            (!log.contains(&format!("{lease}: finished"))).then_some((n, lease))
        });
        if let Some(found) = running {
            break found;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no worker took a job:\n{}",
            farm.log_tail()
        );
        std::thread::sleep(Duration::from_millis(5));
    };
    farm.kill_worker(victim);
    let out = child.wait_with_output().unwrap();
    let log = ok(&out);
    // Every job ran on the farm: the lost one again, on the other worker.
    assert!(all_ran_there(&out, &farm, 16), "{log}");
    let other = farm.worker_log(1 - victim);
    assert!(
        other.contains(&format!("{lease}: running"))
            && other.contains(&format!("{lease}: finished")),
        "{lease} was not run again by the other worker:\n{other}"
    );
    assert!(
        !farm
            .worker_log(victim)
            .contains(&format!("{lease}: finished"))
    );

    same_as_a_local_build(&p, "farm", "farm (one worker lost) and local builds");
}

#[test]
fn a_farm_that_wants_a_token_runs_the_jobs_of_a_builder_that_has_it_and_refuses_others() {
    let p = Project::new(&["box-vertex-colors"]);
    let mut farm = BuildGrid::start_with_token()
        .unwrap_or_else(|e| panic!("cannot start the test's BuildGrid: {e}"));
    farm.add_worker(Path::new(EXE)).unwrap();
    let token = farm.token.clone().unwrap();
    // The same project, once with the token variable named.
    let config = std::fs::read_to_string(p.path("pipeline.toml")).unwrap();
    std::fs::write(
        p.path("with-token.toml"),
        format!("{config}\n[execution]\ntoken_env = \"ORI_TEST_FARM_TOKEN\"\n"),
    )
    .unwrap();
    let with_token = build_command_with(&p, "with-token.toml", "token", Some(&farm))
        .env("ORI_TEST_FARM_TOKEN", &token)
        .output()
        .unwrap();
    let log = ok(&with_token);
    assert!(all_ran_there(&with_token, &farm, 8), "{log}");
    assert!(!log.contains("warning"), "{log}");

    // Without it: refused at the first job, one warning, and the build is made here.
    let without = build(&p, "none", Some(&farm));
    let log = ok(&without);
    let warnings = execution_warnings(&log);
    assert_eq!(warnings.len(), 1, "{log}");
    assert!(warnings[0].contains("Unauthenticated"), "{log}");
    assert_eq!(remote_jobs(&without), 0);
    same_release(
        &tree(&p.path("out-token")),
        &tree(&p.path("out-none")),
        "farm (with a token) and local builds",
    );
}
