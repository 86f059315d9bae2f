//! `cargo xtask bench catalogue`: a studio's catalogue of many distinct assets. For each size,
//! a cold build, no-op rebuilds (nothing changed) and the rebuild after one asset is edited,
//! with their peak memory; then each fitted as a fixed cost plus a cost per asset.
//!
//! The assets are copies of small shared models, each with one vertex moved by a different
//! number of ulps, so every copy is a distinct asset that runs its own jobs. Stages run at
//! light settings (the catalogue's overhead is what is measured, not the stages; `bench
//! scale` measures those), with 64 x 64 maps so that 10,000 packages fit on a build machine's
//! disk.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use crate::bench::median;
use crate::bench_scale::{fit, wait_with_peak};

/// The models copied, round-robin: small, in each format family the loaders read.
const MODELS: [&str; 3] = [
    "stanford/bunny/bunny_npm_lowres.obj",
    "gltf/Duck/Duck.glb",
    "gltf/BoxVertexColors/BoxVertexColors.glb",
];

/// Light stage settings: every stage runs, placement does not search.
const CONFIG: &str = "\
[assets]
root = \"assets\"
[cache]
dir = \"cache\"
[output]
dir = \"out\"
[views]
item_buffer_size = 32
[place]
max_moves = 0
[bake]
resolution = 64
supersample = 1
margin = 1
[select]
rule = \"closest:3\"
s0 = 32
[compress]
quality = \"fast\"
";

/// Assets per folder: a catalogue is a tree, not one flat folder.
const PER_FOLDER: usize = 100;

/// One `build-assets` run.
struct Timed {
    seconds: f64,
    peak_mib: Option<f64>,
    /// Ingest jobs that ran (from the summary table).
    ingests_ran: usize,
}

/// One catalogue size's figures.
struct Row {
    assets: usize,
    cold: Timed,
    /// The first no-op after the cold build (the one that meets what the cold build left).
    first_noop_s: f64,
    /// The median of the others.
    noop_s: f64,
    noop_peak_mib: Option<f64>,
    edit: Timed,
    edited_alone_s: f64,
}

