//! `cargo xtask bench remote`: a cold build of ../shared/models that fills a remote cache (a
//! local nginx WebDAV server, or a local S3-compatible server with `--store s3`), then a build
//! and an `assemble` of the same models, each from an empty local cache, that take everything
//! from it; times and the bytes the client moved.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use crate::bench::copy_tree;
use crate::moto::Moto;
use crate::nginx::Nginx;

/// Which server the benchmark fills.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Store {
    /// nginx WebDAV.
    Http,
    /// An S3 bucket (moto).
    S3,
}

/// The server the benchmark fills.
enum Server {
    Http(Nginx),
    S3(Moto),
}

impl Server {
    fn start(store: Store) -> Result<Server, String> {
        Ok(match store {
            Store::Http => Server::Http(Nginx::start()?),
            Store::S3 => Server::S3(Moto::start()?),
        })
    }

    fn url(&self) -> String {
        match self {
            Server::Http(nginx) => nginx.url("cache"),
            Server::S3(moto) => moto.url("cache"),
        }
    }

    /// What a builder needs in its environment to reach the server.
    fn env(&self, command: &mut Command) {
        if let Server::S3(moto) = self {
            moto.env(command);
        }
    }
}

/// One build: its wall time and its output (summary included).
fn build(
    server: &Server,
    config: &Path,
    cache: &Path,
    out: &Path,
) -> Result<(Duration, String), String> {
    run_command(server, "build-assets", config, cache, out)
}

/// `command` (`build-assets` or `assemble`) on `config`: its wall time and its output.
fn run_command(
    server: &Server,
    command: &str,
    config: &Path,
    cache: &Path,
    out: &Path,
) -> Result<(Duration, String), String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let mut child = Command::new(exe);
    child
        .args([command, "--quiet", "--no-report", "--config"])
        .arg(config)
        .arg("--cache")
        .arg(cache)
        .arg("--out")
        .arg(out);
    server.env(&mut child);
    let start = Instant::now();
    let output = child.output().map_err(|e| e.to_string())?;
    let elapsed = start.elapsed();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    if !output.status.success() {
        return Err(format!("{command} failed:\n{text}"));
    }
    Ok((elapsed, text))
}

/// The summary's line starting with `prefix`.
fn line<'a>(text: &'a str, prefix: &str) -> Result<&'a str, String> {
    text.lines()
        .find(|l| l.starts_with(prefix))
        .ok_or_else(|| format!("no `{prefix}` line in:\n{text}"))
}

/// Jobs run, over every stage of the summary.
fn jobs_ran(text: &str) -> usize {
    [
        "ingest", "views", "bake", "select", "plt", "compress", "package",
    ]
    .iter()
    .filter_map(|s| line(text, &format!("{s} ")).ok())
    .filter_map(|l| l.split_whitespace().nth(1)?.parse::<usize>().ok())
    .sum()
}

/// Output bytes per stage held by a local cache (each blob counted once; the outputs its
/// entries list but that were never fetched are not), e.g. `ingest 12.3 MB, views 0.1 MB, ...`.
fn by_stage(cache: &Path) -> Result<String, String> {
    let mut seen = std::collections::BTreeSet::new();
    let mut sizes: Vec<(String, u64)> = Vec::new();
    for entry in walkdir::WalkDir::new(cache.join("ac")).sort_by_file_name() {
        let entry = entry.map_err(|e| e.to_string())?;
        if !entry.file_type().is_file() {
            continue;
        }
        let text = std::fs::read_to_string(entry.path()).map_err(|e| e.to_string())?;
        let json = text.split_once('\n').map_or("", |(_, j)| j);
        let value: serde_json::Value = serde_json::from_str(json).map_err(|e| e.to_string())?;
        let stage = value["stage"].as_str().unwrap_or("?").to_string();
        let mut bytes = 0;
        for blob in value["outputs"]
            .as_object()
            .into_iter()
            .flat_map(|o| o.values())
        {
            let hash = blob["hash"].as_str().unwrap_or("");
            let held = hash.len() > 2 && cache.join("cas").join(&hash[..2]).join(hash).is_file();
            if held && seen.insert(hash.to_string()) {
                bytes += blob["size"].as_u64().unwrap_or(0);
            }
        }
        match sizes.iter_mut().find(|(s, _)| *s == stage) {
            Some(s) => s.1 += bytes,
            None => sizes.push((stage, bytes)),
        }
    }
    Ok(sizes
        .iter()
        .map(|(s, b)| format!("{s} {:.1} MB", *b as f64 / 1e6))
        .collect::<Vec<_>>()
        .join(", "))
}

