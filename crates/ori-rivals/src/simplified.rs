//! What users pick instead of an impostor: the mesh itself, simplified by meshoptimizer's
//! edge-collapse simplifier until its vertex and index buffers fit the budget, drawn with its
//! own attributes (the evaluator's reference render of the simplified mesh).

use std::sync::OnceLock;

use ori_bake::Baker;
use ori_mesh::Mesh;
use ori_raster::OrthoView;

use crate::{Drawn, Primitive, Rival, RivalError, Technique};

/// A mesh within a byte budget.
pub struct SimplifiedMesh {
    mesh: Mesh,
    /// Its baker (textures decoded, triangles in drawing order), made at the first view
    /// drawn, for every view (none is drawn when the whole mesh fits: the measure draws the
    /// reference instead).
    baker: OnceLock<Box<Baker>>,
    /// Triangles of the original.
    original: usize,
}

/// Bytes of one vertex: position and normal as f32, UVs as f32, colours as 4 x u8.
fn vertex_bytes(mesh: &Mesh) -> u64 {
    24 + if mesh.uvs.is_some() { 8 } else { 0 } + if mesh.colors.is_some() { 4 } else { 0 }
}

/// Bytes of a mesh of `vertices` vertices and `triangles` triangles, indices 16-bit where
/// they fit.
fn mesh_bytes(per_vertex: u64, vertices: usize, triangles: usize) -> u64 {
    let index = if vertices <= 1 << 16 { 2 } else { 4 };
    per_vertex * vertices as u64 + index * 3 * triangles as u64
}

/// The vertices `indices` use, and the triangles renumbered to them (first use order).
pub(crate) fn compact(mesh: &Mesh, indices: &[u32], triangles: &[usize]) -> Mesh {
    let mut out = Mesh {
        textures: mesh.textures.clone(),
        ..materials_only(mesh)
    };
    compact_into(mesh, indices, triangles, &mut out);
    out
}

/// A mesh with `mesh`'s materials and nothing else (no geometry, no textures).
pub(crate) fn materials_only(mesh: &Mesh) -> Mesh {
    Mesh {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: None,
        colors: None,
        triangles: Vec::new(),
        triangle_materials: Vec::new(),
        materials: mesh.materials.clone(),
        textures: Vec::new(),
    }
}

/// [`compact`] into the geometry of `out`, whose materials and textures are kept: no texture
/// is copied.
pub(crate) fn compact_into(mesh: &Mesh, indices: &[u32], triangles: &[usize], out: &mut Mesh) {
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut used = Vec::new();
    let corners: Vec<u32> = indices
        .iter()
        .map(|&i| {
            let slot = &mut remap[i as usize];
            if *slot == u32::MAX {
                *slot = used.len() as u32;
                used.push(i as usize);
            }
            *slot
        })
        .collect();
    let pick = |v: &Vec<[f32; 3]>| used.iter().map(|&i| v[i]).collect::<Vec<_>>();
    out.positions = pick(&mesh.positions);
    out.normals = pick(&mesh.normals);
    out.uvs = mesh
        .uvs
        .as_ref()
        .map(|uv| used.iter().map(|&i| uv[i]).collect());
    out.colors = mesh
        .colors
        .as_ref()
        .map(|c| used.iter().map(|&i| c[i]).collect());
    out.triangles = corners
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    out.triangle_materials = triangles
        .iter()
        .map(|&t| mesh.triangle_materials[t])
        .collect();
}

