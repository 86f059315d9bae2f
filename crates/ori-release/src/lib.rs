//! The two files a build writes beside its packages, as types: `release.json` (the
//! reproducible index `cargo xtask verify` checks) and `report.json` (the log of one build
//! and what it measured). The pipeline writes them and the report and the verifier read them
//! through these types, so a field is named once.
//!
//! This crate knows no packages, meshes or stages: only the two files' shapes.

use serde::{Deserialize, Serialize};

/// The name of the release index in the output folder.
pub const RELEASE_JSON: &str = "release.json";
/// The name of the build log in the output folder.
pub const REPORT_JSON: &str = "report.json";
/// The folder of the HTML report in the output folder (it holds no package).
pub const REPORT_DIR: &str = "report";

/// `release.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Release {
    /// Layout version of this file.
    pub release_version: u32,
    /// The tool that wrote the packages (`ori-pipeline <version>`).
    pub tool: String,
    /// Every package, sorted by asset name.
    pub assets: Vec<ReleaseEntry>,
}

/// One package of a release.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReleaseEntry {
    /// The asset's name (its path under the assets root).
    pub name: String,
    /// The package file, relative to the release folder, `/` separators.
    pub package: String,
    /// blake3 of the package file, lowercase hex.
    pub blake3: String,
    /// Size of the package file.
    pub bytes: u64,
    /// Projected length threshold in pixels (a lower bound when `plt_at_least`).
    pub plt: f64,
    pub plt_at_least: bool,
    /// Bytes of texture data in the package (every node's, for a hierarchy).
    pub texture_bytes: u64,
    /// A hierarchy's node count (absent for a single ORI).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<usize>,
}

/// The package file of an asset: its name with the extension replaced by `.ori`.
pub fn package_path(asset: &str) -> String {
    let (dir, file) = asset.rsplit_once('/').map_or(("", asset), |(d, f)| (d, f));
    let stem = file.rsplit_once('.').map_or(file, |(stem, _)| stem);
    if dir.is_empty() {
        format!("{stem}.ori")
    } else {
        format!("{dir}/{stem}.ori")
    }
}

/// `report.json`: what one build did and measured, per asset. It records which jobs ran and
/// their times, so unlike the packages and `release.json` it is a log of one build, not part
/// of the reproducible release.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BuildReport {
    pub assets: Vec<AssetReport>,
}

/// One asset in `report.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AssetReport {
    pub name: String,
    pub status: AssetStatus,
    pub error: Option<String>,
    pub warnings: Vec<String>,
    pub mesh: Option<MeshSummary>,
    pub mesh_hash: Option<String>,
    /// Content hash of the baked relief maps.
    pub maps_hash: Option<String>,
    /// Selection statistics and the projected length threshold.
    pub quality: Option<QualityReport>,
    /// Relief-map resolution the package was built at.
    pub resolution: u32,
    /// How `bake.resolution = "auto"` chose it.
    pub auto_resolution: Option<AutoReport>,
    /// This build's jobs of the asset, upstream first: what happened and how long it took.
    pub jobs: Vec<JobReport>,
    /// What the package misses of the configuration's `[gate]`, one line per bound (absent:
    /// it passes, or there is no gate).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gate: Vec<String>,
}

/// Whether an asset built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum AssetStatus {
    /// Built now or reused: the same bytes either way.
    #[serde(rename = "ok")]
    Ok,
    #[serde(rename = "failed")]
    Failed,
    #[serde(rename = "not built (dry run)")]
    NotBuilt,
}

impl AssetStatus {
    /// As written in `report.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            AssetStatus::Ok => "ok",
            AssetStatus::Failed => "failed",
            AssetStatus::NotBuilt => "not built (dry run)",
        }
    }
}

/// What the ingest stage reports about a mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshSummary {
    pub vertices: usize,
    pub triangles: usize,
    pub materials: usize,
    /// Base-colour textures as `name (width x height)`.
    pub textures: Vec<String>,
    pub has_uvs: bool,
    pub has_colors: bool,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
}

/// One job of an asset in this build.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobReport {
    pub stage: String,
    pub status: JobStatus,
    pub seconds: f64,
}

/// What happened to a job in this build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum JobStatus {
    #[serde(rename = "ran")]
    Ran,
    #[serde(rename = "reused")]
    Reused,
    #[serde(rename = "would run")]
    WouldRun,
    #[serde(rename = "failed")]
    Failed,
    #[serde(rename = "skipped")]
    Skipped,
    #[serde(rename = "not cached")]
    NotCached,
}

impl JobStatus {
    /// As written in `report.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            JobStatus::Ran => "ran",
            JobStatus::Reused => "reused",
            JobStatus::WouldRun => "would run",
            JobStatus::Failed => "failed",
            JobStatus::Skipped => "skipped",
            JobStatus::NotCached => "not cached",
        }
    }
}

/// The `auto` resolution search of one asset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AutoReport {
    pub target_px: u32,
    /// Whether the chosen resolution's PLT reaches the target (false: the largest allowed).
    pub reached: bool,
    /// Every resolution measured, with its PLT in pixels, in the order tried.
    pub tried: Vec<(u32, f64)>,
}

/// The measured quality of an asset's ORI (the rows of the paper's Table 1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QualityReport {
    /// The runtime rule at the held-out directions, none of which a stage chose anything at:
    /// what a player sees. The PLT comes from its worst view.
    pub held_out: HeldOutReport,
    /// Coverage error over the 320 evaluation directions of the table, percent of s0 x s0.
    pub coverage_error_min_percent: f64,
    pub coverage_error_max_percent: f64,
    pub coverage_error_avg_percent: f64,
    pub impostors_per_view: f64,
    /// Directions drawing 0, 1, 2, ... impostors.
    pub views_by_impostor_count: Vec<u32>,
    pub s0: u32,
    /// GC(s0): the largest coverage error at the held-out directions, in pixels.
    pub gc: u32,
    /// s0^2 / GC(s0); when GC is 0 this is the lower bound s0^2 and `plt_is_lower_bound` is set.
    pub plt: f64,
    pub plt_is_lower_bound: bool,
    /// Power of two nearest to 2 x PLT (the paper's advice).
    pub recommended_resolution: u32,
}

/// The coverage error at the held-out directions (`ori_views::held_out_directions`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeldOutReport {
    pub directions: usize,
    /// Seed of their random half.
    pub seed: u64,
    /// Percent of s0 x s0.
    pub coverage_error_max_percent: f64,
    pub coverage_error_avg_percent: f64,
    /// Mean number of impostors drawn.
    pub impostors_per_view: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn package_paths_replace_the_extension() {
        assert_eq!(package_path("bunny/bunny.obj"), "bunny/bunny.ori");
        assert_eq!(package_path("a.b/c.glb"), "a.b/c.ori");
        assert_eq!(package_path("noext"), "noext.ori");
        assert_eq!(package_path("x/y.tar.gz"), "x/y.tar.ori");
    }
}
