//! Helpers shared by the integration tests.
#![allow(dead_code)]

use ori_mesh::{Material, Mesh};

/// The shared test models (`/work/shared/models` beside the checkout).
pub const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

pub fn load(relative: &str) -> Mesh {
    let path = format!("{MODELS}/{relative}");
    ori_mesh::load_file(path.as_ref(), &Default::default())
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .mesh
}

/// A mesh from positions and triangles, with placeholder normals and one default material.
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

/// An axis-aligned unit cube centred at the origin, two outward triangles per face.
pub fn cube() -> Mesh {
    let positions: Vec<[f32; 3]> = (0..8)
        .map(|i| [i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|b| b as f32 - 0.5))
        .collect();
    let quads = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    mesh(positions, triangles)
}

/// Run `f` on a fresh rayon pool of `threads` threads.
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
        .install(f)
}