pub fn run(
    sizes: &[usize],
    runs: usize,
    keep: Option<&Path>,
    chosen: &[PathBuf],
) -> Result<(), String> {
    if sizes.is_empty() || sizes.contains(&0) {
        return Err("--assets: give one or more sizes, each at least 1".into());
    }
    if runs == 0 {
        return Err("--runs: at least 1".into());
    }
    let paths: Vec<PathBuf> = if chosen.is_empty() {
        MODELS.iter().map(PathBuf::from).collect()
    } else {
        chosen.to_vec()
    };
    let models: Vec<Model> = paths
        .iter()
        .map(|p| Model::read(&crate::bench::shared_models().join(p)))
        .collect::<Result<_, _>>()?;
    println!(
        "models copied: {}",
        models
            .iter()
            .map(|m| m.file_name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut rows = Vec::new();
    for &assets in sizes {
        let temp;
        let dir = match keep {
            Some(dir) => {
                let dir = dir.join(format!("catalogue-{assets}"));
                if dir.exists() {
                    return Err(format!("{}: already exists", dir.display()));
                }
                dir
            }
            None => {
                temp = tempfile::tempdir().map_err(|e| e.to_string())?;
                temp.path().to_path_buf()
            }
        };
        rows.push(measure(&dir, &models, assets, runs)?);
    }
    print(&rows, runs);
    Ok(())
}

fn measure(dir: &Path, models: &[Model], assets: usize, runs: usize) -> Result<Row, String> {
    let write = |path: &Path, bytes: &[u8]| {
        std::fs::create_dir_all(path.parent().unwrap())
            .and_then(|()| std::fs::write(path, bytes))
            .map_err(|e| format!("{}: {e}", path.display()))
    };
    eprintln!("catalogue of {assets}: writing the assets");
    let config = dir.join("pipeline.toml");
    write(&config, CONFIG.as_bytes())?;
    let path_of = |i: usize| {
        let model = &models[i % models.len()];
        let folder = format!("f{:03}", i / PER_FOLDER);
        let file = format!("{i:05}-{}", model.file_name);
        (model, PathBuf::from("assets").join(folder).join(file))
    };
    for i in 0..assets {
        let (model, rel) = path_of(i);
        write(&dir.join(rel), &model.moved(i as u32 + 1)?)?;
    }
    // Let the files age past the stat memo's racy window, as real sources would have.
    std::thread::sleep(ori_graph::RACY_WINDOW + std::time::Duration::from_millis(100));

    eprintln!("catalogue of {assets}: cold build");
    let cold = build(&config)?;
    if cold.ingests_ran != assets {
        return Err(format!(
            "the cold build ran {} ingest jobs for {assets} assets",
            cold.ingests_ran
        ));
    }
    // As a later build would, after the cold build's files have aged past the racy window.
    std::thread::sleep(ori_graph::RACY_WINDOW + std::time::Duration::from_millis(100));
    let mut noops = Vec::new();
    for run in 0..=runs {
        eprintln!("catalogue of {assets}: no-op rebuild {run} of {runs} (0: the first)");
        let noop = build(&config)?;
        if noop.ingests_ran != 0 {
            return Err(format!(
                "a no-op rebuild ran {} ingest jobs",
                noop.ingests_ran
            ));
        }
        noops.push(noop);
    }

    // Move the middle asset's vertex by as many ulps as no copy has (another count each
    // time): all its jobs run again. Each edit is also built alone, cold, in its own project
    // and cache.
    let edited = assets / 2;
    let (model, rel) = path_of(edited);
    let (mut edits, mut alones) = (Vec::new(), Vec::new());
    for run in 1..=runs {
        let moved = model.moved((assets + run) as u32)?;
        eprintln!("catalogue of {assets}: one asset edited ({run} of {runs})");
        write(&dir.join(&rel), &moved)?;
        let edit = build(&config)?;
        if edit.ingests_ran != 1 {
            return Err(format!(
                "the edited rebuild ran {} ingest jobs, not 1",
                edit.ingests_ran
            ));
        }
        edits.push(edit);
        let alone = dir.join("alone");
        if alone.exists() {
            std::fs::remove_dir_all(&alone).map_err(|e| format!("{}: {e}", alone.display()))?;
        }
        write(&alone.join("pipeline.toml"), CONFIG.as_bytes())?;
        write(&alone.join(&rel), &moved)?;
        alones.push(build(&alone.join("pipeline.toml"))?.seconds);
    }
    let edit = Timed {
        seconds: median(edits.iter().map(|t| t.seconds).collect()),
        peak_mib: edits
            .iter()
            .map(|t| t.peak_mib)
            .collect::<Option<Vec<f64>>>()
            .map(median),
        ingests_ran: 1,
    };
    Ok(Row {
        assets,
        cold,
        first_noop_s: noops[0].seconds,
        noop_s: median(noops[1..].iter().map(|t| t.seconds).collect()),
        noop_peak_mib: noops
            .iter()
            .map(|t| t.peak_mib)
            .skip(1)
            .collect::<Option<Vec<f64>>>()
            .map(median),
        edit,
        edited_alone_s: median(alones),
    })
}

/// Run `build-assets` on `config`, measuring the whole process.
fn build(config: &Path) -> Result<Timed, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    // Standard output goes to a file, so that a long one cannot fill a pipe nobody reads.
    let stdout_path = config.with_extension("stdout");
    let stdout = std::fs::File::create(&stdout_path).map_err(|e| e.to_string())?;
    let start = Instant::now();
    let child = Command::new(exe)
        .args(["build-assets", "--quiet", "--config"])
        .arg(config)
        .stdout(stdout)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| e.to_string())?;
    let (success, peak, stderr) = wait_with_peak(child)?;
    let seconds = start.elapsed().as_secs_f64();
    let output = std::fs::read_to_string(&stdout_path).map_err(|e| e.to_string())?;
    if !success {
        return Err(format!(
            "build failed ({}):\n{output}{stderr}",
            config.display()
        ));
    }
    let ingests_ran = crate::bench::ingests_ran(&output)?;
    Ok(Timed {
        seconds,
        peak_mib: peak.map(|b| b as f64 / (1024.0 * 1024.0)),
        ingests_ran,
    })
}

fn print(rows: &[Row], runs: usize) {
    let mib = |m: Option<f64>| m.map_or_else(|| "n/a".into(), |m| format!("{m:.0}"));
    println!(
        "catalogue builds ({} threads; 1st no-op: the first after the cold build; no-op: median \
         of the {runs} after it; edit: one asset's vertex moved, median of {runs}; alone: that \
         asset built cold in its own project, median of {runs})",
        rayon::current_num_threads()
    );
    println!(
        "{:>7} {:>9} {:>9} {:>11} {:>9} {:>9} {:>9} {:>9} {:>11}",
        "assets",
        "cold s",
        "cold MiB",
        "1st no-op s",
        "no-op s",
        "no-op MiB",
        "edit s",
        "edit MiB",
        "alone cold s"
    );
    for r in rows {
        println!(
            "{:>7} {:>9.2} {:>9} {:>11.3} {:>9.3} {:>9} {:>9.2} {:>9} {:>11.2}",
            r.assets,
            r.cold.seconds,
            mib(r.cold.peak_mib),
            r.first_noop_s,
            r.noop_s,
            mib(r.noop_peak_mib),
            r.edit.seconds,
            mib(r.edit.peak_mib),
            r.edited_alone_s
        );
    }
    println!();
    println!("fitted growth (least squares over the sizes above): fixed + per asset");
    let column = |y: fn(&Row) -> Option<f64>| rows.iter().map(y).collect::<Vec<_>>();
    let columns = [
        ("cold s", column(|r| Some(r.cold.seconds)), 1e3, "ms"),
        ("1st no-op s", column(|r| Some(r.first_noop_s)), 1e6, "us"),
        ("no-op s", column(|r| Some(r.noop_s)), 1e6, "us"),
        ("no-op MiB", column(|r| r.noop_peak_mib), 1024.0, "KiB"),
        (
            "edit s",
            column(|r| Some(r.edit.seconds - r.edited_alone_s)),
            1e3,
            "ms",
        ),
        ("edit MiB", column(|r| r.edit.peak_mib), 1024.0, "KiB"),
    ];
    for (name, values, scale, unit) in columns {
        let points: Option<Vec<(f64, f64)>> = rows
            .iter()
            .zip(values)
            .map(|(r, v)| v.map(|v| (r.assets as f64, v)))
            .collect();
        match points.and_then(|p| fit(&p)) {
            Some((fixed, slope)) => println!(
                "{name:<12} {fixed:>10.3} fixed, {:>10.2} {unit} per asset",
                slope * scale
            ),
            None => println!("{name:<12} (needs two sizes)"),
        }
    }
    println!("(edit s: the rebuild's seconds beyond the edited asset's own cold build)");
}

