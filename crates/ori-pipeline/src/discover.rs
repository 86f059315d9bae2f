//! Finding the assets under the assets folder.

use std::path::{Path, PathBuf};

use crate::PipelineError;
use crate::config::{AssetsConfig, glob};

/// One model file to build.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Asset {
    /// Path under the assets folder with `/` separators: the asset's name everywhere.
    pub name: String,
    /// Where the file is.
    pub path: PathBuf,
}

/// Every file under `root` that an include glob matches and no exclude glob does, sorted by
/// name. Hidden files and folders (starting with `.`) are skipped; symbolic links are not
/// followed.
pub fn discover(root: &Path, config: &AssetsConfig) -> Result<Vec<Asset>, PipelineError> {
    if !root.is_dir() {
        return Err(PipelineError::Assets(format!(
            "assets folder {} does not exist",
            root.display()
        )));
    }
    let compile =
        |patterns: &[String]| -> Vec<_> { patterns.iter().filter_map(|p| glob(p).ok()).collect() };
    let (include, exclude) = (compile(&config.include), compile(&config.exclude));
    let mut assets = Vec::new();
    let walker = walkdir::WalkDir::new(root)
        .sort_by_file_name()
        .into_iter()
        .filter_entry(|e| e.depth() == 0 || !e.file_name().to_string_lossy().starts_with('.'));
    for entry in walker {
        let entry = entry.map_err(|e| PipelineError::Assets(format!("cannot scan assets: {e}")))?;
        if !entry.file_type().is_file() {
            continue;
        }
        let relative = entry.path().strip_prefix(root).unwrap_or(entry.path());
        let name = relative
            .components()
            .map(|c| c.as_os_str().to_string_lossy())
            .collect::<Vec<_>>()
            .join("/");
        if include.iter().any(|g| g.is_match(&name)) && !exclude.iter().any(|g| g.is_match(&name)) {
            assets.push(Asset {
                name,
                path: entry.path().to_path_buf(),
            });
        }
    }
    assets.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(assets)
}
