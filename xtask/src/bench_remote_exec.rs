//! `cargo xtask bench remote-exec`: cold builds of ../shared/models on a local BuildGrid farm
//! with 1, 2, 3 workers, against the same machine building alone and against `--shard K/N` in
//! N processes at once (then `assemble`): wall times, and where the farm's job time went.
//! With `--one-core-each`, worker K and shard K run on core K alone, as N one-core machines
//! would: the farm's balance against the static split at equal cores.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::bench::copy_tree;
use crate::buildgrid::BuildGrid;

/// Selection on 64 x 64 views over each entry's corners and edge midpoints, placement at its
/// defaults: the jobs of a build at the defaults, cheaper, with placement's uneven cost per
/// asset (what a static split cannot foresee).
const CONFIG: &str = "[assets]\nroot = \"assets\"\n[select]\ns0 = 64\nregion_steps = 2\n";

/// This program, on core `core` alone when given (`taskset`).
fn program_on(core: Option<usize>) -> Result<Command, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    Ok(match core {
        Some(core) => {
            let mut command = Command::new("taskset");
            command.args(["--cpu-list", &core.to_string()]).arg(exe);
            command
        }
        None => Command::new(exe),
    })
}

/// `build-assets` (or `assemble`, `which`) of the project, quiet, its output captured; on
/// core `core` alone when given.
fn command_on(
    core: Option<usize>,
    which: &str,
    config: &Path,
    cache: &Path,
    out: &Path,
    extra: &[&str],
) -> Result<Command, String> {
    let mut command = program_on(core)?;
    command
        .args([which, "--quiet", "--no-report", "--config"])
        .arg(config)
        .arg("--cache")
        .arg(cache)
        .arg("--out")
        .arg(out)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    Ok(command)
}

/// Wait for `child`; its output, or an error with it.
fn finish(child: Child, what: &str) -> Result<String, String> {
    let output = child.wait_with_output().map_err(|e| e.to_string())?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    if !output.status.success() {
        return Err(format!("{what} failed:\n{text}"));
    }
    Ok(text)
}

fn timed(mut command: Command, what: &str) -> Result<(Duration, String), String> {
    let started = Instant::now();
    let child = command.spawn().map_err(|e| format!("{what}: {e}"))?;
    let text = finish(child, what)?;
    Ok((started.elapsed(), text))
}

/// The seconds the summary's remote-execution line gives: (moving, waiting, running).
fn job_seconds(text: &str) -> Result<(f64, f64, f64), String> {
    let line = text
        .lines()
        .find(|l| l.starts_with("remote execution "))
        .ok_or_else(|| format!("no remote execution line in:\n{text}"))?;
    let numbers: Vec<f64> = line
        .split(['(', ')', ' ', ','])
        .filter_map(|w| w.parse().ok())
        .collect();
    match numbers[..] {
        [_, moving, waiting, running] => Ok((moving, waiting, running)),
        _ => Err(format!("cannot read the job seconds of: {line}")),
    }
}

