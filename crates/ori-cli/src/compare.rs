//! `ori compare MODEL` (also `cargo xtask compare`): every impostor technique of `ori-rivals` and the ORI baked at
//! one byte budget and measured at the held-out directions with the evaluator's views,
//! reference and errors.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use ori_pipeline::ori::OriParams;
use ori_rivals::{Comparison, References, Relief, Rival, Rivals, Row, Technique};

#[derive(clap::Args)]
pub struct Args {
    /// Model file (glTF/GLB, OBJ or PLY).
    model: PathBuf,
    /// Texture (or, for the simplified mesh, vertex and index) bytes every technique may use
    /// (default: the ORI's at the pipeline's defaults, 20 maps of 256 x 256 at 2.5 bytes a
    /// texel).
    #[arg(long)]
    budget_bytes: Option<u64>,
    /// Seed of the 2,000 random held-out directions (after the 1280 regular ones).
    #[arg(long, default_value_t = ori_views::DEFAULT_HELD_OUT_SEED)]
    held_out_seed: u64,
    /// The techniques to compare, comma-separated (default: all of them).
    #[arg(long, value_delimiter = ',', value_parser = parse_technique)]
    techniques: Vec<Technique>,
    /// Measure at N of the held-out directions only, evenly spread through them (default:
    /// all 3280).
    #[arg(long)]
    directions: Option<usize>,
    /// Write the comparison as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Write pictures of the same views of the mesh and of every technique, side by side,
    /// into DIR (PNG).
    #[arg(long, value_name = "DIR")]
    pictures: Option<PathBuf>,
}

fn parse_technique(name: &str) -> Result<Technique, String> {
    Technique::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Technique::ALL.iter().map(|t| t.name()).collect();
        format!("unknown technique {name:?} (one of {})", names.join(", "))
    })
}

/// The ORI's layout for a budget: the pipeline's resolution where its regular view sets fit,
/// else the closest count of the minimal-sampling strategy; (views, resolution).
fn ori_layout(budget: u64) -> Option<(ori_views::ViewParams, u32)> {
    [256u32, 128, 512].into_iter().find_map(|r| {
        let per_map = ori_rivals::relief_bytes(u64::from(r) * u64::from(r));
        let count = ((budget + per_map / 2) / per_map) as usize;
        let strategy = if [6, 20, 80, 320].contains(&count) {
            ori_views::Strategy::Perturbed
        } else {
            ori_views::Strategy::MinimalSampling
        };
        let views = ori_views::ViewParams {
            count,
            strategy,
            ..Default::default()
        };
        ((8..=80).contains(&count)
            && ori_rivals::within_budget(per_map * count as u64, budget)
            && views.validate().is_ok())
        .then_some((views, r))
    })
}

