//! `cargo xtask bench ...`: benchmarks whose figures go into issue notes. Each compares runs
//! within one invocation and reports medians, because the machine is shared and noisy.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use clap::Subcommand;
use ori_pipeline::ori::{self, OriParams};
use rayon::prelude::*;

#[derive(Subcommand)]
pub enum Bench {
    /// Time a no-op rebuild (nothing changed) of many small assets: copies of the samples.
    NoopRebuild {
        /// How many assets to build.
        #[arg(long, default_value_t = 100)]
        assets: usize,
        /// How many timed no-op rebuilds.
        #[arg(long, default_value_t = 10)]
        runs: usize,
    },
    /// Time view planning (default strategy) plus baking of 20 relief maps at 256 x 256 on
    /// real models of growing size, with the default thread pool.
    Bake {
        /// Timed runs per model (the median is reported).
        #[arg(long, default_value_t = 5)]
        runs: usize,
    },
    /// Time selection + PLT (the held-out measure) at the defaults (best:8, s0 = 256) on real
    /// models of growing size, with the default thread pool, beside selection with every mask
    /// traced before the search.
    Select {
        /// Timed runs per model (the median is reported).
        #[arg(long, default_value_t = 3)]
        runs: usize,
    },
    /// Time the mesh's coverage (what every selection and held-out view starts from) in every
    /// view of a selection's plan at the defaults, on real models of growing size, with the
    /// default thread pool; the pixels covered are printed so that two builds can be compared.
    Coverage {
        /// Timed runs per model (the median is reported).
        #[arg(long, default_value_t = 3)]
        runs: usize,
    },
    /// Time the placement search at the defaults (`[place]`, measured with the default bake
    /// and selection) on real models of growing size, with the default thread pool, and what
    /// it did: moves, and the worst view's missed pixels before and after.
    Place {
        /// Timed runs per model (the median is reported).
        #[arg(long, default_value_t = 1)]
        runs: usize,
    },
    /// A cold build of every model in ../shared/models, then the rebuild after one model's
    /// geometry is edited, against that model's own cold build.
    Release,
    /// A cold build of ../shared/models filling a remote cache (a local nginx, or a local
    /// S3-compatible server), then a build and an `assemble` from empty local caches taking
    /// everything from it: times and bytes moved.
    Remote {
        /// Also time a cold build without the remote cache.
        #[arg(long)]
        baseline: bool,
        /// The models to build (default: ../shared/models).
        #[arg(long)]
        models: Option<std::path::PathBuf>,
        /// How the server names blobs: `blake3` or `sha256` (bazel-remote compatible).
        #[arg(long, default_value = "blake3")]
        digest: String,
        /// The server: `http` (nginx WebDAV) or `s3` (moto, from target/test-venv).
        #[arg(long, value_enum, default_value_t = crate::bench_remote::Store::Http)]
        store: crate::bench_remote::Store,
    },
    /// Cold builds on a local BuildGrid farm (target/buildgrid-venv) with 1, 2, 3 workers,
    /// against this machine alone and against `--shard K/N` in N processes: wall times, and
    /// the farm's job time moving blobs, scheduling and running.
    RemoteExec {
        /// The models to build (default: ../shared/models).
        #[arg(long)]
        models: Option<std::path::PathBuf>,
        /// Worker counts (each also the shard count compared).
        #[arg(long, value_delimiter = ',', default_value = "1,2,3")]
        workers: Vec<usize>,
        /// Run each worker and each shard on one core of its own (`taskset`), as on machines
        /// of one core each, so that the farm and the shards have the same cores; counts
        /// must not exceed this machine's cores.
        #[arg(long)]
        one_core_each: bool,
    },
    /// A cold build of one model at a time, models of growing size: the build's seconds, each
    /// stage's job seconds and peak memory, medians, then each fitted as a fixed cost plus a
    /// cost per 100k faces.
    Scale {
        /// Cold builds per model (the median is reported).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Another model to include after the shared ones (repeatable), e.g. the full
        /// Stanford dragon's dragon_vrip.ply.
        #[arg(long = "model")]
        models: Vec<PathBuf>,
    },
    /// A studio's catalogue: a cold build of many distinct small assets (copies of shared
    /// models, one vertex moved per copy), no-op rebuilds and the rebuild after one asset is
    /// edited, with peak memory; each fitted as a fixed cost plus a cost per asset.
    Catalogue {
        /// Catalogue sizes, e.g. `--assets 100,1000,10000`.
        #[arg(long, value_delimiter = ',', default_value = "100,1000")]
        assets: Vec<usize>,
        /// Timed no-op rebuilds per size (the median is reported).
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Build in this folder (one `catalogue-N` folder per size, kept) instead of a
        /// temporary one.
        #[arg(long)]
        keep: Option<PathBuf>,
        /// A model to copy (repeatable; OBJ or GLB, relative to ../shared/models or absolute),
        /// instead of the lowres bunny, the duck and the vertex-coloured box.
        #[arg(long = "model")]
        models: Vec<PathBuf>,
    },
    /// Frame time of drawing the ORI versus the full mesh with the wgpu renderer (whatever
    /// adapter exists: the software driver on a machine without a GPU).
    Render {
        /// Frames per model and representation (the median is reported).
        #[arg(long, default_value_t = 12)]
        frames: usize,
        /// Image edge in pixels.
        #[arg(long, default_value_t = 512)]
        size: u32,
    },
}

