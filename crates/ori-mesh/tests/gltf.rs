//! glTF and GLB loading: the shared sample models, small hand-built documents, and bad input.

use std::collections::HashMap;
use std::io;
use std::path::{Path, PathBuf};

use base64::Engine as _;
use base64::engine::general_purpose::STANDARD as BASE64;
use ori_mesh::{AlphaMode, ErrorKind, LoadOptions, Loaded, Mesh, MeshError, Wrap, load, load_file};

const MODELS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/models");

fn model_path(relative: &str) -> PathBuf {
    Path::new(MODELS).join(relative)
}

fn load_model(relative: &str) -> Loaded {
    let path = model_path(relative);
    load_file(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads `bytes` as `name`, resolving references from `files` only.
fn load_in_memory(name: &str, bytes: &[u8], files: &[(&str, &[u8])]) -> Result<Loaded, MeshError> {
    let files: HashMap<&str, &[u8]> = files.iter().copied().collect();
    let mut resolver = |uri: &str| {
        files
            .get(uri)
            .map(|data| data.to_vec())
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, format!("no file {uri}")))
    };
    load(
        Path::new(name),
        bytes,
        &LoadOptions::default(),
        &mut resolver,
    )
}

fn load_gltf(json: &str) -> Result<Loaded, MeshError> {
    load_in_memory("test.gltf", json.as_bytes(), &[])
}

fn face_normal(mesh: &Mesh, triangle: usize) -> [f32; 3] {
    let [a, b, c] = mesh.triangles[triangle].map(|i| mesh.positions[i as usize]);
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

fn assert_close(actual: [f32; 3], expected: [f32; 3]) {
    let close = actual
        .iter()
        .zip(expected)
        .all(|(a, e)| (a - e).abs() < 1e-5);
    assert!(close, "{actual:?} != {expected:?}");
}

/// A one-mesh document whose single buffer is a data URI: positions (accessor 0), then normals
/// (accessor 1, when given), then u32 indices (last accessor, when given).
struct Doc<'a> {
    positions: &'a [[f32; 3]],
    normals: Option<&'a [[f32; 3]]>,
    indices: Option<&'a [u32]>,
    mode: u32,
    /// The `nodes` array; by default one node drawing mesh 0.
    nodes: &'a str,
    /// Extra top-level members, each followed by a comma.
    extra: &'a str,
    /// Extra primitive members, each preceded by a comma.
    primitive_extra: &'a str,
}

impl Default for Doc<'_> {
    fn default() -> Self {
        Doc {
            positions: &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            normals: None,
            indices: None,
            mode: 4,
            nodes: r#"[{"mesh": 0}]"#,
            extra: "",
            primitive_extra: "",
        }
    }
}

impl Doc<'_> {
    fn json(&self) -> String {
        let mut bin = Vec::new();
        let mut views = Vec::new();
        let mut accessors = Vec::new();
        let mut attributes = vec![r#""POSITION": 0"#.to_string()];
        let mut add = |bin: &mut Vec<u8>, bytes: Vec<u8>, accessor: String| {
            views.push(format!(
                r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}}}"#,
                bin.len(),
                bytes.len()
            ));
            accessors.push(accessor.replace("VIEW", &(views.len() - 1).to_string()));
            bin.extend(bytes);
        };
        let floats = |v: &[[f32; 3]]| v.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        let vec3 = |count: usize| {
            format!(
                r#"{{"bufferView": VIEW, "componentType": 5126, "count": {count}, "type": "VEC3",
                    "min": [-1e9, -1e9, -1e9], "max": [1e9, 1e9, 1e9]}}"#
            )
        };
        add(&mut bin, floats(self.positions), vec3(self.positions.len()));
        if let Some(normals) = self.normals {
            add(&mut bin, floats(normals), vec3(normals.len()));
            attributes.push(r#""NORMAL": 1"#.to_string());
        }
        let mut indices = String::new();
        if let Some(list) = self.indices {
            let accessor = format!(
                r#"{{"bufferView": VIEW, "componentType": 5125, "count": {}, "type": "SCALAR"}}"#,
                list.len()
            );
            add(
                &mut bin,
                list.iter().flat_map(|i| i.to_le_bytes()).collect(),
                accessor,
            );
            indices = format!(r#", "indices": {}"#, accessors.len() - 1);
        }
        format!(
            r#"{{
                "asset": {{"version": "2.0"}},
                {extra}
                "scene": 0,
                "scenes": [{{"nodes": [0]}}],
                "nodes": {nodes},
                "meshes": [{{"name": "thing", "primitives": [
                    {{"attributes": {{{attributes}}}, "mode": {mode}{indices}{primitive_extra}}}
                ]}}],
                "buffers": [{{"byteLength": {len},
                    "uri": "data:application/octet-stream;base64,{data}"}}],
                "bufferViews": [{views}],
                "accessors": [{accessors}]
            }}"#,
            extra = self.extra,
            nodes = self.nodes,
            attributes = attributes.join(", "),
            mode = self.mode,
            primitive_extra = self.primitive_extra,
            len = bin.len(),
            data = BASE64.encode(&bin),
            views = views.join(", "),
            accessors = accessors.join(", "),
        )
    }
}