/// A model file whose first vertex's x coordinate can be moved.
struct Model {
    file_name: String,
    bytes: Vec<u8>,
    /// Where the first vertex's x is.
    x: Coordinate,
}

enum Coordinate {
    /// The text span of the number in an OBJ file.
    Text { start: usize, end: usize },
    /// The byte offset of the little-endian `f32` in a GLB file.
    Float(usize),
}

impl Model {
    fn read(path: &Path) -> Result<Model, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let file_name = path.file_name().unwrap().to_string_lossy().into_owned();
        let x = if file_name.ends_with(".obj") {
            obj_first_x(&bytes)
        } else if file_name.ends_with(".glb") {
            glb_first_x(&bytes)
        } else {
            return Err(format!("{}: not an OBJ or GLB file", path.display()));
        }
        .ok_or_else(|| format!("{}: cannot find its first vertex", path.display()))?;
        Ok(Model {
            file_name,
            bytes,
            x,
        })
    }

    /// The file with its first vertex's x moved by `ulps` units in the last place.
    fn moved(&self, ulps: u32) -> Result<Vec<u8>, String> {
        let step = |x: f32| f32::from_bits(x.to_bits().wrapping_add(ulps));
        match self.x {
            Coordinate::Text { start, end } => {
                let text = std::str::from_utf8(&self.bytes[start..end]).unwrap();
                let x: f32 = text
                    .parse()
                    .map_err(|_| format!("{}: {text:?} is not a number", self.file_name))?;
                let mut out = self.bytes[..start].to_vec();
                out.extend_from_slice(step(x).to_string().as_bytes());
                out.extend_from_slice(&self.bytes[end..]);
                Ok(out)
            }
            Coordinate::Float(at) => {
                let mut out = self.bytes.clone();
                let x = f32::from_le_bytes(out[at..at + 4].try_into().unwrap());
                out[at..at + 4].copy_from_slice(&step(x).to_le_bytes());
                Ok(out)
            }
        }
    }
}

fn obj_first_x(bytes: &[u8]) -> Option<Coordinate> {
    let text = std::str::from_utf8(bytes).ok()?;
    let line = text.find("\nv ")? + 3;
    let rest = &text[line..];
    let skip = rest.len() - rest.trim_start().len();
    let start = line + skip;
    let end = start + text[start..].find(char::is_whitespace)?;
    Some(Coordinate::Text { start, end })
}

/// The first POSITION float of the first primitive, in the GLB's binary chunk.
fn glb_first_x(bytes: &[u8]) -> Option<Coordinate> {
    let u32_at = |at: usize| Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?));
    if bytes.get(0..4)? != b"glTF" {
        return None;
    }
    let json_len = u32_at(12)? as usize;
    let json: serde_json::Value = serde_json::from_slice(bytes.get(20..20 + json_len)?).ok()?;
    let bin_data = 20 + json_len + 8;
    let accessor = json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].as_u64()?;
    let accessor = &json["accessors"][accessor as usize];
    let view = &json["bufferViews"][accessor["bufferView"].as_u64()? as usize];
    let offset = |v: &serde_json::Value| v["byteOffset"].as_u64().unwrap_or(0) as usize;
    let at = bin_data + offset(view) + offset(accessor);
    (at + 4 <= bytes.len()).then_some(Coordinate::Float(at))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_copy_is_distinct_and_the_rest_of_the_file_unchanged() {
        for rel in MODELS {
            let model = Model::read(&crate::bench::shared_models().join(rel)).unwrap();
            let a = model.moved(1).unwrap();
            let b = model.moved(2).unwrap();
            assert_ne!(a, b, "{rel}");
            assert_ne!(a, model.bytes, "{rel}");
            let common = a
                .iter()
                .zip(&model.bytes)
                .take_while(|(x, y)| x == y)
                .count();
            let tail = a
                .iter()
                .rev()
                .zip(model.bytes.iter().rev())
                .take_while(|(x, y)| x == y)
                .count();
            assert!(
                a.len() - common - tail <= 12,
                "{rel}: more than one number changed"
            );
        }
    }
}
