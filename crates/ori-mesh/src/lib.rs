//! Mesh ingest: every supported model format becomes one canonical [`Mesh`].
//!
//! - glTF 2.0 (`.gltf` with external or data-URI buffers and images, `.glb`): every node of
//!   the default scene with its world transform, every triangle primitive (strips and fans
//!   converted, points and lines skipped with a warning), base-colour factor, texture and
//!   vertex colour, alpha mode and cutoff.
//! - OBJ with MTL (`Kd`, `map_Kd`, `d`), polygons fan-triangulated.
//! - PLY, ASCII and binary (both byte orders), with vertex colours, normals and UVs when present.
//!
//! Loading reads referenced files through a resolver callback, so a caller (the build graph)
//! can record every file a model depends on. Missing normals are computed angle-weighted with
//! portable arithmetic, so the same input gives the same bytes on every machine.
//!
//! Colour conventions: vertex colours and material factors in the canonical mesh are *linear*
//! RGBA. glTF stores them linear already; OBJ/MTL and PLY colours are display (sRGB) values and
//! are converted on load. Texture texels stay sRGB-encoded RGBA8, as in the files. The base
//! colour of a surface point is `factor x texture(uv) x vertex colour`, multiplied in linear space.

mod builder;
mod clip;
mod codec;
mod error;
mod gltf_load;
mod normals;
mod obj;
mod ply;
mod texture;

pub use clip::clip_to_box;
pub use error::{ErrorKind, MeshError};
pub use normals::{angle_weighted_normals, face_normal};
pub use ori_artifact::DecodeError;

use std::io;
use std::path::Path;

/// The canonical triangle mesh every stage consumes.
///
/// Invariants (checked by the loaders and by [`Mesh::decode`]): at least one triangle; every
/// index is `< positions.len()`; every position is finite; `normals` has one unit vector per
/// vertex; `uvs` and `colors`, when present, have one entry per vertex; `triangle_materials`
/// has one entry per triangle and each is `< materials.len()`; each material's texture index
/// is `< textures.len()`.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Object-space (glTF: world-space of the default scene) positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals, one per vertex.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates (glTF convention: v grows downwards in the image), if any.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Linear RGBA vertex colours, if any.
    pub colors: Option<Vec<[f32; 4]>>,
    /// Counter-clockwise triangles (outward normals by the right-hand rule).
    pub triangles: Vec<[u32; 3]>,
    /// Material index of each triangle.
    pub triangle_materials: Vec<u32>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
}

/// Surface appearance, reduced to what impostors bake: base colour and alpha cut-outs.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA multiplier.
    pub base_color_factor: [f32; 4],
    /// Index into [`Mesh::textures`] of the base-colour texture (texture coordinate set 0).
    pub base_color_texture: Option<u32>,
    pub alpha_mode: AlphaMode,
    /// Alpha below this is a hole when `alpha_mode` is [`AlphaMode::Mask`] (glTF default 0.5).
    pub alpha_cutoff: f32,
    /// Drawn from both sides; when false, back faces are culled (see [`Mesh::single_sided`]).
    pub double_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: String::from("default"),
            base_color_factor: [1.0; 4],
            base_color_texture: None,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            double_sided: false,
        }
    }
}

/// How alpha is interpreted (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlphaMode {
    Opaque,
    /// Alpha-tested: texels under the cutoff are holes, baked as empty relief texels.
    Mask,
    /// Blended transparency; impostors treat it as opaque.
    Blend,
}

/// A decoded base-colour image.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Where it came from (file name or `image N`), for messages.
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// Row-major RGBA8, colour sRGB-encoded, alpha linear.
    pub rgba8: Vec<u8>,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    /// Magnification filter: nearest or bilinear.
    pub nearest: bool,
}

/// Texture addressing outside `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// Supported model formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Gltf,
    Glb,
    Obj,
    Ply,
}

impl Format {
    /// The format a file name's extension announces (case-insensitive).
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "gltf" => Some(Format::Gltf),
            "glb" => Some(Format::Glb),
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::Ply),
            _ => None,
        }
    }

    /// Lower-case name, as used in pipeline parameters.
    pub fn name(self) -> &'static str {
        match self {
            Format::Gltf => "gltf",
            Format::Glb => "glb",
            Format::Obj => "obj",
            Format::Ply => "ply",
        }
    }
}

