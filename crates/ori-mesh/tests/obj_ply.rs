//! OBJ/MTL and PLY loading: the real models in `shared/models`, small handwritten files for
//! each feature, and broken files that must give the right error without panicking.

mod common;

use std::cell::RefCell;
use std::collections::HashMap;
use std::io;
use std::path::{Path, PathBuf};
use std::time::Instant;

use ori_mesh::{ErrorKind, LoadOptions, Loaded, MeshError};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

// ---------------------------------------------------------------------------------------------
// Helpers

/// Load `text` as `name`, with `files` as everything the resolver can read.
fn load_with(name: &str, bytes: &[u8], files: &[(&str, &[u8])]) -> Result<Loaded, MeshError> {
    common::load_from(name, bytes, files, &LoadOptions::default())
}

fn load(name: &str, bytes: &[u8]) -> Result<Loaded, MeshError> {
    load_with(name, bytes, &[])
}

/// The error of a load that must fail; its message must name `file`.
fn error(result: Result<Loaded, MeshError>, file: &str) -> MeshError {
    let error = result.expect_err("the load should fail");
    assert_eq!(error.file, PathBuf::from(file), "{error}");
    assert!(error.to_string().starts_with(file), "{error}");
    error
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-5
}

fn srgb(c: f64) -> f32 {
    ori_math::srgb_to_linear(c) as f32
}

/// A 2x2 RGBA PNG.
fn png() -> Vec<u8> {
    let pixels = vec![
        255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 128,
    ];
    let image = image::RgbaImage::from_raw(2, 2, pixels).expect("2x2 RGBA");
    let mut bytes = io::Cursor::new(Vec::new());
    image
        .write_to(&mut bytes, image::ImageFormat::Png)
        .expect("encode PNG");
    bytes.into_inner()
}

// ---------------------------------------------------------------------------------------------
// Real models

#[test]
fn every_obj_and_ply_model_loads_with_its_documented_counts() {
    let models = [
        ("stanford/bunny/stanford-bunny.obj", 35_947, 69_451),
        ("stanford/bunny/bunny_npm_lowres.obj", 1_839, 3_674),
        (
            "stanford/armadillo/armadillo_odedstein_remeshed.obj",
            14_587,
            29_170,
        ),
        ("stanford/dragon/dragon_res2_binary.ply", 100_250, 202_520),
        ("stanford/dragon/dragon_res3.ply", 22_998, 47_794),
        ("stanford/dragon/dragon_res4.ply", 5_205, 11_102),
    ];
    for (name, vertices, faces) in models {
        let path = Path::new(MODELS).join(name);
        let start = Instant::now();
        let loaded =
            ori_mesh::load_file(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        eprintln!("{name}: loaded in {:.1?}", start.elapsed());
        let mesh = &loaded.mesh;
        assert_eq!(mesh.vertex_count(), vertices, "{name}");
        assert_eq!(mesh.triangle_count(), faces, "{name}");
        assert!(loaded.warnings.is_empty(), "{name}: {:?}", loaded.warnings);
        for n in &mesh.normals {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-4, "{name}: normal {n:?}");
        }
        let (lo, hi) = mesh.bounds();
        assert!(lo.iter().chain(&hi).all(|c| c.is_finite()), "{name}");
        assert!((0..3).all(|k| lo[k] < hi[k]), "{name}: {lo:?} {hi:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ features

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

#[test]
fn obj_quad_is_fan_triangulated() {
    let mesh = load("quad.obj", format!("{QUAD}f 1 2 3 4\n").as_bytes())
        .unwrap()
        .mesh;
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(mesh.triangle_materials, vec![0, 0]);
    assert!(mesh.normals.iter().all(|n| close(n[2], 1.0)));
    assert!(mesh.uvs.is_none() && mesh.colors.is_none());
}

#[test]
fn obj_pentagon_is_fan_triangulated() {
    let text = "v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5\n";
    let mesh = load("pentagon.obj", text.as_bytes()).unwrap().mesh;
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
}

#[test]
fn obj_negative_indices_are_relative_to_the_vertices_read_so_far() {
    let text = format!("{QUAD}f -4 -3 -2 -1\nv 5 5 5\nf -5 -4 -1\n");
    let mesh = load("negative.obj", text.as_bytes()).unwrap().mesh;
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 4]]);
}

