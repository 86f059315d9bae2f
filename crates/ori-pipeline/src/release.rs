//! The release folder: one `.ori` package per built asset and `release.json`, which lists
//! every package with its content hash, so that `cargo xtask verify` can check a copy.
//!
//! Nothing here depends on time, paths outside the folder or thread count: the same packages
//! give the same folder, byte for byte.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use walkdir::WalkDir;

pub use ori_release::{RELEASE_JSON, Release, ReleaseEntry, package_path};

/// The release entry of a package, checking the package as a reader would and that it was
/// built from the asset `name`.
pub fn entry(name: &str, bytes: &[u8]) -> Result<ReleaseEntry, String> {
    let package = ori_package::read_any(bytes).map_err(|e| format!("invalid package: {e}"))?;
    let source = &package.root().manifest.source.name;
    if source != name {
        return Err(format!(
            "the package was built from `{source}`, but is listed as `{name}`"
        ));
    }
    // A hierarchy's PLT is its root's: the whole object drawn as one ORI.
    let plt = &package.root().manifest.plt;
    Ok(ReleaseEntry {
        name: name.to_string(),
        package: package_path(name),
        blake3: blake3::hash(bytes).to_hex().to_string(),
        bytes: bytes.len() as u64,
        plt: plt.pixels,
        plt_at_least: plt.at_least,
        texture_bytes: package.texture_bytes(),
        nodes: match &package {
            ori_package::AnyPackage::Single(_) => None,
            ori_package::AnyPackage::Hierarchy(h) => Some(h.nodes.len()),
        },
    })
}

/// A release written, and what the user should know about the folder.
#[derive(Clone, Debug)]
pub struct Written {
    pub release: Release,
    /// Files left alone that look like someone else's (one line each).
    pub warnings: Vec<String>,
}

/// Write `packages` (asset name, package bytes; sorted by name) and `release.json` into
/// `dir`. Packages first, the index last, so the index never names a file not yet written.
/// The builder removes only what it wrote: the packages the folder's previous `release.json`
/// lists that are not part of this release, so the folder is the same as a clean build's.
/// Any other `.ori` file is left alone, with a warning. A package whose bytes are already
/// there is not rewritten.
pub fn write(dir: &Path, packages: &[(String, Vec<u8>)]) -> Result<Written, (PathBuf, String)> {
    let mut warnings = Vec::new();
    let previous = previous_packages(dir, &mut warnings);
    let mut assets = Vec::new();
    let mut seen = BTreeSet::new();
    for (name, bytes) in packages {
        let e = entry(name, bytes).map_err(|m| (PathBuf::from(name), m))?;
        if !seen.insert(e.package.clone()) {
            return Err((
                dir.join(&e.package),
                format!("two assets would write this package (the second is {name}); rename one"),
            ));
        }
        let path = dir.join(&e.package);
        if std::fs::read(&path).ok().as_deref() != Some(bytes.as_slice()) {
            ori_graph::write_atomic(&path, bytes)
                .map_err(|err| (path.clone(), format!("cannot write: {err}")))?;
        }
        assets.push(e);
    }
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
    Ok(Written { release, warnings })
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

/// `.ori` files under `dir`, relative, `/` separators, sorted.
fn ori_files(dir: &Path) -> BTreeSet<String> {
    WalkDir::new(dir)
        .sort_by_file_name()
        .into_iter()
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
    let mut problems = Vec::new();
    let mut listed = BTreeSet::new();
    for want in &release.assets {
        let path = dir.join(&want.package);
        listed.insert(want.package.clone());
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                problems.push(format!("{}: cannot read: {e}", path.display()));
                continue;
            }
        };
        let got = match entry(&want.name, &bytes) {
            Ok(got) => got,
            Err(e) => {
                problems.push(format!("{}: {e}", path.display()));
                continue;
            }
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
        for (what, w, g) in checks {
            if w != g {
                problems.push(format!(
                    "{}: {what} is {g}, release.json says {w}",
                    path.display()
                ));
            }
        }
    }
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
