//! Shared test helpers: a small synthetic package with real KTX2 textures, an independent
//! writer that follows `docs/FORMAT.md` without validating, and a deterministic generator.

#![allow(dead_code)]

use ori_package::{
    ALIGN, FORMAT_VERSION, Impostor, ImpostorTextures, MAGIC, Manifest, PltInfo, SelectionEntry,
    SelectionTable, Source, Sphere, TextureFormat, TextureRef,
};
use ori_texture::{Ktx2, Quality, RgbaImage, VkFormat, encode_bc1, encode_bc4, encode_bc5};
use serde_json::json;

/// Edge of the test textures.
pub const RES: u32 = 16;

/// Synthetic textures for impostor `seed`: a disc of relief (empty around it), varied
/// normals and colours.
pub fn textures(resolution: u32, seed: u32, depth_format: TextureFormat) -> ImpostorTextures {
    let r = resolution;
    let texels = || (0..r).flat_map(move |y| (0..r).map(move |x| (x, y)));
    let half = r as i64 / 2;
    let codes: Vec<u8> = texels()
        .map(|(x, y)| {
            let (dx, dy) = (x as i64 - half, y as i64 - half);
            if dx * dx + dy * dy <= (half * 4 / 5).pow(2) {
                ((x * 7 + y * 13 + seed * 5) % 200) as u8
            } else {
                255
            }
        })
        .collect();
    let depth = match depth_format {
        TextureFormat::R8 => Ktx2::new(VkFormat::R8Unorm, r, r, vec![codes]),
        TextureFormat::Bc4 => Ktx2::new(
            VkFormat::Bc4Unorm,
            r,
            r,
            vec![encode_bc4(&codes, r, r, Quality::Fast).unwrap()],
        ),
        other => panic!("{other:?} is not a depth format"),
    }
    .unwrap();
    let xy: Vec<u8> = texels()
        .flat_map(|(x, y)| [((x * 16 + seed * 3) % 256) as u8, ((y * 16) % 256) as u8])
        .collect();
    let normal = Ktx2::new(
        VkFormat::Bc5Unorm,
        r,
        r,
        vec![encode_bc5(&xy, r, r, Quality::Fast).unwrap()],
    )
    .unwrap();
    let rgba: Vec<u8> = texels()
        .flat_map(|(x, y)| {
            [
                ((x * 16) % 256) as u8,
                ((y * 16) % 256) as u8,
                (seed * 40 % 256) as u8,
                255,
            ]
        })
        .collect();
    let image = RgbaImage::new(r, r, rgba).unwrap();
    let albedo = Ktx2::new(
        VkFormat::Bc1RgbSrgb,
        r,
        r,
        vec![encode_bc1(&image, None, Quality::Fast).unwrap()],
    )
    .unwrap();
    ImpostorTextures {
        depth: depth.to_bytes(),
        normal: normal.to_bytes(),
        albedo: albedo.to_bytes(),
    }
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let len = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|x| x / len)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The frame `ori-raster` builds for a direction.
pub fn frame(d: [f64; 3]) -> [[f64; 3]; 3] {
    let d = normalize(d);
    let up = if d[1].abs() < 0.99 {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, -1.0]
    };
    let u = normalize(cross(up, d));
    let v = cross(d, u);
    [u, v, d]
}

/// A placeholder reference; `write` fills it.
pub fn placeholder(format: TextureFormat) -> TextureRef {
    TextureRef {
        format,
        offset: 0,
        length: 0,
        blake3: String::new(),
    }
}

