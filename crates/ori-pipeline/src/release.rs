//! The release folder: one `.ori` package per built asset and `release.json`, which lists
//! every package with its content hash, so that `cargo xtask verify` can check a copy.
//!
//! Nothing here depends on time, paths outside the folder or thread count: the same packages
//! give the same folder, byte for byte.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use ori_graph::{BlobRef, Cache, ContentHash, MemoMap, SourceHasher, SourceRules};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use walkdir::WalkDir;

pub use ori_release::{RELEASE_JSON, Release, ReleaseEntry, package_path};

/// A built asset's package, as the cache holds it: read only when the release needs it.
pub struct BuiltPackage<'a> {
    pub name: String,
    pub blob: BlobRef,
    /// The bytes, verified against `blob`.
    pub read: Box<dyn Fn() -> Result<Vec<u8>, String> + Send + Sync + 'a>,
}

/// What a release entry says about a package's content, found by checking the package as a
/// reader would: a pure function of its bytes, so it is remembered by their hash.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Checked {
    /// The hash of the bytes checked (what the memo file is named after).
    blake3: String,
    bytes: u64,
    /// The asset the package says it was built from.
    source: String,
    plt: f64,
    plt_at_least: bool,
    texture_bytes: u64,
    nodes: Option<usize>,
}

fn check(bytes: &[u8]) -> Result<Checked, String> {
    let package = ori_package::read_any(bytes).map_err(|e| format!("invalid package: {e}"))?;
    // A hierarchy's PLT is its root's: the whole object drawn as one ORI.
    let plt = &package.root().manifest.plt;
    Ok(Checked {
        blake3: blake3::hash(bytes).to_hex().to_string(),
        bytes: bytes.len() as u64,
        source: package.root().manifest.source.name.clone(),
        plt: plt.pixels,
        plt_at_least: plt.at_least,
        texture_bytes: package.texture_bytes(),
        nodes: match &package {
            ori_package::AnyPackage::Single(_) => None,
            ori_package::AnyPackage::Hierarchy(h) => Some(h.nodes.len()),
        },
    })
}

/// The release entry of a checked package, if it was built from the asset `name`.
fn entry_of(name: &str, checked: Checked) -> Result<ReleaseEntry, String> {
    if checked.source != name {
        return Err(format!(
            "the package was built from `{}`, but is listed as `{name}`",
            checked.source
        ));
    }
    Ok(ReleaseEntry {
        name: name.to_string(),
        package: package_path(name),
        blake3: checked.blake3,
        bytes: checked.bytes,
        plt: checked.plt,
        plt_at_least: checked.plt_at_least,
        texture_bytes: checked.texture_bytes,
        nodes: checked.nodes,
    })
}

/// The release entry of a package, checking the package as a reader would and that it was
/// built from the asset `name`.
pub fn entry(name: &str, bytes: &[u8]) -> Result<ReleaseEntry, String> {
    entry_of(name, check(bytes)?)
}

/// What earlier builds learnt, kept in the cache folder so that a release whose packages are
/// unchanged is written without reading them: the check of each package content seen (by
/// hash), and a stat memo of the release folders' files (the same sealed memo, with its racy
/// window, that sources use).
pub struct ReleaseMemo {
    /// Checks by package hash, as loaded, and those this build made.
    checked: MemoMap<ContentHash, Checked>,
    files: SourceHasher,
}

/// The checks' folder under the cache root (an [`ori_graph::MemoMap`] by package hash).
const CHECKED_MEMO: &str = "release-checks";

/// Bumped when what a check records changes.
const CHECKED_VERSION: u32 = 1;

impl ReleaseMemo {
    pub fn open(cache: &Cache) -> ReleaseMemo {
        ReleaseMemo {
            // A damaged memo only costs checking again.
            checked: MemoMap::open(cache.root().join(CHECKED_MEMO), CHECKED_VERSION),
            files: SourceHasher::new(
                cache.root().join("release-stat-memo.json"),
                SourceRules::default(),
            ),
        }
    }

    /// The remembered check of the content `blob`; `None` (check again) when there is none or
    /// it is for other bytes.
    fn checked(&self, blob: &BlobRef) -> Option<Checked> {
        self.known_check(blob).cloned()
    }

    fn known_check(&self, blob: &BlobRef) -> Option<&Checked> {
        let checked = self.checked.get(&blob.hash)?;
        (checked.blake3 == blob.hash.to_hex() && checked.bytes == blob.size).then_some(checked)
    }

    /// Whether the check of the content `blob` is known (so checking it reads nothing).
    pub fn knows(&self, blob: &BlobRef) -> bool {
        self.known_check(blob).is_some()
    }

    /// Remember a check (saved with [`ReleaseMemo::save`]).
    fn remember(&self, checked: &Checked, hash: &ContentHash) {
        self.checked.set(*hash, Some(checked.clone()));
    }

    /// Write the checks this build made into the memo, merged with those another builder
    /// may have written since it was loaded.
    fn save(&self) -> std::io::Result<()> {
        self.checked.save()
    }

