//! `ori eval-table MODEL` (also `cargo xtask eval-table`): the ORI paper's Table 1 for any model (coverage error
//! min / max / avg, PLT, impostors per view for the 1 to 4 closest impostors and `best:M`),
//! plus the rows the paper left out: inverse coverage, p_dif and depth error.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use ori_eval::{EvalParams, Evaluator};
use ori_pipeline::ori::OriParams;
use ori_select::{RegionShape, Rule, RuleSummary, SelectParams, evaluate_rules, summarize};

#[derive(clap::Args)]
pub struct Args {
    /// Model file (glTF/GLB, OBJ or PLY).
    model: PathBuf,
    /// Number of impostors n (view planning).
    #[arg(long, default_value_t = 20)]
    impostors: usize,
    /// View-planning strategy: regular, minimal or perturbed (`[views] strategy`).
    #[arg(long, default_value = "perturbed", value_parser = parse_strategy)]
    strategy: ori_views::Strategy,
    /// Perturbed strategy: how far in degrees a regular direction may move
    /// (`[views] search_radius_deg`).
    #[arg(long)]
    search_radius_deg: Option<f64>,
    /// Placement search: the most impostor moves (`[place] max_moves`; 0: off).
    #[arg(long)]
    place_moves: Option<u32>,
    /// Placement search: how many closest impostors each table view must be drawable with
    /// (`[place] closest`).
    #[arg(long)]
    place_closest: Option<u32>,
    /// Placement search: stop once the worst view is within the selection's own goal times
    /// this (`[place] goal_scale`).
    #[arg(long)]
    place_goal_scale: Option<f64>,
    /// Relief-map resolution.
    #[arg(long, default_value_t = 256)]
    resolution: u32,
    /// Bake sub-samples per texel edge (1, 2 or 4).
    #[arg(long, default_value_t = 2)]
    supersample: u32,
    /// The `best:M` rule of the last column.
    #[arg(long, default_value = "best:8")]
    best: Rule,
    /// Coverage-error goal of `best:M`, percent of s0 x s0.
    #[arg(long)]
    goal_percent: Option<f64>,
    /// Coverage-error goal of `best:M` over each entry's region, percent of s0 x s0.
    #[arg(long)]
    edge_goal_percent: Option<f64>,
    /// Steps along each edge of an entry's triangle between the directions `best:M` measures
    /// its region at (`[select] region_steps`).
    #[arg(long)]
    region_steps: Option<u32>,
    /// Where `best:M` measures each entry's region: `cell` or `triangle`
    /// (`[select] region_shape`).
    #[arg(long)]
    region_shape: Option<RegionShape>,
    /// The region's directions are measured at s0 times this (`[select] region_scale`).
    #[arg(long)]
    region_scale: Option<f64>,
    /// Evaluation image edge s0.
    #[arg(long)]
    s0: Option<u32>,
    /// Linear-search steps of the runtime rule.
    #[arg(long)]
    linear_steps: Option<u32>,
    /// Binary-search steps of the runtime rule.
    #[arg(long)]
    binary_steps: Option<u32>,
    /// Vertical-wall threshold, fraction of an impostor's depth range.
    #[arg(long)]
    wall_threshold: Option<f64>,
    /// Seed of the 2,000 random held-out directions (after the 1280 regular ones).
    #[arg(long, default_value_t = ori_views::DEFAULT_HELD_OUT_SEED)]
    held_out_seed: u64,
    /// Write the error picture of each column's worst view into DIR (PNG).
    #[arg(long, value_name = "DIR")]
    pictures: Option<PathBuf>,
}

