//! Files processed by gltfpack (quantized attributes, meshoptimizer compression, texture
//! coordinate transforms) load as the mesh they came from. gltfpack is the npm package that
//! `.ci/run` installs into `target/gltfpack` (`ORI_GLTFPACK` names another binary).

use std::path::{Path, PathBuf};
use std::process::Command;

use ori_mesh::{LoadOptions, Loaded, Mesh, Wrap, load_file};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

fn gltfpack() -> PathBuf {
    let path = std::env::var_os("ORI_GLTFPACK").map_or_else(
        || {
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../target/gltfpack/node_modules/.bin/gltfpack")
        },
        PathBuf::from,
    );
    assert!(
        path.exists(),
        "{} is missing: `npm install --prefix target/gltfpack gltfpack@1.3.0` (as .ci/run does)",
        path.display()
    );
    path
}

fn load(path: &Path) -> Loaded {
    load_file(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// The base colour at a triangle's centre: material factor, texture (nearest texel at the
/// centre's texture coordinates) and vertex colours.
fn albedo(mesh: &Mesh, triangle: usize) -> [f32; 4] {
    let corners = mesh.triangles[triangle].map(|i| i as usize);
    let material = &mesh.materials[mesh.triangle_materials[triangle] as usize];
    let mut colour = material.base_color_factor;
    if let (Some(texture), Some(uvs)) = (material.base_color_texture, &mesh.uvs) {
        let texture = &mesh.textures[texture as usize];
        let uv = [0, 1].map(|k| corners.iter().map(|&i| uvs[i][k]).sum::<f32>() / 3.0);
        let texel = |coordinate: f32, size: u32, wrap: Wrap| {
            let x = (coordinate * size as f32).floor() as i64;
            match wrap {
                Wrap::ClampToEdge => x.clamp(0, i64::from(size) - 1),
                _ => x.rem_euclid(i64::from(size)),
            }
        };
        let x = texel(uv[0], texture.width, texture.wrap_s);
        let y = texel(uv[1], texture.height, texture.wrap_t);
        let at = (y as usize * texture.width as usize + x as usize) * 4;
        for (c, value) in colour.iter_mut().zip(&texture.rgba8[at..at + 4]) {
            *c *= f32::from(*value) / 255.0;
        }
    }
    if let Some(colors) = &mesh.colors {
        for (k, c) in colour.iter_mut().enumerate() {
            *c *= corners.iter().map(|&i| colors[i][k]).sum::<f32>() / 3.0;
        }
    }
    colour
}

fn centre(mesh: &Mesh, triangle: usize) -> [f32; 3] {
    let corners = mesh.triangles[triangle].map(|i| mesh.positions[i as usize]);
    [0, 1, 2].map(|k| corners.iter().map(|p| p[k]).sum::<f32>() / 3.0)
}

/// Packs `model` with gltfpack's `flags` and compares the two meshes: every packed triangle
/// has a source triangle within the quantization error, with the same base colour.
fn packs_to_the_same_mesh(model: &str, flags: &[&str], extensions: &[&str]) {
    let source = Path::new(MODELS).join(model);
    let temp = tempfile::tempdir().unwrap();
    let packed_path = temp.path().join("packed.glb");
    let out = Command::new(gltfpack())
        .arg("-i")
        .arg(&source)
        .arg("-o")
        .arg(&packed_path)
        .args(flags)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "gltfpack {flags:?} {model}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(&packed_path).unwrap();
    let json_length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = String::from_utf8_lossy(&bytes[20..20 + json_length]);
    for extension in extensions {
        assert!(
            json.contains(extension),
            "{model} {flags:?}: no {extension}"
        );
    }

    let (original, packed) = (load(&source), load(&packed_path));
    let what = format!("{model} packed with {flags:?}");
    assert!(
        packed.warnings.iter().all(|w| !w.contains("extension")),
        "{what}: {:?}",
        packed.warnings
    );
    let (original, packed) = (original.mesh, packed.mesh);
    assert_eq!(packed.triangle_count(), original.triangle_count(), "{what}");
    let (low, high) = original.bounds();
    let diagonal = (0..3)
        .map(|k| (high[k] - low[k]).powi(2))
        .sum::<f32>()
        .sqrt();
    let centres: Vec<[f32; 3]> = (0..original.triangle_count())
        .map(|t| centre(&original, t))
        .collect();
    let (mut worst_distance, mut colour_error, mut compared) = (0.0f32, 0.0f64, 0usize);
    for t in 0..packed.triangle_count() {
        let c = centre(&packed, t);
        let distance = |p: &[f32; 3]| (0..3).map(|k| (p[k] - c[k]).powi(2)).sum::<f32>();
        let nearest = (0..centres.len())
            .min_by(|&a, &b| distance(&centres[a]).total_cmp(&distance(&centres[b])))
            .unwrap();
        worst_distance = worst_distance.max(distance(&centres[nearest]).sqrt() / diagonal);
        let (a, b) = (albedo(&packed, t), albedo(&original, nearest));
        colour_error += (0..3).map(|k| f64::from((a[k] - b[k]).abs())).sum::<f64>() / 3.0;
        compared += 1;
    }
    let colour_error = colour_error / compared as f64 * 255.0;
    eprintln!(
        "{what}: worst centre distance {worst_distance:.2e} of the diagonal, mean colour error {colour_error:.2}/255"
    );
    assert!(worst_distance < 1e-3, "{what}: {worst_distance}");
    assert!(colour_error < 3.0, "{what}: {colour_error}");
}

#[test]
fn quantized_meshes_with_texture_transforms_load_as_their_source() {
    packs_to_the_same_mesh(
        "gltf/Duck/Duck.glb",
        &[],
        &["KHR_mesh_quantization", "KHR_texture_transform"],
    );
    packs_to_the_same_mesh(
        "gltf/Avocado/glTF/Avocado.gltf",
        &[],
        &["KHR_mesh_quantization", "KHR_texture_transform"],
    );
}

#[test]
fn meshopt_compressed_meshes_load_as_their_source() {
    packs_to_the_same_mesh(
        "gltf/Duck/Duck.glb",
        &["-c"],
        &["EXT_meshopt_compression", "KHR_mesh_quantization"],
    );
    // Highest compression: octahedral normals, exponential floats (-vpf keeps positions float).
    packs_to_the_same_mesh(
        "gltf/BoxVertexColors/BoxVertexColors.glb",
        &["-cc", "-vpf"],
        &["EXT_meshopt_compression"],
    );
    packs_to_the_same_mesh(
        "gltf/DamagedHelmet/DamagedHelmet.glb",
        &["-cc"],
        &["EXT_meshopt_compression", "KHR_texture_transform"],
    );
}

/// A GLB with its JSON chunk replaced.
fn with_json(glb: &[u8], json: &serde_json::Value) -> Vec<u8> {
    let old_length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut text = serde_json::to_vec(json).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let rest = &glb[20 + old_length..];
    let mut out = glb[..12].to_vec();
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(rest);
    let total = out.len() as u32;
    out[8..12].copy_from_slice(&total.to_le_bytes());
    out
}

fn load_bytes(bytes: &[u8]) -> Result<Loaded, String> {
    let mut no_files = |uri: &str| -> std::io::Result<Vec<u8>> {
        Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            uri.to_string(),
        ))
    };
    ori_mesh::load(
        Path::new("packed.glb"),
        bytes,
        &LoadOptions::default(),
        &mut no_files,
    )
    .map_err(|e| e.to_string())
}

