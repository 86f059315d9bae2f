//! `cargo xtask bench scale`: cold builds of models of growing size, each stage's seconds and
//! the build's peak memory, then each fitted as a fixed cost plus a cost per 100k faces, so a
//! farm can predict what an asset costs before building it.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use ori_release::{BuildReport, JobStatus, REPORT_JSON};

use crate::bench::median;

/// One cold build of one model: what the child process and its `report.json` say.
struct ColdBuild {
    faces: usize,
    /// The whole `build-assets` process, report included.
    wall: Duration,
    peak_bytes: Option<u64>,
    /// Job seconds summed per stage, in the order the report lists the stages.
    stages: Vec<(String, f64)>,
}

/// One model's medians over its runs.
struct Row {
    name: String,
    faces: usize,
    wall_s: f64,
    peak_mib: Option<f64>,
    stages: Vec<(String, f64)>,
}

pub fn run(runs: usize, extra: &[PathBuf]) -> Result<(), String> {
    let mut models: Vec<PathBuf> = crate::bench::GROWING_MODELS
        .iter()
        .map(|rel| crate::bench::shared_models().join(rel))
        .collect();
    models.extend(extra.iter().cloned());
    println!(
        "cold build-assets of one model at the defaults, {} threads, median of {runs} runs",
        rayon::current_num_threads()
    );
    let mut rows = Vec::new();
    for model in &models {
        let mut builds = Vec::new();
        for run in 1..=runs.max(1) {
            eprintln!("{}: cold build {run} of {runs}", model.display());
            builds.push(cold_build(model)?);
        }
        rows.push(medians(model, &builds)?);
    }
    let stages = stage_names(&rows);
    print_rows(&rows, &stages);
    print_fits(&rows, &stages);
    Ok(())
}

/// Every stage that ran for some model, in the order they first appear.
fn stage_names(rows: &[Row]) -> Vec<String> {
    let mut stages: Vec<String> = Vec::new();
    for row in rows {
        for (stage, _) in &row.stages {
            if !stages.contains(stage) {
                stages.push(stage.clone());
            }
        }
    }
    stages
}

/// A stage's seconds in per-stage times (0 where it did not run).
fn stage_seconds(stages: &[(String, f64)], stage: &str) -> f64 {
    stages.iter().find(|(s, _)| s == stage).map_or(0.0, |s| s.1)
}

/// Build `model` alone (its folder as the assets root, only its file included, so that the
/// files it references resolve) with a fresh cache and output folder.
fn cold_build(model: &Path) -> Result<ColdBuild, String> {
    // The real file: the build neither follows a link to it nor takes a bare file name.
    let model = model
        .canonicalize()
        .map_err(|e| format!("{}: {e}", model.display()))?;
    let (Some(root), Some(file)) = (model.parent(), model.file_name()) else {
        return Err(format!("{}: not a model file", model.display()));
    };
    let file = file.to_string_lossy();
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let config = dir.path().join("pipeline.toml");
    let toml = format!(
        "[assets]\nroot = {}\ninclude = [{}]\n[cache]\ndir = \"cache\"\n[output]\ndir = \"out\"\n",
        toml::Value::String(root.to_string_lossy().into_owned()),
        toml::Value::String(globset::escape(&file)),
    );
    std::fs::write(&config, toml).map_err(|e| e.to_string())?;
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let start = Instant::now();
    let child = Command::new(exe)
        .args(["build-assets", "--quiet", "--config"])
        .arg(&config)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| e.to_string())?;
    let (success, peak_bytes, stderr) = wait_with_peak(child)?;
    let wall = start.elapsed();
    if !success {
        return Err(format!("build of {} failed:\n{stderr}", model.display()));
    }
    let report_path = dir.path().join("out").join(REPORT_JSON);
    let text = std::fs::read_to_string(&report_path)
        .map_err(|e| format!("{}: {e}", report_path.display()))?;
    let report: BuildReport =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", report_path.display()))?;
    let [asset] = report.assets.as_slice() else {
        return Err(format!(
            "{}: {} assets built, expected 1",
            model.display(),
            report.assets.len()
        ));
    };
    let faces = asset
        .mesh
        .as_ref()
        .map(|m| m.triangles)
        .ok_or_else(|| format!("{}: no mesh in {}", model.display(), report_path.display()))?;
    let mut stages: Vec<(String, f64)> = Vec::new();
    for job in asset.jobs.iter().filter(|j| j.status == JobStatus::Ran) {
        match stages.iter_mut().find(|(s, _)| *s == job.stage) {
            Some((_, t)) => *t += job.seconds,
            None => stages.push((job.stage.clone(), job.seconds)),
        }
    }
    Ok(ColdBuild {
        faces,
        wall,
        peak_bytes,
        stages,
    })
}

