//! Hierarchical ORIs (ORI paper, section 5), built by `build-assets` with `[hierarchy]` and
//! drawn by the wgpu renderer's traversal (the software Vulkan driver in CI): junctions
//! without cracks, a camera path that keeps every drawn node within its PLT, and rebuilds that
//! redo only the nodes an edit touches.

mod common;

use std::fs;
use std::path::Path;

use common::*;
use ori_hierarchy::{Cell, Visit};
use ori_mesh::Mesh;
use ori_package::Hierarchy;
use ori_render::{Camera, Draw, GpuMesh, Image, Renderer};

fn renderer() -> &'static Renderer {
    static R: std::sync::OnceLock<Renderer> = std::sync::OnceLock::new();
    R.get_or_init(|| {
        Renderer::new()
            .unwrap_or_else(|e| panic!("no GPU adapter (CI installs mesa-vulkan-drivers): {e}"))
    })
}

/// A project holding one shared model, built with `[hierarchy]` settings `tree`.
fn project(model: &str, tree: &str) -> Project {
    let p = Project::new(&[]);
    let to = p.path("assets").join(model);
    fs::create_dir_all(to.parent().unwrap()).unwrap();
    fs::copy(shared_models().join(model), &to).unwrap();
    p.config(&format!("[hierarchy]\nenabled = true\n{tree}"));
    p
}

fn read_hierarchy(p: &Project, package: &str) -> Hierarchy {
    let bytes = fs::read(p.path("out").join(package)).unwrap();
    ori_package::read_hierarchy(&bytes).unwrap()
}

fn load(path: &Path) -> Mesh {
    ori_mesh::load_file(path, &Default::default()).unwrap().mesh
}

/// Pixels the reference covers and `image` does not.
fn missed(reference: &Image, image: &Image) -> usize {
    (0..reference.len())
        .filter(|&i| reference.covered(i) && !image.covered(i))
        .count()
}

/// The six axis directions and two oblique ones.
fn directions() -> Vec<[f64; 3]> {
    let oblique = [[0.577, 0.577, 0.577], [-0.4, 0.3, -0.866]];
    ori_views::axis_directions()
        .into_iter()
        .chain(oblique)
        .collect()
}