#[test]
fn obj_positions_only_keeps_every_vertex_in_file_order() {
    // Vertex 5 is unused and faces refer forwards; numbering still follows the file.
    let text = "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 9 9 9\n";
    let mesh = load("forward.obj", text.as_bytes()).unwrap().mesh;
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.positions[3], [9.0, 9.0, 9.0]);
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
}

#[test]
fn obj_corners_with_uv_and_normal_are_deduplicated_in_first_use_order() {
    let text = "\
# two quads sharing an edge, with a comment
o thing
g group
s 1
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 2 0 0
v 2 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 3
f 1/1/1 2/2/1 3/3/1 4/4/1
f 2/2/1 5/1/1 6/4/1 3/3/1
f 1//1 2//1 3//1
f 6/1 5/2 3/3
";
    let loaded = load("dedup.obj", text.as_bytes()).unwrap();
    let mesh = loaded.mesh;
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    // (1,1,1) (2,2,1) (3,3,1) (4,4,1) (5,1,1) (6,4,1) (1,-,1) (2,-,1) (3,-,1) (6,1,-) (5,2,-) (3,3,-)
    assert_eq!(mesh.positions.len(), 12);
    assert_eq!(
        mesh.triangles,
        vec![
            [0, 1, 2],
            [0, 2, 3],
            [1, 4, 5],
            [1, 5, 2],
            [6, 7, 8],
            [9, 10, 11]
        ]
    );
    assert_eq!(mesh.positions[4], [2.0, 0.0, 0.0]);
    let uvs = mesh.uvs.expect("uvs");
    // glTF convention: v is flipped.
    assert_eq!(uvs[0], [0.0, 1.0]);
    assert_eq!(uvs[2], [1.0, 0.0]);
    assert_eq!(uvs[6], [0.0, 0.0], "no vt: neutral uv");
    // The file's normal, renormalised.
    assert_eq!(mesh.normals[0], [0.0, 0.0, 1.0]);
}

#[test]
fn obj_vertex_colors_are_converted_from_srgb() {
    let text = "v 0 0 0 1 0.5 0\nv 1 0 0 0 0 0\nv 0 1 0\nf 1 2 3\n";
    let mesh = load("colors.obj", text.as_bytes()).unwrap().mesh;
    let colors = mesh.colors.expect("colours");
    assert_eq!(colors.len(), 3);
    assert!(close(colors[0][0], 1.0) && close(colors[0][2], 0.0));
    assert!(close(colors[0][1], srgb(0.5)));
    assert!(close(colors[0][1], 0.214_041_14));
    assert_eq!(colors[0][3], 1.0);
    assert_eq!(colors[1], [0.0, 0.0, 0.0, 1.0]);
    assert_eq!(colors[2], [1.0; 4], "a `v` without colour is white");
}

