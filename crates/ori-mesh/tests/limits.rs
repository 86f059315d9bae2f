//! `Limits`: what a model may make the loader allocate and the later stages draw. Real models
//! stay far inside the defaults; files built to exhaust memory or time fail with an error
//! naming the limit, before the allocation or the drawing.

mod common;

use std::path::Path;

use ori_mesh::{ErrorKind, LoadOptions, Loaded, MeshError, load_file};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

fn load_obj(
    bytes: &[u8],
    files: &[(&str, Vec<u8>)],
    options: &LoadOptions,
) -> Result<Loaded, MeshError> {
    let files: Vec<(&str, &[u8])> = files.iter().map(|(n, b)| (*n, b.as_slice())).collect();
    common::load_from("m.obj", bytes, &files, options)
}

fn limit_key(e: &MeshError) -> &'static str {
    match &e.kind {
        ErrorKind::Limit { key, .. } => key,
        other => panic!("not a limit error: {other}"),
    }
}

#[test]
fn real_models_are_far_inside_the_default_depth_complexity() {
    let limit = f64::from(ori_mesh::Limits::default().max_depth_complexity);
    for model in [
        "stanford/bunny/stanford-bunny.obj",
        "stanford/armadillo/armadillo_odedstein_remeshed.obj",
        "stanford/dragon/dragon_res2_binary.ply",
        "gltf/Duck/Duck.glb",
        "gltf/DamagedHelmet/DamagedHelmet.glb",
        "gltf/Avocado/glTF/Avocado.gltf",
        "gltf/GlassVaseFlowers/GlassVaseFlowers.glb",
        "vegetation/fern_02/fern_02.glb",
    ] {
        let mesh = load_file(&Path::new(MODELS).join(model), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{e}"))
            .mesh;
        let c = mesh.depth_complexity();
        eprintln!("{model}: depth complexity {c:.2}");
        assert!(c > 0.1 && c < limit / 16.0, "{model}: {c}");
    }
}

/// One face over `n` corners of a star: its fan is `n - 2` long overlapping slivers.
fn star(n: usize) -> Vec<u8> {
    let mut obj = String::new();
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        let r = if i % 2 == 0 { 1.0 } else { 0.3 };
        obj.push_str(&format!("v {} {} 0\n", r * a.cos(), r * a.sin()));
    }
    obj.push('f');
    for i in 1..=n {
        obj.push_str(&format!(" {i}"));
    }
    obj.push('\n');
    obj.into_bytes()
}

#[test]
fn overlapping_slivers_fail_on_depth_complexity_and_long_faces_on_corners() {
    let e = load_obj(&star(2000), &[], &LoadOptions::default()).unwrap_err();
    assert_eq!(limit_key(&e), "[limits] max_depth_complexity", "{e}");
    assert!(e.to_string().starts_with("m.obj: "), "{e}");

    let e = load_obj(&star(5000), &[], &LoadOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .contains("line 5001: a face has more than 4096 corners"),
        "{e}"
    );
    // A convex polygon of as many corners is ordinary geometry.
    let mut disk = String::new();
    for i in 0..4000 {
        let a = i as f64 / 4000.0 * std::f64::consts::TAU;
        disk.push_str(&format!("v {} {} 0\n", a.cos(), a.sin()));
    }
    disk.push('f');
    for i in 1..=4000 {
        disk.push_str(&format!(" {i}"));
    }
    let mesh = load_obj(disk.as_bytes(), &[], &LoadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(mesh.triangle_count(), 3998);
    // Area pi over the cross-section of the sphere around its 2 x 2 x 0 box, 2 pi.
    assert!((mesh.depth_complexity() - 0.5).abs() < 0.01);
}

fn png(width: u32, height: u32) -> Vec<u8> {
    common::png(width, height, [128, 128, 128, 255])
}

#[test]
fn texture_pixels_are_limited_per_image_and_per_model_before_decoding() {
    let obj = b"mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\nusemtl b\nf 1/1 3/1 2/1\n";
    let mtl = b"newmtl a\nmap_Kd a.png\nnewmtl b\nmap_Kd b.png\n".to_vec();
    let files = vec![
        ("m.mtl", mtl),
        ("a.png", png(300, 200)),
        ("b.png", png(200, 200)),
    ];
    let mut options = LoadOptions::default();
    assert!(load_obj(obj, &files, &options).is_ok());

    options.limits.max_texture_pixels = 50_000;
    let e = load_obj(obj, &files, &options).unwrap_err();
    assert_eq!(limit_key(&e), "[limits] max_texture_pixels", "{e}");
    assert!(e.to_string().contains("a.png` (300 x 200)"), "{e}");
    assert!(
        e.to_string().starts_with("m.mtl: "),
        "the MTL names the texture: {e}"
    );

    options.limits = ori_mesh::Limits {
        max_total_texture_pixels: 90_000,
        ..Default::default()
    };
    let e = load_obj(obj, &files, &options).unwrap_err();
    assert_eq!(limit_key(&e), "[limits] max_total_texture_pixels", "{e}");
    assert!(e.to_string().contains("b.png"), "{e}");
}

/// A glTF document whose one-triangle mesh is drawn by `nodes` nodes: a few bytes a node.
fn instanced(nodes: usize) -> String {
    let list: Vec<String> = (0..nodes)
        .map(|i| format!("{{\"mesh\":0,\"translation\":[{i},0,0]}}"))
        .collect();
    let roots: Vec<String> = (0..nodes).map(|i| i.to_string()).collect();
    format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\
         \"buffers\":[{{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}}],\
         \"bufferViews\":[{{\"buffer\":0,\"byteLength\":36}}],\
         \"accessors\":[{{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}}],\
         \"meshes\":[{{\"primitives\":[{{\"attributes\":{{\"POSITION\":0}}}}]}}],\
         \"nodes\":[{}],\"scenes\":[{{\"nodes\":[{}]}}],\"scene\":0}}",
        list.join(","),
        roots.join(",")
    )
}

#[test]
fn instances_count_against_the_triangle_and_vertex_limits_before_they_are_built() {
    let mut options = LoadOptions::default();
    let gltf = instanced(2000);
    let mesh = common::load_from("i.gltf", gltf.as_bytes(), &[], &options)
        .unwrap()
        .mesh;
    assert_eq!(mesh.triangle_count(), 2000);
    options.limits.max_triangles = 1000;
    let e = common::load_from("i.gltf", gltf.as_bytes(), &[], &options).unwrap_err();
    assert_eq!(limit_key(&e), "[limits] max_triangles", "{e}");
    options.limits = ori_mesh::Limits {
        max_vertices: 5000,
        ..Default::default()
    };
    let e = common::load_from("i.gltf", gltf.as_bytes(), &[], &options).unwrap_err();
    assert_eq!(limit_key(&e), "[limits] max_vertices", "{e}");
    // The same limits hold for OBJ and PLY.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\n".to_string() + &"f 1 2 3\n".repeat(2000);
    options.limits = ori_mesh::Limits {
        max_triangles: 1000,
        ..Default::default()
    };
    let e = load_obj(obj.as_bytes(), &[], &options).unwrap_err();
    assert_eq!(limit_key(&e), "[limits] max_triangles", "{e}");
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 2000\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n"
        .to_string()
        + &"3 0 1 2\n".repeat(2000);
    let e = common::load_from("m.ply", ply.as_bytes(), &[], &options).unwrap_err();
    assert_eq!(limit_key(&e), "[limits] max_triangles", "{e}");
}
