//! The last two stages: texture compression (`[compress]`) and packaging. Compression turns
//! each relief map into three KTX2 textures (the guide's 2.5 bytes per texel: R8 depth, BC5
//! normal, BC1 albedo; BC4 depth on request); packaging gathers them with the frames, the
//! selection table and the PLT into one `.ori` file (`ori_package`, `docs/FORMAT.md`).

use ori_bake::{EMPTY_DEPTH, ReliefMap, ReliefSet};
use ori_graph::{JobContext, Stage, StageError};
use ori_package::{
    ImpostorTextures, Manifest, PltInfo, SelectionEntry, SelectionTable, Source, Sphere,
    TextureFormat, TextureRef,
};
use ori_texture::{Ktx2, Quality, RgbaImage, VkFormat};
use serde::{Deserialize, Serialize};

use crate::stages::{MAPS, PLT, SELECTION, params};

/// Output names.
pub const TEXTURES: &str = "textures";
pub const PACKAGE: &str = "package";

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
    fn texture_format(self) -> TextureFormat {
        match self {
            DepthFormat::R8 => TextureFormat::R8,
            DepthFormat::Bc4 => TextureFormat::Bc4,
        }
    }
}

/// The three textures of one relief map, as KTX2 files.
fn compress_map(map: &ReliefMap, params: &CompressParams) -> Result<ImpostorTextures, String> {
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

/// The `textures` artifact: for each map, its depth, normal and albedo KTX2 files, each as a
/// little-endian `u64` length and the bytes, after a `u32` map count.
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
pub struct CompressStage;

impl Stage for CompressStage {
    fn name(&self) -> &'static str {
        "compress"
    }

    fn version(&self) -> u32 {
        1
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        let params: CompressParams = params(ctx)?;
        let set = decode_maps(ctx)?;
        let textures = set
            .maps
            .iter()
            .enumerate()
            .map(|(i, map)| compress_map(map, &params).map_err(|e| format!("map {i}: {e}")))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))?;
        ctx.output(TEXTURES, encode_textures(&textures));
        Ok(())
    }
}

fn decode_maps(ctx: &mut JobContext<'_>) -> Result<ReliefSet, StageError> {
    ReliefSet::decode(&ctx.input(MAPS)?)
        .map_err(|e| StageError::new(format!("{}: {e}", ctx.asset())))
}

/// Parameters of the package job: what the manifest records besides its inputs.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PackageParams {
    /// The asset's name (its path under the assets root).
    pub name: String,
    /// `ori-pipeline <version>`.
    pub tool: String,
    /// The depth texture format the compress job was asked for.
    pub depth: DepthFormat,
    /// Every stage parameter that shaped the package, recorded in the manifest.
    pub pipeline: serde_json::Value,
    /// The GPU adapter selection and PLT were measured on (`--backend gpu`); absent for the
    /// CPU evaluator.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured_on: Option<String>,
}

/// The tool name and version written into every manifest.
pub fn tool() -> String {
    format!("ori-pipeline {}", env!("CARGO_PKG_VERSION"))
}

/// Assembles the `.ori` file from the maps' frames, the selection, the PLT and the textures.
pub struct PackageStage;

impl Stage for PackageStage {
    fn name(&self) -> &'static str {
        "package"
    }

    fn version(&self) -> u32 {
        1
    }

    fn run(&self, ctx: &mut JobContext<'_>) -> Result<(), StageError> {
        let params: PackageParams = params(ctx)?;
        let fail = |ctx: &JobContext<'_>, e: &dyn std::fmt::Display| {
            StageError::new(format!("{}: {e}", ctx.asset()))
        };
        let source = ctx
            .input_hash("source")
            .ok_or_else(|| StageError::new("the package job has no source input"))?;
        let set = decode_maps(ctx)?;
        let selection =
            ori_select::Selection::decode(&ctx.input(SELECTION)?).map_err(|e| fail(ctx, &e))?;
        let plt = ori_plt::Plt::decode(&ctx.input(PLT)?).map_err(|e| fail(ctx, &e))?;
        let textures = decode_textures(&ctx.input(TEXTURES)?).map_err(|e| fail(ctx, &e))?;
        let manifest = manifest(&params, source.to_hex(), &set, &selection, &plt);
        let bytes = ori_package::write(&manifest, &textures).map_err(|e| fail(ctx, &e))?;
        ctx.output(PACKAGE, bytes);
        Ok(())
    }
}

