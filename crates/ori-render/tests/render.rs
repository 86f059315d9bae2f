//! The renderer beyond parity: compositing with meshes through the depth buffer, the
//! perspective camera, the CPU-decode fallback, reference meshes, and a missing adapter.

mod common;

use std::sync::OnceLock;

use common::{Built, build, renderer};
use ori_mesh::{Material, Mesh};
use ori_package::TextureFormat;
use ori_raster::OrthoView;
use ori_render::{
    Camera, Draw, GpuOri, Image, RenderError, Renderer, RendererOptions, SOURCE_MESH, SOURCE_NONE,
};

const SIZE: u32 = 256;

fn duck() -> &'static Built {
    static B: OnceLock<Built> = OnceLock::new();
    B.get_or_init(|| build("gltf/Duck/Duck.glb", 128, TextureFormat::R8))
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|c| c / l)
}

fn view(w: [f64; 3]) -> OrthoView {
    ori_eval::eval_view(&duck().mesh, normalize(w), SIZE).expect("view")
}

/// A red square facing the view, at height `h` along its direction, covering the middle
/// half of the image (pixels 64..192 on both axes).
fn quad(view: &OrthoView, h: f64) -> Mesh {
    let f = view.frame;
    let s = 0.5 * view.half_size;
    let corner = |a: f64, b: f64| -> [f32; 3] {
        let (a, b) = (view.center[0] + a * s, view.center[1] + b * s);
        std::array::from_fn(|k| (f.u[k] * a + f.v[k] * b + f.d[k] * h) as f32)
    };
    Mesh {
        positions: vec![
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
        ],
        normals: vec![f.d.map(|c| c as f32); 4],
        uvs: None,
        colors: None,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![0, 0],
        materials: vec![Material {
            base_color_factor: [1.0, 0.0, 0.0, 1.0],
            ..Default::default()
        }],
        textures: vec![],
    }
}

/// Pixels well inside (`Some(true)`) or well outside (`Some(false)`) the quad's square.
fn in_quad(i: usize) -> Option<bool> {
    let (x, y) = (i % SIZE as usize, i / SIZE as usize);
    let inside = |c: usize| (66..190).contains(&c);
    let outside = |c: usize| !(62..194).contains(&c);
    if inside(x) && inside(y) {
        Some(true)
    } else if outside(x) || outside(y) {
        Some(false)
    } else {
        None
    }
}

fn load() -> (&'static Renderer, GpuOri) {
    let r = renderer();
    (r, r.load_package(&duck().package).expect("load"))
}

#[test]
fn a_quad_in_front_hides_the_ori_and_one_behind_is_hidden_by_it() {
    let (r, ori) = load();
    let v = view([0.3, 0.4, 0.9]);
    let camera = Camera::from_view(&v);
    let alone = r.render_ori(&ori, &camera, SIZE, SIZE).expect("render");
    let range = v.near - v.far;
    let front = r.load_mesh(&quad(&v, v.near + 0.5 * range)).expect("mesh");
    let behind = r.load_mesh(&quad(&v, v.far - 0.5 * range)).expect("mesh");
    let ori_in_quad = (0..alone.len())
        .filter(|&i| in_quad(i) == Some(true) && alone.covered(i))
        .count();
    assert!(ori_in_quad > 5000, "the ORI shows behind the quad's square");
    for (name, scene) in [
        ("front, ORI first", [Draw::Ori(&ori), Draw::Mesh(&front)]),
        ("front, quad first", [Draw::Mesh(&front), Draw::Ori(&ori)]),
    ] {
        let img = r.render(&scene, &camera, SIZE, SIZE).expect("render");
        for i in 0..img.len() {
            match in_quad(i) {
                Some(true) => {
                    assert_eq!(img.source[i], SOURCE_MESH, "{name}: pixel {i}");
                    assert_eq!(img.rgb(i)[1], 0, "{name}: pixel {i} is red");
                }
                Some(false) => assert_eq!(img.source[i], alone.source[i], "{name}: pixel {i}"),
                None => {}
            }
        }
    }
    for (name, scene) in [
        ("behind, ORI first", [Draw::Ori(&ori), Draw::Mesh(&behind)]),
        ("behind, quad first", [Draw::Mesh(&behind), Draw::Ori(&ori)]),
    ] {
        let img = r.render(&scene, &camera, SIZE, SIZE).expect("render");
        for i in 0..img.len() {
            match in_quad(i) {
                Some(true) if alone.covered(i) => {
                    assert_eq!(img.source[i], alone.source[i], "{name}: pixel {i}");
                    assert_eq!(img.rgb(i), alone.rgb(i), "{name}: pixel {i}");
                }
                Some(true) => assert_eq!(img.source[i], SOURCE_MESH, "{name}: pixel {i}"),
                Some(false) => assert_eq!(img.source[i], alone.source[i], "{name}: pixel {i}"),
                None => {}
            }
        }
    }
}

