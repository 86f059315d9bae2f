//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::sync::OnceLock;

use ori_bake::{BakeParams, ReliefSet};
use ori_mesh::{Material, Mesh};

/// The shared test models (`/work/shared/models` beside the checkout).
pub const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

pub fn load(relative: &str) -> Mesh {
    let path = format!("{MODELS}/{relative}");
    ori_mesh::load_file(path.as_ref(), &Default::default())
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .mesh
}

/// The Stanford bunny and its default relief set (planned and baked once per test binary).
pub fn bunny() -> &'static (Mesh, ReliefSet) {
    static CELL: OnceLock<(Mesh, ReliefSet)> = OnceLock::new();
    CELL.get_or_init(|| {
        let mesh = load("stanford/bunny/stanford-bunny.obj");
        let plan = ori_views::plan_views(&mesh, &Default::default()).expect("plan");
        let set = ori_bake::bake(&mesh, &plan.directions, &BakeParams::default()).expect("bake");
        (mesh, set)
    })
}

/// The bounding box `[min, max]` of a mesh's positions.
pub fn bounds(mesh: &Mesh) -> [[f64; 3]; 2] {
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for p in &mesh.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(f64::from(p[k]));
            hi[k] = hi[k].max(f64::from(p[k]));
        }
    }
    [lo, hi]
}

/// A mesh from positions and triangles, with +Z normals and one default material.
pub fn mesh(positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>) -> Mesh {
    Mesh {
        normals: vec![[0.0, 0.0, 1.0]; positions.len()],
        positions,
        uvs: None,
        colors: None,
        triangle_materials: vec![0; triangles.len()],
        triangles,
        materials: vec![Material::default()],
        textures: Vec::new(),
    }
}
