//! Assets known unchanged since they last built. An asset whose source file, the files its
//! jobs read besides it, its parameters, the stages and the limits are what they were when it
//! last built has the same jobs with the same keys, so the same results: its report entry and
//! package are taken from this memo, without searching, planning or looking its jobs up one
//! by one. Only whole successes are remembered; every other asset goes through the graph.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use ori_graph::{
    BlobRef, Build, Cache, ContentHash, DiscoveredFile, Graph, MemoMap, Outcome, SourceHasher,
    SourceRules, canonical_json,
};
use ori_release::{AssetReport, AssetStatus, JobStatus};
use serde::{Deserialize, Serialize};

use crate::config::StageParams;
use crate::discover::Asset;
use crate::plan::AssetJobs;
use crate::release::BuiltPackage;
use crate::stages::Registry;
use crate::stages::package::tool;

/// The memo's folder under the cache root (an [`ori_graph::MemoMap`] by asset name).
pub const ASSET_MEMO: &str = "asset-memo";

/// Bumped when what a key covers changes.
const MEMO_VERSION: u32 = 1;

/// What one asset built into, and what it was built from.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Remembered {
    /// [`AssetMemo::key`] of the build.
    key: ContentHash,
    /// The files its jobs read besides the source, relative to the source's folder.
    discovered: Vec<DiscoveredFile>,
    package: BlobRef,
    /// Its report entry, every job reused.
    report: AssetReport,
    /// Its jobs' warnings, each with the label of the job that printed it.
    warnings: Vec<(String, String)>,
}

/// An asset found unchanged: what its build gives.
pub struct Unchanged {
    pub report: AssetReport,
    pub package: BuiltPackage<'static>,
    /// Its jobs' warnings, each with the label of the job that printed it.
    pub warnings: Vec<(String, String)>,
}

/// What the memo says about an asset.
pub enum Looked {
    Unchanged(Box<Unchanged>),
    /// It goes through the graph; once built, it is remembered under this key (`None`: its
    /// source could not be hashed, so the graph will say why).
    Build(Option<Pending>),
}

/// The key an asset being built will be remembered under, and the source hash it holds.
#[derive(Clone, Copy, Debug)]
pub struct Pending {
    key: ContentHash,
    source: ContentHash,
}

/// The memo of one build.
pub struct AssetMemo {
    cache: Cache,
    /// Hash of what every key shares: the tool, the stages' versions, limits and rules.
    common: ContentHash,
    known: MemoMap<String, Remembered>,
    /// Why some of the memo could not be used, if it could not.
    pub damaged: Option<String>,
}

impl AssetMemo {
    /// Load the memo of `cache` for a build whose stages are `registry`'s, loading models
    /// within `limits` and reading sources under `rules`.
    pub fn open(
        cache: &Cache,
        registry: &Registry,
        limits: ori_mesh::Limits,
        rules: &SourceRules,
    ) -> AssetMemo {
        let common = serde_json::json!({
            "memo": MEMO_VERSION,
            "report_entry": crate::report::ENTRY_VERSION,
            "tool": tool(),
            "stages": registry.versions(),
            "limits": format!("{limits:?}"),
            "sources": format!("{rules:?}"),
        });
        let known = MemoMap::open(cache.root().join(ASSET_MEMO), MEMO_VERSION);
        let damaged = (!known.damaged.is_empty()).then(|| known.damaged.join("; "));
        AssetMemo {
            cache: cache.clone(),
            common: ContentHash::of(canonical_json(&common).as_bytes()),
            known,
            damaged,
        }
    }

    /// The key of `asset` built with `params` from a source whose content hash is `source`.
    fn key(&self, asset: &Asset, params: &StageParams, source: ContentHash) -> ContentHash {
        let mut h = blake3::Hasher::new_derive_key("ori-pipeline asset memo key");
        h.update(&self.common.0);
        h.update(&(asset.name.len() as u64).to_le_bytes());
        h.update(asset.name.as_bytes());
        h.update(&source.0);
        h.update(&self.params_hash(params).0);
        ContentHash(*h.finalize().as_bytes())
    }

    /// The hash of every parameter in `params` (canonical JSON: `-0.0` is not `0.0`).
    fn params_hash(&self, params: &StageParams) -> ContentHash {
        let json = serde_json::json!({
            "stages": params,
            "auto_resolution": params.auto_resolution,
            "select_device": params.select_device,
        });
        ContentHash::of(canonical_json(&json).as_bytes())
    }