/// Choices that change the loaded mesh, and the bounds a model must stay within.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Ignore normals in the file and compute angle-weighted ones everywhere.
    pub recompute_normals: bool,
    pub limits: Limits,
}

/// Bounds on what one model may make the loader allocate and the later stages draw, checked
/// against what the file really holds before anything that size is allocated. A model past a
/// limit fails with an error naming the limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Pixels of one decoded texture.
    pub max_texture_pixels: u64,
    /// Pixels of all the decoded textures of one model together.
    pub max_total_texture_pixels: u64,
    /// Corners of one polygon (OBJ and PLY faces are fan-triangulated).
    pub max_face_corners: usize,
    /// Triangles of the whole model (glTF instances count once per node that draws them).
    pub max_triangles: usize,
    /// Vertices of the whole model.
    pub max_vertices: usize,
    /// [`Mesh::depth_complexity`]: how many layers of surface a ray through the object
    /// crosses on average. Every image of the mesh costs time in proportion to it.
    pub max_depth_complexity: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_texture_pixels: 8192 * 8192,
            max_total_texture_pixels: 2 * 8192 * 8192,
            max_face_corners: 4096,
            max_triangles: 10_000_000,
            max_vertices: 10_000_000,
            max_depth_complexity: 64,
        }
    }
}

/// A loaded mesh and the non-fatal problems found on the way.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub mesh: Mesh,
    /// Human-readable warnings (skipped point/line primitives, ignored features, ...).
    pub warnings: Vec<String>,
}

/// Where the files a model references come from (a glTF's buffers and images, an OBJ's
/// material libraries and their textures). Any `FnMut(&str) -> io::Result<Vec<u8>>` is one.
pub trait Files {
    /// The file referenced as `reference`, exactly as written in the model (relative
    /// references are relative to the model's folder).
    fn read(&mut self, reference: &str) -> io::Result<Vec<u8>>;

    /// Called before the loader reads any of `references`: the files it may read next (a
    /// glTF's external buffers and base-colour images once its JSON is parsed, a material
    /// library's textures once it is parsed), so that a reader which fetches files from
    /// elsewhere can fetch them together. Some may never be read (the texture of a material
    /// no face uses).
    fn will_read(&mut self, references: &[String]) {
        let _ = references;
    }
}

impl<F: FnMut(&str) -> io::Result<Vec<u8>>> Files for F {
    fn read(&mut self, reference: &str) -> io::Result<Vec<u8>> {
        self(reference)
    }
}

/// The files of one model load.
pub type Resolver<'a> = dyn Files + 'a;

/// Load a model from disk, reading referenced files relative to its folder.
pub fn load_file(path: &Path, options: &LoadOptions) -> Result<Loaded, MeshError> {
    let bytes = std::fs::read(path).map_err(|e| ErrorKind::Io(e).in_file(path))?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut resolver = |uri: &str| std::fs::read(dir.join(uri));
    load(path, &bytes, options, &mut resolver)
}

/// Load a model from its bytes. `path` names the file in messages and selects the format by
/// extension; `resolver` reads every other file the model references.
pub fn load(
    path: &Path,
    bytes: &[u8],
    options: &LoadOptions,
    resolver: &mut Resolver<'_>,
) -> Result<Loaded, MeshError> {
    let format = Format::from_path(path).ok_or_else(|| ErrorKind::UnknownFormat.in_file(path))?;
    let mut warnings = Vec::new();
    let limits = &options.limits;
    let builder = match format {
        Format::Gltf | Format::Glb => {
            gltf_load::load(path, bytes, limits, resolver, &mut warnings)?
        }
        Format::Obj => obj::load(path, bytes, limits, resolver, &mut warnings)?,
        Format::Ply => ply::load(bytes, limits, &mut warnings).map_err(|k| k.in_file(path))?,
    };
    let mesh = builder.finish(options).map_err(|k| k.in_file(path))?;
    Ok(Loaded { mesh, warnings })
}