    /// Whether the file at `path` holds the content `blob` (from the stat memo when the file
    /// is unchanged since it was last hashed).
    pub fn holds(&self, path: &Path, blob: &BlobRef) -> bool {
        matches!(self.files.hash(path), Ok(Some(h)) if h == blob.hash)
    }
}

/// A release written, and what the user should know about the folder.
#[derive(Clone, Debug)]
pub struct Written {
    pub release: Release,
    /// Files left alone that look like someone else's (one line each).
    pub warnings: Vec<String>,
}

/// Write `packages` (sorted by asset name; each read from the cache only when needed) and
/// `release.json` into `dir`. Two assets with the same package path are refused before
/// anything is written; packages are written first (in parallel), the index last, so the
/// index never names a file not yet written; after a failure, `release.json` is not written.
/// The builder removes only what it wrote: the packages the folder's previous `release.json`
/// lists that are not part of this release, so the folder is the same as a clean build's.
/// Any other `.ori` file is left alone, with a warning. A package whose bytes are already
/// there is not rewritten, and is not read when `memo` knows both its check and the file.
pub fn write(
    dir: &Path,
    packages: &[BuiltPackage<'_>],
    memo: &ReleaseMemo,
) -> Result<Written, (PathBuf, String)> {
    let mut warnings = Vec::new();
    let previous = previous_packages(dir, &mut warnings);
    let mut seen = BTreeSet::new();
    for p in packages {
        let package = package_path(&p.name);
        if seen.contains(&package) {
            return Err((
                dir.join(&package),
                format!(
                    "two assets would write this package (the second is {}); rename one",
                    p.name
                ),
            ));
        }
        seen.insert(package);
    }
    // Packages are checked and written in parallel, each read only when the memos do not
    // know its check or that its file already holds it.
    let placed: Vec<Result<ReleaseEntry, _>> =
        packages.par_iter().map(|p| place(dir, p, memo)).collect();
    // The first failure in asset order, whatever order the threads met them in.
    let assets = placed.into_iter().collect::<Result<Vec<_>, _>>()?;
    for stale in previous.difference(&seen) {
        let path = dir.join(stale);
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
            std::fs::remove_file(&path)
                .map_err(|err| (path, format!("cannot remove a stale package: {err}")))?;
        }
    }
    let foreign: Vec<String> = ori_files(dir)
        .into_iter()
        .filter(|f| !seen.contains(f) && !previous.contains(f))
        .collect();
    if !foreign.is_empty() {
        let shown: Vec<&str> = foreign.iter().take(3).map(String::as_str).collect();
        warnings.push(format!(
            "{}: {} .ori file(s) this builder did not write were left alone ({}{}); \
             is --out another release's folder?",
            dir.display(),
            foreign.len(),
            shown.join(", "),
            if foreign.len() > shown.len() {
                ", ..."
            } else {
                ""
            }
        ));
    }
    let release = Release {
        release_version: 1,
        tool: crate::stages::package::tool(),
        assets,
    };
    let path = dir.join(RELEASE_JSON);
    let mut json = serde_json::to_vec_pretty(&release).expect("release serialises");
    json.push(b'\n');
    ori_graph::write_atomic(&path, &json).map_err(|err| (path, format!("cannot write: {err}")))?;
    if let Err(e) = memo.files.save().and_then(|()| memo.save()) {
        warnings.push(format!("cannot save the release memos: {e}"));
    }
    Ok(Written { release, warnings })
}

/// A package's release entry, its file in `dir` written unless it already holds the
/// package. The package is checked (from the memo when it knows the content) and the file
/// compared (from the stat memo when the file is unchanged); the bytes are read only when
/// one of the two needs them.
fn place(
    dir: &Path,
    p: &BuiltPackage<'_>,
    memo: &ReleaseMemo,
) -> Result<ReleaseEntry, (PathBuf, String)> {
    let name = &p.name;
    let fail = |m: String| (PathBuf::from(name), m);
    let mut bytes = None;
    let checked = match memo.checked(&p.blob) {
        Some(c) => c,
        None => {
            let b = (p.read)().map_err(fail)?;
            let c = check(&b).map_err(fail)?;
            memo.remember(&c, &p.blob.hash);
            bytes = Some(b);
            c
        }
    };
    let entry = entry_of(name, checked).map_err(fail)?;
    let path = dir.join(&entry.package);
    if !memo.holds(&path, &p.blob) {
        let bytes = match bytes {
            Some(b) => b,
            None => (p.read)().map_err(fail)?,
        };
        ori_graph::write_atomic(&path, &bytes)
            .map_err(|err| (path.clone(), format!("cannot write: {err}")))?;
        memo.files.record(&path, p.blob.hash);
    }
    Ok(entry)
}

