//! The build report: `report/index.html` beside a release, readable at a glance (with
//! `assets-2.html`, ... for a catalogue's further asset sections), and
//! `report/report.json` with the same figures for scripts.
//!
//! It is made from what a build leaves in its output folder (`release.json`, the packages,
//! `report.json`) and the source models (for the reference pictures), so it can be made again
//! without rebuilding (`cargo xtask report`). Every ORI picture is drawn by the CPU evaluator
//! from the package's *decoded* textures: what ships, block compression included.
//!
//! Invariants: the pages are static and self-contained (pictures are PNG files beside them,
//! the histogram is inline SVG, the only script shows and sorts the summary's rows, embedded
//! as JSON, a page at a time, and checks that every picture loaded); nothing is fetched from a network; an asset whose source is missing or changed
//! since its package was built gets its figures without the reference pictures, and says so.
//! An asset's pictures are drawn again only when its package, its source model or the drawing
//! code ([`PICTURES_VERSION`]) changed: a stamp of the three beside them (`pictures.json`)
//! says which pictures a folder holds, so a rebuild after one edit redraws one asset.

mod html;
mod pictures;
mod relief;
mod viewer;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ori_eval::{EvalParams, Evaluator};
use ori_release::{AssetReport, BuildReport, RELEASE_JSON, REPORT_JSON, Release, ReleaseEntry};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use pictures::{Picture, count_colour, error_colour};
pub use relief::relief_set;
use viewer::{MESH_FILE, mesh_bytes};

/// How the report reads source models: under the same rules as the build (inside the asset
/// root, regular files, size and texture limits).
#[derive(Clone, Debug, Default)]
pub struct SourceAccess {
    pub rules: ori_graph::SourceRules,
    pub limits: ori_mesh::Limits,
    /// The build's stat memo of the sources' hashes (`ori_graph::STAT_MEMO` in its cache
    /// folder), so that the report reads no source the build already hashed; `None`: read
    /// them.
    pub stat_memo: Option<PathBuf>,
    /// That memo as the build that just ran holds it, used instead of loading the file.
    pub loaded_stat_memo: Option<Arc<ori_graph::SourceHasher>>,
}

/// Source hashes, from the stat memo where there is one.
struct SourceHashes<'a> {
    access: &'a SourceAccess,
    memo: Option<Arc<ori_graph::SourceHasher>>,
}

