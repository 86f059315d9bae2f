//! `ori preview PACKAGE` (also `cargo xtask preview`): the ORI drawn by the wgpu runtime renderer, the reference
//! mesh with the same camera, and their difference, side by side (one row per direction, or
//! per step of a camera path). A hierarchy package is drawn by the runtime traversal.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ori_package::AnyPackage;
use ori_render::{Camera, Draw, GpuHierarchy, GpuMesh, GpuOri, Image, Renderer, Visit};

#[derive(clap::Args)]
pub struct Args {
    /// The `.ori` package.
    package: PathBuf,
    /// View direction (object -> viewer), e.g. `0,0.3,1`.
    #[arg(long, value_name = "X,Y,Z", conflicts_with = "turntable")]
    dir: Option<String>,
    /// N views around the vertical axis, 20 degrees above the horizon.
    #[arg(long, value_name = "N", conflicts_with = "path")]
    turntable: Option<u32>,
    /// A camera path of N perspective views along `--dir`, from far (the object at a
    /// quarter of its PLT) to near (four times the largest PLT of any node); a hierarchy
    /// draws each node as its ORI, its children or (a leaf past its PLT) its mesh.
    #[arg(long, value_name = "N")]
    path: Option<u32>,
    /// Edge of each picture in pixels.
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// Colour of the pixels nothing covers in the ORI and mesh pictures, as hex `RRGGBB`
    /// (pick one the model does not use to tell them apart from white surfaces).
    #[arg(long, default_value = "ffffff", value_name = "RRGGBB", value_parser = parse_colour)]
    background: [u8; 3],
    /// Pipeline configuration (its assets folder holds the source model).
    #[arg(long, default_value = "pipeline.toml")]
    config: PathBuf,
    /// Assets folder (default: `[assets] root` of the configuration).
    #[arg(long)]
    assets: Option<PathBuf>,
}

/// Exit status 0: written; 1: the package, the adapter or a render failed; 2: bad options.
pub fn run(args: Args) -> ExitCode {
    let directions = match directions(&args) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    match preview(&args, &directions) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn parse_colour(text: &str) -> Result<[u8; 3], String> {
    let bad = || format!("{text:?} is not a colour as hex RRGGBB, e.g. ff00ff");
    if text.len() != 6 || !text.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(bad());
    }
    let byte = |k: usize| u8::from_str_radix(&text[2 * k..2 * k + 2], 16).map_err(|_| bad());
    Ok([byte(0)?, byte(1)?, byte(2)?])
}

fn directions(args: &Args) -> Result<Vec<[f64; 3]>, String> {
    if args.size == 0 || args.size > 4096 {
        return Err(format!("--size {} must be 1 to 4096", args.size));
    }
    if let Some(n) = args.path
        && !(2..=64).contains(&n)
    {
        return Err(format!("--path {n} must be 2 to 64"));
    }
    if let Some(n) = args.turntable {
        if n == 0 || n > 64 {
            return Err(format!("--turntable {n} must be 1 to 64"));
        }
        let elevation = 20f64.to_radians();
        return Ok((0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * f64::from(k) / f64::from(n);
                [
                    elevation.cos() * a.sin(),
                    elevation.sin(),
                    elevation.cos() * a.cos(),
                ]
            })
            .collect());
    }
    let text = args.dir.as_deref().unwrap_or("0.3,0.3,1");
    let parts: Vec<f64> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--dir {text:?}: expected three numbers, e.g. 0,0.3,1"))?;
    let [x, y, z] = parts[..] else {
        return Err(format!(
            "--dir {text:?}: expected three numbers, e.g. 0,0.3,1"
        ));
    };
    let len = (x * x + y * y + z * z).sqrt();
    if !(len > 0.0 && len.is_finite()) {
        return Err(format!("--dir {text:?} has no direction"));
    }
    Ok(vec![[x / len, y / len, z / len]])
}

