//! What a build writes besides the release, on request: packages as inspectable folders
//! (`--explode`) and pictures of relief maps (`--dump-maps`).

use std::path::Path;

use crate::PipelineError;
use crate::plan::AssetJobs;
use crate::release::{self, BuiltPackage};
use crate::stages::bake::MAPS;

/// Write every package as a folder `<dir>/<package path without .ori>/`.
pub fn explode(dir: &Path, packages: &[BuiltPackage<'_>]) -> Result<(), PipelineError> {
    for p in packages {
        let rel = release::package_path(&p.name);
        let folder = dir.join(rel.trim_end_matches(".ori"));
        let fail = |message: String| PipelineError::Output {
            path: folder.clone(),
            message,
        };
        let bytes = (p.read)().map_err(fail)?;
        match ori_package::read_any(&bytes).map_err(|e| fail(e.to_string()))? {
            ori_package::AnyPackage::Single(package) => {
                ori_package::explode(&package, &folder).map_err(|e| fail(e.to_string()))?;
            }
            // A hierarchy: its tree as `hierarchy.json`, each node as `node-N/`.
            ori_package::AnyPackage::Hierarchy(h) => {
                for (i, package) in h.nodes.iter().enumerate() {
                    ori_package::explode(package, &folder.join(format!("node-{i}")))
                        .map_err(|e| fail(e.to_string()))?;
                }
                let json = serde_json::to_vec_pretty(&h.manifest).expect("manifest serialises");
                ori_graph::write_atomic(&folder.join("hierarchy.json"), &json)
                    .map_err(|e| fail(format!("cannot write hierarchy.json: {e}")))?;
            }
        }
    }
    Ok(())
}

/// Write `<dir>/<asset>/map-NN-{depth,normal,albedo}.png` for every relief map of an asset.
pub fn dump_maps(build: &ori_graph::Build<'_>, jobs: &AssetJobs, dir: &Path) -> Result<(), String> {
    let set = MAPS.read_from(build, jobs.bake)?;
    let folder = dir.join(&jobs.asset.name);
    for (i, map) in set.maps.iter().enumerate() {
        ori_bake::write_pngs(map, &folder, &format!("map-{i:02}"))?;
    }
    Ok(())
}