impl<'a> SourceHashes<'a> {
    fn open(access: &'a SourceAccess) -> SourceHashes<'a> {
        let memo = access.loaded_stat_memo.clone().or_else(|| {
            let path = access.stat_memo.clone()?;
            Some(Arc::new(ori_graph::SourceHasher::new(
                path,
                access.rules.clone(),
            )))
        });
        SourceHashes { access, memo }
    }

    /// The blake3 of a source file's content; `None` when it cannot be read.
    fn hash(&self, path: &Path) -> Option<blake3::Hash> {
        match &self.memo {
            Some(memo) => Some(blake3::Hash::from_bytes(memo.hash(path).ok()??.0)),
            None => Some(blake3::hash(&self.access.read(path).ok()?)),
        }
    }

    /// Keep the memo for the next report; failing costs only a re-read next time.
    fn save(&self) {
        if let Some(memo) = &self.memo {
            let _ = memo.save();
        }
    }
}

impl SourceAccess {
    fn read(&self, path: &Path) -> Result<Vec<u8>, String> {
        self.rules
            .read(path)
            .map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Load a model the way the ingest stage does.
    fn load(&self, path: &Path) -> Result<ori_mesh::Mesh, String> {
        let bytes = self.read(path)?;
        let dir = path.parent().unwrap_or(Path::new(""));
        let options = ori_mesh::LoadOptions {
            limits: self.limits,
            ..Default::default()
        };
        let mut resolver = |uri: &str| self.rules.read(&dir.join(uri));
        ori_mesh::load(path, &bytes, &options, &mut resolver)
            .map(|loaded| loaded.mesh)
            .map_err(|e| e.to_string())
    }
}

/// A report written: its page, and every package that failed its check against
/// `release.json` (each naming the file and what is wrong).
#[derive(Debug)]
pub struct Written {
    pub index: PathBuf,
    pub invalid_packages: Vec<String>,
}

/// Directions of the side-by-side comparisons (object -> viewer; y is up in most models):
/// front, right side, from above, and one between impostor directions.
const VIEWS: [(&str, [f64; 3]); 4] = [
    ("front", [0.0, 0.0, 1.0]),
    ("side", [1.0, 0.0, 0.0]),
    ("top", [0.0, 1.0, 0.0]),
    ("oblique", [-0.48, 0.36, -0.8]),
];

/// Edge of the comparison pictures (whatever s0 the selection used: they are for people).
const PICTURE_SIZE: u32 = 256;

/// Version of every picture's drawing, the evaluator's rendering rule included: bump it when
/// either changes, so that the pictures kept from an older report are drawn again. (3: the
/// reference mesh culls the back faces of single-sided materials; 4: the hierarchy note gives
/// the size up to which no leaf mesh is drawn; 5: the viewer's mesh file beside them.)
pub const PICTURES_VERSION: u32 = 5;

/// What [`pictures_of`] adds to an asset's summary, kept beside its pictures with the stamp
/// of what they were drawn from.
#[derive(Debug, Serialize, Deserialize)]
struct Drawn {
    stamp: String,
    impostors: Option<usize>,
    pictures: Vec<(String, String)>,
    notes: Vec<String>,
    p_dif: Option<f64>,
    #[serde(default)]
    comparison: Vec<ori_rivals::Row>,
}

/// The stamp of an asset's pictures: the drawing version, the comparison asked for, the
/// package's blake3 (from `release.json`) and the source model's current content. `None` when the source cannot be
/// read (the pictures say why).
fn stamp(
    package_blake3: &str,
    source: &Path,
    sources: &SourceHashes<'_>,
    options: &ReportOptions,
) -> Option<String> {
    let source = sources.hash(source)?;
    let mut h = blake3::Hasher::new();
    h.update(&PICTURES_VERSION.to_le_bytes());
    let compare = options.compare_directions.map_or(0, |n| n as u64 + 1);
    h.update(&compare.to_le_bytes());
    h.update(package_blake3.as_bytes());
    h.update(source.as_bytes());
    Some(h.finalize().to_hex().to_string())
}

/// The pictures already in `folder` when they were drawn from `stamp` and are all there.
fn kept(folder: &Path, report_dir: &Path, stamp: &str) -> Option<Drawn> {
    let bytes = std::fs::read(folder.join("pictures.json")).ok()?;
    let drawn: Drawn = serde_json::from_slice(&bytes).ok()?;
    // One listing of the folder instead of a look at each picture.
    let listed: HashSet<PathBuf> = std::fs::read_dir(folder)
        .ok()?
        .filter_map(|e| e.ok())
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .map(|e| e.path())
        .collect();
    let complete = drawn.pictures.iter().all(|(_, file)| {
        let path = report_dir.join(file);
        listed.contains(&path) || path.is_file()
    });
    (drawn.stamp == stamp && complete).then_some(drawn)
}

/// One asset's row of the summary and its pictures.
#[derive(Clone, Debug, Default, Serialize)]
pub struct AssetSummary {
    pub name: String,
    /// "ok" or the build's failure.
    pub status: String,
    pub error: Option<String>,
    pub faces: Option<u64>,
    pub impostors: Option<usize>,
    pub resolution: Option<u32>,
    pub package: Option<String>,
    pub package_bytes: Option<u64>,
    pub texture_bytes: Option<u64>,
    /// From the worst held-out view.
    pub plt: Option<f64>,
    /// The runtime rule at the held-out directions (percent of s0 x s0; impostors drawn).
    pub held_out_directions: Option<usize>,
    pub held_out_coverage_error_max_percent: Option<f64>,
    pub held_out_coverage_error_avg_percent: Option<f64>,
    pub held_out_impostors_per_view: Option<f64>,
    /// At the selection table's own directions.
    pub coverage_error_min_percent: Option<f64>,
    pub coverage_error_max_percent: Option<f64>,
    pub coverage_error_avg_percent: Option<f64>,
    pub impostors_per_view: Option<f64>,
    /// Directions drawing 1, 2, 3, ... impostors (index 0: none).
    pub views_by_impostor_count: Vec<u64>,
    /// Mean colour error p_dif (0 to 765) over the comparison views.
    pub p_dif: Option<f64>,
    /// Seconds per stage in this build, and whether each job ran or was reused.
    pub jobs: Vec<(String, String, f64)>,
    /// Picture files, relative to the report folder, by role.
    pub pictures: Vec<(String, String)>,
    /// Why some pictures are missing.
    pub notes: Vec<String>,
    /// `[compare] enabled`: the ORI and its rivals at its texture bytes (`cargo xtask
    /// compare`'s rows); empty otherwise.
    pub comparison: Vec<ori_rivals::Row>,
    /// What the package misses of the build's `[gate]`, one line per bound.
    pub gate: Vec<String>,
    /// Why the package failed its check against `release.json`, if it did.
    #[serde(skip)]
    pub invalid: Option<String>,
}

impl AssetSummary {
    /// Whether the source mesh was drawn beside the ORI (and so `mesh.bin` written, before
    /// the reference pictures).
    fn has_reference_pictures(&self) -> bool {
        self.pictures.iter().any(|p| p.0.ends_with(" reference"))
    }
}

/// What the report draws besides its pictures.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReportOptions {
    /// `[compare] enabled`: compare each ORI with the rival techniques at its texture bytes
    /// (`ori_rivals`) at this many held-out directions; `None`: no comparison.
    pub compare_directions: Option<usize>,
}

/// `report/report.json`.
#[derive(Debug, Serialize)]
pub struct ReportSummary {
    pub assets: Vec<AssetSummary>,
}

/// Write `<out_dir>/report/` from the build in `out_dir`, reading source models under
/// `assets_root` through `access`. Every package is checked against `release.json` first; one
/// that fails is reported in [`Written::invalid_packages`] and gets no pictures.
pub fn write_report(
    out_dir: &Path,
    assets_root: &Path,
    access: &SourceAccess,
    options: &ReportOptions,
) -> Result<Written, String> {
    let build: BuildReport = read_json(&out_dir.join(REPORT_JSON))?;
    let release: Release = read_json(&out_dir.join(RELEASE_JSON))?;
    write_report_of(&build, &release, out_dir, assets_root, access, options)
}

/// [`write_report`] from the build's `report.json` and `release.json` as it wrote them into
/// `out_dir`, at hand in memory.
pub fn write_report_of(
    build: &BuildReport,
    release: &Release,
    out_dir: &Path,
    assets_root: &Path,
    access: &SourceAccess,
    options: &ReportOptions,
) -> Result<Written, String> {
    let dir = out_dir.join(ori_release::REPORT_DIR);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let entries: HashMap<&str, &ReleaseEntry> = release
        .assets
        .iter()
        .map(|e| (e.name.as_str(), e))
        .collect();
    let sources = SourceHashes::open(access);
    let place = Place {
        out_dir,
        assets_root,
        dir: &dir,
        access,
        sources: &sources,
        options,
    };
    let summaries: Vec<AssetSummary> = build
        .assets
        .par_iter()
        .map(|a| asset_summary(a, entries.get(a.name.as_str()).copied(), &place))
        .collect();
    sources.save();
    remove_unused_picture_folders(&dir, &summaries);
    let invalid_packages = summaries.iter().filter_map(|s| s.invalid.clone()).collect();
    let summary = ReportSummary { assets: summaries };
    // Each asset's summary as JSON once: for report.json and for the pages' stamps.
    let rows: Vec<Vec<u8>> = summary
        .assets
        .par_iter()
        .map(|a| serde_json::to_vec(a).expect("summary serialises"))
        .collect();
    write_file(&dir.join("report.json"), &summary_json(&rows))?;
    write_pages(&dir, &summary, &rows)?;
    write_viewer(&dir, &summary)?;
    Ok(Written {
        index: dir.join(html::INDEX),
        invalid_packages,
    })
}

/// The folder of an asset's pictures, under the report folder: named after the asset, so that
/// adding or removing other assets leaves it (and its pictures) where it is.
fn picture_folder(asset: &str) -> String {
    format!("a-{}", &blake3::hash(asset.as_bytes()).to_hex()[..16])
}

/// Whether a folder name is one [`picture_folder`] gives, or the index-numbered `a000` of
/// earlier reports.
fn is_picture_folder(name: &str) -> bool {
    let all = |s: &str, f: fn(&u8) -> bool| !s.is_empty() && s.as_bytes().iter().all(f);
    match name.strip_prefix("a-") {
        Some(hex) => hex.len() == 16 && all(hex, u8::is_ascii_hexdigit),
        None => name
            .strip_prefix('a')
            .is_some_and(|digits| all(digits, u8::is_ascii_digit)),
    }
}

/// Remove the picture folders (named as [`picture_folder`] names them, holding a
/// `pictures.json`) of assets no longer in the report; a failure leaves a folder behind,
/// which costs only disk.
fn remove_unused_picture_folders(dir: &Path, summaries: &[AssetSummary]) {
    let used: HashSet<String> = summaries.iter().map(|s| picture_folder(&s.name)).collect();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name().to_string_lossy().into_owned();
        if used.contains(&name) || !is_picture_folder(&name) {
            continue;
        }
        let path = entry.path();
        let ours =
            entry.file_type().is_ok_and(|t| t.is_dir()) && path.join("pictures.json").is_file();
        if ours {
            let _ = std::fs::remove_dir_all(&path);
        }
    }
}