/// Exit status 1: the model cannot be loaded or evaluated; 2: bad options.
pub fn run(args: Args) -> ExitCode {
    let defaults = SelectParams::default();
    let params = SelectParams {
        rule: args.best,
        goal_percent: args.goal_percent.unwrap_or(defaults.goal_percent),
        edge_goal_percent: args.edge_goal_percent.unwrap_or(defaults.edge_goal_percent),
        region_steps: args.region_steps.unwrap_or(defaults.region_steps),
        region_shape: args.region_shape.unwrap_or(defaults.region_shape),
        region_scale: args.region_scale.unwrap_or(defaults.region_scale),
        s0: args.s0.unwrap_or(defaults.s0),
        linear_steps: args.linear_steps.unwrap_or(defaults.linear_steps),
        binary_steps: args.binary_steps.unwrap_or(defaults.binary_steps),
        wall_threshold: args.wall_threshold.unwrap_or(defaults.wall_threshold),
    };
    if let Err(e) = params.validate() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    match table(&args, &params) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn table(args: &Args, params: &SelectParams) -> Result<(), String> {
    let mesh = ori_mesh::load_file(&args.model, &Default::default())
        .map_err(|e| e.to_string())?
        .mesh;
    let defaults = ori_views::ViewParams::default();
    let views = ori_views::ViewParams {
        count: args.impostors,
        strategy: args.strategy,
        search_radius_deg: args.search_radius_deg.unwrap_or(defaults.search_radius_deg),
        ..defaults
    };
    let bake = ori_bake::BakeParams {
        resolution: args.resolution,
        supersample: args.supersample,
        ..Default::default()
    };
    let place_defaults = ori_place::PlaceParams::default();
    let place = ori_place::PlaceParams {
        max_moves: args.place_moves.unwrap_or(place_defaults.max_moves),
        closest: args.place_closest.unwrap_or(place_defaults.closest),
        goal_scale: args.place_goal_scale.unwrap_or(place_defaults.goal_scale),
        ..place_defaults
    };
    let ori_params = OriParams {
        views,
        place,
        bake,
        select: params.clone(),
    };
    let maps = ori_pipeline::ori::build_maps(&mesh, &ori_params).map_err(|e| e.to_string())?;
    let (placed, set) = (&maps.placement, &maps.set);

    let eval: EvalParams = params.eval_params();
    let evaluator = Evaluator::new(&mesh, set, &eval).map_err(|e| e.to_string())?;
    let rules = [
        Rule::Closest(1),
        Rule::Closest(2),
        Rule::Closest(3),
        Rule::Closest(4),
        params.rule,
    ];
    let directions = ori_views::evaluation_directions();
    let started = Instant::now();
    let per_view = evaluate_rules(&evaluator, &directions, &rules, params.goal_pixels())
        .map_err(|e| e.to_string())?;
    let evaluated = started.elapsed();
    let summaries = summarize(&rules, &per_view);

    println!(
        "{} ({} faces): n = {} ({}), maps {r} x {r}, s0 = {}, {} + {} steps, wall threshold {}, \
         goal {}%",
        args.model.display(),
        mesh.triangles.len(),
        set.maps.len(),
        ori_params.views.strategy.name(),
        params.s0,
        params.linear_steps,
        params.binary_steps,
        params.wall_threshold,
        params.goal_percent,
        r = args.resolution,
    );
    print_table(&summaries, &per_view, params.s0);
    let best = rules.len() - 1;
    let mut counts = vec![0u32; params.rule.m() as usize + 1];
    for v in &per_view {
        counts[v[best].impostors.len()] += 1;
    }
    let shares: Vec<String> = counts
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, &c)| format!("{k}: {:.1}%", 100.0 * f64::from(c) / per_view.len() as f64))
        .collect();
    println!(
        "{} views by impostor count: {}",
        params.rule,
        shares.join(", ")
    );
    // The table the pipeline ships: for best:M chosen over each entry's region, not only at
    // its direction as in the rows above.
    let started = Instant::now();
    let selection = ori_select::select(&mesh, set, params).map_err(|e| e.to_string())?;
    let selected = started.elapsed();
    let table = selection.stats();
    println!(
        "{} table as shipped (chosen over each entry's region) at its directions: coverage \
         error max {:.3}%, avg {:.3}%, impostors per view {:.2}",
        params.rule, table.max_percent, table.avg_percent, table.avg_impostors
    );
    let held_out =
        ori_pipeline::ori::held_out(&mesh, set, &selection, params, args.held_out_seed, None)
            .map_err(|e| e.to_string())?;
    let between = held_out.first(ori_views::HELD_OUT_REGULAR);
    println!(
        "{} between the table's directions (1280 views, each drawn with its nearest entry's \
         subset): coverage error max {:.3}%, avg {:.3}%",
        params.rule,
        between.max_percent(),
        between.avg_percent(),
    );
    // Parsed by scripts: keep the shape.
    println!(
        "held-out ({} directions): coverage error max {:.3}%, avg {:.3}%, impostors per view {:.2}",
        held_out.views.len(),
        held_out.max_percent(),
        held_out.avg_percent(),
        held_out.avg_impostors(),
    );
    // Whether the worst held-out view is the subset's fault or beyond every candidate of its
    // entry (then only placement or more impostors can help).
    let held_out_directions = ori_views::held_out_directions(args.held_out_seed);
    let worst = (0..held_out.views.len())
        .max_by_key(|&d| (held_out.views[d].0, std::cmp::Reverse(d)))
        .unwrap_or(0);
    if let Some(&w) = held_out_directions.get(worst) {
        let entry = selection.nearest(w);
        let m = params.rule.m() as usize;
        let all: Vec<usize> = evaluator
            .facing(directions[entry])
            .into_iter()
            .take(m)
            .collect();
        let floor =
            ori_select::held_out(&evaluator, &[w], &|_| all.clone()).map_err(|e| e.to_string())?;
        println!(
            "worst held-out view {worst} ({:.3}, {:.3}, {:.3}), entry {entry}: {} pixels missed \
             with its {} impostors, {} with all {} candidates of the entry",
            w[0],
            w[1],
            w[2],
            held_out.views[worst].0,
            held_out.views[worst].1,
            floor.worst_missed(),
            all.len()
        );
    }
    println!(
        "placement: {} moves, worst view {} -> {} pixels with all {} closest",
        placed.moves,
        placed.worst_before,
        placed.worst_after,
        params.rule.m()
    );
    println!(
        "time: plan {:.2} s, placement {:.2} s, bake {:.2} s, evaluation of {} views {:.2} s, \
         selection {:.2} s",
        maps.times.views.as_secs_f64(),
        maps.times.place.as_secs_f64(),
        maps.times.bake.as_secs_f64(),
        directions.len(),
        evaluated.as_secs_f64(),
        selected.as_secs_f64()
    );
    if let Some(dir) = &args.pictures {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for (r, s) in summaries.iter().enumerate() {
            let worst = (0..per_view.len())
                .max_by_key(|&d| (per_view[d][r].errors.missed, std::cmp::Reverse(d)))
                .unwrap_or(0);
            let view = evaluator
                .view(directions[worst])
                .map_err(|e| e.to_string())?;
            let reference = evaluator.render_mesh(&view).map_err(|e| e.to_string())?;
            let ori = evaluator.render_ori(&view, &per_view[worst][r].impostors);
            let name = s.rule.to_string().replace(':', "-");
            let path = dir.join(format!("worst-{name}-view{worst}.png"));
            ori_eval::write_error_png(&path, &view, &reference, &ori)?;
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

fn print_table(summaries: &[RuleSummary], per_view: &[Vec<ori_select::RuleView>], s0: u32) {
    let head: Vec<String> = summaries
        .iter()
        .map(|s| match s.rule {
            Rule::Closest(m) => format!("{m} cl."),
            Rule::Best(m) => format!("i<={m} best"),
        })
        .collect();
    let row = |name: &str, cells: Vec<String>| {
        let cells: Vec<String> = cells.iter().map(|c| format!("{c:>11}")).collect();
        println!("{name:<22}{}", cells.join(""));
    };
    row("", head);
    let pct = |f: fn(&RuleSummary) -> f64| -> Vec<String> {
        summaries.iter().map(|s| format!("{:.3}%", f(s))).collect()
    };
    row("coverage error min", pct(|s| s.min_percent));
    row("coverage error max", pct(|s| s.max_percent));
    row("coverage error avg", pct(|s| s.avg_percent));
    row(
        "PLT",
        (0..summaries.len())
            .map(|r| {
                let missed: Vec<u32> = per_view.iter().map(|v| v[r].errors.missed).collect();
                ori_plt::estimate(s0, &missed).to_string()
            })
            .collect(),
    );
    row(
        "impostors per view",
        summaries
            .iter()
            .map(|s| match s.rule {
                Rule::Closest(_) => format!("{:.0}", s.avg_impostors),
                Rule::Best(_) => format!("{:.2} avg", s.avg_impostors),
            })
            .collect(),
    );
    row("inverse coverage avg", pct(|s| s.avg_extra_percent));
    row("inverse coverage max", pct(|s| s.max_extra_percent));
    row(
        "p_dif avg (0-765)",
        summaries
            .iter()
            .map(|s| format!("{:.1}", s.avg_p_dif))
            .collect(),
    );
    row(
        "depth error avg",
        summaries
            .iter()
            .map(|s| format!("{:.4}", s.avg_depth_error))
            .collect(),
    );
}

/// A `[views] strategy` name.
fn parse_strategy(name: &str) -> Result<ori_views::Strategy, String> {
    use ori_views::Strategy;
    [
        Strategy::Regular,
        Strategy::MinimalSampling,
        Strategy::Perturbed,
    ]
    .into_iter()
    .find(|s| s.name() == name)
    .ok_or_else(|| format!("unknown strategy {name:?} (regular, minimal or perturbed)"))
}

#[cfg(test)]
mod tests {
    use super::parse_strategy;
    use ori_views::Strategy;

    #[test]
    fn strategies_are_named_as_in_pipeline_toml() {
        assert_eq!(parse_strategy("regular"), Ok(Strategy::Regular));
        assert_eq!(parse_strategy("minimal"), Ok(Strategy::MinimalSampling));
        assert_eq!(parse_strategy("perturbed"), Ok(Strategy::Perturbed));
        let err = parse_strategy("random").unwrap_err();
        assert!(err.contains("\"random\"") && err.contains("regular, minimal or perturbed"));
    }
}