/// A quad through the middle of the object: each pixel shows whichever is nearer, by the
/// true depth of the impostor's hit.
#[test]
fn a_quad_through_the_ori_composites_by_true_depth() {
    let (r, ori) = load();
    let v = view([-0.5, 0.2, 0.8]);
    let camera = Camera::from_view(&v);
    let alone = r.render_ori(&ori, &camera, SIZE, SIZE).expect("render");
    // At the median height of the ORI's hits inside the square.
    let mut heights: Vec<f64> = (0..alone.len())
        .filter(|&i| in_quad(i) == Some(true) && alone.covered(i))
        .map(|i| camera.ortho_height(f64::from(alone.depth[i])).unwrap())
        .collect();
    heights.sort_by(f64::total_cmp);
    let h = heights[heights.len() / 2];
    let mesh = r.load_mesh(&quad(&v, h)).expect("mesh");
    let img = r
        .render(&[Draw::Mesh(&mesh), Draw::Ori(&ori)], &camera, SIZE, SIZE)
        .expect("render");
    let (mut ori_wins, mut mesh_wins) = (0, 0);
    for i in 0..img.len() {
        if in_quad(i) != Some(true) || !alone.covered(i) {
            continue;
        }
        let hit = camera.ortho_height(f64::from(alone.depth[i])).unwrap();
        let margin = 1e-3 * (v.near - v.far);
        if hit > h + margin {
            assert_eq!(
                img.source[i], alone.source[i],
                "pixel {i}: the ORI is nearer"
            );
            ori_wins += 1;
        } else if hit < h - margin {
            assert_eq!(img.source[i], SOURCE_MESH, "pixel {i}: the quad is nearer");
            mesh_wins += 1;
        }
    }
    eprintln!("through the middle: ORI nearer at {ori_wins} pixels, quad at {mesh_wins}");
    assert!(ori_wins > 1000 && mesh_wins > 1000);
}

fn coverage_disagreement(a: &Image, b: &Image) -> usize {
    (0..a.len())
        .filter(|&i| a.covered(i) != b.covered(i))
        .count()
}

