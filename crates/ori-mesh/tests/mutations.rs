//! A short, deterministic mutation test of every loader on real models (the long runs are the
//! cargo-fuzz targets in `fuzz/`): thousands of damaged copies of OBJ, MTL, PLY, glTF and GLB
//! files, each of which must load or fail with an error, never panic, and never decode a
//! texture or build a face past tight limits.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};

use ori_mesh::{Limits, LoadOptions};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");
const SAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples");

/// The files a model references: (reference, bytes).
type Files = Vec<(&'static str, Vec<u8>)>;

/// xorshift64*: the same mutations on every machine.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Values that break parsers: signs, huge counts, boundaries, separators.
const TOKENS: [&[u8]; 12] = [
    b"-1",
    b"0",
    b"4294967295",
    b"18446744073709551616",
    b"1e309",
    b"nan",
    b"/",
    b"//",
    b"\n",
    b" ",
    b"\xff\xff\xff\x7f",
    b"\x00\x00\x00\x80",
];

/// One to four mutations of `bytes`: bit flips, boundary bytes, token insertions, deletions,
/// duplications and truncation.
fn mutate(bytes: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(out.len());
        match rng.below(6) {
            0 if !out.is_empty() => out[at] ^= 1 << rng.below(8),
            1 if !out.is_empty() => out[at] = [0, 0x7f, 0x80, 0xff][rng.below(4)],
            2 => {
                let token = TOKENS[rng.below(TOKENS.len())];
                out.splice(at..at, token.iter().copied());
            }
            3 => {
                let end = (at + 1 + rng.below(64)).min(out.len());
                out.drain(at..end);
            }
            4 => {
                let end = (at + 1 + rng.below(64)).min(out.len());
                let chunk: Vec<u8> = out[at..end].to_vec();
                out.splice(at..at, chunk);
            }
            _ => out.truncate(at),
        }
    }
    out
}

/// Load `name` from `bytes` with references served from `files`, catching any panic.
fn survives(name: &str, bytes: &[u8], files: &[(&str, Vec<u8>)]) -> Result<(), String> {
    let options = LoadOptions {
        recompute_normals: false,
        limits: Limits {
            max_texture_pixels: 1 << 20,
            max_total_texture_pixels: 1 << 21,
            max_face_corners: 4096,
            max_triangles: 1_000_000,
            max_vertices: 1_000_000,
            max_depth_complexity: 64,
        },
    };
    let files: Vec<(&str, &[u8])> = files.iter().map(|(n, b)| (*n, b.as_slice())).collect();
    let ran = catch_unwind(AssertUnwindSafe(|| {
        let _ = common::load_from(name, bytes, &files, &options);
    }));
    ran.map_err(|panic| {
        panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default()
    })
}

fn read(path: &str) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// A 4 x 4 texture for the MTL cases.
fn png() -> Vec<u8> {
    common::png(4, 4, [200, 100, 50, 255])
}

#[test]
fn damaged_real_models_never_panic_any_loader() {
    let avocado = format!("{SAMPLES}/avocado");
    let gltf = read(&format!("{avocado}/Avocado.gltf"));
    let bin = read(&format!("{avocado}/Avocado.bin"));
    let mtl = b"newmtl m\nKd 0.8 0.4 0.2\nd 0.5\nmap_Kd t.png\n".to_vec();
    let textured_obj =
        b"mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3\n"
            .to_vec();
    // (model name, its bytes, the files it references, which one is mutated: None = the model)
    let cases: Vec<(&str, Vec<u8>, Files, Option<usize>)> = vec![
        (
            "bunny.obj",
            read(&format!("{MODELS}/stanford/bunny/bunny_npm_lowres.obj")),
            vec![],
            None,
        ),
        (
            "t.obj",
            textured_obj.clone(),
            vec![("m.mtl", mtl.clone()), ("t.png", png())],
            None,
        ),
        (
            "t.obj",
            textured_obj,
            vec![("m.mtl", mtl), ("t.png", png())],
            Some(0),
        ),
        (
            "dragon.ply",
            read(&format!("{MODELS}/stanford/dragon/dragon_res4.ply")),
            vec![],
            None,
        ),
        (
            "box.glb",
            read(&format!(
                "{MODELS}/gltf/BoxVertexColors/BoxVertexColors.glb"
            )),
            vec![],
            None,
        ),
        (
            "colors.glb",
            read(&format!(
                "{MODELS}/gltf/VertexColorTest/VertexColorTest.glb"
            )),
            vec![],
            None,
        ),
        (
            "Avocado.gltf",
            gltf,
            vec![
                ("Avocado.bin", bin.clone()),
                ("Avocado_baseColor.png", png()),
            ],
            None,
        ),
        (
            "Avocado.gltf",
            read(&format!("{avocado}/Avocado.gltf")),
            vec![("Avocado.bin", bin), ("Avocado_baseColor.png", png())],
            Some(0),
        ),
    ];
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut failures = Vec::new();
    let mut tried = 0;
    for (name, model, files, target) in &cases {
        for _ in 0..1000 {
            tried += 1;
            let (bytes, files) = match target {
                None => (mutate(model, &mut rng), files.clone()),
                Some(i) => {
                    let mut files = files.clone();
                    files[*i].1 = mutate(&files[*i].1, &mut rng);
                    (model.clone(), files)
                }
            };
            if let Err(panic) = survives(name, &bytes, &files) {
                failures.push(format!("{name} (mutating {target:?}): {panic}"));
            }
        }
    }
    eprintln!("{tried} damaged models loaded or refused");
    assert!(
        failures.is_empty(),
        "{} panics:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