/// Exit status 1: the model cannot be loaded, baked or measured; 2: bad options.
pub fn run(args: Args) -> ExitCode {
    match compare(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Options(e)) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
        Err(Failure::Run(e)) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

enum Failure {
    Options(String),
    Run(String),
}

fn run_error(e: impl std::fmt::Display) -> Failure {
    Failure::Run(e.to_string())
}

fn compare(args: &Args) -> Result<(), Failure> {
    let default_budget = ori_rivals::relief_bytes(20 * 256 * 256);
    let budget = args.budget_bytes.unwrap_or(default_budget);
    let (views, resolution) = ori_layout(budget).ok_or_else(|| {
        Failure::Options(format!(
            "--budget-bytes {budget}: no ORI of 8 to 80 maps of 128, 256 or 512 texels fits it \
             within 5 % (20 maps of 256 x 256 take {default_budget})"
        ))
    })?;
    let started = Instant::now();
    let step = |what: &str| eprintln!("[{:6.1} s] {what}", started.elapsed().as_secs_f64());
    let mesh = ori_mesh::load_file(&args.model, &Default::default())
        .map_err(run_error)?
        .mesh;
    let params = OriParams {
        bake: ori_bake::BakeParams {
            resolution,
            ..Default::default()
        },
        views,
        ..Default::default()
    };
    let s0 = params.select.s0;
    let wanted: Vec<Technique> = if args.techniques.is_empty() {
        Technique::ALL.to_vec()
    } else {
        args.techniques.clone()
    };
    // The ORI and its rivals are baked at once: neither keeps both cores busy throughout.
    let build_ori = || -> Result<_, Failure> {
        if !wanted.contains(&Technique::Ori) {
            return Ok(None);
        }
        step(&format!(
            "ori: {} maps of {resolution} x {resolution} ({})",
            params.views.count,
            params.views.strategy.name()
        ));
        let maps = ori_pipeline::ori::build_maps(&mesh, &params).map_err(run_error)?;
        let selection = ori_select::select(&mesh, &maps.set, &params.select).map_err(run_error)?;
        step("ori baked");
        Ok(Some((maps.set, selection)))
    };
    let bake_rivals = || -> Result<Rivals, Failure> {
        step("tuning views");
        let tuning = References::new(
            &mesh,
            &ori_rivals::tuning_directions(args.held_out_seed),
            s0,
        )
        .map_err(run_error)?;
        Rivals::bake(&mesh, budget, &wanted, &tuning, &|t: Technique| {
            step(&format!("{} baked", t.name()))
        })
        .map_err(run_error)
    };
    let (ori, rivals) = rayon::join(build_ori, bake_rivals);
    let (ori, rivals) = (ori?, rivals?);
    let mut all = rivals.all(&mesh).map_err(run_error)?;
    if let Some((set, selection)) = &ori {
        all.push(Box::new(
            Relief::ori(&mesh, set, selection, &params.select.eval_params()).map_err(run_error)?,
        ));
    }
    let refs: Vec<&dyn Rival> = all.iter().map(|r| r.as_ref() as &dyn Rival).collect();

    // No count: all of them (the sample takes every direction at or above their number).
    let directions =
        ori_rivals::held_out_sample(args.held_out_seed, args.directions.unwrap_or(usize::MAX));
    step(&format!(
        "measuring at {} held-out directions",
        directions.len()
    ));
    let per_view = ori_rivals::measure(&mesh, &refs, &directions, s0).map_err(run_error)?;
    step("done");
    for (k, r) in refs.iter().enumerate() {
        let total: std::time::Duration = per_view.iter().map(|v| v[k].time).sum();
        eprintln!(
            "  {:<24} {:8.2} ms per view",
            r.technique().name(),
            total.as_secs_f64() * 1e3 / per_view.len().max(1) as f64
        );
    }
    let rows = ori_rivals::summarize(&refs, &per_view);
    print_table(args, budget, directions.len(), &rows);

    if let Some(path) = &args.json {
        let comparison = Comparison {
            model: args.model.display().to_string(),
            budget_bytes: budget,
            held_out_seed: args.held_out_seed,
            directions: directions.len(),
            s0,
            rows,
        };
        let text = serde_json::to_string_pretty(&comparison).map_err(run_error)?;
        std::fs::write(path, text + "\n")
            .map_err(|e| Failure::Run(format!("{}: {e}", path.display())))?;
    }
    if let Some(dir) = &args.pictures {
        write_pictures(dir, &mesh, &refs, &directions, s0)?;
    }
    Ok(())
}

fn print_table(args: &Args, budget: u64, directions: usize, rows: &[Row]) {
    println!(
        "{}: budget {budget} bytes, {directions} held-out directions (seed {})",
        args.model.display(),
        args.held_out_seed
    );
    println!(
        "{:<24} {:>9} {:>9} {:>9} {:>9} {:>7} {:>8} {:>16}  layout",
        "technique", "bytes", "cov avg%", "cov max%", "inv avg%", "p_dif", "depth", "drawn/view"
    );
    for r in rows {
        let drawn = r.drawn.name();
        println!(
            "{:<24} {:>9} {:>9.3} {:>9.3} {:>9.3} {:>7.1} {:>8.4} {:>6.2} {:<9}  {}",
            r.technique.name(),
            r.bytes,
            r.coverage_error_avg_percent,
            r.coverage_error_max_percent,
            r.inverse_coverage_avg_percent,
            r.p_dif_avg,
            r.depth_error_avg,
            r.drawn_per_view,
            drawn,
            r.layout
        );
    }
}

/// Four views of the measured directions: the first two and two from the middle.
fn write_pictures(
    dir: &std::path::Path,
    mesh: &ori_mesh::Mesh,
    rivals: &[&dyn Rival],
    directions: &[[f64; 3]],
    s0: u32,
) -> Result<(), Failure> {
    std::fs::create_dir_all(dir).map_err(|e| Failure::Run(format!("{}: {e}", dir.display())))?;
    // Two regular directions and, with all 3280 measured, two random ones.
    let n = directions.len();
    let mut picks: Vec<usize> = [0, 1, n / 2, n / 2 + 1]
        .into_iter()
        .filter(|&i| i < n)
        .collect();
    picks.dedup();
    let names: Vec<&str> = rivals.iter().map(|r| r.technique().name()).collect();
    for (k, &i) in picks.iter().enumerate() {
        let w = directions[i];
        let (width, height, rgb) = ori_rivals::picture(mesh, rivals, w, s0).map_err(run_error)?;
        let path = dir.join(format!("view-{k}.png"));
        image::save_buffer_with_format(
            &path,
            &rgb,
            width,
            height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Failure::Run(format!("{}: {e}", path.display())))?;
    }
    let legend = format!("mesh, {}\n", names.join(", "));
    std::fs::write(dir.join("panels.txt"), legend)
        .map_err(|e| Failure::Run(format!("{}: {e}", dir.display())))?;
    Ok(())
}
