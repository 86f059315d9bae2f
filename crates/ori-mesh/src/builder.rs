//! Accumulates vertices and triangles from any loader, then checks and completes them.

use crate::normals::angle_weighted_normals;
use crate::{ErrorKind, LoadOptions, Material, Mesh, Texture};

/// What loaders fill; [`MeshBuilder::finish`] turns it into a valid [`Mesh`].
#[derive(Default)]
pub(crate) struct MeshBuilder {
    pub positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    /// Whether the file gave this vertex a normal.
    has_normal: Vec<bool>,
    uvs: Vec<[f32; 2]>,
    any_uv: bool,
    colors: Vec<[f32; 4]>,
    any_color: bool,
    pub triangles: Vec<[u32; 3]>,
    triangle_materials: Vec<u32>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
}

impl MeshBuilder {
    /// Append a vertex; absent attributes get neutral values (UV 0, white).
    pub fn push_vertex(
        &mut self,
        position: [f32; 3],
        normal: Option<[f32; 3]>,
        uv: Option<[f32; 2]>,
        color: Option<[f32; 4]>,
    ) -> u32 {
        let index = self.positions.len() as u32;
        self.positions.push(position);
        self.has_normal.push(normal.is_some());
        self.normals.push(normal.unwrap_or([0.0; 3]));
        self.any_uv |= uv.is_some();
        self.uvs.push(uv.unwrap_or([0.0; 2]));
        self.any_color |= color.is_some();
        self.colors.push(color.unwrap_or([1.0; 4]));
        index
    }

    /// Check that `vertices` and `triangles` more fit within `limits`, before they are added.
    pub fn check_room(
        &self,
        vertices: usize,
        triangles: usize,
        limits: &crate::Limits,
    ) -> Result<(), ErrorKind> {
        let checks = [
            (
                "the vertex count",
                self.positions.len().saturating_add(vertices),
                limits.max_vertices,
                "[limits] max_vertices",
            ),
            (
                "the triangle count",
                self.triangles.len().saturating_add(triangles),
                limits.max_triangles,
                "[limits] max_triangles",
            ),
        ];
        for (what, value, limit, key) in checks {
            if value > limit {
                return Err(ErrorKind::Limit {
                    what: what.to_string(),
                    value: value as u64,
                    limit: limit as u64,
                    key,
                });
            }
        }
        Ok(())
    }

    /// Append a triangle of already-validated vertex indices.
    pub fn push_triangle(&mut self, corners: [u32; 3], material: u32) {
        self.triangles.push(corners);
        self.triangle_materials.push(material);
    }

    /// Append a material, returning its index.
    pub fn add_material(&mut self, material: Material) -> u32 {
        self.materials.push(material);
        (self.materials.len() - 1) as u32
    }

    /// Validate, compute missing normals, and produce the canonical mesh.
    pub fn finish(mut self, options: &LoadOptions) -> Result<Mesh, ErrorKind> {
        if let Some((vertex, p)) = self
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.iter().all(|c| c.is_finite()))
        {
            return Err(ErrorKind::NonFinite { vertex, value: *p });
        }
        if self.triangles.is_empty() {
            return Err(ErrorKind::Empty(String::new()));
        }
        let count = self.positions.len();
        if let Some(&index) = self
            .triangles
            .iter()
            .flatten()
            .find(|&&i| i as usize >= count)
        {
            return Err(ErrorKind::IndexOutOfRange {
                context: String::from("triangle"),
                index: index as i64,
                count,
            });
        }
        if self.materials.is_empty() {
            self.materials.push(Material::default());
        }

        // Normals from the file are renormalised; zero or non-finite ones count as missing.
        for (n, known) in self.normals.iter_mut().zip(&mut self.has_normal) {
            let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
            if *known && len2.is_finite() && len2 > 1e-20 && !options.recompute_normals {
                let inv = 1.0 / len2.sqrt();
                *n = [n[0] * inv, n[1] * inv, n[2] * inv];
            } else {
                *known = false;
            }
        }
        if self.has_normal.iter().any(|known| !known) {
            let computed = angle_weighted_normals(&self.positions, &self.triangles);
            for ((n, known), c) in self.normals.iter_mut().zip(&self.has_normal).zip(computed) {
                if !known {
                    *n = c;
                }
            }
        }

        let mesh = Mesh {
            positions: self.positions,
            normals: self.normals,
            uvs: self.any_uv.then_some(self.uvs),
            colors: self.any_color.then_some(self.colors),
            triangles: self.triangles,
            triangle_materials: self.triangle_materials,
            materials: self.materials,
            textures: self.textures,
        };
        let complexity = mesh.depth_complexity();
        let limit = options.limits.max_depth_complexity;
        if complexity > f64::from(limit) {
            return Err(ErrorKind::Limit {
                what: format!(
                    "the depth complexity (surface area over the bounding sphere's cross-section, {complexity:.0})"
                ),
                value: complexity.ceil() as u64,
                limit: u64::from(limit),
                key: "[limits] max_depth_complexity",
            });
        }
        Ok(mesh)
    }
}
