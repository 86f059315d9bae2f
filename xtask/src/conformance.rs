//! `cargo xtask conformance [--write]`: check the runtime's conformance data
//! (`docs/conformance`) against the CPU evaluator, or write it again after a documented change
//! of the runtime rule.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ori_conformance::{
    CASES_DIR, Case, Directions, Expected, RUNTIME_DOC, differences, documented_version,
};

#[derive(clap::Args)]
pub struct Args {
    /// Write each case's expected.json from the CPU evaluator. Results that differ from those
    /// recorded are written only when docs/RUNTIME.md's `Runtime version` is newer than the
    /// recorded one.
    #[arg(long)]
    write: bool,
    /// The repository root (holding docs/).
    #[arg(long, default_value = ".")]
    root: PathBuf,
}

/// Exit status 1: a case differs (or could not be computed); 2: the data or the document
/// cannot be read.
pub fn run(args: Args) -> ExitCode {
    match check_all(&args.root, args.write) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn check_all(root: &Path, write: bool) -> Result<bool, String> {
    let doc = root.join(RUNTIME_DOC);
    let text = std::fs::read_to_string(&doc).map_err(|e| format!("{}: {e}", doc.display()))?;
    let version = documented_version(&text)
        .ok_or_else(|| format!("{}: no line `Runtime version: N`", doc.display()))?;
    let dir = root.join(CASES_DIR);
    let mut all_pass = true;
    let directions = Directions::compute();
    if Directions::recorded(&dir).ok().as_ref() == Some(&directions) {
        println!("{}: pass", Directions::FILE);
    } else if write {
        let path = dir.join(Directions::FILE);
        let json = serde_json::to_string_pretty(&directions).map_err(|e| e.to_string())?;
        std::fs::write(&path, json + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
        println!("{}: wrote {}", Directions::FILE, path.display());
    } else {
        println!(
            "{}: differs from the direction sets of ori_views",
            Directions::FILE
        );
        all_pass = false;
    }
    let cases = Case::all(&dir)?;
    if cases.is_empty() {
        return Err(format!("no case (a folder with case.json) in {CASES_DIR}"));
    }
    for case in &cases {
        let name = case.name();
        let found = case.load().and_then(|l| l.compute(version));
        let found = match found {
            Ok(f) => f,
            Err(e) => {
                println!("{name}: cannot compute: {e}");
                all_pass = false;
                continue;
            }
        };
        let recorded = case.expected().ok();
        let diff = recorded
            .as_ref()
            .map(|r| differences(r, &found, 20))
            .unwrap_or_else(|| vec!["no expected.json".into()]);
        if diff.is_empty() {
            println!(
                "{name}: pass ({} views, {} masks, {} table entries, {} held-out views)",
                found.views.len(),
                found
                    .views
                    .iter()
                    .map(|v| v.impostors.len() + 1)
                    .sum::<usize>(),
                found.table.len(),
                found.held_out.directions
            );
            continue;
        }
        // New results need a new version; a new version alone may be recorded.
        let allowed = recorded.as_ref().is_none_or(|r| {
            version > r.runtime_version
                || Expected {
                    runtime_version: r.runtime_version,
                    ..found.clone()
                } == *r
        });
        if write && allowed {
            let json = serde_json::to_string_pretty(&found).map_err(|e| e.to_string())?;
            let path = case.expected_path();
            std::fs::write(&path, json + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
            println!("{name}: wrote {}", path.display());
            continue;
        }
        all_pass = false;
        println!("{name}: differs from the recorded results:");
        for line in diff {
            println!("  {line}");
        }
        if write {
            println!(
                "  not written: the results changed but {RUNTIME_DOC} still says `Runtime \
                 version: {version}`; document the change and raise the version first"
            );
        }
    }
    Ok(all_pass)
}
