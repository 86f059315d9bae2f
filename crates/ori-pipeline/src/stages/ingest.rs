//! ingest: a model file (and whatever it references) to the canonical mesh.

use std::path::PathBuf;

use ori_artifact::DecodeError;
use ori_graph::{JobContext, StageError};
use ori_mesh::{LoadOptions, Mesh};
use ori_release::MeshSummary;
use serde::{Deserialize, Serialize};

use super::{Artifact, PipelineStage, Slot};
use crate::config::IngestParams;

/// The canonical mesh (also the output of `clip`: a hierarchy node's part of it).
pub const MESH: Slot<Mesh> = Slot::new("mesh");
/// What `report.json` says about the mesh.
pub const SUMMARY: Slot<MeshSummary> = Slot::new("summary");
/// The model file's input name (hashed, and read by ingest).
pub const SOURCE: &str = "source";

impl Artifact for Mesh {
    fn encode(&self) -> Vec<u8> {
        Mesh::encode(self)
    }

    fn decode(bytes: &[u8]) -> Result<Mesh, DecodeError> {
        Mesh::decode(bytes)
    }
}

impl Artifact for MeshSummary {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec_pretty(self).expect("a mesh summary serialises")
    }

    fn decode(bytes: &[u8]) -> Result<MeshSummary, DecodeError> {
        serde_json::from_slice(bytes).map_err(|e| DecodeError {
            kind: "mesh summary",
            detail: e.to_string(),
        })
    }
}

/// Loads a model with `ori_mesh`, recording every referenced file it reads. The `[limits]`
/// are not parameters: they decide whether a model loads, never what it loads to.
pub struct Ingest {
    pub limits: ori_mesh::Limits,
}

/// The ingest job's parameters. The format is a parameter (not part of the content) because
/// the same bytes under another extension would be parsed differently.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IngestJob {
    /// `obj`, `ply`, `gltf` or `glb`; `None` for a file of no known format (the job fails).
    pub format: Option<String>,
    #[serde(flatten)]
    pub ingest: IngestParams,
}

impl IngestJob {
    pub fn new(path: &std::path::Path, ingest: &IngestParams) -> IngestJob {
        IngestJob {
            format: ori_mesh::Format::from_path(path).map(|f| f.name().to_string()),
            ingest: ingest.clone(),
        }
    }
}

/// The summary of a mesh.
pub fn summary(mesh: &Mesh) -> MeshSummary {
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

impl PipelineStage for Ingest {
    const NAME: &'static str = "ingest";
    /// 2: warnings for what the ORI does not carry (alpha blending, emission, material
    /// extensions), which a cached ingest would not give. 3: gltfpack's extensions
    /// (quantized attributes, meshopt compression, KHR_texture_transform on base colour).
    const VERSION: u32 = 3;
    type Params = IngestJob;

    fn run(&self, params: IngestJob, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let path: PathBuf = job
            .source_path(SOURCE)
            .ok_or_else(|| StageError::Plan("ingest job without a source file".into()))?
            .to_path_buf();
        let bytes = job.input(SOURCE)?;
        let options = LoadOptions {
            recompute_normals: params.ingest.recompute_normals,
            limits: self.limits,
        };
        let loaded = ori_mesh::load(&path, &bytes, &options, &mut DiscoveredFiles(job))
            .map_err(|e| StageError::file(e.file, e.kind))?;
        for warning in loaded.warnings {
            job.warn(warning);
        }
        SUMMARY.write(job, &summary(&loaded.mesh));
        MESH.write(job, &loaded.mesh);
        Ok(())
    }
}

/// A model's files, as files the job discovers.
struct DiscoveredFiles<'j, 'c>(&'j mut JobContext<'c>);

impl ori_mesh::Files for DiscoveredFiles<'_, '_> {
    fn read(&mut self, reference: &str) -> std::io::Result<Vec<u8>> {
        self.0.read_discovered(reference)
    }

    fn will_read(&mut self, references: &[String]) {
        self.0.will_read(references);
    }
}

impl super::Makes<Mesh> for Ingest {}
impl super::Makes<MeshSummary> for Ingest {}
