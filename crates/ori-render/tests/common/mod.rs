//! Shared by the GPU tests: packages built in the test (as the pipeline builds them), the
//! CPU evaluator's relief set from a package's decoded textures, and one renderer.

#![allow(dead_code)]

use std::sync::OnceLock;

use ori_bake::{BakeParams, EMPTY_DEPTH, ReliefMap, ReliefSet};
use ori_mesh::Mesh;
use ori_package::{
    ImpostorTextures, Manifest, Package, PltInfo, SelectionEntry, SelectionTable, Source, Sphere,
    TextureFormat, TextureRef,
};
use ori_raster::{Frame, OrthoView};
use ori_render::Renderer;
use ori_select::SelectParams;
use ori_texture::decode::to_u8;
use ori_texture::{Ktx2, Quality, RgbaImage, VkFormat};

pub const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

/// The renderer every test shares. No adapter is a failure, never a skip: CI installs Mesa's
/// lavapipe (`mesa-vulkan-drivers`).
pub fn renderer() -> &'static Renderer {
    static RENDERER: OnceLock<Renderer> = OnceLock::new();
    RENDERER.get_or_init(|| {
        let r = Renderer::new().unwrap_or_else(|e| {
            panic!("no GPU adapter for the ori-render tests (CI needs mesa-vulkan-drivers): {e}")
        });
        eprintln!(
            "adapter: {}; BC textures sampled compressed: {}",
            r.adapter_summary(),
            r.compressed_textures()
        );
        r
    })
}

/// A renderer that decodes BC textures on the CPU (the fallback path), with the same
/// decoders the CPU evaluator's maps come from.
pub fn fallback_renderer() -> &'static Renderer {
    static RENDERER: OnceLock<Renderer> = OnceLock::new();
    RENDERER.get_or_init(|| {
        Renderer::with_options(&ori_render::RendererOptions {
            decode_on_cpu: true,
            ..Default::default()
        })
        .unwrap_or_else(|e| panic!("no GPU adapter for the ori-render tests: {e}"))
    })
}

/// A model and its package.
pub struct Built {
    pub mesh: Mesh,
    pub package: Package,
}