impl Mesh {
    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The surface area of all triangles over the cross-section of the sphere around the
    /// bounds: about how many layers of surface a ray through the object crosses (real
    /// scans and game models have 0.4 to 2). Drawing the mesh costs time in proportion to
    /// it; a fan of long overlapping slivers has thousands.
    pub fn depth_complexity(&self) -> f64 {
        let (lo, hi) = self.bounds();
        let d: Vec<f64> = (0..3)
            .map(|k| f64::from(hi[k]) - f64::from(lo[k]))
            .collect();
        let r2 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / 4.0;
        if r2 <= 0.0 || !r2.is_finite() {
            return 0.0;
        }
        let p = |i: u32| self.positions[i as usize].map(f64::from);
        let area: f64 = self
            .triangles
            .iter()
            .map(|&[a, b, c]| {
                let (a, b, c) = (p(a), p(b), p(c));
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() / 2.0
            })
            .sum();
        area / (std::f64::consts::PI * r2)
    }

    /// Axis-aligned bounds `(min, max)` of the positions.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }

    /// Triangle indices sorted along a Morton curve of the triangles' centroids: neighbours
    /// in this order are neighbours in space, so drawing in it reads vertices that are near
    /// in memory once [`Mesh::reordered`] has renumbered them.
    pub fn spatial_order(&self) -> Vec<u32> {
        let (lo, hi) = self.bounds();
        let cell = |c: f32, k: usize| -> u64 {
            let t = if hi[k] > lo[k] {
                (c - lo[k]) / (hi[k] - lo[k])
            } else {
                0.0
            };
            (t.clamp(0.0, 1.0) * 1023.0) as u64
        };
        let morton = |t: &[u32; 3]| -> u64 {
            let mut code = 0u64;
            for k in 0..3 {
                let c = t
                    .iter()
                    .map(|&i| self.positions[i as usize][k])
                    .sum::<f32>()
                    / 3.0;
                let v = cell(c, k);
                for bit in 0..10 {
                    code |= ((v >> bit) & 1) << (3 * bit + k);
                }
            }
            code
        };
        let mut order: Vec<(u64, u32)> = self
            .triangles
            .iter()
            .enumerate()
            .map(|(i, t)| (morton(t), i as u32))
            .collect();
        order.sort_unstable();
        order.into_iter().map(|(_, t)| t).collect()
    }

    /// The same surface with its triangles in `order` (a permutation of their indices), each
    /// keeping its corners' order and material, and the vertices renumbered in order of
    /// first use, those no triangle uses last (so the positions' bounds are unchanged).
    /// Textures are not copied: the result is for drawing with textures already decoded.
    pub fn reordered(&self, order: &[u32]) -> Mesh {
        let mut remap = vec![u32::MAX; self.positions.len()];
        let mut used = Vec::with_capacity(self.positions.len());
        let triangles = order
            .iter()
            .map(|&t| {
                self.triangles[t as usize].map(|v| {
                    let slot = &mut remap[v as usize];
                    if *slot == u32::MAX {
                        *slot = used.len() as u32;
                        used.push(v as usize);
                    }
                    *slot
                })
            })
            .collect();
        used.extend((0..self.positions.len()).filter(|&v| remap[v] == u32::MAX));
        fn pick<T: Copy>(used: &[usize], values: &[T]) -> Vec<T> {
            used.iter().map(|&v| values[v]).collect()
        }
        Mesh {
            positions: pick(&used, &self.positions),
            normals: pick(&used, &self.normals),
            uvs: self.uvs.as_deref().map(|uvs| pick(&used, uvs)),
            colors: self.colors.as_deref().map(|colors| pick(&used, colors)),
            triangles,
            triangle_materials: order
                .iter()
                .map(|&t| self.triangle_materials[t as usize])
                .collect(),
            materials: self.materials.clone(),
            textures: Vec::new(),
        }
    }

    /// Per triangle, whether its material is single-sided: drawn only from the side its
    /// winding faces (counter-clockwise seen from the front), as a real-time engine culls
    /// back faces. glTF says so per material; OBJ and PLY carry no flag and are single-sided,
    /// as engines import them.
    pub fn single_sided(&self) -> Vec<bool> {
        self.triangle_materials
            .iter()
            .map(|&m| {
                self.materials
                    .get(m as usize)
                    .is_none_or(|mat| !mat.double_sided)
            })
            .collect()
    }

    /// Serialise to the canonical little-endian byte layout (see `codec.rs`).
    pub fn encode(&self) -> Vec<u8> {
        codec::encode(self)
    }

    /// Parse bytes written by [`Mesh::encode`], checking every invariant.
    pub fn decode(bytes: &[u8]) -> Result<Mesh, DecodeError> {
        codec::decode(bytes)
    }
}