/// A sphere holding the object: the one through the corners of the smallest map's box (every
/// map's box holds the whole object).
fn bounding_sphere(set: &ReliefSet) -> Sphere {
    let corners = |map: &ReliefMap| {
        let v = &map.view;
        let (u, w, d) = (v.frame.u, v.frame.v, v.frame.d);
        let mut out = Vec::with_capacity(8);
        for su in [-1.0, 1.0] {
            for sv in [-1.0, 1.0] {
                for h in [v.near, v.far] {
                    let a = v.center[0] + su * v.half_size;
                    let b = v.center[1] + sv * v.half_size;
                    out.push(std::array::from_fn::<f64, 3, _>(|i| {
                        u[i] * a + w[i] * b + d[i] * h
                    }));
                }
            }
        }
        out
    };
    let smallest = set
        .maps
        .iter()
        .min_by(|a, b| a.view.half_size.total_cmp(&b.view.half_size))
        .expect("at least one map");
    let pts = corners(smallest);
    let center: [f64; 3] = std::array::from_fn(|i| pts.iter().map(|p| p[i]).sum::<f64>() / 8.0);
    let radius = pts
        .iter()
        .map(|p| {
            let d: [f64; 3] = std::array::from_fn(|i| p[i] - center[i]);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        })
        .fold(0.0f64, f64::max);
    Sphere { center, radius }
}

fn manifest(
    params: &PackageParams,
    source_hash: String,
    set: &ReliefSet,
    selection: &ori_select::Selection,
    plt: &ori_plt::Plt,
) -> Manifest {
    let placeholder = |format| TextureRef {
        format,
        offset: 0,
        length: 0,
        blake3: String::new(),
    };
    let impostors = set
        .maps
        .iter()
        .map(|map| {
            let v = &map.view;
            ori_package::Impostor {
                direction: v.frame.d,
                frame: [v.frame.u, v.frame.v, v.frame.d],
                center: v.center,
                half_size: v.half_size,
                near: v.near,
                far: v.far,
                occupied: ori_eval::march::occupied_volume(&map.depth, map.size() as usize),
                depth: placeholder(params.depth.texture_format()),
                normal: placeholder(TextureFormat::Bc5),
                albedo: placeholder(TextureFormat::Bc1Srgb),
            }
        })
        .collect();
    let (at_least, pixels) = match plt.value() {
        ori_plt::PltValue::AtLeast(p) => (true, p),
        ori_plt::PltValue::Pixels(p) => (false, p),
    };
    Manifest {
        format_version: ori_package::FORMAT_VERSION,
        tool: params.tool.clone(),
        source: Source {
            name: params.name.clone(),
            blake3: source_hash,
        },
        bounding_sphere: bounding_sphere(set),
        resolution: set.maps.first().map_or(0, |m| m.size()),
        depth_format: params.depth.texture_format(),
        impostors,
        selection: SelectionTable {
            directions: "icosahedron-320".into(),
            rule: selection.rule.to_string(),
            goal_percent: selection.goal_percent,
            s0: selection.s0,
            entries: selection
                .entries
                .iter()
                .map(|e| SelectionEntry {
                    impostors: e.impostors.clone(),
                    missed: e.missed,
                })
                .collect(),
        },
        plt: PltInfo {
            s0: plt.s0,
            gc: plt.gc,
            pixels,
            at_least,
            recommended_resolution: plt.recommended_resolution(),
            measured_by: format!(
                "{} ({} linear + {} binary steps, wall threshold {}), {} x {} \
                 orthographic views of the 320 directions",
                match &params.measured_on {
                    Some(device) => format!("wgpu renderer on {device}"),
                    None => "cpu evaluator".to_string(),
                },
                params.pipeline["select"]["linear_steps"],
                params.pipeline["select"]["binary_steps"],
                params.pipeline["select"]["wall_threshold"],
                plt.s0,
                plt.s0
            ),
        },
        params: params.pipeline.clone(),
    }
}

/// A package of `set` to measure with the GPU renderer (`gpu_select`): exact R8 depth (all
/// that coverage reads), quickly compressed normal and albedo, and a placeholder selection
/// table (every direction: impostor 0) and PLT. Never written anywhere.
pub(crate) fn measuring_package(
    set: &ReliefSet,
    select: &ori_select::SelectParams,
) -> Result<ori_package::Package, String> {
    let compress = CompressParams {
        quality: CompressQuality::Fast,
        depth: DepthFormat::R8,
    };
    let textures = set
        .maps
        .iter()
        .map(|m| compress_map(m, &compress))
        .collect::<Result<Vec<_>, _>>()?;
    let directions = ori_views::evaluation_directions().len();
    let selection = ori_select::Selection {
        rule: select.rule,
        goal_percent: select.goal_percent,
        s0: select.s0,
        impostor_count: set.maps.len() as u32,
        entries: vec![
            ori_select::Entry {
                impostors: vec![0],
                missed: 0,
            };
            directions
        ],
    };
    let plt = ori_plt::estimate(select.s0, &vec![0; directions]);
    let params = PackageParams {
        name: "measurement".into(),
        tool: tool(),
        depth: DepthFormat::R8,
        pipeline: serde_json::json!({ "select": select }),
        measured_on: None,
    };
    let manifest = manifest(&params, "0".repeat(64), set, &selection, &plt);
    let bytes = ori_package::write(&manifest, &textures).map_err(|e| e.to_string())?;
    ori_package::read(&bytes).map_err(|e| e.to_string())
}