#[test]
fn obj_crlf_and_line_continuation() {
    let text = "v 0 0 0\r\nv 1 0 \\\r\n 0\r\nv 0 1 0\r\nf 1 2 \\\n3\r\nl 1 2\r\np 1\r\n";
    let loaded = load("crlf.obj", text.as_bytes()).unwrap();
    assert_eq!(loaded.mesh.positions[1], [1.0, 0.0, 0.0]);
    assert_eq!(loaded.mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(
        loaded.warnings[0].contains("2 line/point"),
        "{:?}",
        loaded.warnings
    );
}

#[test]
fn obj_materials_from_mtl_with_kd_alpha_and_shared_texture() {
    let obj = "\
mtllib a.mtl mats/b.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
usemtl red
f 1/1 2/2 3/3
usemtl textured
f 1/1 3/3 4/1
usemtl also_textured
f 1/1 2/2 4/1
usemtl nowhere
f 2/2 3/3 4/1
usemtl red
f 4/1 3/3 2/2
";
    let a = "\
# unused statements are fine
Ka 0 0 0
newmtl red
Kd 1 0.5 0
Ks 1 1 1
d 0.5
newmtl textured
Kd 1 1 1
map_Kd -s 1 1 1 -clamp on tex.png
";
    let b = "newmtl also_textured\nKd 0.5\nTr 0.25\nmap_Kd ../tex.png\nmap_d alpha.png\n";
    let png = png();
    let reads = RefCell::new(Vec::new());
    let files: HashMap<&str, &[u8]> = HashMap::from([
        ("a.mtl", a.as_bytes()),
        ("mats/b.mtl", b.as_bytes()),
        ("tex.png", &png[..]),
        ("mats/../tex.png", &png[..]),
    ]);
    let mut resolver = |uri: &str| {
        reads.borrow_mut().push(uri.to_string());
        files
            .get(uri)
            .map(|b| b.to_vec())
            .ok_or_else(|| io::Error::from(io::ErrorKind::NotFound))
    };
    let loaded = ori_mesh::load(
        Path::new("dir/model.obj"),
        obj.as_bytes(),
        &LoadOptions::default(),
        &mut resolver,
    )
    .unwrap();
    assert_eq!(
        *reads.borrow(),
        ["a.mtl", "mats/b.mtl", "tex.png", "mats/../tex.png"],
        "each file read once, MTL-relative texture paths"
    );
    let mesh = loaded.mesh;
    let names: Vec<&str> = mesh.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["red", "textured", "also_textured", "default"]);
    assert_eq!(mesh.triangle_materials, vec![0, 1, 2, 3, 0]);

    let red = &mesh.materials[0];
    assert_eq!(red.base_color_factor, [1.0, srgb(0.5), 0.0, 0.5]);
    assert_eq!(red.base_color_texture, None);
    assert_eq!(red.alpha_mode, ori_mesh::AlphaMode::Opaque);

    assert_eq!(mesh.materials[1].base_color_texture, Some(0));
    assert_eq!(mesh.materials[1].base_color_factor, [1.0; 4]);
    let also = &mesh.materials[2];
    assert_eq!(also.base_color_texture, Some(1));
    assert_eq!(
        also.base_color_factor,
        [srgb(0.5), srgb(0.5), srgb(0.5), 0.75]
    );

    assert_eq!(mesh.textures.len(), 2);
    let texture = &mesh.textures[0];
    assert_eq!((texture.width, texture.height), (2, 2));
    assert_eq!(texture.name, "tex.png");
    assert_eq!(&texture.rgba8[12..16], &[255, 255, 255, 128]);

    let warnings = loaded.warnings.join("\n");
    assert!(warnings.contains("map_d"), "{warnings}");
    assert!(
        warnings.contains("line 15") && warnings.contains("nowhere"),
        "{warnings}"
    );
}

#[test]
fn obj_texture_is_loaded_once_and_only_for_used_materials() {
    let obj = format!("mtllib m.mtl\n{QUAD}usemtl a\nf 1 2 3\nusemtl b\nf 1 3 4\n");
    let mtl = "newmtl a\nmap_Kd t.png\nnewmtl b\nmap_Kd t.png\nnewmtl unused\nmap_Kd gone.png\n";
    let png = png();
    let mesh = load_with(
        "model.obj",
        obj.as_bytes(),
        &[("m.mtl", mtl.as_bytes()), ("t.png", &png)],
    )
    .unwrap()
    .mesh;
    assert_eq!(mesh.textures.len(), 1);
    assert_eq!(mesh.materials.len(), 2, "no default material when unused");
    assert!(
        mesh.materials
            .iter()
            .all(|m| m.base_color_texture == Some(0))
    );
}

#[test]
fn obj_library_names_its_textures_before_any_is_read() {
    struct Recorder<'a>(&'a [(&'a str, &'a [u8])], Vec<String>);
    impl ori_mesh::Files for Recorder<'_> {
        fn read(&mut self, reference: &str) -> std::io::Result<Vec<u8>> {
            self.1.push(format!("read {reference}"));
            let found = self.0.iter().find(|(n, _)| *n == reference);
            found
                .map(|(_, b)| b.to_vec())
                .ok_or_else(|| std::io::ErrorKind::NotFound.into())
        }
        fn will_read(&mut self, references: &[String]) {
            self.1.push(format!("will read {}", references.join(", ")));
        }
    }
    let obj = format!("mtllib m.mtl\n{QUAD}usemtl a\nf 1 2 3\nusemtl b\nf 1 3 4\n");
    let mtl = "newmtl a\nmap_Kd t.png\nnewmtl b\nmap_Kd t.png\nnewmtl unused\nmap_Kd gone.png\n";
    let png = png();
    let files: &[(&str, &[u8])] = &[("m.mtl", mtl.as_bytes()), ("t.png", &png)];
    let mut recorder = Recorder(files, Vec::new());
    let options = LoadOptions::default();
    ori_mesh::load(
        Path::new("model.obj"),
        obj.as_bytes(),
        &options,
        &mut recorder,
    )
    .unwrap();
    // (The unused material's texture is named too: which are used is known only later.)
    assert_eq!(
        recorder.1,
        ["read m.mtl", "will read gone.png, t.png", "read t.png"]
    );
}