/// `baseline`: also time a cold build without the remote cache (the cost of uploading).
pub fn run(baseline: bool, models: &Path, digest: &str, store: Store) -> Result<(), String> {
    let server = Server::start(store)?;
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    copy_tree(models, &dir.path().join("assets"))?;
    let with_remote = dir.path().join("remote.toml");
    let plain = dir.path().join("plain.toml");
    let assets = "[assets]\nroot = \"assets\"\n";
    std::fs::write(&plain, assets).map_err(|e| e.to_string())?;
    std::fs::write(
        &with_remote,
        format!(
            "{assets}[cache.remote]\nurl = \"{}\"\nmode = \"read-write\"\ntimeout_s = 60\ndigest = \"{digest}\"\n",
            server.url()
        ),
    )
    .map_err(|e| e.to_string())?;
    std::thread::sleep(ori_graph::RACY_WINDOW + Duration::from_millis(100));
    let p = |name: &str| dir.path().join(name);

    if baseline {
        let (t, _) = build(&server, &plain, &p("cache-plain"), &p("out-plain"))?;
        println!(
            "cold build of {} without a remote cache: {:.2} s",
            models.display(),
            t.as_secs_f64()
        );
    }
    let (cold, text) = build(&server, &with_remote, &p("cache-a"), &p("out-a"))?;
    println!(
        "cold build, filling the remote cache:           {:.2} s ({} jobs ran)\n  {}",
        cold.as_secs_f64(),
        jobs_ran(&text),
        line(&text, "remote cache")?
    );
    let (warm, text) = build(&server, &with_remote, &p("cache-b"), &p("out-b"))?;
    let ran = jobs_ran(&text);
    println!(
        "build from an empty local cache (all remote):   {:.2} s ({ran} jobs ran)\n  {}",
        warm.as_secs_f64(),
        line(&text, "remote cache")?
    );
    if ran != 0 {
        return Err(format!("the build from the remote cache ran {ran} jobs"));
    }
    println!("  output bytes held by stage: {}", by_stage(&p("cache-b"))?);
    let (noop, _) = build(&server, &with_remote, &p("cache-b"), &p("out-b"))?;
    println!(
        "then a no-op rebuild (local cache, no request): {:.2} s",
        noop.as_secs_f64()
    );
    let (assemble, text) = run_command(
        &server,
        "assemble",
        &with_remote,
        &p("cache-c"),
        &p("out-c"),
    )?;
    let packages: u64 = walkdir::WalkDir::new(p("out-c"))
        .into_iter()
        .filter_map(Result::ok)
        .filter(|e| e.path().extension().is_some_and(|x| x == "ori"))
        .filter_map(|e| e.metadata().ok().map(|m| m.len()))
        .sum();
    println!(
        "assemble from an empty local cache:             {:.2} s (the packages are {:.2} MB)\n  {}",
        assemble.as_secs_f64(),
        packages as f64 / 1e6,
        line(&text, "remote cache")?
    );
    let release = |out: &str| std::fs::read(p(out).join("release.json")).map_err(|e| e.to_string());
    if release("out-a")? != release("out-b")? || release("out-a")? != release("out-c")? {
        return Err("the releases differ".into());
    }
    ori_pipeline::release::verify(&p("out-b")).map_err(|e| e.join("\n"))?;
    let Server::Http(nginx) = &server else {
        println!("releases identical");
        return Ok(());
    };
    let stored: Vec<u64> = walkdir::WalkDir::new(nginx.root())
        .into_iter()
        .filter_map(Result::ok)
        .filter(|e| e.file_type().is_file())
        .filter_map(|e| e.metadata().ok().map(|m| m.len()))
        .collect();
    println!(
        "releases identical; the server holds {} files, {:.2} MB ({} requests served)",
        stored.len(),
        stored.iter().sum::<u64>() as f64 / 1e6,
        nginx.access_log().lines().count()
    );
    Ok(())
}
