//! The `.ori` package: one file per asset, everything the runtime renderer needs to draw an
//! Omni-directional Relief Impostor (ORI).
//!
//! A package holds a JSON [`Manifest`] (where the asset came from, the impostors' frames and
//! depth ranges, the selection table over the 320 evaluation directions, the PLT and the
//! pipeline parameters) and, per impostor, three KTX2 textures: depth (R8, or BC4), normal
//! x, y (BC5) and albedo (BC1, sRGB). The byte layout is specified in `docs/FORMAT.md`.
//!
//! - [`write()`] builds the file from a manifest and the KTX2 bytes, filling every
//!   [`TextureRef`] itself.
//! - [`read`] checks everything and returns a [`Package`].
//! - [`explode`] writes an inspectable folder (pretty manifest, the KTX2 files, PNG previews).
//!
//! # Invariants
//!
//! - **One validation.** [`write()`] runs the checks [`read`] runs, so every file `write`
//!   returns reads back, and `read(&write(m, t)?)` gives `m` (with its texture references
//!   filled) and `t`.
//! - **Canonical bytes.** A manifest has exactly one byte form (serde_json's compact output,
//!   fields in declaration order, `params` keys sorted) and textures are packed in one order
//!   at the first [`ALIGN`]ed offset after the previous part, with zero padding. The reader
//!   rejects any other form, so a valid file is the unique encoding of its content, and
//!   `write` is deterministic: the same inputs give the same bytes on every machine.
//! - **Robust reading.** [`read`] never panics and never allocates more than a small multiple
//!   of the input's size: every length and offset is checked (with checked arithmetic)
//!   against the file before anything is sliced or copied.
//! - **Cheap to depend on.** No pipeline crate; only serde, blake3, image (PNG previews) and
//!   `ori-texture` (KTX2 and the block decoders).

#![warn(missing_docs)]

mod explode;
mod hierarchy;
mod layout;
mod validate;

use std::path::PathBuf;

use ori_texture::{Ktx2, VkFormat};
use serde::{Deserialize, Serialize};

pub use explode::explode;
pub use hierarchy::{
    AnyPackage, Hierarchy, HierarchyManifest, HierarchyNode, MAX_NODES, PartRef, SplitKind,
    read_any, read_hierarchy, write_hierarchy,
};
pub use layout::{read, write};

/// The file's first 8 bytes. The `\r\n` catches a transfer in text mode (line endings
/// rewritten).
pub const MAGIC: [u8; 8] = *b"ORIPKG\r\n";

/// The version of the byte layout and manifest schema of a single-ORI package.
pub const FORMAT_VERSION: u32 = 1;

/// The version of a hierarchy package: the same header, a tree manifest, and a
/// version-1 package per node ([`read_hierarchy`]).
pub const HIERARCHY_FORMAT_VERSION: u32 = 2;

/// Every texture starts at a multiple of this many bytes from the start of the file (GPU
/// upload alignment); so does the payload.
pub const ALIGN: u64 = 256;

/// The package's description: everything but the texture bytes. Serialised as the
/// canonical JSON of `docs/FORMAT.md`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Must equal [`FORMAT_VERSION`] (and the header's version).
    pub format_version: u32,
    /// The program that wrote the package, e.g. `"ori-pipeline 0.1.0"`; non-empty.
    pub tool: String,
    /// The model the package was built from.
    pub source: Source,
    /// A sphere enclosing the object, in object space; the runtime's stand-in for the
    /// object's projected size (PLT check).
    pub bounding_sphere: Sphere,
    /// Texture edge in texels, the same for every map: a power of two in `4..=8192`.
    pub resolution: u32,
    /// Format of every depth map: [`TextureFormat::R8`] (the default) or
    /// [`TextureFormat::Bc4`].
    pub depth_format: TextureFormat,
    /// The relief maps, 1 to 256; indices into this list are impostor numbers.
    pub impostors: Vec<Impostor>,
    /// Which impostors to draw for each of the 320 evaluation directions.
    pub selection: SelectionTable,
    /// The Projected Length Threshold and how it was measured.
    pub plt: PltInfo,
    /// The pipeline parameters that shaped the package: an opaque JSON object (keys sorted
    /// in the file).
    pub params: serde_json::Value,
}

/// The runtime rule's search parameters, as the pipeline records them in `params.select`
/// (`linear_steps` 1 to 1024, `binary_steps` 0 to 32, `wall_threshold` finite and >= 0): the
/// one part of `params` a reader looks at. Each is `None` when absent or out of range.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RecordedMarch {
    /// Linear-search steps of the ray-heightfield search.
    pub linear_steps: Option<u32>,
    /// Binary-search steps after it.
    pub binary_steps: Option<u32>,
    /// Vertical-wall threshold, a fraction of an impostor's depth range.
    pub wall_threshold: Option<f64>,
}