#[test]
fn obj_texture_in_another_format_is_dropped_with_a_warning() {
    let obj = format!("mtllib m.mtl\n{QUAD}usemtl a\nf 1 2 3\n");
    let mtl = "newmtl a\nKd 1 0 0\nmap_Kd t.dds\n";
    let loaded = load_with(
        "model.obj",
        obj.as_bytes(),
        &[("m.mtl", mtl.as_bytes()), ("t.dds", b"DDS \x7c\0\0\0")],
    )
    .unwrap();
    let warnings = loaded.warnings.join("\n");
    assert!(
        warnings.contains("material `a`: its texture `t.dds` is DDS"),
        "{warnings}"
    );
    assert_eq!(loaded.mesh.materials[0].base_color_texture, None);
    assert!(loaded.mesh.textures.is_empty());
}

#[test]
fn obj_faces_before_usemtl_use_the_default_material() {
    let obj = format!("mtllib m.mtl\n{QUAD}f 1 2 3\nusemtl green\nf 1 3 4\n");
    let mtl = "newmtl green\nKd 0 1 0\n";
    let mesh = load_with("model.obj", obj.as_bytes(), &[("m.mtl", mtl.as_bytes())])
        .unwrap()
        .mesh;
    assert_eq!(mesh.materials[0], ori_mesh::Material::default());
    assert_eq!(mesh.materials[1].base_color_factor, [0.0, 1.0, 0.0, 1.0]);
    assert_eq!(mesh.triangle_materials, vec![0, 1]);
}

// ---------------------------------------------------------------------------------------------
// OBJ errors