/// Compressed views whose description lies, and compressed bytes that are damaged, give an
/// error naming the view or a mesh; never a crash, never an allocation the file did not pay for.
#[test]
fn damaged_meshopt_data_is_an_error_not_a_crash() {
    let temp = tempfile::tempdir().unwrap();
    let packed = temp.path().join("box.glb");
    let source = Path::new(MODELS).join("gltf/BoxVertexColors/BoxVertexColors.glb");
    let status = Command::new(gltfpack())
        .arg("-i")
        .arg(&source)
        .args(["-cc", "-o"])
        .arg(&packed)
        .status()
        .unwrap();
    assert!(status.success());
    let glb = std::fs::read(&packed).unwrap();
    assert!(load_bytes(&glb).is_ok());
    let json_length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_length]).unwrap();
    let (positions, normals, indices) = (0, 1, 3);
    assert_eq!(
        json["bufferViews"][normals]["extensions"]["EXT_meshopt_compression"]["filter"],
        "OCTAHEDRAL"
    );
    let extension = |view: usize| format!("/bufferViews/{view}/extensions/EXT_meshopt_compression");
    let cases: [(&str, &str, serde_json::Value, &str); 7] = [
        (
            "a stride that does not fill the view",
            "byteStride",
            6.into(),
            "elements of 6 bytes are not the view's",
        ),
        (
            "an index count that does not fill the view",
            "count",
            35.into(),
            "elements of 2 bytes are not the view's",
        ),
        (
            "a filter on the wrong stride",
            "filter",
            "QUATERNION".into(),
            "filter QUATERNION does not apply to a 4-byte stride",
        ),
        (
            "an unknown mode",
            "mode",
            "VERTICES".into(),
            "mode VERTICES with filter NONE",
        ),
        (
            "compressed bytes outside their buffer",
            "byteLength",
            1_000_000.into(),
            "the compressed bytes lie outside their buffer",
        ),
        (
            "compressed bytes too short",
            "byteLength",
            10.into(),
            "the compressed data is corrupt",
        ),
        (
            "a negative count",
            "count",
            (-1).into(),
            "`count` is missing or not a count",
        ),
    ];
    for (what, key, value, expected) in cases {
        let view = match what {
            "an index count that does not fill the view" => indices,
            "a filter on the wrong stride" => normals,
            _ => positions,
        };
        let mut changed = json.clone();
        let target = changed.pointer_mut(&extension(view)).unwrap();
        target[key] = value;
        let error = load_bytes(&with_json(&glb, &changed)).err();
        assert!(
            error.as_deref().is_some_and(|e| e.contains(expected)),
            "{what}: {error:?}"
        );
    }
    // A view that claims to be huge (its count and stride agreeing) is refused before any
    // memory is set aside for it.
    let mut huge = json.clone();
    huge["bufferViews"][positions]["byteLength"] = (1u64 << 40).into();
    huge.pointer_mut(&extension(positions)).unwrap()["count"] = (1u64 << 37).into();
    let error = load_bytes(&with_json(&glb, &huge)).err();
    assert!(
        error
            .as_deref()
            .is_some_and(|e| e.contains("the view extends past the end of buffer 1")),
        "{error:?}"
    );
    let mut huge = json.clone();
    huge["buffers"][1]["byteLength"] = 1_000_000_000_000u64.into();
    let error = load_bytes(&with_json(&glb, &huge)).err();
    assert!(
        error
            .as_deref()
            .is_some_and(|e| e.contains("fallback buffers declare more than")),
        "{error:?}"
    );

    // Damaged compressed bytes: each load ends in a mesh or an error.
    let binary_start = 20 + json_length + 8;
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..500 {
        let mut damaged = glb.clone();
        for _ in 0..3 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let at = binary_start + (state as usize) % (glb.len() - binary_start);
            damaged[at] ^= 1 << (state >> 61);
        }
        let _ = load_bytes(&damaged);
    }
}