const QUAD_STRIP: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 1.0, 0.0],
];

#[test]
fn sample_models_load_with_expected_counts() {
    // (path, vertices, triangles), as listed in SOURCES.md, except GlassVaseFlowers: SOURCES
    // counts each mesh once (5,989 / 10,218), but its scene draws mesh "Flowers" from two nodes,
    // so the loaded world-space scene holds it twice (+2,561 vertices / +3,818 triangles).
    let models = [
        ("gltf/Duck/Duck.glb", 2_399, 4_212),
        ("gltf/DamagedHelmet/DamagedHelmet.glb", 14_556, 15_452),
        ("gltf/Avocado/glTF/Avocado.gltf", 406, 682),
        ("gltf/BoxVertexColors/BoxVertexColors.glb", 24, 12),
        ("gltf/VertexColorTest/VertexColorTest.glb", 72, 36),
        (
            "gltf/GlassVaseFlowers/GlassVaseFlowers.glb",
            5_989 + 2_561,
            10_218 + 3_818,
        ),
        ("vegetation/fern_02/fern_02.glb", 4_337, 6_232),
    ];
    for (path, vertices, triangles) in models {
        let loaded = load_model(path);
        let mesh = &loaded.mesh;
        assert_eq!(mesh.vertex_count(), vertices, "{path}");
        assert_eq!(mesh.triangle_count(), triangles, "{path}");
        assert_eq!(mesh.normals.len(), vertices, "{path}");
        for n in &mesh.normals {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-4, "{path}: normal {n:?}");
        }
        assert_eq!(mesh.triangle_materials.len(), triangles, "{path}");
        assert_eq!(&Mesh::decode(&mesh.encode()).expect(path), mesh, "{path}");
    }
}

#[test]
fn duck_has_its_base_colour_texture() {
    let mesh = load_model("gltf/Duck/Duck.glb").mesh;
    assert_eq!(mesh.materials.len(), 1);
    assert_eq!(mesh.materials[0].base_color_texture, Some(0));
    assert_eq!(mesh.textures.len(), 1);
    let texture = &mesh.textures[0];
    assert_eq!((texture.width, texture.height), (512, 512));
    assert_eq!(texture.rgba8.len(), 512 * 512 * 4);
    assert_eq!(
        (texture.wrap_s, texture.wrap_t, texture.nearest),
        (Wrap::Repeat, Wrap::Repeat, false)
    );
    assert!(mesh.uvs.is_some());
}

/// Records what the loader says it will read and what it reads, in order.
struct Recorder {
    dir: PathBuf,
    events: Vec<String>,
}

impl ori_mesh::Files for Recorder {
    fn read(&mut self, reference: &str) -> std::io::Result<Vec<u8>> {
        self.events.push(format!("read {reference}"));
        std::fs::read(self.dir.join(reference))
    }
    fn will_read(&mut self, references: &[String]) {
        self.events
            .push(format!("will read {}", references.join(", ")));
    }
}

