//! The ingest stage: a model file (and whatever it references) to the canonical mesh.

use std::path::PathBuf;

use ori_graph::{JobContext, Stage, StageError};
use ori_mesh::{LoadOptions, Mesh};
use serde::{Deserialize, Serialize};

use crate::config::IngestParams;

/// Output names of the ingest stage.
pub const MESH: &str = "mesh";
pub const SUMMARY: &str = "summary";

/// Loads a model with `ori_mesh`, recording every referenced file it reads.
///
/// Parameters: `{"format": "obj"|"ply"|"gltf"|"glb", "recompute_normals": bool}`. The format is
/// a parameter (not part of the content) because the same bytes under another extension
/// would be parsed differently. The `[limits]` are not parameters: they decide whether a
/// model loads, never what it loads to.
pub struct IngestStage {
    pub limits: ori_mesh::Limits,
}

/// What the ingest stage reports about a mesh (its `summary` output).
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

impl MeshSummary {
    pub fn of(mesh: &Mesh) -> MeshSummary {
        let (bounds_min, bounds_max) = mesh.bounds();
        MeshSummary {
            vertices: mesh.vertex_count(),
            triangles: mesh.triangle_count(),
            materials: mesh.materials.len(),
            textures: mesh
                .textures
                .iter()
                .map(|t| format!("{} ({} x {})", t.name, t.width, t.height))
                .collect(),
            has_uvs: mesh.uvs.is_some(),
            has_colors: mesh.colors.is_some(),
            bounds_min,
            bounds_max,
        }
    }
}

/// The ingest job's parameters.
pub fn params(format: ori_mesh::Format, p: &IngestParams) -> serde_json::Value {
    serde_json::json!({ "format": format.name(), "recompute_normals": p.recompute_normals })
}

impl Stage for IngestStage {
    fn name(&self) -> &'static str {
        "ingest"
    }

    fn version(&self) -> u32 {
        1
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        let params: IngestParams = serde_json::from_value(serde_json::json!({
            "recompute_normals": ctx.params()["recompute_normals"],
        }))
        .map_err(StageError::new)?;
        let path: PathBuf = ctx
            .source_path("source")
            .ok_or_else(|| StageError::new("ingest job without a source file"))?
            .to_path_buf();
        let bytes = ctx.input("source")?;
        let options = LoadOptions {
            recompute_normals: params.recompute_normals,
            limits: self.limits,
        };
        let loaded = ori_mesh::load(&path, &bytes, &options, &mut |uri: &str| {
            ctx.read_discovered(uri)
        })
        .map_err(StageError::new)?;
        for warning in loaded.warnings {
            ctx.warn(warning);
        }
        let summary =
            serde_json::to_vec_pretty(&MeshSummary::of(&loaded.mesh)).map_err(StageError::new)?;
        ctx.output(MESH, loaded.mesh.encode());
        ctx.output(SUMMARY, summary);
        Ok(())
    }
}