/// The source model of a package, if it is where the configuration says and unchanged.
pub fn source_mesh(
    manifest: &ori_package::Manifest,
    config: &Path,
    assets: Option<PathBuf>,
) -> Result<ori_mesh::Mesh, String> {
    let root = match assets {
        Some(a) => a,
        None => {
            let c = ori_pipeline::Config::load(config).map_err(|e| e.to_string())?;
            c.resolve(&c.assets.root)
        }
    };
    let path = root.join(&manifest.source.name);
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    if blake3::hash(&bytes).to_hex().as_str() != manifest.source.blake3 {
        return Err(format!(
            "{}: changed since the package was built",
            path.display()
        ));
    }
    Ok(ori_mesh::load_file(&path, &Default::default())
        .map_err(|e| e.to_string())?
        .mesh)
}

/// What is drawn: one ORI, or a hierarchy with its leaves' meshes.
enum Scene {
    Single(Box<GpuOri>),
    Tree {
        hierarchy: GpuHierarchy,
        leaves: Vec<Option<GpuMesh>>,
    },
}

impl Scene {
    /// The draws for `camera`, and a description of them.
    fn draws(&self, camera: &Camera, size: u32) -> Result<(Vec<Draw<'_>>, String), String> {
        match self {
            Scene::Single(ori) => {
                let (center, _) = ori.bounding_sphere();
                let n = ori.selection(camera.view_direction(center)).len();
                Ok((vec![Draw::Ori(ori)], format!("{n} impostor(s)")))
            }
            Scene::Tree { hierarchy, leaves } => {
                let visits = hierarchy.traverse(camera, size);
                let describe: Vec<String> = visits
                    .iter()
                    .map(|&v| {
                        let m = hierarchy.node(v.node()).manifest();
                        let s = &m.bounding_sphere;
                        let px = camera
                            .projected_sphere_edge(s.center, s.radius, size)
                            .map_or("unbounded".to_string(), |p| format!("{p:.0}"));
                        match v {
                            Visit::Ori(i) => {
                                format!("ori {i} ({px} px <= PLT {:.0})", m.plt.pixels)
                            }
                            Visit::Mesh(i) => {
                                format!("mesh {i} ({px} px > PLT {:.0})", m.plt.pixels)
                            }
                        }
                    })
                    .collect();
                let draws = hierarchy
                    .draws(&visits, leaves)
                    .map_err(|e| e.to_string())?;
                Ok((draws, format!("nodes: {}", describe.join(", "))))
            }
        }
    }
}

fn preview(args: &Args, directions: &[[f64; 3]]) -> Result<(), String> {
    let bytes = std::fs::read(&args.package)
        .map_err(|e| format!("{}: cannot read: {e}", args.package.display()))?;
    let package =
        ori_package::read_any(&bytes).map_err(|e| format!("{}: {e}", args.package.display()))?;
    let renderer = Renderer::new().map_err(|e| e.to_string())?;
    println!("adapter: {}", renderer.adapter_summary());
    if !renderer.compressed_textures() {
        println!("notice: the adapter cannot sample BC textures; they are decoded on the CPU");
    }
    let root = package.root().manifest.clone();
    let source = source_mesh(&root, &args.config, args.assets.clone());
    let mesh = match &source {
        Ok(mesh) => Some(renderer.load_mesh(mesh).map_err(|e| e.to_string())?),
        Err(e) => {
            println!("no reference mesh ({e}): the ORI alone");
            None
        }
    };
    let scene = match &package {
        AnyPackage::Single(p) => Scene::Single(Box::new(
            renderer.load_package(p).map_err(|e| e.to_string())?,
        )),
        AnyPackage::Hierarchy(h) => {
            println!("hierarchy: {} nodes", h.nodes.len());
            // The runtime supplies leaf meshes: the source clipped to each leaf's cell.
            let leaves = h
                .manifest
                .nodes
                .iter()
                .map(|n| match &source {
                    Ok(m) if n.children.is_empty() => {
                        ori_mesh::clip_to_box(m, n.bounds[0], n.bounds[1])
                            .map(|c| renderer.load_mesh(&c))
                            .transpose()
                    }
                    _ => Ok(None),
                })
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| e.to_string())?;
            Scene::Tree {
                hierarchy: renderer.load_hierarchy(h).map_err(|e| e.to_string())?,
                leaves,
            }
        }
    };
    let size = args.size;
    let cameras = cameras(args, &package, directions, size);
    let columns = if mesh.is_some() { 3 } else { 1 };
    let mut sheet = vec![255u8; (3 * size * columns * size * cameras.len() as u32) as usize];
    let stride = (3 * size * columns) as usize;
    for (row, (camera, label)) in cameras.iter().enumerate() {
        let (draws, what) = scene.draws(camera, size)?;
        let (images, line) = row_images(
            &renderer,
            &draws,
            mesh.as_ref(),
            camera,
            size,
            args.background,
        )?;
        println!("{label}: {what}; {line}");
        for (col, rgb) in images.iter().enumerate() {
            for y in 0..size as usize {
                let dst = (row * size as usize + y) * stride + col * 3 * size as usize;
                let src = y * 3 * size as usize;
                sheet[dst..dst + 3 * size as usize]
                    .copy_from_slice(&rgb[src..src + 3 * size as usize]);
            }
        }
    }
    image::save_buffer_with_format(
        &args.out,
        &sheet,
        size * columns,
        size * cameras.len() as u32,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("{}: {e}", args.out.display()))?;
    println!("wrote {}", args.out.display());
    Ok(())
}

