//! `pipeline.toml`: where assets are, where outputs and the cache go, and the parameters of
//! every stage, with per-asset overrides chosen by glob.

use std::path::{Path, PathBuf};

use globset::{GlobBuilder, GlobMatcher};
use serde::{Deserialize, Serialize};

use crate::PipelineError;

/// The parsed configuration. Relative paths are resolved against `base_dir` (the folder of the
/// configuration file).
#[derive(Clone, Debug)]
pub struct Config {
    /// The file it was read from, for messages.
    pub path: PathBuf,
    pub base_dir: PathBuf,
    pub assets: AssetsConfig,
    pub cache: CacheConfig,
    pub output: OutputConfig,
    /// Stage parameters before overrides.
    stages: toml::Table,
    overrides: Vec<Override>,
}

/// `[assets]`: which files are assets.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AssetsConfig {
    /// Folder scanned for models.
    pub root: PathBuf,
    /// Globs, relative to `root`, of the files that are assets.
    pub include: Vec<String>,
    /// Globs of files to leave out even though `include` matches them.
    pub exclude: Vec<String>,
}

impl Default for AssetsConfig {
    fn default() -> Self {
        AssetsConfig {
            root: PathBuf::from("samples"),
            include: ["**/*.gltf", "**/*.glb", "**/*.obj", "**/*.ply"]
                .map(String::from)
                .to_vec(),
            exclude: Vec::new(),
        }
    }
}

/// `[cache]`: the local artifact cache.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CacheConfig {
    pub dir: PathBuf,
}

impl Default for CacheConfig {
    fn default() -> Self {
        CacheConfig {
            dir: PathBuf::from("target/ori-cache"),
        }
    }
}

/// `[output]`: where the build writes its results.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    pub dir: PathBuf,
}

impl Default for OutputConfig {
    fn default() -> Self {
        OutputConfig {
            dir: PathBuf::from("target/ori-out"),
        }
    }
}

/// Parameters of every stage for one asset, after overrides.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StageParams {
    #[serde(default)]
    pub ingest: IngestParams,
    #[serde(default)]
    pub views: ori_views::ViewParams,
    #[serde(default)]
    pub bake: ori_bake::BakeParams,
    #[serde(default)]
    pub select: ori_select::SelectParams,
    #[serde(default)]
    pub compress: crate::package::CompressParams,
    /// `[plt]`: the target of `bake.resolution = "auto"`.
    #[serde(default)]
    pub plt: ori_plt::PltParams,
    /// `bake.resolution = "auto"`: the build picks the resolution (see `ori_plt::auto`);
    /// `bake.resolution` then holds the default until it does.
    #[serde(skip)]
    pub auto_resolution: bool,
}

/// `[ingest]`: mesh loading.
#[derive(Clone, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct IngestParams {
    /// Ignore the normals stored in the files and compute angle-weighted ones everywhere.
    pub recompute_normals: bool,
}

/// One `[[overrides]]` table: stage parameters for the assets its glob matches.
#[derive(Clone, Debug)]
struct Override {
    pattern: String,
    matcher: GlobMatcher,
    stages: toml::Table,
}

/// The file as written; the stage sections are kept as tables so overrides can be merged
/// into them key by key before they are checked.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ConfigFile {
    #[serde(default)]
    assets: AssetsConfig,
    #[serde(default)]
    cache: CacheConfig,
    #[serde(default)]
    output: OutputConfig,
    #[serde(default)]
    ingest: Option<toml::Table>,
    #[serde(default)]
    views: Option<toml::Table>,
    #[serde(default)]
    bake: Option<toml::Table>,
    #[serde(default)]
    select: Option<toml::Table>,
    #[serde(default)]
    compress: Option<toml::Table>,
    #[serde(default)]
    plt: Option<toml::Table>,
    #[serde(default)]
    overrides: Vec<OverrideFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OverrideFile {
    /// Glob over asset paths relative to the assets root, e.g. `trees/**`.
    assets: String,
    #[serde(default)]
    ingest: Option<toml::Table>,
    #[serde(default)]
    views: Option<toml::Table>,
    #[serde(default)]
    bake: Option<toml::Table>,
    #[serde(default)]
    select: Option<toml::Table>,
    #[serde(default)]
    compress: Option<toml::Table>,
    #[serde(default)]
    plt: Option<toml::Table>,
}