#[test]
fn children_cover_the_mesh_at_least_as_well_as_their_parent() {
    // The armadillo split once: the root and its non-empty octants, placed (the planned
    // directions leave some octants' worst views far below the root's) and measured at
    // s0 = 128 (at the tests' usual 64 a worst view misses a few dozen pixels, too coarse a
    // PLT to compare nodes by).
    let p = project(
        "stanford/armadillo/armadillo_odedstein_remeshed.obj",
        "max_depth = 1\ntarget_px = 1000000\n[place]\n\
         [[overrides]]\nassets = \"**\"\nselect.s0 = 128\n",
    );
    ok(&p.build(&[]));
    let h = read_hierarchy(&p, "stanford/armadillo/armadillo_odedstein_remeshed.ori");
    assert_eq!(h.manifest.nodes[0].children.len(), h.nodes.len() - 1);
    assert!(h.nodes.len() >= 5, "{} nodes", h.nodes.len());
    // report.json lists every job of the asset: a package per node, then the hierarchy.
    let report = p.report();
    let stages: Vec<&str> = report["assets"][0]["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["stage"].as_str().unwrap())
        .collect();
    let count = |stage: &str| stages.iter().filter(|s| **s == stage).count();
    assert_eq!(count("package"), h.nodes.len(), "{stages:?}");
    assert_eq!(stages.last(), Some(&"hierarchy"), "{stages:?}");

    let r = renderer();
    let mesh = load(&p.path("assets/stanford/armadillo/armadillo_odedstein_remeshed.obj"));
    let gpu_mesh = r.load_mesh(&mesh).unwrap();
    let gpu = r.load_hierarchy(&h).unwrap();
    let root = &h.nodes[0].manifest;
    // At the parent's PLT: the largest size the parent may be drawn at.
    let size = (root.plt.pixels.floor() as u32).clamp(64, 1024);
    let (center, radius) = (root.bounding_sphere.center, root.bounding_sphere.radius);
    let children: Vec<Draw<'_>> = (1..h.nodes.len()).map(|i| Draw::Ori(gpu.node(i))).collect();
    let (mut parent_missed, mut children_missed, mut covered) = (0, 0, 0);
    let directions = directions();
    for &dir in &directions {
        let camera = Camera::ortho_framing(center, radius, dir);
        let reference = r.render_mesh(&gpu_mesh, &camera, size, size).unwrap();
        let parent = r
            .render(&[Draw::Ori(gpu.node(0))], &camera, size, size)
            .unwrap();
        let split = r.render(&children, &camera, size, size).unwrap();
        let (a, b) = (missed(&reference, &parent), missed(&reference, &split));
        eprintln!("{dir:?} at {size} px: parent misses {a}, children {b}");
        parent_missed += a;
        children_missed += b;
        covered += reference.coverage_count();
    }
    eprintln!(
        "{} nodes; over {} views at {size} px ({covered} mesh pixels): parent misses \
         {parent_missed}, children {children_missed}",
        h.nodes.len(),
        directions.len()
    );
    assert!(
        children_missed <= parent_missed,
        "children miss {children_missed} pixels, the parent {parent_missed}"
    );

    // The range: the object size up to which the traversal draws no leaf mesh, here (an
    // orthographic camera) just where the first leaf mesh appears.
    let leafless = ori_hierarchy::leafless_size(&h.manifest, |i| {
        let m = &h.nodes[i].manifest;
        (m.plt.pixels, m.bounding_sphere.radius)
    });
    let meshes_at = |size: f64| {
        let per_unit = size / (2.0 * radius);
        let edge = |_: [f64; 3], r: f64| Some(ori_plt::ortho_sphere_edge(r, per_unit));
        let visits = ori_hierarchy::traverse(&h.manifest, |i| &h.nodes[i].manifest, &edge);
        visits
            .iter()
            .filter(|v| matches!(v, Visit::Mesh(_)))
            .count()
    };
    assert_eq!(meshes_at(leafless * 0.999), 0);
    assert!(meshes_at(leafless * 1.001) > 0);
    for (i, n) in h.nodes.iter().enumerate() {
        let m = &n.manifest;
        let scaled = m.plt.pixels * radius / m.bounding_sphere.radius;
        eprintln!(
            "node {i}: PLT {:.0} px, radius {:.3}: fits up to {scaled:.0} px",
            m.plt.pixels, m.bounding_sphere.radius
        );
    }
    let range = leafless / root.plt.pixels;
    eprintln!("no leaf mesh up to {leafless:.0} px: {range:.2} x the root's PLT");
    // Halving the children's goals (`goal_scale`) is what makes the range: with the root's
    // goals it was 1.39, and 1.00 when what a node's cuts expose counted against it. The bound
    // leaves a margin under the 1.56 measured with the regions at 0.75 of s0 (`region_scale`).
    assert!(range >= 1.5, "{range:.2} x the root's PLT");
}

/// The leaf meshes a runtime supplies: the model clipped to each leaf's cell.
fn leaf_meshes(r: &Renderer, h: &Hierarchy, mesh: &Mesh) -> Vec<Option<GpuMesh>> {
    h.manifest
        .nodes
        .iter()
        .map(|n| {
            let cell = Cell {
                min: n.bounds[0],
                max: n.bounds[1],
            };
            if !n.children.is_empty() {
                return None;
            }
            ori_mesh::clip_to_box(mesh, cell.min, cell.max).map(|m| r.load_mesh(&m).unwrap())
        })
        .collect()
}

#[test]
fn a_camera_path_keeps_every_drawn_node_within_its_plt() {
    let p = project(
        "stanford/dragon/dragon_res2_binary.ply",
        "max_depth = 1\ntarget_px = 1000000\n",
    );
    ok(&p.build(&[]));
    let h = read_hierarchy(&p, "stanford/dragon/dragon_res2_binary.ori");
    let r = renderer();
    let mesh = load(&p.path("assets/stanford/dragon/dragon_res2_binary.ply"));
    let gpu_mesh = r.load_mesh(&mesh).unwrap();
    let gpu = r.load_hierarchy(&h).unwrap();
    let leaves = leaf_meshes(r, &h, &mesh);
    let root = &h.nodes[0].manifest;
    let (center, radius) = (root.bounding_sphere.center, root.bounding_sphere.radius);
    let root_plt = root.plt.pixels;
    // The single-ORI goal of selection (`[select] goal_percent`, 0.2 % by default).
    let goal = root.selection.goal_percent;
    // From far (the whole dragon at half its PLT) to near (eight times the largest PLT).
    let (size, fov) = (256u32, 0.8f64);
    let largest = h
        .nodes
        .iter()
        .map(|n| n.manifest.plt.pixels)
        .fold(0.0, f64::max);
    let dir = [0.3, 0.4, 0.866];
    let (mut saw_root, mut saw_children, mut saw_mesh) = (false, false, false);
    for step in 0..8 {
        let edge = 0.5 * root_plt * (16.0 * largest / root_plt).powf(f64::from(step) / 7.0);
        let camera = Camera::perspective_sized(center, radius, dir, fov, edge, size);
        let visits = gpu.traverse(&camera, size);
        for &v in &visits {
            let node = &h.nodes[v.node()].manifest;
            let s = &node.bounding_sphere;
            let px = camera.projected_sphere_edge(s.center, s.radius, size);
            match v {
                Visit::Ori(_) => assert!(
                    px.is_some_and(|px| px <= node.plt.pixels),
                    "step {step}: node {} drawn at {px:?} px, PLT {}",
                    v.node(),
                    node.plt.pixels
                ),
                Visit::Mesh(i) => assert!(h.manifest.nodes[i].children.is_empty()),
            }
        }
        saw_root |= visits == [Visit::Ori(0)];
        saw_children |= visits.iter().any(|v| matches!(v, Visit::Ori(i) if *i > 0));
        saw_mesh |= visits.iter().any(|v| matches!(v, Visit::Mesh(_)));
        let draws = gpu.draws(&visits, &leaves).unwrap();
        let reference = r.render_mesh(&gpu_mesh, &camera, size, size).unwrap();
        let image = r.render(&draws, &camera, size, size).unwrap();
        let m = missed(&reference, &image);
        let area = (edge * edge).min(f64::from(size * size));
        let percent = 100.0 * m as f64 / area;
        let kinds: Vec<String> = visits.iter().map(|v| format!("{v:?}")).collect();
        eprintln!(
            "step {step}: object {edge:.0} px, {} draws, missed {m} ({percent:.3} %): {}",
            visits.len(),
            kinds.join(" ")
        );
        assert!(
            percent <= goal,
            "step {step}: {percent:.3} % missed, over the single-ORI goal {goal} %"
        );
    }
    assert!(
        saw_root && saw_children && saw_mesh,
        "the path must reach every case"
    );
}

#[test]
fn a_hierarchy_rebuilds_only_the_nodes_an_edit_touches() {
    // A scene: the bunny twice, 10 units apart, in one OBJ.
    let p = Project::new(&[]);
    fs::create_dir_all(p.path("assets")).unwrap();
    let bunny = fs::read_to_string(samples().join("bunny/bunny_npm_lowres.obj")).unwrap();
    let vertices: Vec<[f32; 3]> = bunny
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f32> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect();
    let faces: Vec<&str> = bunny.lines().filter(|l| l.starts_with("f ")).collect();
    // The edit moves one vertex well inside the second bunny's box (so the scene's bounding
    // cube, and with it every cell, stays the same).
    let (lo, hi) = (0..3).fold(([f32::MAX; 3], [f32::MIN; 3]), |(mut lo, mut hi), k| {
        for v in &vertices {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
        (lo, hi)
    });
    let inner = vertices
        .iter()
        .position(|v| {
            (0..3).all(|k| {
                (v[k] - lo[k]) > 0.3 * (hi[k] - lo[k]) && (hi[k] - v[k]) > 0.3 * (hi[k] - lo[k])
            })
        })
        .expect("an inner vertex");
    let scene = |moved: f32| {
        let mut out = String::new();
        for (copy, dx) in [(0, 0.0), (1, 10.0)] {
            for (i, v) in vertices.iter().enumerate() {
                let dy = if copy == 1 && i == inner { moved } else { 0.0 };
                out += &format!("v {} {} {}\n", v[0] + dx, v[1] + dy, v[2]);
            }
        }
        for copy in 0..2 {
            for f in &faces {
                let idx: Vec<String> = f[2..]
                    .split_whitespace()
                    .map(|c| {
                        let i: usize = c.split('/').next().unwrap().parse().unwrap();
                        (i + copy * vertices.len()).to_string()
                    })
                    .collect();
                out += &format!("f {}\n", idx.join(" "));
            }
        }
        out
    };
    fs::write(p.path("assets/scene.obj"), scene(0.0)).unwrap();
    p.config("[hierarchy]\nenabled = true\nmax_depth = 1\ntarget_px = 1000000\n");
    ok(&p.build(&[]));
    let nodes = read_hierarchy(&p, "scene.ori").nodes.len();
    assert!(nodes >= 3, "{nodes} nodes");
    // The edit re-bakes the root and the cells around the vertex, not the first bunny's.
    fs::write(p.path("assets/scene.obj"), scene(0.05)).unwrap();
    let second = p.build(&["--explain"]);
    let t = ok(&second);
    let bakes = ran(&second, "bake");
    assert!(
        bakes >= 2 && bakes <= 1 + nodes / 2,
        "{bakes} of {nodes} nodes re-baked:\n{t}"
    );
    assert_eq!(ran(&second, "hierarchy"), 1, "{t}");
    assert_eq!(read_hierarchy(&p, "scene.ori").nodes.len(), nodes);
    // Nothing changed: nothing runs.
    assert_eq!(ran(&p.build(&[]), "bake"), 0);

    // `preview --path`: one row per step, each naming the nodes the traversal drew.
    let png = p.path("path.png");
    let out = std::process::Command::new(EXE)
        .arg("preview")
        .arg(p.path("out/scene.ori"))
        .arg("--config")
        .arg(p.path("pipeline.toml"))
        .args(["--path", "3", "--dir", "0,0.3,1", "--size", "64", "--out"])
        .arg(&png)
        .output()
        .unwrap();
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    assert!(t.contains(&format!("hierarchy: {nodes} nodes")), "{t}");
    let steps: Vec<&str> = t.lines().filter(|l| l.starts_with("step ")).collect();
    assert_eq!(steps.len(), 3, "{t}");
    // Far: the root alone; near: leaves as meshes.
    assert!(steps[0].contains("nodes: ori 0 "), "{t}");
    assert!(steps[2].contains("mesh "), "{t}");
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (3 * 64, 3 * 64));
}