/// The cameras of the rows, with their labels: orthographic framings of the bounding sphere
/// per direction, or (`--path N`) perspective views approaching along the first direction.
fn cameras(
    args: &Args,
    package: &AnyPackage,
    directions: &[[f64; 3]],
    size: u32,
) -> Vec<(Camera, String)> {
    let root = &package.root().manifest;
    let (center, radius) = (root.bounding_sphere.center, root.bounding_sphere.radius);
    let Some(steps) = args.path else {
        return directions
            .iter()
            .map(|&dir| {
                (
                    Camera::ortho_framing(center, radius, dir),
                    format!("dir {dir:.3?}"),
                )
            })
            .collect();
    };
    let largest = match package {
        AnyPackage::Single(p) => p.manifest.plt.pixels,
        AnyPackage::Hierarchy(h) => h
            .nodes
            .iter()
            .map(|n| n.manifest.plt.pixels)
            .fold(0.0, f64::max),
    };
    let (far, near) = (0.25 * root.plt.pixels, 4.0 * largest);
    let fov = 0.8f64;
    (0..steps)
        .map(|k| {
            let edge = far * (near / far).powf(f64::from(k) / f64::from(steps - 1));
            let camera = Camera::perspective_sized(center, radius, directions[0], fov, edge, size);
            (camera, format!("step {k}: object {edge:.0} px"))
        })
        .collect()
}

/// One row: the draws, and with a mesh the mesh and the difference (red: the mesh covers, the
/// drawn scene misses; blue: it covers, the mesh does not; both: the colour difference x 4).
fn row_images(
    renderer: &Renderer,
    draws: &[Draw<'_>],
    mesh: Option<&GpuMesh>,
    camera: &Camera,
    size: u32,
    background: [u8; 3],
) -> Result<(Vec<Vec<u8>>, String), String> {
    let drawn = renderer
        .render(draws, camera, size, size)
        .map_err(|e| e.to_string())?;
    let on_background = |img: &Image| -> Vec<u8> {
        (0..img.len())
            .flat_map(|i| {
                if img.covered(i) {
                    img.rgb(i)
                } else {
                    background
                }
            })
            .collect()
    };
    let Some(mesh) = mesh else {
        let line = format!("{} px drawn", drawn.coverage_count());
        return Ok((vec![on_background(&drawn)], line));
    };
    let reference = renderer
        .render_mesh(mesh, camera, size, size)
        .map_err(|e| e.to_string())?;
    let (mut missed, mut extra) = (0, 0);
    let difference: Vec<u8> = (0..drawn.len())
        .flat_map(|i| match (reference.covered(i), drawn.covered(i)) {
            (true, false) => {
                missed += 1;
                [255, 0, 0]
            }
            (false, true) => {
                extra += 1;
                [0, 0, 255]
            }
            (false, false) => [255; 3],
            (true, true) => {
                let (a, b) = (reference.rgb(i), drawn.rgb(i));
                std::array::from_fn(|k| 255 - (a[k].abs_diff(b[k]) as u32 * 4).min(255) as u8)
            }
        })
        .collect();
    let line = format!(
        "mesh {} px, ORI {} px, missed {missed}, added {extra}",
        reference.coverage_count(),
        drawn.coverage_count()
    );
    Ok((
        vec![on_background(&drawn), on_background(&reference), difference],
        line,
    ))
}
