//! The runtime's conformance data: small packages with what the runtime rule of
//! `docs/RUNTIME.md` must give on them, so that an implementation of the rule (the CPU
//! evaluator, the wgpu shader, an engine's own shader) can test itself.
//!
//! A case is a folder of `docs/conformance/` holding `case.json` ([`CaseInputs`]: the package
//! and the model it was baked from, written by hand) and `expected.json` ([`Expected`]:
//! computed here by the CPU evaluator from the package's decoded textures). Both are plain
//! JSON so that any language can read them; masks are rows of hexadecimal digits
//! ([`mask_rows`]).
//!
//! The expected results carry the version of the runtime rule they were computed for
//! (`docs/RUNTIME.md`'s line `Runtime version: N`, [`documented_version`]): results that
//! change without that version changing are a failure (`cargo xtask conformance`, and the
//! crate's tests), so the documents and the code cannot drift apart silently.
//!
//! This crate knows the data's layout and how to compute it; it does not build packages (the
//! pipeline does) and does not draw on a GPU (its tests compare the wgpu renderer against the
//! data).

use std::path::{Path, PathBuf};

use ori_eval::{Evaluator, Mask};
use ori_mesh::Mesh;
use ori_package::{Package, SelectionEntry};
use ori_raster::{Frame, OrthoView};
use ori_select::{SelectParams, Selection};
use serde::{Deserialize, Serialize};

/// The folder of the cases, relative to the repository root.
pub const CASES_DIR: &str = "docs/conformance";
/// The document whose version the results are of, relative to the repository root.
pub const RUNTIME_DOC: &str = "docs/RUNTIME.md";

/// The table directions a case measures views at (indices into the 320).
pub const TABLE_VIEWS: [usize; 4] = [0, 107, 213, 319];
/// The held-out directions (seed [`ori_views::DEFAULT_HELD_OUT_SEED`]) a case measures views
/// at: the first and last regular one, the first and last random one.
pub const HELD_OUT_VIEWS: [usize; 4] = [0, 1279, 1280, 3279];
/// Views straight along the up axis and against it, where frames take their fallback.
pub const AXIS_VIEWS: [[f64; 3]; 2] = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]];

/// `docs/RUNTIME.md`'s version: the number on its line `Runtime version: N`.
pub fn documented_version(runtime_md: &str) -> Option<u32> {
    runtime_md
        .lines()
        .find_map(|l| l.trim().strip_prefix("Runtime version: "))
        .and_then(|v| v.trim().parse().ok())
}

/// The direction sets every case shares (`directions.json` beside the cases), for checking a
/// generator bit for bit: JSON numbers are written in the shortest form that reads back to
/// the same `f64`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Directions {
    /// The 320 table directions, in entry order.
    pub table: Vec<[f64; 3]>,
    /// The held-out directions of `held_out_seed`: the first 8 regular ones, then the first 8
    /// random ones.
    pub held_out_seed: u64,
    pub held_out_regular: Vec<[f64; 3]>,
    pub held_out_random: Vec<[f64; 3]>,
}

impl Directions {
    pub const FILE: &'static str = "directions.json";

    /// The sets as `ori_views` makes them.
    pub fn compute() -> Directions {
        let seed = ori_views::DEFAULT_HELD_OUT_SEED;
        let held_out = ori_views::held_out_directions(seed);
        let regular = ori_views::HELD_OUT_REGULAR;
        Directions {
            table: ori_views::evaluation_directions(),
            held_out_seed: seed,
            held_out_regular: held_out[..8].to_vec(),
            held_out_random: held_out[regular..regular + 8].to_vec(),
        }
    }

    /// The recorded sets in `cases` (the folder of the cases).
    pub fn recorded(cases: &Path) -> Result<Directions, String> {
        let path = cases.join(Directions::FILE);
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// A case's inputs (`case.json`), paths relative to the case's folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseInputs {
    /// The `.ori` package.
    pub package: String,
    /// The model the package was baked from: its coverage is the reference.
    pub mesh: String,
}

/// What the runtime rule gives on a case's package (`expected.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expected {
    /// `docs/RUNTIME.md`'s version the results are of.
    pub runtime_version: u32,
    /// Evaluation image edge s0 (from the package's `params.select`).
    pub s0: u32,
    /// The `M` of the package's `best:M` or `closest:M` rule.
    pub m: u32,
    /// Views at table, held-out and axis directions.
    pub views: Vec<ViewResult>,
    /// The selection table recomputed from the package's decoded textures and the model: one
    /// entry per table direction, equal to the package's own table (the pipeline selects on
    /// the depth it ships).
    pub table: Vec<SelectionEntry>,
    /// The held-out measure of the package.
    pub held_out: HeldOutFigures,
}