/// A valid manifest for `n` impostors (texture references left for `write` to fill).
pub fn manifest(n: usize, resolution: u32, depth_format: TextureFormat) -> Manifest {
    let dirs = [
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 1.0],
        [-1.0, 0.5, -0.25],
        [0.3, -0.9, 0.1],
    ];
    let impostors = (0..n)
        .map(|i| {
            let f = frame(dirs[i % dirs.len()]);
            let e = resolution as f32;
            Impostor {
                direction: f[2],
                frame: f,
                center: [0.1 * i as f64, -0.2],
                half_size: 1.5,
                near: 1.0,
                far: -1.0 / 3.0,
                occupied: [1.0, e - 1.0, 2.0, e - 2.0, 0.0, 199.0],
                depth: placeholder(depth_format),
                normal: placeholder(TextureFormat::Bc5),
                albedo: placeholder(TextureFormat::Bc1Srgb),
            }
        })
        .collect();
    let entries: Vec<SelectionEntry> = (0..320)
        .map(|e| {
            let mut impostors = vec![(e % n) as u16];
            if n > 1 {
                impostors.push(((e + 1) % n) as u16);
            }
            SelectionEntry {
                impostors,
                missed: (e as u32 * 37) % 500,
            }
        })
        .collect();
    let gc = entries.iter().map(|e| e.missed).max().unwrap();
    Manifest {
        format_version: FORMAT_VERSION,
        tool: "ori-package tests".into(),
        source: Source {
            name: "samples/teapot.glb".into(),
            blake3: blake3::hash(b"model").to_hex().to_string(),
        },
        bounding_sphere: Sphere {
            center: [0.0, 0.25, -0.125],
            radius: 1.2,
        },
        resolution,
        depth_format,
        impostors,
        selection: SelectionTable {
            directions: "icosahedron-320".into(),
            rule: "best:6".into(),
            goal_percent: 0.2,
            s0: 256,
            entries,
        },
        plt: PltInfo {
            s0: 256,
            gc,
            pixels: 65536.0 / f64::from(gc),
            at_least: false,
            recommended_resolution: 256,
            measured_by: "ori-eval march 16+7".into(),
        },
        params: json!({
            "views": {"strategy": "regular", "count": 20},
            "bake": {"resolution": resolution, "margin_texels": 1},
            "alpha": 0.5,
        }),
    }
}

/// A small valid package's inputs: `n` impostors at [`RES`].
pub fn sample(n: usize, depth_format: TextureFormat) -> (Manifest, Vec<ImpostorTextures>) {
    let m = manifest(n, RES, depth_format);
    let t = (0..n as u32)
        .map(|i| textures(RES, i, depth_format))
        .collect();
    (m, t)
}

/// Writes a package by `docs/FORMAT.md` alone, without any validation: texture references
/// get their offset, length and blake3 (formats are kept as given), then the smallest
/// consistent payload offset is found.
pub fn assemble(manifest: &Manifest, textures: &[ImpostorTextures]) -> Vec<u8> {
    let mut m = manifest.clone();
    let data: Vec<&[u8]> = textures
        .iter()
        .flat_map(|t| [&t.depth[..], &t.normal[..], &t.albedo[..]])
        .collect();
    let mut payload = ALIGN;
    loop {
        let mut pos = payload;
        let refs = m
            .impostors
            .iter_mut()
            .flat_map(|i| [&mut i.depth, &mut i.normal, &mut i.albedo]);
        for (r, d) in refs.zip(&data) {
            r.offset = pos.next_multiple_of(ALIGN);
            r.length = d.len() as u64;
            r.blake3 = blake3::hash(d).to_hex().to_string();
            pos = r.offset + r.length;
        }
        let json = serde_json::to_vec(&m).unwrap();
        let needed = (64 + json.len() as u64).next_multiple_of(ALIGN);
        if needed == payload {
            let mut out = header(&json, payload);
            out.extend_from_slice(&json);
            let refs = m
                .impostors
                .iter()
                .flat_map(|i| [&i.depth, &i.normal, &i.albedo]);
            for (r, d) in refs.zip(&data) {
                out.resize(r.offset as usize, 0);
                out.extend_from_slice(d);
            }
            return out;
        }
        payload = needed;
    }
}

/// The 64-byte header for `json` with `payload` offset.
pub fn header(json: &[u8], payload: u64) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(json.len() as u64).to_le_bytes());
    out.extend_from_slice(blake3::hash(json).as_bytes());
    out.extend_from_slice(&payload.to_le_bytes());
    out
}

/// A file with `json` as its manifest (correct header, hash and padding) and no textures:
/// for errors found in the manifest before the layout is looked at.
pub fn rewrap(json: &[u8]) -> Vec<u8> {
    let payload = (64 + json.len() as u64).next_multiple_of(ALIGN);
    let mut out = header(json, payload);
    out.extend_from_slice(json);
    out.resize(payload as usize, 0);
    out
}

/// The manifest bytes of a package file.
pub fn manifest_json(file: &[u8]) -> &[u8] {
    let len = u64::from_le_bytes(file[16..24].try_into().unwrap()) as usize;
    &file[64..64 + len]
}

/// xorshift64: a small deterministic generator.
pub struct XorShift(pub u64);

impl XorShift {
    pub fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }

    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}