/// A distant perspective camera with a narrow field of view sees (nearly) the orthographic
/// image; a close one draws the ORI where the GPU draws the mesh, at the same depth.
#[test]
fn perspective_camera() {
    let (r, ori) = load();
    let (center, radius) = ori.bounding_sphere();
    let w = normalize([0.2, 0.3, 0.9]);
    let ortho = r
        .render_ori(&ori, &Camera::ortho_framing(center, radius, w), SIZE, SIZE)
        .expect("ortho");
    let far = Camera::perspective_framing(center, radius, w, 0.2f64.to_radians());
    let distant = r.render_ori(&ori, &far, SIZE, SIZE).expect("distant");
    let d = coverage_disagreement(&ortho, &distant);
    eprintln!(
        "perspective at fov 0.2 deg vs orthographic: coverage differs at {d} of {} pixels ({} \
         covered)",
        ortho.len(),
        ortho.coverage_count()
    );
    assert!(d * 100 < ortho.coverage_count(), "{d} pixels differ");

    let near = Camera::perspective_framing(center, radius, w, 50f64.to_radians());
    let mesh = r.load_mesh(&duck().mesh).expect("mesh");
    let ori_img = r.render_ori(&ori, &near, SIZE, SIZE).expect("ori");
    let mesh_img = r.render_mesh(&mesh, &near, SIZE, SIZE).expect("mesh");
    let (both, either) = (0..ori_img.len()).fold((0, 0), |(b, e), i| {
        let (o, m) = (ori_img.covered(i), mesh_img.covered(i));
        (b + usize::from(o && m), e + usize::from(o || m))
    });
    // Depth agreement in view distance, relative to the object's size.
    let Some(ori_render::Projection::Perspective {
        near: zn, far: zf, ..
    }) = Some(near.projection)
    else {
        unreachable!()
    };
    let distance = |z: f32| zn * zf / (zf - f64::from(z) * (zf - zn));
    let mut depth_err = Vec::new();
    for i in 0..ori_img.len() {
        if ori_img.covered(i) && mesh_img.covered(i) {
            depth_err
                .push((distance(ori_img.depth[i]) - distance(mesh_img.depth[i])).abs() / radius);
        }
    }
    depth_err.sort_by(f64::total_cmp);
    let median = depth_err[depth_err.len() / 2];
    let iou = both as f64 / either as f64;
    eprintln!(
        "perspective at fov 50 deg: ORI vs GPU mesh coverage IoU {iou:.4}, median |depth \
         difference| {median:.2e} of the radius"
    );
    assert!(iou > 0.95, "IoU {iou}");
    assert!(median < 0.01, "median depth difference {median}");
}

/// The CPU-decode fallback draws what the BC path draws: the same coverage and impostors,
/// colours within the decoders' rounding.
#[test]
fn cpu_decoded_textures_draw_the_same() {
    let (r, ori) = load();
    let fallback = Renderer::with_options(&RendererOptions {
        decode_on_cpu: true,
        ..Default::default()
    })
    .expect("renderer");
    assert!(!fallback.compressed_textures());
    let decoded = fallback.load_package(&duck().package).expect("load");
    assert!(!decoded.compressed());
    let camera = Camera::from_view(&view([0.6, -0.3, 0.5]));
    let a = r.render_ori(&ori, &camera, SIZE, SIZE).expect("bc");
    let b = fallback
        .render_ori(&decoded, &camera, SIZE, SIZE)
        .expect("decoded");
    assert_eq!(a.source, b.source);
    let (mut sum, mut max, mut n) = (0u64, 0u8, 0u64);
    for i in (0..a.len()).filter(|&i| a.covered(i)) {
        for (x, y) in a.rgb(i).into_iter().zip(b.rgb(i)) {
            sum += u64::from(x.abs_diff(y));
            max = max.max(x.abs_diff(y));
        }
        n += 3;
    }
    let mean = sum as f64 / n as f64;
    eprintln!(
        "BC sampled by {} vs decoded on the CPU: colour mean {mean:.3}, max {max}",
        r.adapter_info().name
    );
    assert!(mean < 1.0, "mean colour difference {mean}");
}

/// The GPU's reference mesh covers the pixels the CPU rasterizer covers.
#[test]
fn mesh_coverage_matches_the_cpu_rasterizer() {
    let r = renderer();
    let built = duck();
    let mesh = r.load_mesh(&built.mesh).expect("mesh");
    let set = common::decoded_set(&built.package);
    let ev = ori_eval::Evaluator::new(&built.mesh, &set, &Default::default()).expect("eval");
    let v = view([0.1, 0.2, -0.9]);
    let cpu = ev.mesh_coverage(&v);
    let gpu = r
        .render_mesh(&mesh, &Camera::from_view(&v), SIZE, SIZE)
        .expect("render");
    let differ = (0..gpu.len())
        .filter(|&i| gpu.covered(i) != cpu.get(i))
        .count();
    eprintln!(
        "mesh coverage: GPU and CPU rasterizers differ at {differ} of {} covered pixels",
        cpu.count()
    );
    assert!(differ * 200 < cpu.count() as usize);
    assert!((0..gpu.len()).all(|i| gpu.source[i] == SOURCE_MESH || gpu.source[i] == SOURCE_NONE));
}