/// Wait for the child; its exit status, its peak resident memory where the platform reports
/// it, and its standard error.
pub(crate) fn wait_with_peak(
    mut child: std::process::Child,
) -> Result<(bool, Option<u64>, String), String> {
    use std::io::Read;
    let mut bytes = Vec::new();
    if let Some(mut pipe) = child.stderr.take() {
        // An error reading it still leaves the child to reap below.
        let _ = pipe.read_to_end(&mut bytes);
    }
    let mut stderr = String::from_utf8_lossy(&bytes).into_owned();
    #[cfg(target_os = "linux")]
    {
        let pid = child.id() as libc::pid_t;
        let mut status: libc::c_int = 0;
        // SAFETY: an all-zero rusage is valid, and `wait4` only writes into the two locals.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        loop {
            let reaped = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
            if reaped == pid {
                break;
            }
            let error = std::io::Error::last_os_error();
            if error.kind() != std::io::ErrorKind::Interrupted {
                return Err(format!("wait4: {error}"));
            }
        }
        if libc::WIFSIGNALED(status) {
            stderr += &format!("\nkilled by signal {}", libc::WTERMSIG(status));
        }
        let success = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
        // Linux reports ru_maxrss in KiB.
        Ok((success, Some(usage.ru_maxrss as u64 * 1024), stderr))
    }
    #[cfg(not(target_os = "linux"))]
    {
        let status = child.wait().map_err(|e| e.to_string())?;
        Ok((status.success(), None, stderr))
    }
}

fn medians(model: &Path, builds: &[ColdBuild]) -> Result<Row, String> {
    let first = &builds[0];
    if builds.iter().any(|b| b.faces != first.faces) {
        return Err(format!(
            "{}: face counts differ between runs",
            model.display()
        ));
    }
    let stages = first
        .stages
        .iter()
        .map(|(stage, _)| {
            let times = builds
                .iter()
                .map(|b| stage_seconds(&b.stages, stage))
                .collect();
            (stage.clone(), median(times))
        })
        .collect();
    let peaks: Option<Vec<f64>> = builds
        .iter()
        .map(|b| b.peak_bytes.map(|p| p as f64 / (1024.0 * 1024.0)))
        .collect();
    Ok(Row {
        name: model
            .file_name()
            .map_or_else(String::new, |f| f.to_string_lossy().into_owned()),
        faces: first.faces,
        wall_s: median(builds.iter().map(|b| b.wall.as_secs_f64()).collect()),
        peak_mib: peaks.map(median),
        stages,
    })
}

fn print_rows(rows: &[Row], stages: &[String]) {
    let mut header = format!(
        "{:<36} {:>8} {:>8} {:>9}",
        "model", "faces", "total s", "peak MiB"
    );
    for stage in stages {
        header += &format!(" {stage:>8}");
    }
    println!("{header}");
    for row in rows {
        let mut line = format!(
            "{:<36} {:>8} {:>8.2} {:>9}",
            row.name,
            row.faces,
            row.wall_s,
            row.peak_mib
                .map_or_else(|| "n/a".into(), |m| format!("{m:.0}"))
        );
        for stage in stages {
            line += &format!(" {:>8.2}", stage_seconds(&row.stages, stage));
        }
        println!("{line}");
    }
}

/// Least-squares `y = fixed + slope * x` (x: hundreds of thousands of faces, or assets).
pub(crate) fn fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (points.len() >= 2 && sxx > 0.0).then(|| {
        let slope = sxy / sxx;
        (my - slope * mx, slope)
    })
}

fn print_fits(rows: &[Row], stages: &[String]) {
    let per_100k = |faces: usize| faces as f64 / 1e5;
    let mut columns: Vec<(String, Vec<(f64, f64)>)> = vec![(
        "total s".into(),
        rows.iter().map(|r| (per_100k(r.faces), r.wall_s)).collect(),
    )];
    let peaks: Option<Vec<(f64, f64)>> = rows
        .iter()
        .map(|r| r.peak_mib.map(|m| (per_100k(r.faces), m)))
        .collect();
    if let Some(peaks) = peaks {
        columns.push(("peak MiB".into(), peaks));
    }
    for stage in stages {
        let points = rows
            .iter()
            .map(|r| (per_100k(r.faces), stage_seconds(&r.stages, stage)))
            .collect();
        columns.push((format!("{stage} s"), points));
    }
    println!();
    println!("fitted growth (least squares over the models above): fixed + per 100k faces");
    println!(
        "{:<12} {:>10} {:>14} {:>16}",
        "", "fixed", "per 100k faces", "worst residual"
    );
    for (name, points) in columns {
        match fit(&points) {
            Some((fixed, slope)) => {
                let worst = points
                    .iter()
                    .map(|(x, y)| (y - (fixed + slope * x)).abs())
                    .fold(0.0, f64::max);
                println!("{name:<12} {fixed:>10.2} {slope:>14.2} {worst:>16.2}");
            }
            None => println!("{name:<12} (needs two models of different size)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_line_and_needs_two_sizes() {
        let (fixed, slope) = fit(&[(0.5, 2.0), (1.0, 3.0), (3.0, 7.0)]).unwrap();
        assert!((fixed - 1.0).abs() < 1e-12 && (slope - 2.0).abs() < 1e-12);
        assert!(fit(&[(1.0, 2.0), (1.0, 3.0)]).is_none());
        assert!(fit(&[(1.0, 2.0)]).is_none());
    }
}