/// `report/report.json` from each asset's summary as JSON (`{"assets": [...]}`).
fn summary_json(rows: &[Vec<u8>]) -> Vec<u8> {
    let mut json = b"{\"assets\":[".to_vec();
    for (i, row) in rows.iter().enumerate() {
        if i > 0 {
            json.push(b',');
        }
        json.extend_from_slice(row);
    }
    json.extend_from_slice(b"]}\n");
    json
}

/// The pages' memo in the report folder: the stamp each page was made from
/// ([`html::page_stamp`]) and the version of its file as written, so that a page whose rows
/// did not change is not made or written again.
const PAGES_MEMO: &str = "pages.json";

#[derive(Default, Serialize, Deserialize)]
struct PagesMemo {
    pages: BTreeMap<String, KeptPage>,
}

#[derive(Clone, Copy, Serialize, Deserialize)]
struct KeptPage {
    stamp: [u8; 32],
    file: ori_graph::FileVersion,
}

/// Write the report's pages, each only when the memo does not say its file already holds it;
/// remove the pages of a larger earlier report.
fn write_pages(dir: &Path, summary: &ReportSummary, rows: &[Vec<u8>]) -> Result<(), String> {
    let count = html::page_count(rows.len());
    remove_unused_pages(dir, count);
    let memo_path = dir.join(PAGES_MEMO);
    // A memo that cannot be read costs only making every page again.
    let memo: PagesMemo = std::fs::read(&memo_path)
        .ok()
        .and_then(|bytes| serde_json::from_slice(&bytes).ok())
        .unwrap_or_default();
    let written: Vec<Result<(String, KeptPage), String>> = (1..=count)
        .into_par_iter()
        .map(|k| {
            let file = html::page_file(k);
            let path = dir.join(&file);
            let stamp = html::page_stamp(k, count, rows);
            let version = ori_graph::FileVersion::of(&path);
            if let Some(&kept) = memo.pages.get(&file)
                && kept.stamp == stamp
                && version == Some(kept.file)
            {
                return Ok((file, kept));
            }
            // A new file each time: a reader never sees half a page, and its version changes
            // whatever the file system's clock.
            ori_graph::write_atomic(&path, html::page(summary, k, count).as_bytes())
                .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
            let version = ori_graph::FileVersion::of(&path)
                .ok_or_else(|| format!("{}: gone after writing it", path.display()))?;
            Ok((
                file,
                KeptPage {
                    stamp,
                    file: version,
                },
            ))
        })
        .collect();
    // The first failure in page order, whatever order the threads met them in; the memo
    // kept on disk then names only files this report did not write.
    let pages = written.into_iter().collect::<Result<_, String>>()?;
    let json = serde_json::to_vec(&PagesMemo { pages }).expect("memo serialises");
    // A memo that cannot be written costs only making every page again next time.
    let _ = ori_graph::write_atomic(&memo_path, &json);
    Ok(())
}