impl SimplifiedMesh {
    /// The mesh with the most triangles whose buffers fit `budget`; the whole mesh when it
    /// fits. Materials are kept: each material's triangles are simplified separately (with
    /// the vertices they share locked), so that no triangle changes material. meshoptimizer
    /// is C++ built by the platform's compiler: where that contracts multiply-adds (not on
    /// x86-64), its collapses, and so this row, may differ by platform.
    pub fn new(mesh: &Mesh, budget: u64) -> Result<SimplifiedMesh, RivalError> {
        let per_vertex = vertex_bytes(mesh);
        let original = mesh.triangles.len();
        if mesh_bytes(per_vertex, mesh.positions.len(), original) <= budget {
            return Ok(SimplifiedMesh {
                mesh: mesh.clone(),
                baker: OnceLock::new(),
                original,
            });
        }
        // The largest target (in triangles) whose result fits, by bisection: the result only
        // shrinks as the target does.
        let simplify = |target: usize| -> Mesh {
            let (indices, triangles) = simplify_to(mesh, target);
            compact(mesh, &indices, &triangles)
        };
        let bytes = |m: &Mesh| mesh_bytes(per_vertex, m.positions.len(), m.triangles.len());
        let (mut lo, mut hi) = (1usize, original);
        let mut best = None;
        while lo <= hi {
            let mid = lo + (hi - lo) / 2;
            let m = simplify(mid);
            if bytes(&m) <= budget && !m.triangles.is_empty() {
                best = Some(m);
                lo = mid + 1;
            } else {
                hi = mid - 1;
            }
        }
        let mesh = best.ok_or(RivalError::Budget {
            technique: Technique::SimplifiedMesh.name(),
            budget,
            closest: mesh_bytes(per_vertex, 3, 1),
        })?;
        Ok(SimplifiedMesh {
            mesh,
            baker: OnceLock::new(),
            original,
        })
    }

    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }
}

/// meshoptimizer's simplifier towards `target` triangles in all, shared among the materials
/// by their triangle counts; the corners and the original index of each kept triangle.
fn simplify_to(mesh: &Mesh, target: usize) -> (Vec<u32>, Vec<usize>) {
    let total = mesh.triangles.len();
    let mut by_material: Vec<Vec<usize>> = vec![Vec::new(); mesh.materials.len()];
    for (t, &m) in mesh.triangle_materials.iter().enumerate() {
        by_material[m as usize].push(t);
    }
    // Vertices of more than one material stay where they are, so that materials simplified
    // apart keep meeting without cracks.
    let mut owner = vec![u32::MAX; mesh.positions.len()];
    let mut shared = vec![false; mesh.positions.len()];
    for (tri, &m) in mesh.triangles.iter().zip(&mesh.triangle_materials) {
        for &v in tri {
            let o = &mut owner[v as usize];
            if *o == u32::MAX {
                *o = m;
            } else if *o != m {
                shared[v as usize] = true;
            }
        }
    }
    let (mut indices, mut triangles) = (Vec::new(), Vec::new());
    for group in by_material.iter().filter(|g| !g.is_empty()) {
        let corners: Vec<u32> = group.iter().flat_map(|&t| mesh.triangles[t]).collect();
        let share = (target as u128 * group.len() as u128 / total as u128) as usize;
        let kept = meshopt::simplify_with_locks_decoder(
            &corners,
            &mesh.positions,
            &shared,
            3 * share.max(1),
            1.0,
            meshopt::SimplifyOptions::None,
            None,
        );
        // Each kept triangle takes the material of its group, so any index of it will do.
        triangles.extend(std::iter::repeat_n(group[0], kept.len() / 3));
        indices.extend(kept);
    }
    (indices, triangles)
}

impl Rival for SimplifiedMesh {
    fn technique(&self) -> Technique {
        Technique::SimplifiedMesh
    }

    fn bytes(&self) -> u64 {
        mesh_bytes(
            vertex_bytes(&self.mesh),
            self.mesh.positions.len(),
            self.mesh.triangles.len(),
        )
    }

    fn layout(&self) -> String {
        let (v, t) = (self.mesh.positions.len(), self.mesh.triangles.len());
        if t == self.original {
            format!("the whole mesh: {v} vertices, {t} triangles")
        } else {
            format!("{v} vertices, {t} of {} triangles", self.original)
        }
    }

    fn primitive(&self) -> Primitive {
        Primitive::Triangles
    }

    fn draws_the_mesh(&self) -> Option<u32> {
        let triangles = self.mesh.triangles.len();
        (triangles == self.original).then_some(triangles as u32)
    }

    fn draw(&self, view: &OrthoView) -> Result<Drawn, RivalError> {
        let baker = self.baker.get_or_init(|| Box::new(Baker::new(&self.mesh)));
        Ok(Drawn {
            render: ori_eval::render_mesh(baker, view)?,
            count: self.mesh.triangles.len() as u32,
        })
    }
}