#[test]
fn the_loader_names_the_files_it_will_read_before_reading_them() {
    // Avocado: one buffer and three images, of which only the base colour one is read.
    let path = model_path("gltf/Avocado/glTF/Avocado.gltf");
    let mut files = Recorder {
        dir: path.parent().unwrap().to_path_buf(),
        events: Vec::new(),
    };
    let bytes = std::fs::read(&path).unwrap();
    load(&path, &bytes, &LoadOptions::default(), &mut files).unwrap();
    assert_eq!(
        files.events,
        [
            "will read Avocado.bin, Avocado_baseColor.png",
            "read Avocado.bin",
            "read Avocado_baseColor.png"
        ]
    );
    // A percent-encoded name is named as it is read.
    let (json, bin) = external_buffer_doc("my%20mesh.bin");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("my mesh.bin"), &bin).unwrap();
    let mut files = Recorder {
        dir: dir.path().to_path_buf(),
        events: Vec::new(),
    };
    load(
        Path::new("a.gltf"),
        json.as_bytes(),
        &LoadOptions::default(),
        &mut files,
    )
    .unwrap();
    assert_eq!(files.events, ["will read my mesh.bin", "read my mesh.bin"]);
}

#[test]
fn avocado_reads_only_its_buffer_and_base_colour_image() {
    let path = model_path("gltf/Avocado/glTF/Avocado.gltf");
    let dir = path.parent().unwrap().to_path_buf();
    let bytes = std::fs::read(&path).unwrap();
    let mut asked = Vec::new();
    let mut resolver = |uri: &str| {
        asked.push(uri.to_string());
        std::fs::read(dir.join(uri))
    };
    let loaded = load(&path, &bytes, &LoadOptions::default(), &mut resolver).unwrap();
    assert_eq!(asked, ["Avocado.bin", "Avocado_baseColor.png"]);
    let mesh = loaded.mesh;
    assert_eq!(mesh.textures.len(), 1);
    assert_eq!(
        (mesh.textures[0].width, mesh.textures[0].height),
        (2048, 2048)
    );
    assert_eq!(mesh.textures[0].name, "Avocado_baseColor.png");
    assert_eq!(mesh.materials[0].name, "2256_Avocado_d");
}

#[test]
fn box_vertex_colors_has_colours() {
    let mesh = load_model("gltf/BoxVertexColors/BoxVertexColors.glb").mesh;
    let colors = mesh.colors.expect("vertex colours");
    assert_eq!(colors.len(), 24);
    assert!(colors.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
    assert!(colors.iter().any(|c| c != &colors[0]), "colours vary");
    // No glTF material: the primitives get the default one.
    assert_eq!(mesh.materials.len(), 1);
    assert_eq!(mesh.materials[0].name, "default");
}

#[test]
fn vertex_color_test_decodes_each_image_once() {
    let mesh = load_model("gltf/VertexColorTest/VertexColorTest.glb").mesh;
    assert_eq!(mesh.materials.len(), 2);
    assert_eq!(mesh.textures.len(), 2);
    assert!(mesh.colors.is_some());
}

#[test]
fn glass_vase_flowers_materials() {
    let loaded = load_model("gltf/GlassVaseFlowers/GlassVaseFlowers.glb");
    let materials = &loaded.mesh.materials;
    let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["Flowers", "GlassAlpha", "GlassTransmission"]);
    assert_eq!(materials[0].alpha_mode, AlphaMode::Mask);
    assert_eq!(materials[0].alpha_cutoff, 0.5);
    assert!(materials[0].double_sided);
    assert!(materials[0].base_color_texture.is_some());
    assert_eq!(materials[1].alpha_mode, AlphaMode::Blend);
    assert_eq!(materials[1].base_color_factor, [0.15, 0.15, 0.15, 0.3]);
    assert_eq!(materials[2].alpha_mode, AlphaMode::Opaque);
    // Only the flowers' base-colour image is decoded, though the file holds four.
    assert_eq!(loaded.mesh.textures.len(), 1);
}

#[test]
fn damaged_helmet_decodes_only_the_base_colour_image() {
    let mesh = load_model("gltf/DamagedHelmet/DamagedHelmet.glb").mesh;
    assert_eq!(mesh.textures.len(), 1);
    assert_eq!(mesh.materials[0].base_color_texture, Some(0));
}