/// The packages the folder's `release.json` lists, which this builder wrote. Only entries
/// whose package path is the one their name gives (relative, no `..`, ending in `.ori`) are
/// taken, so a damaged or hostile index cannot name a file elsewhere.
fn previous_packages(dir: &Path, warnings: &mut Vec<String>) -> BTreeSet<String> {
    let index = dir.join(RELEASE_JSON);
    let Ok(bytes) = std::fs::read(&index) else {
        return BTreeSet::new();
    };
    let Ok(release) = serde_json::from_slice::<Release>(&bytes) else {
        warnings.push(format!(
            "{}: not a release index; no earlier package is removed",
            index.display()
        ));
        return BTreeSet::new();
    };
    release
        .assets
        .into_iter()
        .map(|e| e.package)
        .filter(|p| owned_package_path(p))
        .collect()
}

/// Whether `package` is a path [`package_path`] can give: relative, `/`-separated, no empty,
/// `.` or `..` component, ending in `.ori`.
fn owned_package_path(package: &str) -> bool {
    package.ends_with(".ori")
        && !package.starts_with('/')
        && !package.contains('\\')
        && package
            .split('/')
            .all(|c| !c.is_empty() && c != "." && c != "..")
}

/// `.ori` files under `dir`, relative, `/` separators, sorted; the report's folder (its
/// pictures, no package) is not searched.
fn ori_files(dir: &Path) -> BTreeSet<String> {
    WalkDir::new(dir)
        .sort_by_file_name()
        .into_iter()
        .filter_entry(|e| !(e.depth() == 1 && e.file_name() == ori_release::REPORT_DIR))
        .filter_map(Result::ok)
        .filter(|e| e.file_type().is_file() && e.path().extension().is_some_and(|x| x == "ori"))
        .filter_map(|e| {
            let rel = e.path().strip_prefix(dir).ok()?;
            let parts: Vec<_> = rel.iter().map(|c| c.to_string_lossy()).collect();
            Some(parts.join("/"))
        })
        .collect()
}

/// Check a release folder against its `release.json`: every listed package exists, has the
/// listed size and hash, reads back valid, and has the listed PLT and texture bytes; no
/// unlisted package lies beside them. Returns the number of packages checked, or every
/// mismatch found (each naming its file).
pub fn verify(dir: &Path) -> Result<usize, Vec<String>> {
    let index = dir.join(RELEASE_JSON);
    let release: Release = match std::fs::read(&index) {
        Err(e) => return Err(vec![format!("{}: cannot read: {e}", index.display())]),
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map_err(|e| vec![format!("{}: not a release index: {e}", index.display())])?,
    };
    // Packages are checked in parallel (each read whole once: a package is checked as a
    // reader would read it); problems are listed in asset order.
    let per_package: Vec<Vec<String>> = release
        .assets
        .par_iter()
        .map(|want| verify_package(dir, want))
        .collect();
    let mut problems: Vec<String> = per_package.into_iter().flatten().collect();
    let listed: BTreeSet<String> = release.assets.iter().map(|e| e.package.clone()).collect();
    for extra in ori_files(dir).difference(&listed) {
        problems.push(format!(
            "{}: not listed in release.json",
            dir.join(extra).display()
        ));
    }
    if problems.is_empty() {
        Ok(release.assets.len())
    } else {
        Err(problems)
    }
}

/// What is wrong with one listed package (nothing when it matches its entry).
fn verify_package(dir: &Path, want: &ReleaseEntry) -> Vec<String> {
    if !owned_package_path(&want.package) {
        return vec![format!(
            "{}: {:?} is not a package path inside the folder",
            dir.join(RELEASE_JSON).display(),
            want.package
        )];
    }
    let path = dir.join(&want.package);
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => return vec![format!("{}: cannot read: {e}", path.display())],
    };
    let got = match entry(&want.name, &bytes) {
        Ok(got) => got,
        Err(e) => return vec![format!("{}: {e}", path.display())],
    };
    let checks = [
        ("size", want.bytes.to_string(), got.bytes.to_string()),
        ("blake3", want.blake3.clone(), got.blake3.clone()),
        ("package name", want.package.clone(), got.package.clone()),
        ("PLT", want.plt.to_string(), got.plt.to_string()),
        (
            "PLT bound",
            want.plt_at_least.to_string(),
            got.plt_at_least.to_string(),
        ),
        (
            "texture bytes",
            want.texture_bytes.to_string(),
            got.texture_bytes.to_string(),
        ),
    ];
    checks
        .into_iter()
        .filter(|(_, w, g)| w != g)
        .map(|(what, w, g)| format!("{}: {what} is {g}, release.json says {w}", path.display()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verify_reads_no_file_outside_the_folder() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("release");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(root.path().join("outside.ori"), b"not yours").unwrap();
        let release = Release {
            release_version: 1,
            tool: "test".into(),
            assets: vec![ReleaseEntry {
                name: "a.obj".into(),
                package: "../outside.ori".into(),
                blake3: String::new(),
                bytes: 9,
                plt: 1.0,
                plt_at_least: false,
                texture_bytes: 0,
                nodes: None,
            }],
        };
        std::fs::write(
            dir.join(RELEASE_JSON),
            serde_json::to_vec(&release).unwrap(),
        )
        .unwrap();
        let problems = verify(&dir).unwrap_err();
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(
            problems[0].contains("\"../outside.ori\" is not a package path"),
            "{problems:?}"
        );
    }
}