pub fn run(which: Bench) -> ExitCode {
    let result = match which {
        Bench::NoopRebuild { assets, runs } => noop_rebuild(assets, runs),
        Bench::Bake { runs } => bake(runs),
        Bench::Select { runs } => select(runs),
        Bench::Coverage { runs } => coverage(runs),
        Bench::Place { runs } => place(runs),
        Bench::Release => release(),
        Bench::RemoteExec {
            models,
            workers,
            one_core_each,
        } => crate::bench_remote_exec::run(
            &models.unwrap_or_else(shared_models),
            &workers,
            one_core_each,
        ),
        Bench::Remote {
            baseline,
            models,
            digest,
            store,
        } => crate::bench_remote::run(
            baseline,
            &models.unwrap_or_else(shared_models),
            &digest,
            store,
        ),
        Bench::Scale { runs, models } => crate::bench_scale::run(runs, &models),
        Bench::Catalogue {
            assets,
            runs,
            keep,
            models,
        } => crate::bench_catalogue::run(&assets, runs, keep.as_deref(), &models),
        Bench::Render { frames, size } => render(frames, size),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn samples_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../samples")
}

/// Copy each sample's folder round-robin until `count` assets exist under `dest`.
fn copy_samples(dest: &Path, count: usize) -> Result<(), String> {
    let mut folders: Vec<PathBuf> = std::fs::read_dir(samples_dir())
        .map_err(|e| format!("cannot list {}: {e}", samples_dir().display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    if folders.is_empty() {
        return Err("no sample folders".into());
    }
    for i in 0..count {
        let from = &folders[i % folders.len()];
        let to = dest.join(format!(
            "{i:04}-{}",
            from.file_name().unwrap().to_string_lossy()
        ));
        std::fs::create_dir_all(&to).map_err(|e| e.to_string())?;
        for f in std::fs::read_dir(from).map_err(|e| e.to_string())? {
            let f = f.map_err(|e| e.to_string())?.path();
            if f.is_file() {
                std::fs::copy(&f, to.join(f.file_name().unwrap())).map_err(|e| e.to_string())?;
            }
        }
    }
    Ok(())
}

/// Run `xtask build-assets` on the benchmark folder; returns its wall time and how many
/// ingest jobs ran.
fn timed_build(config: &Path) -> Result<(Duration, usize), String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let start = Instant::now();
    let out = Command::new(exe)
        .args(["build-assets", "--quiet", "--config"])
        .arg(config)
        .output()
        .map_err(|e| e.to_string())?;
    let elapsed = start.elapsed();
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        return Err(format!(
            "build failed:\n{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok((elapsed, ingests_ran(&stdout)?))
}

/// How many ingest jobs ran, from the summary table `build-assets` prints.
pub(crate) fn ingests_ran(stdout: &str) -> Result<usize, String> {
    stdout
        .lines()
        .find(|l| l.starts_with("ingest"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|n| n.parse().ok())
        .ok_or_else(|| format!("no summary in the output:\n{stdout}"))
}

fn noop_rebuild(assets: usize, runs: usize) -> Result<(), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    copy_samples(&dir.path().join("assets"), assets)?;
    let config = dir.path().join("pipeline.toml");
    std::fs::write(&config, "[assets]\nroot = \"assets\"\n").map_err(|e| e.to_string())?;
    // Let the copies age past the stat memo's racy window, as real sources would have.
    std::thread::sleep(ori_graph::RACY_WINDOW + Duration::from_millis(100));
    let (cold, ran) = timed_build(&config)?;
    println!(
        "cold build of {assets} assets: {:.3} s ({ran} ingest jobs ran)",
        cold.as_secs_f64()
    );
    let mut times = Vec::new();
    for _ in 0..runs {
        let (t, ran) = timed_build(&config)?;
        if ran != 0 {
            return Err(format!("a no-op rebuild ran {ran} jobs"));
        }
        times.push(t);
    }
    times.sort();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "no-op rebuild of {assets} assets, {runs} runs (whole process): median {:.1} ms, min {:.1} ms, max {:.1} ms (target < 300 ms)",
        ms(times[times.len() / 2]),
        ms(times[0]),
        ms(times[times.len() - 1])
    );
    Ok(())
}

pub(crate) fn shared_models() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/models")
}

/// The middle value (the upper one of an even count). Panics on an empty list or a NaN.
pub(crate) fn median<T: PartialOrd>(mut values: Vec<T>) -> T {
    values.sort_by(|a, b| a.partial_cmp(b).expect("no NaN among timings"));
    values.swap_remove(values.len() / 2)
}

/// Real models of growing size (3.7k to 203k faces) under ../shared/models, for the timing
/// benchmarks.
pub(crate) const GROWING_MODELS: [&str; 4] = [
    "stanford/bunny/bunny_npm_lowres.obj",
    "stanford/armadillo/armadillo_odedstein_remeshed.obj",
    "stanford/bunny/stanford-bunny.obj",
    "stanford/dragon/dragon_res2_binary.ply",
];

/// The default ORI parameters, without placement (for benches that time later steps).
fn unplaced() -> OriParams {
    OriParams {
        place: ori_place::PlaceParams {
            max_moves: 0,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn load(rel: &str) -> Result<ori_mesh::Mesh, String> {
    let path = shared_models().join(rel);
    Ok(
        ori_mesh::load_file(&path, &ori_mesh::LoadOptions::default())
            .map_err(|e| e.to_string())?
            .mesh,
    )
}

fn bake(runs: usize) -> Result<(), String> {
    let params = unplaced();
    println!(
        "views ({:?}, n = {}) + bake ({} maps at {}^2, supersample {}), {} threads, median of {runs}",
        params.views.strategy,
        params.views.count,
        params.views.count,
        params.bake.resolution,
        params.bake.supersample,
        rayon::current_num_threads()
    );
    println!(
        "{:<52} {:>8} {:>9} {:>9} {:>9}",
        "model", "faces", "views s", "bake s", "total s"
    );
    for rel in GROWING_MODELS {
        let mesh = load(rel)?;
        let (mut tv, mut tb) = (Vec::new(), Vec::new());
        for _ in 0..runs.max(1) {
            let maps = ori::build_maps(&mesh, &params).map_err(|e| e.to_string())?;
            tv.push(maps.times.views);
            tb.push(maps.times.bake);
        }
        let (v, b) = (median(tv), median(tb));
        println!(
            "{rel:<52} {:>8} {:>9.3} {:>9.3} {:>9.3}",
            mesh.triangle_count(),
            v.as_secs_f64(),
            b.as_secs_f64(),
            (v + b).as_secs_f64()
        );
    }
    Ok(())
}

fn place(runs: usize) -> Result<(), String> {
    println!(
        "{:<36} {:>7} {:>10} {:>6} {:>14}",
        "model", "faces", "place s", "moves", "worst px"
    );
    let params = OriParams::default();
    for rel in GROWING_MODELS {
        let mesh = load(rel)?;
        let plan = ori_views::plan_views(&mesh, &params.views).map_err(|e| e.to_string())?;
        let mut times = Vec::new();
        let mut placed = None;
        for _ in 0..runs.max(1) {
            let t = Instant::now();
            placed = Some(
                ori::place(
                    &mesh,
                    &plan,
                    &params.place,
                    &params.bake,
                    &ori::PlacementGoal::of(&params.select),
                    params.views.item_buffer_size,
                    None,
                )
                .map_err(|e| e.to_string())?,
            );
            times.push(t.elapsed());
        }
        let placed = placed.expect("one run at least");
        let name = Path::new(rel).file_name().unwrap().to_string_lossy();
        println!(
            "{:<36} {:>7} {:>10.2} {:>6} {:>14}",
            name,
            mesh.triangles.len(),
            median(times).as_secs_f64(),
            placed.moves,
            format!("{} -> {}", placed.worst_before, placed.worst_after)
        );
    }
    Ok(())
}

/// The mesh's coverage in every view of a selection's plan (unplaced maps: the plan's views
/// do not depend on placement), timed alone.
fn coverage(runs: usize) -> Result<(), String> {
    let params = unplaced();
    let select = &params.select;
    println!(
        "mesh coverage in the views of a selection's plan ({}, region steps {}, {:?}, s0 = {} \
         and {} in the regions), {} threads, median of {runs}",
        select.rule,
        select.region_steps,
        select.region_shape,
        select.s0,
        select.region_size(),
        rayon::current_num_threads()
    );
    println!(
        "{:<36} {:>7} {:>6} {:>11} {:>16} {:>14}",
        "model", "faces", "views", "coverage s", "us/view/100k f", "pixels covered"
    );
    for rel in GROWING_MODELS {
        let mesh = load(rel)?;
        let set = ori::build_maps(&mesh, &params)
            .map_err(|e| e.to_string())?
            .set;
        let evaluator = ori_eval::Evaluator::new(&mesh, &set, &select.eval_params())
            .map_err(|e| e.to_string())?;
        let plan = ori_select::MaskPlan::new(&evaluator, select);
        let views = (0..plan.directions.len())
            .map(|k| plan.view(&evaluator, k))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| e.to_string())?;
        let (mut times, mut covered) = (Vec::new(), 0);
        for _ in 0..runs.max(1) {
            let t = Instant::now();
            covered = views
                .par_iter()
                .map(|v| u64::from(evaluator.mesh_coverage(v).count()))
                .sum::<u64>();
            times.push(t.elapsed());
        }
        let secs = median(times).as_secs_f64();
        let faces = mesh.triangles.len();
        let name = Path::new(rel).file_name().unwrap().to_string_lossy();
        println!(
            "{:<36} {:>7} {:>6} {:>11.3} {:>16.2} {:>14}",
            name,
            faces,
            views.len(),
            secs,
            secs * 1e6 / views.len() as f64 / (faces as f64 / 1e5),
            covered
        );
    }
    Ok(())
}

/// Selection as the pipeline runs it (masks traced where the subset search needs them), beside
/// every mask of the plan traced first and then searched (as `--backend gpu` does; the same
/// table), and the PLT, on unplaced maps.
fn select(runs: usize) -> Result<(), String> {
    let params = unplaced();
    let select = &params.select;
    println!(
        "selection ({}, goal {}%, region steps {} at scale {}, s0 = {}) + PLT, {} threads, \
         median of {runs}",
        select.rule,
        select.goal_percent,
        select.region_steps,
        select.region_scale,
        select.s0,
        rayon::current_num_threads()
    );
    println!(
        "{:<36} {:>7} {:>8} {:>12} {:>8} {:>8} {:>6} {:>18} {:>18}",
        "model",
        "faces",
        "select s",
        "all masks s",
        "plt s",
        "total s",
        "PLT",
        "at region_scale 1 s",
        "on triangles s"
    );
    // The same selection with the region's views at s0, as before `[select] region_scale`,
    // and on the triangles' grids, as before `[select] region_shape`.
    let variants = [
        ori_select::SelectParams {
            region_scale: 1.0,
            ..select.clone()
        },
        ori_select::SelectParams {
            region_shape: ori_select::RegionShape::Triangle,
            ..select.clone()
        },
    ];
    for rel in GROWING_MODELS {
        let mesh = load(rel)?;
        let set = ori::build_maps(&mesh, &params)
            .map_err(|e| e.to_string())?
            .set;
        let (mut ts, mut ta, mut tp) = (Vec::new(), Vec::new(), Vec::new());
        let mut tv = [Vec::new(), Vec::new()];
        let mut plt = None;
        for _ in 0..runs.max(1) {
            let evaluator = ori_eval::Evaluator::new(&mesh, &set, &select.eval_params())
                .map_err(|e| e.to_string())?;
            let t = Instant::now();
            let selection =
                ori_select::select_with(&evaluator, select).map_err(|e| e.to_string())?;
            ts.push(t.elapsed());
            let t = Instant::now();
            let plan = ori_select::MaskPlan::new(&evaluator, select);
            let masks = ori_select::all_view_masks(&evaluator, &plan).map_err(|e| e.to_string())?;
            let searched = ori_select::select_from_masks(&masks, select, set.maps.len())
                .map_err(|e| e.to_string())?;
            ta.push(t.elapsed());
            if searched != selection {
                return Err(format!(
                    "{rel}: the two ways of selecting chose differently"
                ));
            }
            let t = Instant::now();
            let held_out = ori::held_out(
                &mesh,
                &set,
                &selection,
                select,
                ori_views::DEFAULT_HELD_OUT_SEED,
                None,
            )
            .map_err(|e| e.to_string())?;
            plt = Some(ori::plt(&held_out));
            tp.push(t.elapsed());
            for (variant, times) in variants.iter().zip(&mut tv) {
                let t = Instant::now();
                ori_select::select_with(&evaluator, variant).map_err(|e| e.to_string())?;
                times.push(t.elapsed());
            }
        }
        let (s, a, p) = (median(ts), median(ta), median(tp));
        let [c, g] = tv.map(median);
        let name = Path::new(rel).file_name().unwrap().to_string_lossy();
        println!(
            "{:<36} {:>7} {:>8.3} {:>12.3} {:>8.3} {:>8.3} {:>6} {:>18.3} {:>18.3}",
            name,
            mesh.triangles.len(),
            s.as_secs_f64(),
            a.as_secs_f64(),
            p.as_secs_f64(),
            (s + p).as_secs_f64(),
            plt.expect("one run at least").to_string(),
            c.as_secs_f64(),
            g.as_secs_f64()
        );
    }
    Ok(())
}

/// Copy a folder tree.
pub(crate) fn copy_tree(from: &Path, to: &Path) -> Result<(), String> {
    for entry in walkdir::WalkDir::new(from).sort_by_file_name() {
        let entry = entry.map_err(|e| e.to_string())?;
        let rel = entry.path().strip_prefix(from).map_err(|e| e.to_string())?;
        let dest = to.join(rel);
        if entry.file_type().is_dir() {
            std::fs::create_dir_all(&dest).map_err(|e| e.to_string())?;
        } else {
            std::fs::copy(entry.path(), &dest).map_err(|e| format!("{}: {e}", dest.display()))?;
        }
    }
    Ok(())
}

fn release() -> Result<(), String> {
    const EDITED: &str = "stanford/armadillo/armadillo_odedstein_remeshed.obj";
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let all = dir.path().join("all");
    copy_tree(&shared_models(), &all.join("assets"))?;
    let config = |root: &Path| -> Result<PathBuf, String> {
        let path = root.join("pipeline.toml");
        std::fs::write(&path, "[assets]\nroot = \"assets\"\n").map_err(|e| e.to_string())?;
        Ok(path)
    };
    std::thread::sleep(ori_graph::RACY_WINDOW + Duration::from_millis(100));
    let (cold, ran) = timed_build(&config(&all)?)?;
    println!(
        "cold build of ../shared/models ({ran} assets): {:.2} s",
        cold.as_secs_f64()
    );

    // The edited asset alone, cold, in its own project and cache.
    let alone = dir.path().join("alone");
    let edited_rel = Path::new(EDITED);
    std::fs::create_dir_all(alone.join("assets")).map_err(|e| e.to_string())?;
    std::fs::copy(
        shared_models().join(edited_rel),
        alone.join("assets").join(edited_rel.file_name().unwrap()),
    )
    .map_err(|e| e.to_string())?;
    let (own_cold, _) = timed_build(&config(&alone)?)?;

    // Move one vertex: its mesh changes, so every one of its jobs runs again.
    let path = all.join("assets").join(edited_rel);
    let text = std::fs::read_to_string(&path).map_err(|e| e.to_string())?;
    let moved = text.replacen("\nv ", "\nv 0.001 0.002 0.003 # was: ", 1);
    std::fs::write(&path, moved).map_err(|e| e.to_string())?;
    let (edited, ran) = timed_build(&config(&all)?)?;
    if ran != 1 {
        return Err(format!("the edited rebuild ran {ran} ingest jobs, not 1"));
    }
    println!(
        "one asset edited ({EDITED}): rebuild {:.2} s; that asset's own cold build {:.2} s; \
         overhead {:+.2} s (target <= +0.30 s)",
        edited.as_secs_f64(),
        own_cold.as_secs_f64(),
        (edited.as_secs_f64() - own_cold.as_secs_f64())
    );
    Ok(())
}

/// Build the package of one shared model in a temporary project; returns the package bytes.
fn package_of(rel: &str, dir: &Path) -> Result<Vec<u8>, String> {
    let assets = dir.join("assets");
    std::fs::create_dir_all(&assets).map_err(|e| e.to_string())?;
    let file = Path::new(rel).file_name().unwrap();
    std::fs::copy(shared_models().join(rel), assets.join(file)).map_err(|e| e.to_string())?;
    let config = dir.join("pipeline.toml");
    std::fs::write(&config, "[assets]\nroot = \"assets\"\n").map_err(|e| e.to_string())?;
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let out = Command::new(exe)
        .args(["build-assets", "--quiet", "--no-report", "--config"])
        .arg(&config)
        .output()
        .map_err(|e| e.to_string())?;
    if !out.status.success() {
        return Err(format!(
            "build of {rel} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let package = dir
        .join("target/ori-out")
        .join(ori_pipeline::release::package_path(&file.to_string_lossy()));
    std::fs::read(&package).map_err(|e| format!("{}: {e}", package.display()))
}

fn render(frames: usize, size: u32) -> Result<(), String> {
    let renderer = ori_render::Renderer::new().map_err(|e| e.to_string())?;
    println!("adapter: {}", renderer.adapter_summary());
    println!(
        "{size} x {size}, orthographic turntable of {frames} frames, each frame read back to the CPU; medians"
    );
    println!(
        "{:<28} {:>8} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9}",
        "model", "faces", "empty ms", "ORI ms", "mesh ms", "ORI net", "mesh net", "mesh/ORI"
    );
    for rel in [
        "stanford/bunny/stanford-bunny.obj",
        "stanford/dragon/dragon_res2_binary.ply",
    ] {
        let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
        let bytes = package_of(rel, dir.path())?;
        let package = ori_package::read(&bytes).map_err(|e| e.to_string())?;
        let mesh = ori_mesh::load_file(&shared_models().join(rel), &Default::default())
            .map_err(|e| e.to_string())?
            .mesh;
        let ori = renderer.load_package(&package).map_err(|e| e.to_string())?;
        let gpu_mesh = renderer.load_mesh(&mesh).map_err(|e| e.to_string())?;
        let (center, radius) = ori.bounding_sphere();
        let cameras: Vec<ori_render::Camera> = (0..frames.max(1))
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / frames.max(1) as f64;
                ori_render::Camera::ortho_framing(center, radius, [a.sin(), 0.35, a.cos()])
            })
            .collect();
        // One untimed frame of each: pipelines and textures warm.
        renderer
            .render_ori(&ori, &cameras[0], size, size)
            .map_err(|e| e.to_string())?;
        renderer
            .render_mesh(&gpu_mesh, &cameras[0], size, size)
            .map_err(|e| e.to_string())?;
        let (mut t_ori, mut t_mesh, mut t_empty) = (Vec::new(), Vec::new(), Vec::new());
        for camera in &cameras {
            // The fixed cost of a frame (targets, submission, read-back), to subtract.
            let t = Instant::now();
            renderer
                .render(&[], camera, size, size)
                .map_err(|e| e.to_string())?;
            t_empty.push(t.elapsed());
            let t = Instant::now();
            renderer
                .render_ori(&ori, camera, size, size)
                .map_err(|e| e.to_string())?;
            t_ori.push(t.elapsed());
            let t = Instant::now();
            renderer
                .render_mesh(&gpu_mesh, camera, size, size)
                .map_err(|e| e.to_string())?;
            t_mesh.push(t.elapsed());
        }
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let (e, o, m) = (ms(median(t_empty)), ms(median(t_ori)), ms(median(t_mesh)));
        println!(
            "{:<28} {:>8} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>9.2}",
            Path::new(rel).file_name().unwrap().to_string_lossy(),
            mesh.triangles.len(),
            e,
            o,
            m,
            o - e,
            m - e,
            (m - e) / (o - e).max(1e-3)
        );
    }
    Ok(())
}