impl RecordedMarch {
    /// What a `params` object records.
    pub fn of_params(params: &serde_json::Value) -> RecordedMarch {
        let select = params.get("select");
        let int = |key: &str, range: std::ops::RangeInclusive<u64>| {
            select
                .and_then(|s| s.get(key))
                .and_then(serde_json::Value::as_u64)
                .filter(|v| range.contains(v))
                .map(|v| v as u32)
        };
        RecordedMarch {
            linear_steps: int("linear_steps", 1..=1024),
            binary_steps: int("binary_steps", 0..=32),
            wall_threshold: select
                .and_then(|s| s.get("wall_threshold"))
                .and_then(serde_json::Value::as_f64)
                .filter(|v| v.is_finite() && *v >= 0.0),
        }
    }
}

impl Manifest {
    /// The search parameters the package was measured with.
    pub fn recorded_march(&self) -> RecordedMarch {
        RecordedMarch::of_params(&self.params)
    }
}

/// The model a package was built from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Source {
    /// Asset path relative to the assets root, `/` separators; non-empty, not absolute.
    pub name: String,
    /// blake3 of the model file: 64 lowercase hex digits.
    pub blake3: String,
}

/// A sphere in object space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sphere {
    /// Centre.
    pub center: [f64; 3],
    /// Radius, > 0.
    pub radius: f64,
}

/// One relief map: its orthographic frame, quad and depth range, and its three textures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Impostor {
    /// Unit vector from the object towards the viewer.
    pub direction: [f64; 3],
    /// The frame `u, v, d`: unit, orthogonal, right-handed (`u x v = d`), `d == direction`
    /// (all within 1e-6). Texel rows grow along `-v`, columns along `u`.
    pub frame: [[f64; 3]; 3],
    /// `(u, v)` coordinates of the quad's centre.
    pub center: [f64; 2],
    /// Half the quad's edge, in world units; > 0.
    pub half_size: f64,
    /// Height `d . p` of depth code 0 (the plane nearest the viewer).
    pub near: f64,
    /// Height `d . p` of depth code 254 (the far side of the object); `near > far`.
    pub far: f64,
    /// The occupied relief volume the runtime searches: `x0, x1, y0, y1` in texels
    /// (`0 <= x0 <= x1 <= resolution`, likewise y) and `z0, z1` in depth codes
    /// (`0 <= z0 <= z1 <= 254`); all zero for a map with no surface.
    pub occupied: [f32; 6],
    /// The depth map (code 255 = empty).
    pub depth: TextureRef,
    /// The normal map: x, y in the impostor frame, z >= 0 rebuilt.
    pub normal: TextureRef,
    /// The albedo map, sRGB.
    pub albedo: TextureRef,
}

/// The texel formats of a package's maps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TextureFormat {
    /// 8-bit depth codes, uncompressed (`VK_FORMAT_R8_UNORM`).
    R8,
    /// BC4 depth, the denser option (`VK_FORMAT_BC4_UNORM_BLOCK`).
    Bc4,
    /// BC5 normal x, y (`VK_FORMAT_BC5_UNORM_BLOCK`).
    Bc5,
    /// BC1 sRGB albedo (`VK_FORMAT_BC1_RGB_SRGB_BLOCK`).
    Bc1Srgb,
}

impl TextureFormat {
    /// The KTX2 / Vulkan format of textures in this format.
    pub fn vk_format(self) -> VkFormat {
        match self {
            TextureFormat::R8 => VkFormat::R8Unorm,
            TextureFormat::Bc4 => VkFormat::Bc4Unorm,
            TextureFormat::Bc5 => VkFormat::Bc5Unorm,
            TextureFormat::Bc1Srgb => VkFormat::Bc1RgbSrgb,
        }
    }
}

/// Where one texture's KTX2 file lies in the package.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureRef {
    /// Texel format of the KTX2 file.
    pub format: TextureFormat,
    /// Byte offset from the start of the package; a multiple of [`ALIGN`].
    pub offset: u64,
    /// Length in bytes of the KTX2 file.
    pub length: u64,
    /// blake3 of those bytes: 64 lowercase hex digits.
    pub blake3: String,
}

/// The view-dependent selection table (`GUIDE.md`, "Selection").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionTable {
    /// The direction set the entries follow: always `"icosahedron-320"`, the face
    /// centroids of the twice-subdivided icosahedron, in the order `ori-views` generates.
    pub directions: String,
    /// The selection rule that made the table, e.g. `"best:6"`; non-empty.
    pub rule: String,
    /// The coverage-error goal, percent of s0 x s0, in `[0, 100]`.
    pub goal_percent: f64,
    /// Evaluation image edge s0 in pixels; > 0.
    pub s0: u32,
    /// One entry per direction: exactly 320.
    pub entries: Vec<SelectionEntry>,
}

/// What to draw for one evaluation direction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionEntry {
    /// Impostor indices, closest direction first; non-empty, each `< impostors.len()`, no
    /// repeats.
    pub impostors: Vec<u16>,
    /// Coverage error d_i(s0) of this subset, in pixels; `<= s0 * s0`.
    pub missed: u32,
}