/// One view: its framing, the mesh's coverage and each candidate impostor's coverage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewResult {
    /// Where the direction comes from: `table I`, `held-out I`, `axis +Y` or `axis -Y`.
    pub label: String,
    /// The view direction `w`, unit, from the object towards the viewer.
    pub direction: [f64; 3],
    /// The evaluation view: frame (u, v, d), window centre on (u, v), half its edge, and the
    /// heights of depth 0 and 1.
    pub frame: [[f64; 3]; 3],
    pub center: [f64; 2],
    pub half_size: f64,
    pub near: f64,
    pub far: f64,
    /// Pixels the mesh covers.
    pub mesh: Vec<String>,
    /// The `M` closest impostors facing `w`, closest first, each with every pixel where it
    /// draws a fragment (traced at every pixel, not only the mesh's).
    pub impostors: Vec<ImpostorMask>,
    /// The entry of the package's table nearest to `w` and the impostors it draws.
    pub entry: usize,
    pub drawn: Vec<u16>,
    /// Pixels of the mesh that none of `drawn` covers.
    pub missed: u32,
}

/// One impostor's coverage in a view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImpostorMask {
    pub impostor: usize,
    pub mask: Vec<String>,
}

/// The held-out measure: every held-out direction drawn with the impostors of the package's
/// table entry nearest to it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeldOutFigures {
    pub seed: u64,
    pub directions: usize,
    /// The first three random directions (after the 1280 regular ones), to check a generator.
    pub first_random: [[f64; 3]; 3],
    /// The worst view's missed pixels (GC(s0)), the sum over the views, and the impostors
    /// drawn summed over the views.
    pub worst_missed: u32,
    pub total_missed: u64,
    pub total_drawn: u64,
}

/// Rows of a mask from the top, each `ceil(size / 4)` hexadecimal digits (lower case); pixel
/// `x` of a row is bit `3 - x % 4` of digit `x / 4` (the leftmost pixel is the digit's high
/// bit), padding bits 0.
pub fn mask_rows(mask: &Mask) -> Vec<String> {
    let size = mask.size() as usize;
    (0..size)
        .map(|y| {
            (0..size.div_ceil(4))
                .map(|digit| {
                    let nibble = (0..4)
                        .filter(|&b| {
                            let x = 4 * digit + b;
                            x < size && mask.get(y * size + x)
                        })
                        .fold(0u32, |acc, b| acc | 8 >> b);
                    char::from_digit(nibble, 16).expect("a nibble")
                })
                .collect()
        })
        .collect()
}

/// Whether pixel (`x`, `y`) is set in `rows` ([`mask_rows`]'s layout); `None` when the rows
/// do not hold it or a digit is not hexadecimal.
pub fn row_pixel(rows: &[String], x: usize, y: usize) -> Option<bool> {
    let digit = rows.get(y)?.as_bytes().get(x / 4)?;
    let value = char::from(*digit).to_digit(16)?;
    Some(value & (8 >> (x % 4)) != 0)
}

/// A case's folder and what it holds.
pub struct Case {
    pub dir: PathBuf,
    pub inputs: CaseInputs,
}

impl Case {
    /// The case in `dir` (its `case.json`).
    pub fn open(dir: &Path) -> Result<Case, String> {
        let path = dir.join("case.json");
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let inputs = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(Case {
            dir: dir.to_path_buf(),
            inputs,
        })
    }

    /// Every case under `cases` (folders with a `case.json`), by name.
    pub fn all(cases: &Path) -> Result<Vec<Case>, String> {
        let entries = std::fs::read_dir(cases).map_err(|e| format!("{}: {e}", cases.display()))?;
        let mut dirs: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.join("case.json").is_file())
            .collect();
        dirs.sort();
        dirs.iter().map(|d| Case::open(d)).collect()
    }

    pub fn name(&self) -> String {
        self.dir
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
    }

    pub fn expected_path(&self) -> PathBuf {
        self.dir.join("expected.json")
    }

    /// The recorded results (`expected.json`).
    pub fn expected(&self) -> Result<Expected, String> {
        let path = self.expected_path();
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The package and the model, loaded.
    pub fn load(&self) -> Result<Loaded, String> {
        let package_path = self.dir.join(&self.inputs.package);
        let bytes =
            std::fs::read(&package_path).map_err(|e| format!("{}: {e}", package_path.display()))?;
        let package =
            ori_package::read(&bytes).map_err(|e| format!("{}: {e}", package_path.display()))?;
        let mesh_path = self.dir.join(&self.inputs.mesh);
        let mesh = ori_mesh::load_file(&mesh_path, &Default::default())
            .map_err(|e| e.to_string())?
            .mesh;
        Ok(Loaded { package, mesh })
    }
}