#[test]
fn triangle_strip_alternates_winding() {
    let json = Doc {
        positions: &QUAD_STRIP,
        mode: 5,
        ..Doc::default()
    }
    .json();
    let mesh = load_gltf(&json).unwrap().mesh;
    assert_eq!(mesh.triangles, [[0, 1, 2], [1, 3, 2]]);
    for t in 0..2 {
        assert!(face_normal(&mesh, t)[2] > 0.0, "triangle {t} faces +z");
    }
}

#[test]
fn indexed_triangle_fan() {
    let positions = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 0.5, 0.0],
    ];
    let json = Doc {
        positions: &positions,
        indices: Some(&[0, 1, 2, 3, 4]),
        mode: 6,
        ..Doc::default()
    }
    .json();
    let mesh = load_gltf(&json).unwrap().mesh;
    assert_eq!(mesh.triangles, [[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
}

#[test]
fn points_primitive_is_skipped_with_one_warning() {
    // The same mesh drawn by two nodes still warns once.
    let json = Doc {
        nodes: r#"[{"mesh": 0, "children": [1]}, {"mesh": 0}]"#,
        primitive_extra: r#"}, {"attributes": {"POSITION": 0}, "mode": 0"#,
        ..Doc::default()
    }
    .json();
    let loaded = load_gltf(&json).unwrap();
    assert_eq!(loaded.mesh.triangle_count(), 2);
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(
        loaded.warnings[0].contains("thing"),
        "{}",
        loaded.warnings[0]
    );
    assert!(
        loaded.warnings[0].contains("Points"),
        "{}",
        loaded.warnings[0]
    );
}

#[test]
fn mirroring_transform_flips_winding() {
    let json = Doc {
        nodes: r#"[{"mesh": 0, "scale": [-1, 1, 1]}]"#,
        ..Doc::default()
    }
    .json();
    let mesh = load_gltf(&json).unwrap().mesh;
    assert_eq!(mesh.positions[1], [-1.0, 0.0, 0.0]);
    assert_eq!(mesh.triangles, [[0, 2, 1]]);
    assert!(face_normal(&mesh, 0)[2] > 0.0, "still faces +z");
    assert_close(mesh.normals[0], [0.0, 0.0, 1.0]);
}

#[test]
fn child_transforms_compose_and_normals_use_the_inverse_transpose() {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let json = Doc {
        normals: Some(&[[s, s, 0.0]; 3]),
        nodes: r#"[
            {"translation": [10, 0, 0], "scale": [2, 1, 1], "children": [1]},
            {"mesh": 0, "translation": [0, 1, 0]}
        ]"#,
        ..Doc::default()
    }
    .json();
    let mesh = load_gltf(&json).unwrap().mesh;
    // (1, 0, 0) -> child (1, 1, 0) -> parent scale (2, 1, 0) -> translate (12, 1, 0).
    assert_eq!(mesh.positions[1], [12.0, 1.0, 0.0]);
    assert_eq!(mesh.positions[2], [10.0, 2.0, 0.0]);
    // Stretching x by 2 halves the normal's x before renormalising.
    let expected = 1.0 / (0.25f32 + 1.0).sqrt();
    assert_close(mesh.normals[0], [0.5 * expected, expected, 0.0]);
}

#[test]
fn data_uri_buffers_do_not_use_the_resolver() {
    let json = Doc::default().json();
    let mut resolver = |uri: &str| -> io::Result<Vec<u8>> { panic!("resolver asked for {uri}") };
    let loaded = load(
        Path::new("a.gltf"),
        json.as_bytes(),
        &LoadOptions::default(),
        &mut resolver,
    );
    assert_eq!(loaded.unwrap().mesh.triangles, [[0, 1, 2]]);
}

/// A document whose buffer lives in an external file named by `uri`.
fn external_buffer_doc(uri: &str) -> (String, Vec<u8>) {
    let json = Doc::default().json();
    let start = json.find("data:").unwrap();
    let end = start + json[start..].find('"').unwrap();
    let data = BASE64
        .decode(json[start..end].split_once(',').unwrap().1)
        .unwrap();
    (format!("{}{uri}{}", &json[..start], &json[end..]), data)
}

#[test]
fn sparse_accessors_override_their_base() {
    // Accessor 0: three stored positions with vertex 2 replaced by (5, 5, 0); accessor 1: the
    // same override on implicit zeros (no buffer view).
    let mut bin = Vec::new();
    for f in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend(f.to_le_bytes());
    }
    bin.extend(2u32.to_le_bytes());
    for f in [5.0f32, 5.0, 0.0] {
        bin.extend(f.to_le_bytes());
    }
    let sparse = r#""sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5125},
        "values": {"bufferView": 2}}"#;
    let json = format!(
        r#"{{
            "asset": {{"version": "2.0"}},
            "scenes": [{{"nodes": [0]}}],
            "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}},
                                         {{"attributes": {{"POSITION": 1}}}}]}}],
            "buffers": [{{"byteLength": 52, "uri": "data:;base64,{data}"}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}},
                            {{"buffer": 0, "byteOffset": 36, "byteLength": 4}},
                            {{"buffer": 0, "byteOffset": 40, "byteLength": 12}}],
            "accessors": [
                {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0, 0, 0], "max": [5, 5, 0], {sparse}}},
                {{"componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0, 0, 0], "max": [5, 5, 0], {sparse}}}
            ]
        }}"#,
        data = BASE64.encode(&bin)
    );
    let mesh = load_gltf(&json).unwrap().mesh;
    assert_eq!(
        mesh.positions,
        [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [5.0, 5.0, 0.0],
            [0.0; 3],
            [0.0; 3],
            [5.0, 5.0, 0.0]
        ]
    );
    assert_eq!(mesh.triangles, [[0, 1, 2], [3, 4, 5]]);
}