pub fn run(models: &Path, workers: &[usize], one_core_each: bool) -> Result<(), String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if one_core_each && workers.iter().any(|&n| n > cores) {
        return Err(format!(
            "--one-core-each: this machine has {cores} cores, fewer than the counts {workers:?}"
        ));
    }
    // Worker or shard `k` (from 0): its core, with --one-core-each.
    let core = |k: usize| one_core_each.then_some(k);
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    copy_tree(models, &dir.path().join("assets"))?;
    let config = dir.path().join("pipeline.toml");
    std::fs::write(&config, CONFIG).map_err(|e| e.to_string())?;
    std::thread::sleep(ori_graph::RACY_WINDOW + Duration::from_millis(100));
    let p = |name: &str| dir.path().join(name);
    let release = |out: &str| std::fs::read(p(out).join("release.json")).map_err(|e| e.to_string());

    let (alone, _) = timed(
        command_on(
            None,
            "build-assets",
            &config,
            &p("cache-alone"),
            &p("out-alone"),
            &[],
        )?,
        "build",
    )?;
    println!(
        "cold build of {} on this machine alone ({cores} cores): {:.1} s",
        models.display(),
        alone.as_secs_f64()
    );
    if one_core_each {
        println!("worker k and shard k run on core k alone (the builder on any)");
    }
    println!(
        "{:>7} {:>10} {:>10} {:>12} {:>10} {:>10} {:>10}   {:>10} {:>10}  shard parts (s)",
        "workers",
        "farm (s)",
        "moving",
        "scheduling",
        "running",
        "overhead",
        "busy",
        "shards (s)",
        "assemble"
    );
    for &n in workers {
        // The farm: a fresh one (its action cache would answer everything), n workers.
        let mut farm = BuildGrid::start()?;
        for k in 0..n {
            farm.add_worker_on(&exe, program_on(core(k))?)?;
        }
        let (name_cache, name_out) = (format!("cache-farm{n}"), format!("out-farm{n}"));
        let (wall, text) = timed(
            command_on(
                None,
                "build-assets",
                &config,
                &p(&name_cache),
                &p(&name_out),
                &["--remote-exec", &farm.url],
            )?,
            "farm build",
        )?;
        drop(farm);
        let (moving, waiting, running) = job_seconds(&text)?;
        if release(&name_out)? != release("out-alone")? {
            return Err(format!("the release built with {n} workers differs"));
        }

        // The same count of shards, all at once on this machine, one cache.
        let cache = p(&format!("cache-shards{n}"));
        let started = Instant::now();
        let mut parts: Vec<(Option<f64>, Child)> = (1..=n)
            .map(|k| {
                let shard = format!("{k}/{n}");
                let mut c = command_on(
                    core(k - 1),
                    "build-assets",
                    &config,
                    &cache,
                    &p("out-unused"),
                    &["--shard", &shard],
                )?;
                c.spawn()
                    .map(|child| (None, child))
                    .map_err(|e| e.to_string())
            })
            .collect::<Result<_, String>>()?;
        // Each part's own finishing time (their output is small: --quiet).
        while parts.iter().any(|(done, _)| done.is_none()) {
            for (done, child) in &mut parts {
                if done.is_none() && child.try_wait().map_err(|e| e.to_string())?.is_some() {
                    *done = Some(started.elapsed().as_secs_f64());
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let shards = started.elapsed();
        let mut part_times = Vec::new();
        for (k, (done, child)) in parts.into_iter().enumerate() {
            finish(child, &format!("shard {}/{n}", k + 1))?;
            part_times.push(done.unwrap_or_default());
        }
        let assemble = command_on(
            None,
            "assemble",
            &config,
            &cache,
            &p(&format!("out-shards{n}")),
            &[],
        )?;
        let (assembled, _) = timed(assemble, "assemble")?;
        if release(&format!("out-shards{n}"))? != release("out-alone")? {
            return Err(format!("the release assembled from {n} shards differs"));
        }
        let parts: Vec<String> = part_times.iter().map(|t| format!("{t:.1}")).collect();
        println!(
            "{n:>7} {:>10.1} {:>9.1}s {:>11.1}s {:>9.1}s {:>9.0}% {:>9.0}%   {:>10.1} {:>9.1}s  {}",
            wall.as_secs_f64(),
            moving,
            waiting - running,
            running,
            100.0 * (moving + waiting - running) / (moving + waiting).max(1e-9),
            100.0 * running / (n as f64 * wall.as_secs_f64()),
            shards.as_secs_f64(),
            assembled.as_secs_f64(),
            parts.join(", ")
        );
    }
    println!(
        "moving, scheduling, running: job seconds summed over the farm's jobs (scheduling: \
         waiting for a result less the command's own run); overhead: moving + scheduling as a \
         share of the jobs' time; busy: the workers' running time over workers x wall time; every release identical to the machine-alone build"
    );
    Ok(())
}