#[test]
fn obj_index_zero_is_out_of_range() {
    let e = error(
        load("zero.obj", format!("{QUAD}f 0 1 2\n").as_bytes()),
        "zero.obj",
    );
    assert!(
        matches!(
            e.kind,
            ErrorKind::IndexOutOfRange {
                index: 0,
                count: 4,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("line 5"), "{e}");
}

#[test]
fn obj_face_index_out_of_range() {
    let e = error(
        load("big.obj", format!("{QUAD}f 1 2 5\n").as_bytes()),
        "big.obj",
    );
    assert!(
        matches!(
            e.kind,
            ErrorKind::IndexOutOfRange {
                index: 5,
                count: 4,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("line 5"), "{e}");

    let e = error(
        load("neg.obj", format!("{QUAD}f 1 2 -5\n").as_bytes()),
        "neg.obj",
    );
    assert!(
        matches!(e.kind, ErrorKind::IndexOutOfRange { index: -5, .. }),
        "{e}"
    );

    let text = format!("{QUAD}vt 0 0\nf 1/1 2/2 3/1\n");
    let e = error(load("uv.obj", text.as_bytes()), "uv.obj");
    assert!(
        matches!(
            e.kind,
            ErrorKind::IndexOutOfRange {
                index: 2,
                count: 1,
                ..
            }
        ),
        "{e}"
    );

    let e = error(
        load(
            "huge.obj",
            format!("{QUAD}f 1 2 99999999999999999999\n").as_bytes(),
        ),
        "huge.obj",
    );
    assert!(matches!(e.kind, ErrorKind::Syntax { line: 5, .. }), "{e}");
}

#[test]
fn obj_malformed_number_names_its_line() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1.2.3 0\nf 1 2 3\n";
    let e = error(load("bad.obj", text.as_bytes()), "bad.obj");
    assert!(matches!(e.kind, ErrorKind::Syntax { line: 3, .. }), "{e}");
    assert!(
        e.to_string().contains("line 3") && e.to_string().contains("1.2.3"),
        "{e}"
    );
}

#[test]
fn obj_malformed_statements() {
    for (text, line) in [
        ("v 0 0\n", 1),
        ("v 0 0 0 1 1\n", 1),
        ("v 0 0 0\nvn 0 1\n", 2),
        ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3),
        ("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 x\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1/1/1/1 2 3\n", 4),
        ("v 0 0 0\nvt nan 0\n", 2),
        ("usemtl\n", 1),
    ] {
        let e = error(load("bad.obj", text.as_bytes()), "bad.obj");
        assert!(
            matches!(e.kind, ErrorKind::Syntax { line: l, .. } if l == line),
            "{text:?}: {e}"
        );
    }
}

#[test]
fn obj_nan_position_is_non_finite() {
    let e = error(
        load("nan.obj", b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"),
        "nan.obj",
    );
    assert!(
        matches!(e.kind, ErrorKind::NonFinite { vertex: 1, .. }),
        "{e}"
    );
}

#[test]
fn obj_without_faces_is_empty() {
    let e = error(load("points.obj", QUAD.as_bytes()), "points.obj");
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
    let e = error(load("nothing.obj", b""), "nothing.obj");
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
}

#[test]
fn obj_missing_mtl_is_reported_on_the_obj() {
    let text = format!("mtllib gone.mtl\n{QUAD}f 1 2 3\n");
    let e = error(load("dir/model.obj", text.as_bytes()), "dir/model.obj");
    assert!(
        matches!(&e.kind, ErrorKind::MissingExternal { uri, .. } if uri == "gone.mtl"),
        "{e}"
    );
}

#[test]
fn obj_missing_texture_is_reported_on_the_mtl() {
    let text = format!("mtllib m.mtl\n{QUAD}usemtl a\nf 1 2 3\n");
    let mtl = "newmtl a\nmap_Kd gone.png\n";
    let e = error(
        load_with(
            "dir/model.obj",
            text.as_bytes(),
            &[("m.mtl", mtl.as_bytes())],
        ),
        "dir/m.mtl",
    );
    assert!(
        matches!(&e.kind, ErrorKind::MissingExternal { uri, .. } if uri == "gone.png"),
        "{e}"
    );
}

#[test]
fn obj_undecodable_texture_is_reported_on_the_mtl() {
    let text = format!("mtllib m.mtl\n{QUAD}usemtl a\nf 1 2 3\n");
    let mtl = "newmtl a\nmap_Kd t.png\n";
    let e = error(
        load_with(
            "model.obj",
            text.as_bytes(),
            &[("m.mtl", mtl.as_bytes()), ("t.png", b"not a png")],
        ),
        "m.mtl",
    );
    assert!(matches!(e.kind, ErrorKind::Image { .. }), "{e}");
}

#[test]
fn mtl_malformed_number_is_reported_on_the_mtl() {
    let text = format!("mtllib m.mtl\n{QUAD}f 1 2 3\n");
    let mtl = "newmtl a\nKd 1 zero 0\n";
    let e = error(
        load_with(
            "dir/model.obj",
            text.as_bytes(),
            &[("m.mtl", mtl.as_bytes())],
        ),
        "dir/m.mtl",
    );
    assert!(matches!(e.kind, ErrorKind::Syntax { line: 2, .. }), "{e}");
}

// ---------------------------------------------------------------------------------------------
// PLY

/// One typed value of a PLY body.
#[derive(Clone, Copy)]
enum Value {
    I8(i8),
    U8(u8),
    U16(u16),
    I32(i32),
    F32(f32),
    F64(f64),
}

const PLY_HEADER: &str = "\
ply
format FORMAT 1.0
comment handwritten test model
obj_info no info
element vertex 4
property double x
property float y
property float z
property float nx
property float ny
property float nz
property uchar red
property uchar green
property uchar blue
property uchar alpha
property float32 u
property float v
element face 2
property list uchar int vertex_indices
property uint8 flags
element edge 1
property list ushort uint16 vertex
property int8 kind
end_header
";

fn ply_values() -> Vec<Value> {
    use Value::*;
    let corners = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let mut values = Vec::new();
    for (i, [x, y]) in corners.into_iter().enumerate() {
        values.extend([F64(x), F32(y as f32), F32(0.0)]);
        values.extend([F32(0.0), F32(0.0), F32(2.0)]);
        values.extend([U8(255), U8(128), U8(i as u8), U8(51)]);
        values.extend([F32(x as f32 * 0.5), F32(y as f32 * 0.25)]);
    }
    values.extend([U8(4), I32(0), I32(1), I32(2), I32(3), U8(7)]);
    values.extend([U8(3), I32(3), I32(2), I32(0), U8(0)]);
    values.extend([U16(2), U16(0), U16(1), I8(-1)]);
    values
}

fn ply_ascii(values: &[Value]) -> Vec<u8> {
    let mut text = PLY_HEADER.replace("FORMAT", "ascii");
    for v in values {
        let word = match *v {
            Value::I8(x) => x.to_string(),
            Value::U8(x) => x.to_string(),
            Value::U16(x) => x.to_string(),
            Value::I32(x) => x.to_string(),
            Value::F32(x) => x.to_string(),
            Value::F64(x) => x.to_string(),
        };
        text.push_str(&word);
        text.push(' ');
    }
    text.push('\n');
    text.into_bytes()
}

fn ply_binary(values: &[Value], big_endian: bool) -> Vec<u8> {
    let format = if big_endian {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let mut bytes = PLY_HEADER.replace("FORMAT", format).into_bytes();
    macro_rules! put {
        ($x:expr) => {
            bytes.extend_from_slice(&if big_endian {
                $x.to_be_bytes()
            } else {
                $x.to_le_bytes()
            })
        };
    }
    for v in values {
        match *v {
            Value::I8(x) => put!(x),
            Value::U8(x) => put!(x),
            Value::U16(x) => put!(x),
            Value::I32(x) => put!(x),
            Value::F32(x) => put!(x),
            Value::F64(x) => put!(x),
        }
    }
    bytes
}

#[test]
fn ply_ascii_and_both_binary_orders_give_the_same_mesh() {
    let values = ply_values();
    let ascii = load("m.ply", &ply_ascii(&values)).unwrap();
    let little = load("m.ply", &ply_binary(&values, false)).unwrap();
    let big = load("m.ply", &ply_binary(&values, true)).unwrap();
    assert_eq!(ascii.mesh, little.mesh);
    assert_eq!(ascii.mesh, big.mesh);
    assert_eq!(little.warnings, ["ignored PLY face properties: flags"]);

    let mesh = little.mesh;
    assert_eq!(mesh.positions[2], [1.0, 1.0, 0.0]);
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 0]]);
    assert_eq!(mesh.normals[1], [0.0, 0.0, 1.0], "file normals, normalised");
    let uvs = mesh.uvs.expect("uvs");
    assert_eq!(uvs[2], [0.5, 0.75], "v flipped");
    let colors = mesh.colors.expect("colours");
    assert_eq!(colors[0][0], 1.0);
    assert!(close(colors[0][1], srgb(128.0 / 255.0)));
    assert!(close(colors[3][2], srgb(3.0 / 255.0)));
    assert!(close(colors[0][3], 0.2), "alpha stays linear");
    assert_eq!(mesh.materials.len(), 1);
}

#[test]
fn ply_float_colors_and_vertex_index_alias() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nproperty float red\nproperty float green\nproperty float blue\n\
                element face 1\nproperty list uint8 uint32 vertex_index\nend_header\n\
                0 0 0 0.5 1 0\n1 0 0 0 0 0\n0 1 0 1 1 1\n3 0 1 2\n";
    let mesh = load("c.ply", text.as_bytes()).unwrap().mesh;
    let colors = mesh.colors.expect("colours");
    assert!(close(colors[0][0], srgb(0.5)) && colors[0][1] == 1.0);
    assert_eq!(colors[2], [1.0; 4]);
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
}