/// A glob where `*` stays within one path component and `**` crosses them.
pub(crate) fn glob(pattern: &str) -> Result<GlobMatcher, globset::Error> {
    Ok(GlobBuilder::new(pattern)
        .literal_separator(true)
        .build()?
        .compile_matcher())
}

/// The stage sections present in a file (or an override), by name.
fn stage_tables(sections: [(&str, Option<toml::Table>); 6]) -> toml::Table {
    let mut t = toml::Table::new();
    for (name, section) in sections {
        if let Some(section) = section {
            t.insert(name.into(), toml::Value::Table(section));
        }
    }
    t
}

/// Merge `over` into `base`: tables recursively, other values replaced.
fn merge(base: &mut toml::Table, over: &toml::Table) {
    for (key, value) in over {
        match (base.get_mut(key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            _ => {
                base.insert(key.clone(), value.clone());
            }
        }
    }
}

/// Deserialise stage sections and check their values.
fn to_params(mut table: toml::Table) -> Result<StageParams, String> {
    let bake = table.get_mut("bake").and_then(|b| b.as_table_mut());
    let auto = match bake {
        Some(bake) if bake.get("resolution").and_then(|r| r.as_str()) == Some("auto") => {
            bake.remove("resolution");
            true
        }
        _ => false,
    };
    let mut params =
        StageParams::deserialize(toml::Value::Table(table)).map_err(|e| e.message().to_string())?;
    params.auto_resolution = auto;
    params.plt.validate()?;
    params.views.validate().map_err(|e| e.to_string())?;
    params.bake.validate().map_err(|e| e.to_string())?;
    params.select.validate().map_err(|e| e.to_string())?;
    Ok(params)
}

impl Config {
    /// Read and check a configuration file: unknown keys, bad globs and bad parameter values
    /// (in the base sections and in every override) are errors that name the file.
    pub fn load(path: &Path) -> Result<Config, PipelineError> {
        let text = std::fs::read_to_string(path).map_err(|e| PipelineError::Config {
            path: path.to_path_buf(),
            message: format!("cannot read: {e}"),
        })?;
        Config::parse(path, &text)
    }

    /// Parse configuration text; `path` names it in messages and gives the base folder.
    pub fn parse(path: &Path, text: &str) -> Result<Config, PipelineError> {
        let fail = |message: String| PipelineError::Config {
            path: path.to_path_buf(),
            message,
        };
        let file: ConfigFile = toml::from_str(text).map_err(|e| fail(e.to_string()))?;
        let stages = stage_tables([
            ("ingest", file.ingest),
            ("views", file.views),
            ("bake", file.bake),
            ("select", file.select),
            ("compress", file.compress),
            ("plt", file.plt),
        ]);
        to_params(stages.clone()).map_err(fail)?;
        let mut overrides = Vec::new();
        for (i, o) in file.overrides.into_iter().enumerate() {
            let what = format!("[[overrides]] #{} (assets = {:?})", i + 1, o.assets);
            let matcher = glob(&o.assets).map_err(|e| fail(format!("{what}: {e}")))?;
            let over = stage_tables([
                ("ingest", o.ingest),
                ("views", o.views),
                ("bake", o.bake),
                ("select", o.select),
                ("compress", o.compress),
                ("plt", o.plt),
            ]);
            let mut merged = stages.clone();
            merge(&mut merged, &over);
            to_params(merged).map_err(|e| fail(format!("{what}: {e}")))?;
            overrides.push(Override {
                pattern: o.assets,
                matcher,
                stages: over,
            });
        }
        for pattern in file.assets.include.iter().chain(&file.assets.exclude) {
            glob(pattern).map_err(|e| fail(format!("[assets] pattern {pattern:?}: {e}")))?;
        }
        Ok(Config {
            path: path.to_path_buf(),
            base_dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
            assets: file.assets,
            cache: file.cache,
            output: file.output,
            stages,
            overrides,
        })
    }

    /// Stage parameters for the asset at `relative` (its path under the assets root, with
    /// `/` separators): the base sections with every matching override applied in file order.
    pub fn params_for(&self, relative: &str) -> StageParams {
        let mut merged = self.stages.clone();
        for o in self
            .overrides
            .iter()
            .filter(|o| o.matcher.is_match(relative))
        {
            merge(&mut merged, &o.stages);
        }
        to_params(merged).expect("every override combination was checked at load")
    }

    /// The override patterns, in file order.
    pub fn override_patterns(&self) -> impl Iterator<Item = &str> {
        self.overrides.iter().map(|o| o.pattern.as_str())
    }

    /// Resolve a configured path against the configuration's folder.
    pub fn resolve(&self, path: &Path) -> PathBuf {
        self.base_dir.join(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Config, String> {
        Config::parse(Path::new("conf/pipeline.toml"), text).map_err(|e| e.to_string())
    }

    #[test]
    fn defaults_when_empty() {
        let c = parse("").unwrap();
        assert_eq!(c.assets.root, PathBuf::from("samples"));
        assert_eq!(c.params_for("a.obj"), StageParams::default());
        assert_eq!(
            c.resolve(&c.cache.dir),
            PathBuf::from("conf/target/ori-cache")
        );
    }

    #[test]
    fn unknown_keys_are_named_with_the_valid_ones() {
        let e = parse("[ingest]\nrecompute_normal = true\n").unwrap_err();
        assert!(e.starts_with("conf/pipeline.toml: "), "{e}");
        assert!(e.contains("unknown field `recompute_normal`"), "{e}");
        assert!(e.contains("recompute_normals"), "{e}");
        let e = parse("[baking]\nn = 3\n").unwrap_err();
        assert!(
            e.contains("unknown field `baking`") && e.contains("bake"),
            "{e}"
        );
        let e = parse("[bake]\nresolutoin = 3\n").unwrap_err();
        assert!(
            e.contains("`resolutoin`") && e.contains("resolution"),
            "{e}"
        );
        let e = parse("[[overrides]]\nassets = \"t/**\"\ningest = { nope = 1 }\n").unwrap_err();
        assert!(
            e.contains("#1") && e.contains("t/**") && e.contains("`nope`"),
            "{e}"
        );
        let e = parse("[ingest]\nrecompute_normals = 3\n").unwrap_err();
        assert!(e.contains("invalid type"), "{e}");
        let e = parse("[views]\ncount = 7\n").unwrap_err();
        assert!(e.contains("views.count = 7"), "{e}");
        let e = parse("[[overrides]]\nassets = \"*\"\nbake.supersample = 9\n").unwrap_err();
        assert!(e.contains("bake.supersample = 9"), "{e}");
    }

    #[test]
    fn overrides_apply_by_glob_in_order() {
        let c = parse(
            "[[overrides]]\nassets = \"trees/**\"\ningest.recompute_normals = true\n\
             [[overrides]]\nassets = \"trees/palm/*.glb\"\ningest.recompute_normals = false\n",
        )
        .unwrap();
        assert!(c.params_for("trees/oak/oak.obj").ingest.recompute_normals);
        assert!(!c.params_for("trees/palm/p.glb").ingest.recompute_normals);
        assert!(!c.params_for("rocks/trees/x.obj").ingest.recompute_normals);
        assert!(
            c.params_for("trees/palm/deep/p.glb")
                .ingest
                .recompute_normals
        );
    }

    #[test]
    fn bad_glob_is_an_error() {
        let e = parse("[[overrides]]\nassets = \"a/[b\"\n").unwrap_err();
        assert!(e.contains("a/[b"), "{e}");
    }
}
