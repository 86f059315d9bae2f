//! package: the `.ori` file (`ori_package`, `docs/FORMAT.md`) from the maps' frames, the
//! selection table, the PLT and the textures.

use ori_artifact::DecodeError;
use ori_graph::{JobContext, StageError};
use ori_package::{
    Manifest, PltInfo, SelectionEntry, SelectionTable, Source, Sphere, TextureFormat, TextureRef,
};
use ori_relief::{ReliefMap, ReliefSet};
use serde::{Deserialize, Serialize};

use super::bake::MAPS;
use super::compress::{CompressParams, CompressQuality, DepthFormat, TEXTURES, compress_map};
use super::plt::PLT;
use super::select::SELECTION;
use super::{Artifact, PipelineStage, Slot};

/// The package file's bytes.
pub const PACKAGE: Slot<PackageBytes> = Slot::new("package");

/// A package file (single or hierarchy), as written.
pub struct PackageBytes(pub Vec<u8>);

impl Artifact for PackageBytes {
    fn encode(&self) -> Vec<u8> {
        self.0.clone()
    }

    /// Taken as it is: the release checks it as a reader would (`release::entry`).
    fn decode(bytes: &[u8]) -> Result<PackageBytes, DecodeError> {
        Ok(PackageBytes(bytes.to_vec()))
    }
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
pub struct Package;

impl PipelineStage for Package {
    const NAME: &'static str = "package";
    /// 2: the occupied volume of the depth as shipped (BC4 decoded); `measured_by` names the
    /// held-out directions.
    const VERSION: u32 = 2;
    type Params = PackageParams;

    fn run(&self, params: PackageParams, job: &mut JobContext<'_>) -> Result<(), StageError> {
        let source = job
            .input_hash(super::ingest::SOURCE)
            .ok_or_else(|| StageError::Plan("the package job has no source input".into()))?;
        let set = MAPS.read(job)?;
        let selection = SELECTION.read(job)?;
        let plt = PLT.read(job)?;
        let textures = TEXTURES.read(job)?;
        let manifest = manifest(
            &params,
            source.to_hex(),
            &set,
            &selection,
            &plt,
            &textures.0,
        )
        .map_err(StageError::asset)?;
        let bytes = ori_package::write(&manifest, &textures.0).map_err(StageError::asset)?;
        PACKAGE.write(job, &PackageBytes(bytes));
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
    textures: &[ori_package::ImpostorTextures],
) -> Result<Manifest, String> {
    let march = ori_package::RecordedMarch::of_params(&params.pipeline);
    let placeholder = |format| TextureRef {
        format,
        offset: 0,
        length: 0,
        blake3: String::new(),
    };
    let impostors = set
        .maps
        .iter()
        .zip(textures)
        .enumerate()
        .map(|(i, (map, shipped))| {
            let v = &map.view;
            // The occupied volume of the depth codes a runtime reads: with BC4 they are not
            // the baked ones, and a volume that misses a decoded texel would cut rays short.
            let ktx = ori_texture::Ktx2::from_bytes(&shipped.depth)
                .map_err(|e| format!("impostor {i}'s depth texture: {e}"))?;
            let level = ktx.levels().first().map_or(&[][..], Vec::as_slice);
            let depth = ori_texture::decode::to_bytes(ktx.format(), level, map.size())
                .map_err(|e| format!("impostor {i}'s depth texture: {e}"))?;
            Ok(ori_package::Impostor {
                direction: v.frame.d,
                frame: [v.frame.u, v.frame.v, v.frame.d],
                center: v.center,
                half_size: v.half_size,
                near: v.near,
                far: v.far,
                occupied: ori_eval::march::occupied_volume(&depth, map.size() as usize),
                depth: placeholder(params.depth.texture_format()),
                normal: placeholder(TextureFormat::Bc5),
                albedo: placeholder(TextureFormat::Bc1Srgb),
            })
        })
        .collect::<Result<_, String>>()?;
    let (at_least, pixels) = match plt.value() {
        ori_plt::PltValue::AtLeast(p) => (true, p),
        ori_plt::PltValue::Pixels(p) => (false, p),
    };
    Ok(Manifest {
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
                "{} ({} linear + {} binary steps, wall threshold {}), {s0} x {s0} \
                 orthographic views: the selection at the 320 table directions, the PLT by \
                 the cpu evaluator at the {} held-out directions of seed {}",
                match &params.measured_on {
                    Some(device) => format!("wgpu renderer on {device}"),
                    None => "cpu evaluator".to_string(),
                },
                shown(march.linear_steps),
                shown(march.binary_steps),
                shown(march.wall_threshold),
                ori_views::HELD_OUT_REGULAR + ori_views::HELD_OUT_RANDOM,
                shown(params.pipeline.pointer("/plt/held_out_seed").cloned()),
                s0 = plt.s0,
            ),
        },
        params: params.pipeline.clone(),
    })
}

/// A recorded number as the manifest's JSON writes it (`0.25`, `1.0`), or `null`.
fn shown(value: Option<impl Into<serde_json::Value>>) -> serde_json::Value {
    value.map_or(serde_json::Value::Null, Into::into)
}

/// What a measuring package records: the selection parameters it is measured with.
#[derive(Serialize)]
struct MeasuredWith<'a> {
    select: &'a ori_select::SelectParams,
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
        pipeline: serde_json::to_value(MeasuredWith { select }).expect("parameters serialise"),
        measured_on: None,
    };
    let manifest = manifest(&params, "0".repeat(64), set, &selection, &plt, &textures)?;
    let bytes = ori_package::write(&manifest, &textures).map_err(|e| e.to_string())?;
    ori_package::read(&bytes).map_err(|e| e.to_string())
}

impl super::Makes<PackageBytes> for Package {}