/// Load `relative` (under the shared models), plan (defaults: n = 20), bake at `resolution`,
/// select (best:6 at s0 = 256, the defaults), estimate the PLT, compress (R8 or BC4 depth,
/// BC5, BC1) and package it, then read the package back, as the pipeline does.
pub fn build(relative: &str, resolution: u32, depth: TextureFormat) -> Built {
    let path = format!("{MODELS}/{relative}");
    let mesh = ori_mesh::load_file(path.as_ref(), &Default::default())
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .mesh;
    let plan = ori_views::plan_views(&mesh, &Default::default()).expect("plan");
    let bake = BakeParams {
        resolution,
        ..Default::default()
    };
    let set = ori_bake::bake(&mesh, &plan.directions, &bake).expect("bake");
    // Any table serves parity; the corners and edge midpoints of each region are enough.
    let params = SelectParams {
        region_steps: 2,
        ..Default::default()
    };
    let selection = ori_select::select(&mesh, &set, &params).expect("select");
    let plt = ori_plt::estimate(selection.s0, &selection.missed());
    let textures: Vec<ImpostorTextures> = set.maps.iter().map(|m| compress(m, depth)).collect();
    let placeholder = |format| TextureRef {
        format,
        offset: 0,
        length: 0,
        blake3: String::new(),
    };
    let (lo, hi) = mesh.bounds();
    let center: [f64; 3] = std::array::from_fn(|k| 0.5 * (f64::from(lo[k]) + f64::from(hi[k])));
    let radius = mesh
        .positions
        .iter()
        .map(|p| {
            (0..3)
                .map(|k| (f64::from(p[k]) - center[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    let (at_least, pixels) = match plt.value() {
        ori_plt::PltValue::AtLeast(p) => (true, p),
        ori_plt::PltValue::Pixels(p) => (false, p),
    };
    let manifest = Manifest {
        format_version: ori_package::FORMAT_VERSION,
        tool: "ori-render tests".into(),
        source: Source {
            name: relative.into(),
            blake3: "0".repeat(64),
        },
        bounding_sphere: Sphere { center, radius },
        resolution,
        depth_format: depth,
        impostors: set
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
                    depth: placeholder(depth),
                    normal: placeholder(TextureFormat::Bc5),
                    albedo: placeholder(TextureFormat::Bc1Srgb),
                }
            })
            .collect(),
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
            measured_by: "cpu evaluator".into(),
        },
        params: serde_json::json!({
            "select": {
                "binary_steps": params.binary_steps,
                "linear_steps": params.linear_steps,
                "wall_threshold": params.wall_threshold,
            }
        }),
    };
    let bytes = ori_package::write(&manifest, &textures).expect("write");
    let package = ori_package::read(&bytes).expect("read");
    Built { mesh, package }
}

/// The three KTX2 textures of one map, as `ori-pipeline`'s compress stage makes them.
fn compress(map: &ReliefMap, depth: TextureFormat) -> ImpostorTextures {
    let n = map.size();
    let ktx = |format: VkFormat, data: Vec<u8>| {
        Ktx2::new(format, n, n, vec![data])
            .expect("ktx2")
            .to_bytes()
    };
    let depth = match depth {
        TextureFormat::Bc4 => ktx(
            VkFormat::Bc4Unorm,
            ori_texture::encode_bc4(&map.depth, n, n, Quality::Fast).expect("bc4"),
        ),
        _ => ktx(VkFormat::R8Unorm, map.depth.clone()),
    };
    let xy: Vec<u8> = map.normal.iter().flatten().copied().collect();
    let normal = ktx(
        VkFormat::Bc5Unorm,
        ori_texture::encode_bc5(&xy, n, n, Quality::Fast).expect("bc5"),
    );
    let rgba: Vec<u8> = map
        .albedo
        .iter()
        .flat_map(|c| [c[0], c[1], c[2], 255])
        .collect();
    let mask: Vec<bool> = map.depth.iter().map(|&d| d != EMPTY_DEPTH).collect();
    let image = RgbaImage::new(n, n, rgba).expect("image");
    let albedo = ktx(
        VkFormat::Bc1RgbSrgb,
        ori_texture::encode_bc1(&image, Some(&mask), Quality::Fast).expect("bc1"),
    );
    ImpostorTextures {
        depth,
        normal,
        albedo,
    }
}

/// The relief set the CPU evaluator draws: the package's frames and its textures decoded
/// with `ori_texture`'s decoders (so compression is the same on both sides).
pub fn decoded_set(package: &Package) -> ReliefSet {
    let m = &package.manifest;
    let n = m.resolution;
    let maps = m
        .impostors
        .iter()
        .enumerate()
        .map(|(i, imp)| {
            let depth = package.depth(i);
            let depth = match depth.format() {
                VkFormat::Bc4Unorm => ori_texture::decode_bc4(&depth.levels()[0], n, n)
                    .expect("bc4")
                    .into_iter()
                    .map(to_u8)
                    .collect(),
                _ => depth.levels()[0].clone(),
            };
            let normal = ori_texture::decode_bc5(&package.normal(i).levels()[0], n, n)
                .expect("bc5")
                .into_iter()
                .map(|t| t.map(to_u8))
                .collect();
            let albedo = ori_texture::decode_bc1(&package.albedo(i).levels()[0], n, n)
                .expect("bc1")
                .into_iter()
                .map(|t| [to_u8(t[0]), to_u8(t[1]), to_u8(t[2])])
                .collect();
            ReliefMap {
                view: OrthoView {
                    frame: Frame {
                        u: imp.frame[0],
                        v: imp.frame[1],
                        d: imp.frame[2],
                    },
                    center: imp.center,
                    half_size: imp.half_size,
                    near: imp.near,
                    far: imp.far,
                    size: n,
                },
                depth,
                normal,
                albedo,
            }
        })
        .collect();
    ReliefSet { maps }
}