#[test]
fn truncated_binary_ply_is_an_error_at_every_length() {
    for big_endian in [false, true] {
        let bytes = ply_binary(&ply_values(), big_endian);
        for len in 0..bytes.len() {
            let result = load("cut.ply", &bytes[..len]);
            let e = error(result, "cut.ply");
            assert!(
                matches!(e.kind, ErrorKind::Corrupt(_) | ErrorKind::Syntax { .. }),
                "{len}: {e}"
            );
        }
        load("whole.ply", &bytes).unwrap();
    }
}

#[test]
fn ply_bad_headers() {
    let body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let good = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    load("good.ply", format!("{good}{body}").as_bytes()).unwrap();
    for (from, to) in [
        ("ply\n", "plx\n"),
        ("ascii 1.0", "utf8 1.0"),
        ("ascii 1.0", "ascii 2.0"),
        ("property float x", "property quad x"),
        ("vertex 3", "vertex -3"),
        ("vertex 3", "vertex three"),
        ("list uchar int", "list float int"),
        ("list uchar int", "list uchar float"),
        ("property float z", "property float w"),
        ("end_header\n", "end_header_x\n"),
        ("end_header\n", ""),
        ("format ascii 1.0\n", ""),
        ("element face 1\n", "element face 1\nwhat is this\n"),
        ("element vertex 3\n", "property float q\nelement vertex 3\n"),
    ] {
        let text = format!("{}{body}", good.replacen(from, to, 1));
        let e = error(load("bad.ply", text.as_bytes()), "bad.ply");
        assert!(
            matches!(e.kind, ErrorKind::Corrupt(_) | ErrorKind::Syntax { .. }),
            "{from:?} -> {to:?}: {e}"
        );
    }
}