    /// Whether `asset`, built with `params`, is known unchanged and its package `usable` (the
    /// caller's check that it can be had). Source files are hashed through `sources` (its
    /// stat memo).
    pub fn look_up(
        &self,
        asset: &Asset,
        params: &StageParams,
        sources: &SourceHasher,
        usable: impl Fn(&Asset, &BlobRef) -> bool,
    ) -> Looked {
        let Ok(Some(source)) = sources.hash(&asset.path) else {
            return Looked::Build(None);
        };
        let key = self.key(asset, params, source);
        let pending = Looked::Build(Some(Pending { key, source }));
        let Some(known) = self.known.get(&asset.name).filter(|k| k.key == key) else {
            return pending;
        };
        let dir = asset.path.parent().unwrap_or(Path::new(""));
        let unchanged = known
            .discovered
            .iter()
            .all(|file| sources.hash(&dir.join(&file.path)).ok().flatten() == file.hash);
        if !unchanged || !usable(asset, &known.package) {
            return pending;
        }
        let (cache, blob) = (self.cache.clone(), known.package);
        Looked::Unchanged(Box::new(Unchanged {
            report: known.report.clone(),
            package: BuiltPackage {
                name: asset.name.clone(),
                blob,
                read: Box::new(move || cache.read_blob(&blob).map_err(|e| e.to_string())),
            },
            warnings: known.warnings.clone(),
        }))
    }

    /// Remember what `asset` built into in `build` (its jobs `jobs`, its report entry
    /// `report`), when it built whole and its source still holds what `pending` was keyed
    /// with; otherwise forget what was known of it.
    pub fn remember(
        &self,
        pending: Pending,
        sources: &SourceHasher,
        (graph, build): (&Graph, &Build<'_>),
        jobs: &AssetJobs,
        report: &AssetReport,
        package: Option<&BlobRef>,
    ) {
        let name = &jobs.asset.name;
        let entry = remembered(pending, sources, (graph, build), jobs, report, package);
        if entry.is_some() || self.known.get(name).is_some() {
            self.known.set(name.clone(), entry);
        }
    }

    /// Forget every asset not in `kept` (a build of every asset: the others are gone).
    pub fn keep_only(&self, kept: &BTreeSet<&str>) {
        for name in self.known.keys().filter(|n| !kept.contains(n.as_str())) {
            self.known.set(name.clone(), None);
        }
    }

    /// Write what this build learnt into the memo, merged with what another builder may have
    /// written since it was loaded. Nothing is written when nothing was learnt.
    pub fn save(&self) -> std::io::Result<()> {
        self.known.save()
    }
}

/// The memo entry of an asset built whole in `build`, or `None`.
fn remembered(
    pending: Pending,
    sources: &SourceHasher,
    (graph, build): (&Graph, &Build<'_>),
    jobs: &AssetJobs,
    report: &AssetReport,
    package: Option<&BlobRef>,
) -> Option<Remembered> {
    let package = *package?;
    let whole = report.status == AssetStatus::Ok && report.quality.is_some();
    let ids = jobs.all();
    let results = ids.iter().map(|&id| build.result(id));
    if !whole
        || !results
            .clone()
            .all(|r| matches!(r.outcome, Outcome::Reused | Outcome::Ran(_)))
        || sources.hash(&jobs.asset.path).ok().flatten() != Some(pending.source)
    {
        return None;
    }
    let mut discovered: BTreeMap<&str, &DiscoveredFile> = BTreeMap::new();
    for file in results.clone().flat_map(|r| &r.discovered) {
        // Two jobs that saw one file differently: it changed during the build.
        if discovered
            .insert(&file.path, file)
            .is_some_and(|f| f != file)
        {
            return None;
        }
    }
    let warnings = ids
        .iter()
        .flat_map(|&id| {
            let label = &graph.job(id).asset;
            build
                .result(id)
                .warnings
                .iter()
                .map(|w| (label.clone(), w.clone()))
        })
        .collect();
    let mut report = report.clone();
    for job in &mut report.jobs {
        job.status = JobStatus::Reused;
        job.seconds = 0.0;
    }
    Some(Remembered {
        key: pending.key,
        discovered: discovered.into_values().cloned().collect(),
        package,
        report,
        warnings,
    })
}