#[test]
fn base_colour_texture_on_a_second_uv_set_uses_that_set() {
    let mut png = Vec::new();
    image::RgbaImage::from_raw(2, 1, vec![255, 0, 0, 255, 0, 0, 255, 255])
        .unwrap()
        .write_to(&mut io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let mut bin = Vec::new();
    let floats: [&[f32]; 3] = [
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[0.0; 6],
        &[0.25, 0.5, 0.75, 0.5, 0.25, 0.0],
    ];
    for f in floats.concat() {
        bin.extend(f.to_le_bytes());
    }
    let json = format!(
        r#"{{
            "asset": {{"version": "2.0"}},
            "scenes": [{{"nodes": [0]}}],
            "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"material": 0,
                "attributes": {{"POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 2}}}}]}}],
            "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0, "texCoord": 1}}}}}}],
            "textures": [{{"source": 0}}],
            "images": [{{"uri": "t.png"}}],
            "buffers": [{{"byteLength": 84, "uri": "data:;base64,{data}"}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}},
                            {{"buffer": 0, "byteOffset": 36, "byteLength": 24}},
                            {{"buffer": 0, "byteOffset": 60, "byteLength": 24}}],
            "accessors": [
                {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                  "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}},
                {{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}}
            ]
        }}"#,
        data = BASE64.encode(&bin)
    );
    let mesh = load_in_memory("a.gltf", json.as_bytes(), &[("t.png", &png)])
        .unwrap()
        .mesh;
    assert_eq!(mesh.uvs.unwrap(), [[0.25, 0.5], [0.75, 0.5], [0.25, 0.0]]);
    assert_eq!(mesh.textures[0].rgba8, [255, 0, 0, 255, 0, 0, 255, 255]);
}

#[test]
fn external_buffer_uri_is_percent_decoded() {
    let (json, bin) = external_buffer_doc("my%20mesh.bin");
    let loaded = load_in_memory("a.gltf", json.as_bytes(), &[("my mesh.bin", &bin)]).unwrap();
    assert_eq!(loaded.mesh.vertex_count(), 3);
}

#[test]
fn missing_external_buffer_names_the_uri() {
    let (json, _) = external_buffer_doc("missing.bin");
    let error = load_in_memory("dir/a.gltf", json.as_bytes(), &[]).unwrap_err();
    assert_eq!(error.file, Path::new("dir/a.gltf"));
    match &error.kind {
        ErrorKind::MissingExternal { uri, .. } => assert_eq!(uri, "missing.bin"),
        other => panic!("{other}"),
    }
    assert!(error.to_string().contains("missing.bin"), "{error}");
}

#[test]
fn short_external_buffer_is_truncated() {
    let (json, bin) = external_buffer_doc("a.bin");
    let error = load_in_memory("a.gltf", json.as_bytes(), &[("a.bin", &bin[..10])]).unwrap_err();
    assert!(
        matches!(&error.kind, ErrorKind::Corrupt(m) if m.contains("buffer 0 is truncated")),
        "{error}"
    );
}

#[test]
fn missing_image_names_the_uri() {
    let json = Doc {
        extra: r#""materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
                  "textures": [{"source": 0}],
                  "images": [{"uri": "missing.png"}],"#,
        primitive_extra: r#", "material": 0"#,
        ..Doc::default()
    }
    .json();
    let error = load_gltf(&json).unwrap_err();
    assert!(
        matches!(&error.kind, ErrorKind::MissingExternal { uri, .. } if uri == "missing.png"),
        "{error}"
    );
}

#[test]
fn material_order_sampler_and_texture_set() {
    let png = std::fs::read(model_path("gltf/Avocado/glTF/Avocado_baseColor.png")).unwrap();
    let json = Doc {
        extra: r#""materials": [
                    {"name": "unused"},
                    {"name": "used", "alphaMode": "MASK", "alphaCutoff": 0.25, "doubleSided": true,
                     "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1, 1],
                        "baseColorTexture": {"index": 0}}}],
                  "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 33648}],
                  "textures": [{"source": 0, "sampler": 0}],
                  "images": [{"uri": "tex.png"}],"#,
        primitive_extra: r#", "material": 1"#,
        ..Doc::default()
    }
    .json();
    let mesh = load_in_memory("a.gltf", json.as_bytes(), &[("tex.png", &png)])
        .unwrap()
        .mesh;
    assert_eq!(mesh.materials.len(), 1);
    let material = &mesh.materials[0];
    assert_eq!(material.name, "used");
    assert_eq!(material.alpha_mode, AlphaMode::Mask);
    assert_eq!(material.alpha_cutoff, 0.25);
    assert!(material.double_sided);
    assert_eq!(material.base_color_factor, [0.5, 0.25, 1.0, 1.0]);
    let texture = &mesh.textures[0];
    assert_eq!(
        (texture.wrap_s, texture.wrap_t, texture.nearest),
        (Wrap::ClampToEdge, Wrap::MirroredRepeat, true)
    );
}

