//! compress: each relief map to three KTX2 textures (`[compress]`; the guide's 2.5 bytes per
//! texel: R8 depth, BC5 normal, BC1 albedo; BC4 depth on request).

use ori_bake::{EMPTY_DEPTH, ReliefMap};
use ori_graph::{JobContext, StageError};
use ori_package::{ImpostorTextures, TextureFormat};
use ori_texture::{Ktx2, Quality, RgbaImage, VkFormat};
use serde::{Deserialize, Serialize};

use super::{Artifact, PipelineStage, Slot, bake::MAPS, in_asset};

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

/// The three textures of one relief map, as KTX2 files.
pub(crate) fn compress_map(
    map: &ReliefMap,
    params: &CompressParams,
) -> Result<ImpostorTextures, String> {
    let n = map.size();
    let quality = match params.quality {
        CompressQuality::High => Quality::High,
        CompressQuality::Fast => Quality::Fast,
    };
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

/// For each map, its depth, normal and albedo KTX2 files, each as a little-endian `u64`
/// length and the bytes, after a `u32` map count.
impl Artifact for Textures {
    fn encode(&self) -> Vec<u8> {
        encode_textures(&self.0)
    }

    fn decode(bytes: &[u8]) -> Result<Textures, String> {
        decode_textures(bytes).map(Textures)
    }
}

fn encode_textures(textures: &[ImpostorTextures]) -> Vec<u8> {
    let mut out = (textures.len() as u32).to_le_bytes().to_vec();
    for t in textures {
        for file in [&t.depth, &t.normal, &t.albedo] {
            out.extend_from_slice(&(file.len() as u64).to_le_bytes());
            out.extend_from_slice(file);
        }
    }
    out
}

fn decode_textures(bytes: &[u8]) -> Result<Vec<ImpostorTextures>, String> {
    let bad = || "the textures artifact is truncated".to_string();
    let mut rest = bytes;
    let mut take = |n: usize| -> Result<&[u8], String> {
        if rest.len() < n {
            return Err(bad());
        }
        let (head, tail) = rest.split_at(n);
        rest = tail;
        Ok(head)
    };
    let count = u32::from_le_bytes(take(4)?.try_into().expect("4 bytes"));
    let mut out = Vec::new();
    for _ in 0..count {
        let mut file = || -> Result<Vec<u8>, String> {
            let len = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes"));
            Ok(take(usize::try_from(len).map_err(|_| bad())?)?.to_vec())
        };
        out.push(ImpostorTextures {
            depth: file()?,
            normal: file()?,
            albedo: file()?,
        });
    }
    Ok(out)
}

/// Compresses every relief map (`[compress]` parameters).
pub struct Compress;

impl PipelineStage for Compress {
    const NAME: &'static str = "compress";
    const VERSION: u32 = 1;
    type Params = CompressParams;

    fn run(&self, params: CompressParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let set = MAPS.read(job)?;
        let textures = set
            .maps
            .iter()
            .enumerate()
            .map(|(i, map)| compress_map(map, &params).map_err(|e| format!("map {i}: {e}")))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| in_asset(job, e))?;
        TEXTURES.write(job, &Textures(textures));
        Ok(())
    }
}