/// The Projected Length Threshold (`GUIDE.md`, "PLT").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PltInfo {
    /// Evaluation image edge s0; equals `selection.s0`.
    pub s0: u32,
    /// GC(s0): the largest `missed` over the selection entries.
    pub gc: u32,
    /// PLT in pixels: `s0 * s0 / gc` computed in f64 (`f64::from(s0) * f64::from(s0) /
    /// f64::from(gc)`), or `s0 * s0` when `gc == 0`.
    pub pixels: f64,
    /// True exactly when `gc == 0`: the PLT is then at least `pixels`.
    pub at_least: bool,
    /// The advised texture edge (about 2 x PLT): a power of two.
    pub recommended_resolution: u32,
    /// What measured the coverage errors (e.g. the evaluator and its settings).
    pub measured_by: String,
}

/// The textures of one impostor: KTX2 files ([`Ktx2::to_bytes`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ImpostorTextures {
    /// Depth map, in the manifest's `depth_format`.
    pub depth: Vec<u8>,
    /// Normal map, BC5.
    pub normal: Vec<u8>,
    /// Albedo map, BC1 sRGB.
    pub albedo: Vec<u8>,
}

impl ImpostorTextures {
    /// The three maps with their names, in file order.
    pub(crate) fn maps(&self) -> [(&'static str, &[u8]); 3] {
        [
            ("depth", &self.depth),
            ("normal", &self.normal),
            ("albedo", &self.albedo),
        ]
    }
}

/// A package as read: the manifest and every impostor's KTX2 bytes, all validated.
#[derive(Clone, Debug, PartialEq)]
pub struct Package {
    /// The manifest, texture references filled.
    pub manifest: Manifest,
    /// One entry per impostor, in manifest order.
    pub textures: Vec<ImpostorTextures>,
}

impl Package {
    /// Impostor `i`'s depth map, decoded.
    ///
    /// # Panics
    /// If `i` is out of range, or if `textures` was changed after [`read`] to bytes that are
    /// not a KTX2 file.
    pub fn depth(&self, i: usize) -> Ktx2 {
        decode(&self.textures[i].depth)
    }

    /// Impostor `i`'s normal map, decoded. Panics as [`Package::depth`].
    pub fn normal(&self, i: usize) -> Ktx2 {
        decode(&self.textures[i].normal)
    }

    /// Impostor `i`'s albedo map, decoded. Panics as [`Package::depth`].
    pub fn albedo(&self, i: usize) -> Ktx2 {
        decode(&self.textures[i].albedo)
    }

    /// Bytes of texture data: the sum of the texture references' lengths.
    pub fn texture_bytes(&self) -> u64 {
        self.manifest
            .impostors
            .iter()
            .map(|m| m.depth.length + m.normal.length + m.albedo.length)
            .sum()
    }
}

fn decode(bytes: &[u8]) -> Ktx2 {
    Ktx2::from_bytes(bytes).expect("textures were validated by read")
}

/// Everything that can go wrong reading, writing or exploding a package. Messages say what
/// is wrong; callers prepend the file name.
#[derive(Debug, thiserror::Error)]
pub enum PackageError {
    /// The file does not start with [`MAGIC`].
    #[error(
        "not an ORI package: the file does not start with \"ORIPKG\\r\\n\" (a transfer in text \
         mode rewrites the \\r\\n)"
    )]
    BadMagic,
    /// The header's format version is not [`FORMAT_VERSION`].
    #[error(
        "unsupported package format version {0} (this reader reads versions {FORMAT_VERSION} \
         and {HIERARCHY_FORMAT_VERSION})"
    )]
    UnsupportedVersion(u32),
    /// [`read`] was given a hierarchy (version 2); [`read_hierarchy`] or [`read_any`] reads it.
    #[error(
        "a hierarchy package (format version {HIERARCHY_FORMAT_VERSION}): read it with read_hierarchy or read_any"
    )]
    IsHierarchy,
    /// The file ends before a part it declares.
    #[error("truncated file: the {what} needs {need} bytes, the file has {have}")]
    Truncated {
        /// The part that does not fit.
        what: &'static str,
        /// The file length the part needs.
        need: u64,
        /// The file length.
        have: u64,
    },
    /// A header field is invalid (flags, lengths, payload offset).
    #[error("invalid header: {0}")]
    Header(String),
    /// The manifest bytes do not match the blake3 in the header.
    #[error("manifest is corrupt: its blake3 does not match the header")]
    ManifestHash,
    /// The manifest is not valid JSON for the schema, not canonical, or inconsistent.
    #[error("invalid manifest: {0}")]
    Manifest(String),
    /// A texture is not what the manifest says (KTX2, format, size).
    #[error("impostor {impostor} {map} texture: {reason}")]
    Texture {
        /// Impostor index.
        impostor: usize,
        /// `"depth"`, `"normal"` or `"albedo"`.
        map: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A texture's bytes do not match the blake3 in the manifest.
    #[error("impostor {impostor} {map} texture is corrupt: its blake3 does not match the manifest")]
    HashMismatch {
        /// Impostor index.
        impostor: usize,
        /// `"depth"`, `"normal"` or `"albedo"`.
        map: &'static str,
    },
    /// Parts misplaced: misaligned, overlapping, gaps, nonzero padding, trailing bytes.
    #[error("invalid layout: {0}")]
    Layout(String),
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}