/// A case's package and model.
pub struct Loaded {
    pub package: Package,
    pub mesh: Mesh,
}

impl Loaded {
    /// The selection parameters the package was measured with (its `params.select`).
    pub fn select_params(&self) -> Result<SelectParams, String> {
        let select = self.package.manifest.params.get("select").cloned();
        let mut select = select.ok_or("the package's params have no \"select\" section")?;
        // Packages written before `region_scale` existed measured the regions at s0, and
        // those written before `region_shape` on the triangles' grids.
        if let Some(keys) = select.as_object_mut() {
            keys.entry("region_scale").or_insert(serde_json::json!(1.0));
            keys.entry("region_shape")
                .or_insert(serde_json::json!("triangle"));
        }
        let params: SelectParams =
            serde_json::from_value(select).map_err(|e| format!("params.select: {e}"))?;
        params.validate().map_err(|e| e.to_string())?;
        Ok(params)
    }

    /// Everything [`Expected`] holds, computed by the CPU evaluator from the package's
    /// decoded textures, for runtime version `version`.
    pub fn compute(&self, version: u32) -> Result<Expected, String> {
        let params = self.select_params()?;
        let set = ori_report::relief_set(&self.package)?;
        let evaluator =
            Evaluator::new(&self.mesh, &set, &params.eval_params()).map_err(|e| e.to_string())?;
        let recomputed = ori_select::select_with(&evaluator, &params).map_err(|e| e.to_string())?;
        // The runtime draws the package's own table (the tests hold it equal to the
        // recomputed one): the views and the held-out measure use what ships.
        let table = Table {
            lookup: &recomputed,
            entries: &self.package.manifest.selection.entries,
        };

        let table_directions = ori_views::evaluation_directions();
        let held_out = ori_views::held_out_directions(ori_views::DEFAULT_HELD_OUT_SEED);
        let mut directions: Vec<(String, [f64; 3])> = Vec::new();
        for i in TABLE_VIEWS {
            directions.push((format!("table {i}"), table_directions[i]));
        }
        for i in HELD_OUT_VIEWS {
            directions.push((format!("held-out {i}"), held_out[i]));
        }
        for (w, name) in AXIS_VIEWS.into_iter().zip(["+Y", "-Y"]) {
            directions.push((format!("axis {name}"), w));
        }
        let views = directions
            .into_iter()
            .map(|(label, w)| view_result(&evaluator, &table, params.rule.m(), label, w))
            .collect::<Result<_, _>>()?;

        let subset = |w: [f64; 3]| {
            let entry = &table.entries[table.lookup.nearest(w)];
            entry.impostors.iter().map(|&i| usize::from(i)).collect()
        };
        let measured =
            ori_select::held_out(&evaluator, &held_out, &subset).map_err(|e| e.to_string())?;
        let random = ori_views::HELD_OUT_REGULAR;
        Ok(Expected {
            runtime_version: version,
            s0: params.s0,
            m: params.rule.m(),
            views,
            table: recomputed
                .entries
                .iter()
                .map(|e| SelectionEntry {
                    impostors: e.impostors.clone(),
                    missed: e.missed,
                })
                .collect(),
            held_out: HeldOutFigures {
                seed: ori_views::DEFAULT_HELD_OUT_SEED,
                directions: held_out.len(),
                first_random: [held_out[random], held_out[random + 1], held_out[random + 2]],
                worst_missed: measured.worst_missed(),
                total_missed: measured.views.iter().map(|v| u64::from(v.0)).sum(),
                total_drawn: measured.views.iter().map(|v| v.1 as u64).sum(),
            },
        })
    }
}

/// The package's table, looked up as [`Selection::nearest`] does (the directions depend only
/// on the entry count).
struct Table<'a> {
    lookup: &'a Selection,
    entries: &'a [SelectionEntry],
}

fn view_result(
    evaluator: &Evaluator<'_>,
    table: &Table<'_>,
    m: u32,
    label: String,
    w: [f64; 3],
) -> Result<ViewResult, String> {
    let view = evaluator.view(w).map_err(|e| e.to_string())?;
    let mesh = evaluator.mesh_coverage(&view);
    let impostors = evaluator
        .facing(w)
        .into_iter()
        .take(m as usize)
        .map(|i| ImpostorMask {
            impostor: i,
            mask: mask_rows(&evaluator.impostor_mask(&view, i, None)),
        })
        .collect();
    let entry = table.lookup.nearest(w);
    let drawn = table.entries[entry].impostors.clone();
    let mut missed = mesh.clone();
    for &i in &drawn {
        missed.remove(&evaluator.impostor_mask(&view, usize::from(i), None));
    }
    let Frame { u, v, d } = view.frame;
    Ok(ViewResult {
        label,
        direction: w,
        frame: [u, v, d],
        center: view.center,
        half_size: view.half_size,
        near: view.near,
        far: view.far,
        mesh: mask_rows(&mesh),
        impostors,
        entry,
        drawn,
        missed: missed.count(),
    })
}

