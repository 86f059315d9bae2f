//! compress: each relief map to three KTX2 textures (`[compress]`; the guide's 2.5 bytes per
//! texel: R8 depth, BC5 normal, BC1 albedo; BC4 depth on request).

use ori_artifact::{DecodeError, Layout};
use ori_graph::{JobContext, StageError};
use ori_package::{ImpostorTextures, TextureFormat};
use ori_relief::{EMPTY_DEPTH, ReliefMap, ReliefSet};
use ori_texture::{Ktx2, Quality, RgbaImage, VkFormat};
use serde::{Deserialize, Serialize};

use super::{Artifact, PipelineStage, Slot, bake::MAPS};

/// For each map, its depth, normal and albedo KTX2 files.
pub const TEXTURES: Slot<Textures> = Slot::new("textures");

/// The compressed textures of every map.
pub struct Textures(pub Vec<ImpostorTextures>);

/// `[compress]`: how relief maps become GPU textures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompressParams {
    /// Encoder effort: "high" (packages) or "fast" (previews); both are deterministic.
    pub quality: CompressQuality,
    /// Depth format: "r8" (exact, 1 byte per texel) or "bc4" (0.5 byte, lossy).
    pub depth: DepthFormat,
}

impl Default for CompressParams {
    fn default() -> Self {
        CompressParams {
            quality: CompressQuality::High,
            depth: DepthFormat::R8,
        }
    }
}

/// Encoder effort, as in `ori_texture::Quality`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CompressQuality {
    High,
    Fast,
}

/// How the depth map is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DepthFormat {
    R8,
    Bc4,
}

impl DepthFormat {
    pub(crate) fn texture_format(self) -> TextureFormat {
        match self {
            DepthFormat::R8 => TextureFormat::R8,
            DepthFormat::Bc4 => TextureFormat::Bc4,
        }
    }
}

/// The compression a package's depth goes through when it is lossy (BC4), for the stages that
/// measure what a runtime will read (`select`, `plt`); `None` for exact R8 depth, so that
/// those jobs' keys stay what they were.
pub(crate) fn lossy_depth(params: &CompressParams) -> Option<CompressParams> {
    (params.depth == DepthFormat::Bc4).then_some(*params)
}

/// `set` with each map's depth codes as a runtime decodes them from the package
/// (`docs/RUNTIME.md`, "Depth codes"): the same encoder as [`compress_map`], then decoded.
/// Normal and albedo are kept (coverage does not read them).
pub(crate) fn as_shipped(
    mut set: ReliefSet,
    lossy: Option<&CompressParams>,
) -> Result<ReliefSet, String> {
    let Some(params) = lossy else {
        return Ok(set);
    };
    for (i, map) in set.maps.iter_mut().enumerate() {
        let n = map.size();
        let encoded = match params.depth {
            DepthFormat::R8 => continue,
            DepthFormat::Bc4 => ori_texture::encode_bc4(&map.depth, n, n, quality(params))
                .map_err(|e| format!("map {i}'s depth: {e}"))?,
        };
        map.depth = ori_texture::decode::to_bytes(VkFormat::Bc4Unorm, &encoded, n)
            .map_err(|e| format!("map {i}'s depth: {e}"))?;
    }
    Ok(set)
}

fn quality(params: &CompressParams) -> Quality {
    match params.quality {
        CompressQuality::High => Quality::High,
        CompressQuality::Fast => Quality::Fast,
    }
}

/// The three textures of one relief map, as KTX2 files.
pub(crate) fn compress_map(
    map: &ReliefMap,
    params: &CompressParams,
) -> Result<ImpostorTextures, String> {
    let n = map.size();
    let quality = quality(params);
    let err = |e: ori_texture::TextureError| e.to_string();
    let ktx = |format: VkFormat, data: Vec<u8>| -> Result<Vec<u8>, String> {
        Ok(Ktx2::new(format, n, n, vec![data]).map_err(err)?.to_bytes())
    };
    let depth = match params.depth {
        DepthFormat::R8 => ktx(VkFormat::R8Unorm, map.depth.clone())?,
        DepthFormat::Bc4 => ktx(
            VkFormat::Bc4Unorm,
            ori_texture::encode_bc4(&map.depth, n, n, quality).map_err(err)?,
        )?,
    };
    let xy: Vec<u8> = map.normal.iter().flatten().copied().collect();
    let normal = ktx(
        VkFormat::Bc5Unorm,
        ori_texture::encode_bc5(&xy, n, n, quality).map_err(err)?,
    )?;
    let rgba: Vec<u8> = map
        .albedo
        .iter()
        .flat_map(|c| [c[0], c[1], c[2], 255])
        .collect();
    // Empty texels are never drawn: they do not constrain the colour endpoints.
    let mask: Vec<bool> = map.depth.iter().map(|&d| d != EMPTY_DEPTH).collect();
    let image = RgbaImage::new(n, n, rgba).map_err(err)?;
    let albedo = ktx(
        VkFormat::Bc1RgbSrgb,
        ori_texture::encode_bc1(&image, Some(&mask), quality).map_err(err)?,
    )?;
    Ok(ImpostorTextures {
        depth,
        normal,
        albedo,
    })
}

/// The textures artifact: the shared artifact header, a `u32` map count, then each map's
/// depth, normal and albedo KTX2 files as blobs (`u64` length and the bytes).
const TEXTURES_LAYOUT: Layout = Layout {
    kind: "textures",
    magic: *b"ORITEXS\0",
    version: 1,
};

impl Artifact for Textures {
    fn encode(&self) -> Vec<u8> {
        let mut w = TEXTURES_LAYOUT.writer();
        w.count(self.0.len());
        for t in &self.0 {
            for file in [&t.depth, &t.normal, &t.albedo] {
                w.blob(file);
            }
        }
        w.finish()
    }

    fn decode(bytes: &[u8]) -> Result<Textures, DecodeError> {
        let mut r = TEXTURES_LAYOUT.reader(bytes)?;
        // Three blob lengths per map.
        let count = r.count(24)?;
        let mut out = Vec::with_capacity(count);
        for _ in 0..count {
            out.push(ImpostorTextures {
                depth: r.blob()?.to_vec(),
                normal: r.blob()?.to_vec(),
                albedo: r.blob()?.to_vec(),
            });
        }
        r.finish()?;
        Ok(Textures(out))
    }
}

/// Compresses every relief map (`[compress]` parameters).
pub struct Compress;

impl PipelineStage for Compress {
    const NAME: &'static str = "compress";
    const VERSION: u32 = 2;
    type Params = CompressParams;

    fn run(&self, params: CompressParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let set = MAPS.read(job)?;
        let textures = set
            .maps
            .iter()
            .enumerate()
            .map(|(i, map)| compress_map(map, &params).map_err(|e| format!("map {i}: {e}")))
            .collect::<Result<Vec<_>, _>>()
            .map_err(StageError::asset)?;
        TEXTURES.write(job, &Textures(textures));
        Ok(())
    }
}

impl super::Makes<Textures> for Compress {}