/// Single-sided materials are culled from behind on the GPU as on the CPU: looking into the
/// cut of half a duck, its inside (back faces) is drawn only once the material is made
/// double-sided.
#[test]
fn back_faces_of_single_sided_materials_are_culled_as_on_the_cpu() {
    let r = renderer();
    let built = duck();
    let (lo, hi) = built.mesh.bounds();
    let (lo, mut hi) = (lo.map(f64::from), hi.map(f64::from));
    hi[0] = 0.5 * (lo[0] + hi[0]);
    let half = ori_mesh::clip_to_box(&built.mesh, lo, hi).expect("clip");
    let set = common::decoded_set(&built.package);
    let v = ori_eval::eval_view(&half, [1.0, 0.0, 0.0], SIZE).expect("view");
    let covered = |mesh: &Mesh| {
        let ev = ori_eval::Evaluator::new(mesh, &set, &Default::default()).expect("eval");
        let cpu = ev.mesh_coverage(&v);
        let on_gpu = r.load_mesh(mesh).expect("mesh");
        let gpu = r
            .render_mesh(&on_gpu, &Camera::from_view(&v), SIZE, SIZE)
            .expect("render");
        let differ = (0..gpu.len())
            .filter(|&i| gpu.covered(i) != cpu.get(i))
            .count();
        eprintln!("GPU and CPU differ at {differ} of {} pixels", cpu.count());
        assert!(differ * 200 < cpu.count() as usize);
        cpu.count()
    };
    let single = covered(&half);
    let mut double = half.clone();
    double
        .materials
        .iter_mut()
        .for_each(|m| m.double_sided = true);
    let both = covered(&double);
    assert!(single * 10 < both * 9, "culled {single} of {both} pixels");
}

#[test]
fn no_adapter_is_an_error_not_a_panic() {
    let out = Renderer::with_options(&RendererOptions {
        backends: ori_render::wgpu::Backends::empty(),
        ..Default::default()
    });
    match out {
        Err(RenderError::NoAdapter(_)) => {}
        Err(e) => panic!("expected NoAdapter, got {e}"),
        Ok(_) => panic!("a renderer without backends"),
    }
}

#[test]
fn bad_input_is_an_error() {
    let (r, ori) = load();
    let camera = Camera::from_view(&view([0.0, 0.0, 1.0]));
    assert!(matches!(
        r.render_ori(&ori, &camera, 0, 16),
        Err(RenderError::Size { .. })
    ));
    assert!(matches!(
        r.render(&[Draw::OriSubset(&ori, &[999])], &camera, 16, 16),
        Err(RenderError::Scene(_))
    ));
    let mut flat = camera;
    flat.projection = ori_render::Projection::Orthographic {
        center: [0.0; 2],
        half_size: 0.0,
        near: 1.0,
        far: 0.0,
    };
    assert!(matches!(
        r.render_ori(&ori, &flat, 16, 16),
        Err(RenderError::Camera(_))
    ));
}

/// A package with BC4 depth draws with the depth sampled as BC4 by the adapter, and as
/// CPU-decoded R8 by the fallback, with (nearly) the same coverage.
#[test]
fn bc4_depth_packages_draw() {
    let built = build("gltf/Duck/Duck.glb", 128, TextureFormat::Bc4);
    let (r, f) = (renderer(), common::fallback_renderer());
    let a = r.load_package(&built.package).expect("load");
    let b = f.load_package(&built.package).expect("load");
    let camera = Camera::from_view(&view([0.4, 0.1, -0.9]));
    let ia = r.render_ori(&a, &camera, SIZE, SIZE).expect("bc4");
    let ib = f.render_ori(&b, &camera, SIZE, SIZE).expect("decoded");
    let d = coverage_disagreement(&ia, &ib);
    eprintln!(
        "BC4 depth sampled vs decoded on the CPU: coverage differs at {d} of {} covered pixels",
        ia.coverage_count()
    );
    assert!(ia.coverage_count() > 10_000);
    assert!(d * 1000 <= ia.len(), "{d} pixels differ");
}