#[test]
fn index_out_of_range_names_the_mesh() {
    let json = Doc {
        indices: Some(&[0, 1, 3]),
        ..Doc::default()
    }
    .json();
    let error = load_gltf(&json).unwrap_err();
    match &error.kind {
        ErrorKind::IndexOutOfRange {
            context,
            index,
            count,
        } => {
            assert!(
                context.contains("thing") && context.contains("primitive 0"),
                "{context}"
            );
            assert_eq!((*index, *count), (3, 3));
        }
        other => panic!("{other}"),
    }
}

#[test]
fn reads_outside_buffers_are_corrupt() {
    let json = Doc::default().json();
    let cases = [
        (
            r#""count": 3, "type": "VEC3""#,
            r#""count": 4, "type": "VEC3""#,
            "reads past the end",
        ),
        (
            r#""byteLength": 36}"#,
            r#""byteLength": 400}"#,
            "extends past the end of buffer 0",
        ),
        (
            r#""byteOffset": 0,"#,
            r#""byteOffset": 1000,"#,
            "extends past the end of buffer 0",
        ),
    ];
    for (from, to, message) in cases {
        assert!(json.contains(from), "{from}");
        let error = load_gltf(&json.replace(from, to)).unwrap_err();
        assert!(
            matches!(&error.kind, ErrorKind::Corrupt(m) if m.contains(message)),
            "{to}: {error}"
        );
    }
}