#[test]
fn ply_count_beyond_the_data_is_refused_before_allocating() {
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
                      property float x\nproperty float y\nproperty float z\nelement face 1\n\
                      property list uchar int vertex_indices\nend_header\n"
        .to_vec();
    bytes.extend_from_slice(&[0; 64]);
    let e = error(load("huge.ply", &bytes), "huge.ply");
    assert!(
        matches!(&e.kind, ErrorKind::Corrupt(m) if m.contains("claims")),
        "{e}"
    );
}

#[test]
fn ply_face_index_out_of_range() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
                end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 3\n";
    let e = error(load("range.ply", text.as_bytes()), "range.ply");
    assert!(
        matches!(&e.kind, ErrorKind::IndexOutOfRange { index: 3, count: 3, context } if context == "face 1"),
        "{e}"
    );
    let negative = text.replace("3 0 1 3", "3 0 -1 2");
    let e = error(load("range.ply", negative.as_bytes()), "range.ply");
    assert!(
        matches!(e.kind, ErrorKind::IndexOutOfRange { index: -1, .. }),
        "{e}"
    );
    let two = text.replace("3 0 1 3", "2 0 1");
    let e = error(load("two.ply", two.as_bytes()), "two.ply");
    assert!(matches!(e.kind, ErrorKind::Corrupt(_)), "{e}");
}

#[test]
fn ply_malformed_ascii_number_names_its_line() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                end_header\n0 0 0\n1 0 0\n0 one 0\n3 0 1 2\n";
    let e = error(load("bad.ply", text.as_bytes()), "bad.ply");
    assert!(matches!(e.kind, ErrorKind::Syntax { line: 12, .. }), "{e}");
    assert!(e.to_string().contains("vertex 2"), "{e}");
}

#[test]
fn ply_nan_position_is_non_finite() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                end_header\n0 0 0\n1 0 NaN\n0 1 0\n3 0 1 2\n";
    let e = error(load("nan.ply", text.as_bytes()), "nan.ply");
    assert!(
        matches!(e.kind, ErrorKind::NonFinite { vertex: 1, .. }),
        "{e}"
    );
}

#[test]
fn ply_without_faces_is_empty() {
    let points = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                  property float z\nend_header\n0 0 0\n";
    let e = error(load("points.ply", points.as_bytes()), "points.ply");
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
    let no_faces = points.replace(
        "end_header",
        "element face 0\nproperty list uchar int vertex_indices\nend_header",
    );
    let e = error(load("none.ply", no_faces.as_bytes()), "none.ply");
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
}

#[test]
fn byte_mutations_never_panic() {
    let obj =
        format!("{QUAD}vt 0 0\nvt 1 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/1/1 -1/2/1\nf 1//1 2//1 3//1\n");
    let values = ply_values();
    let inputs = [
        ("m.obj", obj.into_bytes()),
        ("m.ply", ply_ascii(&values)),
        ("m.ply", ply_binary(&values, false)),
        ("m.ply", ply_binary(&values, true)),
    ];
    for (name, bytes) in inputs {
        for i in 0..bytes.len() {
            for replacement in [0u8, b'-', b'9', b' ', b'\n', b'/', 0xff] {
                let mut mutated = bytes.clone();
                mutated[i] = replacement;
                // Ok or Err are both fine; a panic fails the test.
                let _ = load(name, &mutated);
            }
        }
    }
}