/// `viewer.html` listing every asset with a package (written only when it changed).
fn write_viewer(dir: &Path, summary: &ReportSummary) -> Result<(), String> {
    let assets: Vec<viewer::ViewerAsset> = summary
        .assets
        .iter()
        .filter_map(|a| {
            let package = a.package.as_ref()?;
            let folder = picture_folder(&a.name);
            Some(viewer::ViewerAsset {
                name: a.name.clone(),
                package: format!("../{package}"),
                mesh: a
                    .has_reference_pictures()
                    .then(|| format!("{folder}/{}", viewer::MESH_FILE)),
            })
        })
        .collect();
    let page = viewer::page(&assets);
    let path = dir.join(viewer::VIEWER);
    if std::fs::read(&path).is_ok_and(|old| old == page.as_bytes()) {
        return Ok(());
    }
    ori_graph::write_atomic(&path, page.as_bytes())
        .map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

/// Remove the asset pages beyond the `count` pages this report has (from a larger build).
fn remove_unused_pages(dir: &Path, count: usize) {
    for k in count + 1.. {
        let path = dir.join(html::page_file(k));
        if std::fs::remove_file(&path).is_err() {
            break;
        }
    }
}

/// A JSON file of the output folder, read with its type.
fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    serde_json::from_slice(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// Whether the package file has the size `release.json` lists and was not written after the
/// pictures in `folder` were drawn from it.
fn unchanged_since_drawn(package: &Path, entry: &ReleaseEntry, folder: &Path) -> bool {
    let (Ok(p), Ok(d)) = (
        std::fs::metadata(package),
        std::fs::metadata(folder.join("pictures.json")),
    ) else {
        return false;
    };
    let older = match (p.modified(), d.modified()) {
        (Ok(p), Ok(d)) => p <= d,
        _ => false,
    };
    older && entry.bytes == p.len()
}

/// Check a package file against its `release.json` entry (hash, then a validating read).
fn check_package(path: &Path, entry: &ReleaseEntry) -> Result<(), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let hash = blake3::hash(&bytes).to_hex();
    if entry.blake3 != hash.as_str() {
        return Err(format!(
            "{}: its blake3 is {hash}, release.json says {:?}",
            path.display(),
            entry.blake3
        ));
    }
    ori_package::read_any(&bytes)
        .map_err(|e| format!("{}: invalid package: {e}", path.display()))?;
    Ok(())
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

/// Where a report is written from and to, and what it draws.
struct Place<'a> {
    out_dir: &'a Path,
    assets_root: &'a Path,
    dir: &'a Path,
    access: &'a SourceAccess,
    sources: &'a SourceHashes<'a>,
    options: &'a ReportOptions,
}

fn asset_summary(a: &AssetReport, entry: Option<&ReleaseEntry>, place: &Place<'_>) -> AssetSummary {
    let Place {
        out_dir,
        assets_root,
        dir,
        sources,
        options,
        ..
    } = *place;
    let name = a.name.clone();
    let q = a.quality.as_ref();
    let mut s = AssetSummary {
        name: name.clone(),
        status: a.status.as_str().to_string(),
        error: a.error.clone(),
        faces: a.mesh.as_ref().map(|m| m.triangles as u64),
        resolution: Some(a.resolution),
        plt: q.map(|q| q.plt),
        held_out_directions: q.map(|q| q.held_out.directions),
        held_out_coverage_error_max_percent: q.map(|q| q.held_out.coverage_error_max_percent),
        held_out_coverage_error_avg_percent: q.map(|q| q.held_out.coverage_error_avg_percent),
        held_out_impostors_per_view: q.map(|q| q.held_out.impostors_per_view),
        coverage_error_min_percent: q.map(|q| q.coverage_error_min_percent),
        coverage_error_max_percent: q.map(|q| q.coverage_error_max_percent),
        coverage_error_avg_percent: q.map(|q| q.coverage_error_avg_percent),
        impostors_per_view: q.map(|q| q.impostors_per_view),
        views_by_impostor_count: q.map_or(Vec::new(), |q| {
            q.views_by_impostor_count
                .iter()
                .map(|&n| u64::from(n))
                .collect()
        }),
        jobs: a
            .jobs
            .iter()
            .map(|j| (j.stage.clone(), j.status.as_str().to_string(), j.seconds))
            .collect(),
        gate: a.gate.clone(),
        ..AssetSummary::default()
    };
    let Some(entry) = entry else {
        return s;
    };
    s.package = Some(entry.package.clone());
    s.package_bytes = Some(entry.bytes);
    s.texture_bytes = Some(entry.texture_bytes);
    let package_path = out_dir.join(&entry.package);
    let folder = picture_folder(&name);
    let stamp = stamp(&entry.blake3, &assets_root.join(&name), sources, options);
    // Pictures are reused only while the package file is the one they were drawn from (its
    // size as listed, not written since); any other package is checked in full first.
    if let Some(d) = stamp
        .as_deref()
        .and_then(|st| kept(&dir.join(&folder), dir, st))
        .filter(|_| unchanged_since_drawn(&package_path, entry, &dir.join(&folder)))
    {
        (s.impostors, s.pictures, s.p_dif) = (d.impostors, d.pictures, d.p_dif);
        s.comparison = d.comparison;
        s.notes.extend(d.notes);
        return s;
    }
    if let Err(e) = check_package(&package_path, entry) {
        s.notes.push(format!("no pictures: {e}"));
        s.invalid = Some(e);
        return s;
    }
    match pictures_of(&mut s, place, &dir.join(&folder), &folder) {
        // Only a complete set is kept: a failure is tried again next time.
        Ok(()) => {
            if let Some(stamp) = stamp {
                let drawn = Drawn {
                    stamp,
                    impostors: s.impostors,
                    pictures: s.pictures.clone(),
                    notes: s.notes.clone(),
                    p_dif: s.p_dif,
                    comparison: s.comparison.clone(),
                };
                let json = serde_json::to_vec_pretty(&drawn).expect("serialises");
                if let Err(e) = write_file(&dir.join(&folder).join("pictures.json"), &json) {
                    s.notes.push(e);
                }
            }
        }
        Err(e) => s.notes.push(e),
    }
    s
}

/// Draw every picture of an asset into `folder` (named `rel` from the report folder).
fn pictures_of(
    s: &mut AssetSummary,
    place: &Place<'_>,
    folder: &Path,
    rel: &str,
) -> Result<(), String> {
    let Place {
        out_dir,
        assets_root,
        access,
        options,
        ..
    } = *place;
    let package_path = out_dir.join(s.package.as_deref().unwrap_or_default());
    let bytes = std::fs::read(&package_path)
        .map_err(|e| format!("{}: cannot read: {e}", package_path.display()))?;
    // A hierarchy is pictured by its root: the whole object as one ORI.
    let package = match ori_package::read_any(&bytes)
        .map_err(|e| format!("{}: {e}", package_path.display()))?
    {
        ori_package::AnyPackage::Single(p) => p,
        ori_package::AnyPackage::Hierarchy(h) => {
            let leaves = h.manifest.nodes.iter();
            let leaves = leaves.filter(|n| n.children.is_empty()).count();
            let plts: Vec<f64> = h.nodes.iter().map(|n| n.manifest.plt.pixels).collect();
            let leafless = ori_hierarchy::leafless_size(&h.manifest, |i| {
                (plts[i], h.nodes[i].manifest.bounding_sphere.radius)
            });
            s.notes.push(format!(
                "A hierarchy of {} nodes ({leaves} leaves, node PLTs {:.0} to {:.0} px; no \
                 leaf mesh is drawn up to an object size of {leafless:.0} px, {:.2} x the \
                 root's PLT): the pictures show its root, the whole object as one ORI; texture \
                 bytes count every node.",
                plts.len(),
                plts.iter().copied().fold(f64::MAX, f64::min),
                plts.iter().copied().fold(0.0, f64::max),
                leafless / plts[0],
            ));
            h.nodes.into_iter().next().expect("a root")
        }
    };
    let m = &package.manifest;
    s.impostors = Some(m.impostors.len());
    let set = relief_set(&package)?;
    std::fs::create_dir_all(folder).map_err(|e| format!("{}: {e}", folder.display()))?;
    let mut save = |role: &str, file: &str, p: &Picture| -> Result<(), String> {
        p.save(&folder.join(file))?;
        s.pictures.push((role.to_string(), format!("{rel}/{file}")));
        Ok(())
    };
    // Pictures of the package alone.
    let cell = (m.resolution / 2).clamp(32, 128);
    for (channel, file) in [
        (pictures::Channel::Albedo, "maps-albedo.png"),
        (pictures::Channel::Normal, "maps-normal.png"),
        (pictures::Channel::Depth, "maps-depth.png"),
    ] {
        save(file, file, &pictures::contact_sheet(&set, channel, cell))?;
    }
    let directions = ori_views::evaluation_directions();
    let s0 = m.selection.s0.max(1);
    let percent: Vec<f64> = m
        .selection
        .entries
        .iter()
        .map(|e| 100.0 * f64::from(e.missed) / (f64::from(s0) * f64::from(s0)))
        .collect();
    save(
        "sphere",
        "sphere.png",
        &pictures::sphere_picture(&directions, &percent, m.selection.goal_percent, 360),
    )?;

    // Pictures that need the source mesh.
    let source = assets_root.join(&m.source.name);
    let source_bytes = access
        .read(&source)
        .map_err(|e| format!("no reference pictures: {e}"))?;
    if blake3::hash(&source_bytes).to_hex().as_str() != m.source.blake3 {
        return Err(format!(
            "no reference pictures: {} changed since the package was built",
            source.display()
        ));
    }
    let mesh = access
        .load(&source)
        .map_err(|e| format!("no reference pictures: {e}"))?;
    write_file(&folder.join(MESH_FILE), &mesh_bytes(&mesh))?;
    let recorded = m.recorded_march();
    let d = EvalParams::default();
    let params = EvalParams {
        s0: PICTURE_SIZE,
        linear_steps: recorded.linear_steps.unwrap_or(d.linear_steps),
        binary_steps: recorded.binary_steps.unwrap_or(d.binary_steps),
        wall_threshold: recorded.wall_threshold.unwrap_or(d.wall_threshold),
        ..d
    };
    let evaluator = Evaluator::new(&mesh, &set, &params).map_err(|e| e.to_string())?;
    let subset_for = |w: [f64; 3]| -> Vec<usize> {
        let nearest = nearest(&directions, w);
        m.selection.entries[nearest]
            .impostors
            .iter()
            .map(|&i| usize::from(i))
            .collect()
    };
    let mut p_dif = Vec::new();
    for (label, w) in VIEWS {
        let w = normalize(w);
        let ([reference, ori, error], errors) =
            pictures::comparison(&evaluator, w, &subset_for(w))?;
        p_dif.push(errors.p_dif);
        save(
            &format!("{label} reference"),
            &format!("{label}-mesh.png"),
            &reference,
        )?;
        save(&format!("{label} ori"), &format!("{label}-ori.png"), &ori)?;
        save(
            &format!("{label} error"),
            &format!("{label}-error.png"),
            &error,
        )?;
    }
    s.p_dif = Some(p_dif.iter().sum::<f64>() / p_dif.len() as f64);
    // The worst of the 320 directions, as the selection measured it.
    let worst = (0..m.selection.entries.len())
        .max_by_key(|&i| (m.selection.entries[i].missed, std::cmp::Reverse(i)))
        .unwrap_or(0);
    let w = directions[worst];
    let ([_, _, error], _) = pictures::comparison(&evaluator, w, &subset_for(w))?;
    save(
        &format!("worst view (direction {worst})"),
        "worst-error.png",
        &error,
    )?;
    if let Some(count) = options.compare_directions {
        let eval = EvalParams {
            s0: m.selection.s0,
            ..params.clone()
        };
        let subsets = Box::new(subset_for);
        let ori = ori_rivals::Relief::ori_with(&mesh, &set, subsets, &eval)
            .map_err(|e| format!("comparison: {e}"))?;
        s.comparison = compare(&mesh, &set, &ori, count, m.selection.s0)
            .map_err(|e| format!("comparison: {e}"))?;
    }
    // Figure 2: how many impostors sample each triangle.
    let impostor_dirs: Vec<[f64; 3]> = m.impostors.iter().map(|i| i.direction).collect();
    let counts = ori_views::sampling_coverage_with_visible(
        &mesh,
        &impostor_dirs,
        m.resolution,
        vec![true; mesh.triangles.len()],
    )
    .counts;
    for (label, w) in [VIEWS[0], VIEWS[3]] {
        let p = pictures::sampling_picture(&mesh, &counts, normalize(w), PICTURE_SIZE);
        save(
            &format!("sampling {label}"),
            &format!("sampling-{label}.png"),
            &p,
        )?;
    }
    Ok(())
}

/// Every rival technique baked within the ORI's texture bytes and measured with it at
/// `count` held-out directions ([`ori_rivals::held_out_sample`]).
fn compare(
    mesh: &ori_mesh::Mesh,
    set: &ori_relief::ReliefSet,
    ori: &dyn ori_rivals::Rival,
    count: usize,
    s0: u32,
) -> Result<Vec<ori_rivals::Row>, ori_rivals::RivalError> {
    let seed = ori_views::DEFAULT_HELD_OUT_SEED;
    let texels = set.maps.iter().map(|m| u64::from(m.size()).pow(2)).sum();
    let budget = ori_rivals::relief_bytes(texels);
    let tuning = ori_rivals::References::new(mesh, &ori_rivals::tuning_directions(seed), s0)?;
    let rivals =
        ori_rivals::Rivals::bake(mesh, budget, &ori_rivals::Technique::ALL, &tuning, &|_| ())?;
    let all = rivals.all(mesh)?;
    let mut drawn: Vec<&dyn ori_rivals::Rival> = all.iter().map(|r| r.as_ref() as _).collect();
    drawn.push(ori);
    let directions = ori_rivals::held_out_sample(seed, count);
    ori_rivals::compare(mesh, &drawn, &directions, s0)
}

fn normalize(w: [f64; 3]) -> [f64; 3] {
    let l = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    w.map(|c| c / l)
}

/// Index of the direction nearest to `w` (largest dot product, lowest index on ties), as the
/// runtime looks up the selection table.
fn nearest(directions: &[[f64; 3]], w: [f64; 3]) -> usize {
    let mut best = (0, f64::NEG_INFINITY);
    for (i, d) in directions.iter().enumerate() {
        let dot = d[0] * w[0] + d[1] * w[1] + d[2] * w[2];
        if dot > best.1 {
            best = (i, dot);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_picture_folders_are_taken_for_ours() {
        assert!(is_picture_folder(&picture_folder("f/a.obj")));
        assert!(is_picture_folder("a000") && is_picture_folder("a1234"));
        for other in [
            "a",
            "a-",
            "a-0123",
            "a-0123456789abcdeg",
            "assets",
            "b000",
            "a0x",
        ] {
            assert!(!is_picture_folder(other), "{other}");
        }
    }

    fn summary_of(names: usize) -> ReportSummary {
        ReportSummary {
            assets: (0..names)
                .map(|i| AssetSummary {
                    name: format!("f/{i:04}.obj"),
                    status: "ok".into(),
                    ..AssetSummary::default()
                })
                .collect(),
        }
    }

    fn rows(summary: &ReportSummary) -> Vec<Vec<u8>> {
        let rows = summary.assets.iter();
        rows.map(|a| serde_json::to_vec(a).unwrap()).collect()
    }

    fn versions(dir: &Path, count: usize) -> Vec<Option<ori_graph::FileVersion>> {
        let files = (1..=count).map(html::page_file);
        files
            .map(|f| ori_graph::FileVersion::of(&dir.join(f)))
            .collect()
    }

    /// Every page holds what it would be made into now.
    fn assert_current(dir: &Path, summary: &ReportSummary) {
        let count = html::page_count(summary.assets.len());
        for k in 1..=count {
            let file = dir.join(html::page_file(k));
            let written = std::fs::read_to_string(&file).unwrap();
            assert!(
                written == html::page(summary, k, count),
                "{}",
                file.display()
            );
        }
    }

    #[test]
    fn only_pages_whose_rows_changed_are_written_again() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let mut summary = summary_of(2 * html::ASSETS_PER_PAGE + 7);
        write_pages(dir, &summary, &rows(&summary)).unwrap();
        assert_current(dir, &summary);
        let first = versions(dir, 3);
        assert!(first.iter().all(Option::is_some));

        // Nothing changed: nothing written.
        write_pages(dir, &summary, &rows(&summary)).unwrap();
        assert_eq!(versions(dir, 3), first);

        // An asset of the third page: its page and the index (which lists every asset).
        summary.assets[2 * html::ASSETS_PER_PAGE + 1].faces = Some(12);
        write_pages(dir, &summary, &rows(&summary)).unwrap();
        assert_current(dir, &summary);
        let second = versions(dir, 3);
        assert!(second[0] != first[0] && second[1] == first[1] && second[2] != first[2]);

        // A page changed by someone else is made again; a removed one too.
        std::fs::write(dir.join(html::page_file(2)), "edited").unwrap();
        std::fs::remove_file(dir.join(html::page_file(3))).unwrap();
        write_pages(dir, &summary, &rows(&summary)).unwrap();
        assert_current(dir, &summary);

        // A damaged memo costs making every page again, nothing else.
        std::fs::write(dir.join(PAGES_MEMO), "{").unwrap();
        write_pages(dir, &summary, &rows(&summary)).unwrap();
        assert_current(dir, &summary);

        // Fewer assets: the pages beyond are removed.
        let fewer = summary_of(3);
        write_pages(dir, &fewer, &rows(&fewer)).unwrap();
        assert_current(dir, &fewer);
        assert!(!dir.join(html::page_file(2)).exists());
    }
}