#[test]
fn nan_position_is_non_finite() {
    let json = Doc {
        positions: &[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]],
        ..Doc::default()
    }
    .json();
    let error = load_gltf(&json).unwrap_err();
    assert!(
        matches!(error.kind, ErrorKind::NonFinite { vertex: 1, .. }),
        "{error}"
    );
}

#[test]
fn mesh_without_triangles_is_empty() {
    let json = Doc {
        mode: 1,
        positions: &QUAD_STRIP,
        ..Doc::default()
    }
    .json();
    let error = load_gltf(&json).unwrap_err();
    assert!(matches!(error.kind, ErrorKind::Empty(_)), "{error}");
    assert!(error.to_string().contains("points or lines"), "{error}");
}

/// (gltfpack's extensions load: tests/gltfpack.rs.)
#[test]
fn geometry_extensions_are_refused() {
    for (key, name) in [
        ("extensionsRequired", "KHR_draco_mesh_compression"),
        ("extensionsUsed", "KHR_meshopt_compression"),
        ("extensionsRequired", "EXT_mesh_gpu_instancing"),
    ] {
        let extra = match key {
            "extensionsUsed" => format!(r#""extensionsUsed": ["{name}"],"#),
            _ => format!(r#""extensionsUsed": ["{name}"], "{key}": ["{name}"],"#),
        };
        let json = Doc {
            extra: &extra,
            ..Doc::default()
        }
        .json();
        let error = load_gltf(&json).unwrap_err();
        assert!(
            matches!(&error.kind, ErrorKind::UnsupportedExtension(n) if n == name),
            "{error}"
        );
        assert!(error.to_string().contains(name), "{error}");
    }
}

#[test]
fn material_extensions_load_with_warnings() {
    let json = Doc {
        extra: r#""extensionsUsed": ["KHR_materials_pbrSpecularGlossiness", "KHR_texture_transform"],
                  "extensionsRequired": ["KHR_materials_pbrSpecularGlossiness"],
                  "materials": [{"name": "old", "extensions": {"KHR_materials_pbrSpecularGlossiness":
                      {"diffuseFactor": [1, 0, 0, 1]}}}],"#,
        primitive_extra: r#", "material": 0"#,
        ..Doc::default()
    }
    .json();
    let loaded = load_gltf(&json).unwrap();
    let warnings = loaded.warnings.join("\n");
    assert!(
        warnings.contains("required extension `KHR_materials_pbrSpecularGlossiness`"),
        "{warnings}"
    );
    assert!(
        warnings.contains("material `old` uses KHR_materials_pbrSpecularGlossiness"),
        "{warnings}"
    );
}

#[test]
fn what_the_ori_does_not_carry_is_said() {
    let json = Doc {
        extra: r#""extensionsUsed": ["KHR_materials_transmission", "KHR_materials_volume"],
                  "materials": [
                      {"name": "glass", "alphaMode": "BLEND", "extensions": {
                          "KHR_materials_transmission": {"transmissionFactor": 1},
                          "KHR_materials_volume": {}}},
                      {"name": "lamp", "emissiveFactor": [1, 0.5, 0]},
                      {"name": "plain", "alphaMode": "MASK"}],"#,
        primitive_extra: r#", "material": 0"#,
        ..Doc::default()
    }
    .json();
    let warnings = load_gltf(&json).unwrap().warnings.join("\n");
    for said in [
        "material `glass` is alpha-blended (alphaMode BLEND); the ORI draws it opaque",
        "material `glass`: KHR_materials_transmission is ignored",
        "material `glass`: KHR_materials_volume is ignored",
    ] {
        assert!(warnings.contains(said), "{said}: {warnings}");
    }
    // Only the materials drawn are looked at.
    assert!(
        !warnings.contains("lamp") && !warnings.contains("plain"),
        "{warnings}"
    );
    let json = json.replace(r#""material": 0"#, r#""material": 1"#);
    let warnings = load_gltf(&json).unwrap().warnings.join("\n");
    assert!(
        warnings.contains("material `lamp`: its emission is ignored"),
        "{warnings}"
    );
    let json = json.replace(r#""material": 1"#, r#""material": 2"#);
    assert!(load_gltf(&json).unwrap().warnings.is_empty());
}

#[test]
fn corrupt_json_is_corrupt() {
    for json in [
        "",
        "{",
        "[]",
        r#"{"asset": {"version": "2.0"}, "nodes": 3}"#,
        "\u{0}glTF",
    ] {
        let error = load_gltf(json).unwrap_err();
        assert!(
            matches!(error.kind, ErrorKind::Corrupt(_)),
            "{json:?}: {error}"
        );
    }
}

#[test]
fn node_cycle_is_an_error() {
    let json = Doc {
        nodes: r#"[{"mesh": 0, "children": [1]}, {"children": [0]}]"#,
        ..Doc::default()
    }
    .json();
    let error = load_gltf(&json).unwrap_err();
    assert!(matches!(error.kind, ErrorKind::Corrupt(_)), "{error}");
}

#[test]
fn every_truncated_glb_is_an_error() {
    let bytes = std::fs::read(model_path("gltf/BoxVertexColors/BoxVertexColors.glb")).unwrap();
    for len in 0..bytes.len() {
        let result = load_in_memory("box.glb", &bytes[..len], &[]);
        assert!(result.is_err(), "prefix of {len} bytes loaded");
    }
    let error = load_in_memory("box.glb", &bytes[..100], &[]).unwrap_err();
    assert!(error.to_string().contains("truncated GLB"), "{error}");
}

#[test]
fn damaged_glb_never_panics() {
    // Overwrite every byte with values that stress lengths, counts and offsets.
    let bytes = std::fs::read(model_path("gltf/BoxVertexColors/BoxVertexColors.glb")).unwrap();
    for at in 0..bytes.len() {
        for value in [0x00, 0xFF, b'9', b'0'] {
            let mut damaged = bytes.clone();
            damaged[at] = value;
            let _ = load_in_memory("box.glb", &damaged, &[]);
        }
    }
}

/// A base-colour image in a format the loader does not decode (KTX2 through
/// KHR_texture_basisu, WebP through EXT_texture_webp, with no PNG fallback) is dropped with a
/// warning naming the material, the image and the format; the model still loads.
#[test]
fn base_colour_images_in_other_formats_are_dropped_with_a_warning() {
    let mut bin = Vec::new();
    for f in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend(f.to_le_bytes());
    }
    let ktx2 = b"\xABKTX 20\xBB\r\n\x1A\n\0\0\0\0";
    let webp = b"RIFF\x10\0\0\0WEBPVP8L";
    for (extension, file, bytes, format) in [
        ("KHR_texture_basisu", "t.ktx2", &ktx2[..], "KTX2"),
        ("EXT_texture_webp", "t.webp", &webp[..], "WebP"),
    ] {
        let json = format!(
            r#"{{
                "asset": {{"version": "2.0"}},
                "extensionsUsed": ["{extension}"], "extensionsRequired": ["{extension}"],
                "scenes": [{{"nodes": [0]}}],
                "nodes": [{{"mesh": 0}}],
                "meshes": [{{"primitives": [{{"material": 0, "attributes": {{"POSITION": 0}}}}]}}],
                "materials": [{{"name": "skin", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}},
                    "baseColorFactor": [0.5, 0.5, 0.5, 1]}}}}],
                "textures": [{{"extensions": {{"{extension}": {{"source": 0}}}}}}],
                "images": [{{"uri": "{file}"}}],
                "buffers": [{{"byteLength": 36, "uri": "data:;base64,{data}"}}],
                "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
                "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                    "min": [0, 0, 0], "max": [1, 1, 0]}}]
            }}"#,
            data = BASE64.encode(&bin)
        );
        let loaded = load_in_memory("a.gltf", json.as_bytes(), &[(file, bytes)])
            .unwrap_or_else(|e| panic!("{extension}: {e}"));
        let warnings = loaded.warnings.join("\n");
        assert!(
            warnings.contains(&format!(
                "material `skin`: its base-colour image `{file}` is {format}"
            )),
            "{warnings}"
        );
        let material = &loaded.mesh.materials[0];
        assert_eq!(material.base_color_texture, None);
        assert_eq!(material.base_color_factor, [0.5, 0.5, 0.5, 1.0]);
    }
}
