//! The pictures of one asset, drawn with the CPU evaluator from the package's decoded maps.

use std::path::Path;
use std::sync::{Arc, Mutex};

use ori_eval::{Evaluator, Render, Shading, ViewErrors};
use ori_mesh::Mesh;
use ori_raster::{EMPTY, Frame, OrthoView, rasterize};
use ori_relief::{EMPTY_DEPTH, ReliefSet};

/// An RGB picture, row-major, row 0 at the top.
pub struct Picture {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

impl Picture {
    fn new(width: u32, height: u32, fill: [u8; 3]) -> Picture {
        Picture {
            width,
            height,
            rgb: fill.repeat((width * height) as usize),
        }
    }

    fn set(&mut self, x: u32, y: u32, c: [u8; 3]) {
        let i = 3 * (y * self.width + x) as usize;
        self.rgb[i..i + 3].copy_from_slice(&c);
    }

    pub fn save(&self, path: &Path) -> Result<(), String> {
        image::save_buffer_with_format(
            path,
            &self.rgb,
            self.width,
            self.height,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// A render shaded as the evaluator measures colour (`Shading`), on white.
pub fn shaded(view: &OrthoView, render: &Render) -> Picture {
    let shading = Shading::new(view);
    let mut p = Picture::new(render.size, render.size, [255; 3]);
    for i in render.coverage.ones() {
        let (x, y) = (i as u32 % render.size, i as u32 / render.size);
        p.set(x, y, shading.shade(render.albedo[i], render.normal[i]));
    }
    p
}

/// The reference mesh, the ORI (drawn with `subset`) and their error picture (missed pixels
/// red, added pixels blue) seen along `w`, with the view's errors.
pub fn comparison(
    evaluator: &Evaluator<'_>,
    w: [f64; 3],
    subset: &[usize],
) -> Result<([Picture; 3], ViewErrors), String> {
    let view = evaluator.view(w).map_err(|e| e.to_string())?;
    let mesh = evaluator.render_mesh(&view).map_err(|e| e.to_string())?;
    let ori = evaluator.render_ori(&view, subset);
    let errors = ori_eval::compare(&view, &mesh, &ori);
    let error = Picture {
        width: mesh.size,
        height: mesh.size,
        rgb: ori_eval::error_image(&view, &mesh, &ori),
    };
    Ok(([shaded(&view, &mesh), shaded(&view, &ori), error], errors))
}

/// Colour of a count of impostors seeing a triangle (the paper's Figure 2): black for none,
/// then red (1) through yellow and green to blue (10 or more).
pub fn count_colour(count: u32) -> [u8; 3] {
    const RAMP: [[u8; 3]; 11] = [
        [0, 0, 0],
        [200, 30, 30],
        [230, 90, 30],
        [240, 150, 30],
        [240, 210, 40],
        [200, 220, 50],
        [140, 200, 60],
        [70, 180, 90],
        [40, 160, 150],
        [40, 120, 200],
        [40, 70, 220],
    ];
    RAMP[count.min(10) as usize]
}

/// The mesh seen along `w`, each triangle coloured by `counts` (how many impostors sample it),
/// shaded by its facing so the shape reads.
pub fn sampling_picture(mesh: &Mesh, counts: &[u32], w: [f64; 3], size: u32) -> Picture {
    let frame = Frame::from_direction(w);
    let mut p = Picture::new(size, size, [255; 3]);
    let Ok(view) = OrthoView::fit(frame, &mesh.positions, size, 4) else {
        return p;
    };
    let raster = rasterize(&view, &mesh.positions, &mesh.triangles, None, None);
    for (i, &tri) in raster.tri.iter().enumerate() {
        if tri == EMPTY {
            continue;
        }
        let t = mesh.triangles[tri as usize].map(|k| mesh.positions[k as usize].map(f64::from));
        let (a, b) = (sub(t[1], t[0]), sub(t[2], t[0]));
        let n = [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let facing = if len > 0.0 {
            ((n[0] * w[0] + n[1] * w[1] + n[2] * w[2]) / len).abs()
        } else {
            1.0
        };
        let light = 0.45 + 0.55 * facing;
        let c = count_colour(counts[tri as usize]).map(|v| (f64::from(v) * light) as u8);
        p.set(i as u32 % size, i as u32 / size, c);
    }
    p
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Which map of a contact sheet.
#[derive(Clone, Copy)]
pub enum Channel {
    Albedo,
    Normal,
    Depth,
}

/// Every relief map of one channel in a grid of five columns, each at `cell` pixels (nearest
/// sampling), separated by a 2-pixel grey gutter.
pub fn contact_sheet(set: &ReliefSet, channel: Channel, cell: u32) -> Picture {
    let cols = 5u32.min(set.maps.len() as u32).max(1);
    let rows = (set.maps.len() as u32).div_ceil(cols).max(1);
    let gutter = 2;
    let mut p = Picture::new(
        cols * (cell + gutter) + gutter,
        rows * (cell + gutter) + gutter,
        [128; 3],
    );
    for (k, map) in set.maps.iter().enumerate() {
        let (cx, cy) = (k as u32 % cols, k as u32 / cols);
        let n = map.size();
        for y in 0..cell {
            for x in 0..cell {
                let (sx, sy) = (x * n / cell, y * n / cell);
                let i = (sy * n + sx) as usize;
                let empty = map.depth[i] == EMPTY_DEPTH;
                let c = match channel {
                    Channel::Albedo if empty => [0; 3],
                    Channel::Albedo => map.albedo[i],
                    Channel::Normal if empty => [0; 3],
                    Channel::Normal => {
                        let [nx, ny] = map.normal[i];
                        let (fx, fy) = (f64::from(nx) / 127.5 - 1.0, f64::from(ny) / 127.5 - 1.0);
                        let nz = (1.0 - fx * fx - fy * fy).max(0.0).sqrt();
                        [nx, ny, (nz * 255.0) as u8]
                    }
                    Channel::Depth if empty => [0, 0, 40],
                    // Near is light, far is dark.
                    Channel::Depth => [255 - (map.depth[i] as u32 * 200 / 254) as u8; 3],
                };
                p.set(
                    gutter + cx * (cell + gutter) + x,
                    gutter + cy * (cell + gutter) + y,
                    c,
                );
            }
        }
    }
    p
}

/// Colour of a coverage error (percent of s0 x s0): white at 0, yellow at the goal, red at
/// four times the goal and beyond.
pub fn error_colour(percent: f64, goal: f64) -> [u8; 3] {
    let t = (percent / goal.max(1e-9)).max(0.0);
    if t <= 1.0 {
        // White to yellow.
        [255, 255, (255.0 * (1.0 - t)) as u8]
    } else {
        // Yellow to red.
        let s = ((t - 1.0) / 3.0).min(1.0);
        [255, (255.0 * (1.0 - s)) as u8, 0]
    }
}

/// The coverage error of every direction over the sphere, as an equirectangular picture
/// (longitude across, +y up): each pixel shows the error of the nearest of `directions`.
pub fn sphere_picture(directions: &[[f64; 3]], percent: &[f64], goal: f64, width: u32) -> Picture {
    let height = width / 2;
    let mut p = Picture::new(width, height, [255; 3]);
    let nearest = nearest_directions(directions, width);
    for y in 0..height {
        for x in 0..width {
            let i = nearest[(y * width + x) as usize];
            p.set(x, y, error_colour(percent[i as usize], goal));
        }
    }
    p
}

/// For each pixel of the sphere picture, the direction nearest to it (the last of equals).
/// Every asset's picture uses the same directions, so the last map made is kept.
fn nearest_directions(directions: &[[f64; 3]], width: u32) -> Arc<Vec<u32>> {
    type Kept = Option<(Vec<[f64; 3]>, u32, Arc<Vec<u32>>)>;
    static KEPT: Mutex<Kept> = Mutex::new(None);
    if let Some((d, w, map)) = &*KEPT.lock().unwrap()
        && d.as_slice() == directions
        && *w == width
    {
        return map.clone();
    }
    let height = width / 2;
    let mut map = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        let lat = std::f64::consts::PI * (0.5 - (f64::from(y) + 0.5) / f64::from(height));
        for x in 0..width {
            let lon = std::f64::consts::TAU * ((f64::from(x) + 0.5) / f64::from(width))
                - std::f64::consts::PI;
            let w = [lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos()];
            let mut best = (0, f64::NEG_INFINITY);
            for (i, d) in directions.iter().enumerate() {
                let dot = d[0] * w[0] + d[1] * w[1] + d[2] * w[2];
                if dot.total_cmp(&best.1).is_ge() {
                    best = (i as u32, dot);
                }
            }
            map.push(best.0);
        }
    }
    let map = Arc::new(map);
    *KEPT.lock().unwrap() = Some((directions.to_vec(), width, map.clone()));
    map
}