impl ViewResult {
    /// The evaluation view these results are of, at `s0` pixels.
    pub fn ortho_view(&self, s0: u32) -> OrthoView {
        let [u, v, d] = self.frame;
        OrthoView {
            frame: Frame { u, v, d },
            center: self.center,
            half_size: self.half_size,
            near: self.near,
            far: self.far,
            size: s0,
        }
    }
}

/// Where `found` differs from `expected`, one line per difference (at most `limit` lines,
/// then a count): empty when they agree.
pub fn differences(expected: &Expected, found: &Expected, limit: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut note = |line: String| lines.push(line);
    if expected.runtime_version != found.runtime_version {
        note(format!(
            "runtime version {} recorded, {} documented",
            expected.runtime_version, found.runtime_version
        ));
    }
    if (expected.s0, expected.m) != (found.s0, found.m) {
        note(format!(
            "s0 / M: {} / {} expected, {} / {} found",
            expected.s0, expected.m, found.s0, found.m
        ));
    }
    if expected.views.len() != found.views.len() {
        note(format!(
            "{} views expected, {} found",
            expected.views.len(),
            found.views.len()
        ));
    }
    for (e, f) in expected.views.iter().zip(&found.views) {
        let at = &e.label;
        if (e.direction, e.frame, e.center) != (f.direction, f.frame, f.center)
            || (e.half_size, e.near, e.far) != (f.half_size, f.near, f.far)
        {
            note(format!("view {at}: the framing differs"));
        }
        if e.mesh != f.mesh {
            note(format!("view {at}: the mesh's coverage differs"));
        }
        let ids = |v: &ViewResult| v.impostors.iter().map(|i| i.impostor).collect::<Vec<_>>();
        if ids(e) != ids(f) {
            note(format!(
                "view {at}: candidates {:?} expected, {:?} found",
                ids(e),
                ids(f)
            ));
        }
        for (a, b) in e.impostors.iter().zip(&f.impostors) {
            if a.mask != b.mask {
                let pixels = (0..found.s0 as usize)
                    .flat_map(|y| (0..found.s0 as usize).map(move |x| (x, y)))
                    .filter(|&(x, y)| row_pixel(&a.mask, x, y) != row_pixel(&b.mask, x, y))
                    .count();
                note(format!(
                    "view {at}: impostor {}'s mask differs at {pixels} pixels",
                    a.impostor
                ));
            }
        }
        if (e.entry, &e.drawn, e.missed) != (f.entry, &f.drawn, f.missed) {
            note(format!(
                "view {at}: entry {} drawing {:?} missing {} px expected, entry {} drawing {:?} \
                 missing {} px found",
                e.entry, e.drawn, e.missed, f.entry, f.drawn, f.missed
            ));
        }
    }
    let differing: Vec<usize> = (0..expected.table.len().max(found.table.len()))
        .filter(|&i| expected.table.get(i) != found.table.get(i))
        .collect();
    if let Some(&first) = differing.first() {
        note(format!(
            "{} of {} table entries differ (first: entry {first}, {:?} expected, {:?} found)",
            differing.len(),
            expected.table.len(),
            expected.table.get(first),
            found.table.get(first)
        ));
    }
    if expected.held_out != found.held_out {
        note(format!(
            "held-out measure: {:?} expected, {:?} found",
            expected.held_out, found.held_out
        ));
    }
    if lines.len() > limit {
        let more = lines.len() - limit;
        lines.truncate(limit);
        lines.push(format!("... and {more} more"));
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mask_rows_put_the_leftmost_pixel_in_the_high_bit() {
        let mut mask = Mask::new(6);
        mask.set(0); // (0, 0)
        mask.set(6 + 5); // (5, 1)
        let rows = mask_rows(&mask);
        assert_eq!(rows[0], "80");
        assert_eq!(rows[1], "04");
        assert_eq!(rows.len(), 6);
        for y in 0..6 {
            for x in 0..6 {
                assert_eq!(row_pixel(&rows, x, y), Some(mask.get(y * 6 + x)));
            }
        }
        assert_eq!(row_pixel(&rows, 8, 0), None);
    }

    #[test]
    fn the_version_is_read_from_its_line() {
        let doc = "# Runtime\n\nRuntime version: 3\n\ntext";
        assert_eq!(documented_version(doc), Some(3));
        assert_eq!(documented_version("no version"), None);
    }
}
