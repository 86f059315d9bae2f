//! Error measures between a mesh render and an ORI render of the same view, and the error
//! picture.

use std::path::Path;
use std::sync::OnceLock;

use ori_raster::OrthoView;

use crate::Render;

/// The errors of one view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewErrors {
    /// Evaluation image edge s0.
    pub size: u32,
    /// Pixels the mesh covers.
    pub mesh_pixels: u32,
    /// Pixels the ORI covers.
    pub ori_pixels: u32,
    /// Coverage error d_i(s0): pixels covered by the mesh and not by the ORI.
    pub missed: u32,
    /// Inverse coverage: pixels covered by the ORI and not by the mesh.
    pub extra: u32,
    /// Pixels covered by either (the union of both silhouettes).
    pub union_pixels: u32,
    /// p_dif = |dR| + |dG| + |dB| of the shaded 8-bit sRGB colours (0 to 765, background
    /// black), averaged over the union of both silhouettes (0 when the union is empty).
    pub p_dif: f64,
    /// Mean |depth difference| over the pixels both cover, as a fraction of the object's
    /// extent along the view direction (0 when none).
    pub depth_error: f64,
}

impl ViewErrors {
    /// Coverage error as a percentage of s0 x s0 (the paper's tables).
    pub fn missed_percent(&self) -> f64 {
        percent(self.missed, self.size)
    }

    /// Inverse coverage as a percentage of s0 x s0.
    pub fn extra_percent(&self) -> f64 {
        percent(self.extra, self.size)
    }
}

/// `count` as a percentage of `size` x `size` pixels.
pub fn percent(count: u32, size: u32) -> f64 {
    100.0 * f64::from(count) / (f64::from(size) * f64::from(size))
}

/// Ambient and diffuse weights of the comparison shading.
const AMBIENT: f64 = 0.3;
const DIFFUSE: f64 = 0.7;

/// The shading colour errors are measured on: `albedo x (0.3 + 0.7 max(0, n . l))` in linear
/// light, encoded to 8-bit sRGB; `l` is a key light fixed to the view, from the upper right
/// front: `normalize(0.3 u + 0.5 v + w)` of the view's frame. So p_dif sees both albedo and
/// normal errors, as the reference renders of the billboard paper (lit, predetermined light).
pub struct Shading {
    light: [f64; 3],
}

struct Tables {
    decode: [f64; 256],
    /// Linear values where the sRGB code steps up (rounding in sRGB space).
    thresholds: [f64; 255],
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| Tables {
        decode: std::array::from_fn(|c| ori_math::srgb_to_linear(c as f64 / 255.0)),
        thresholds: std::array::from_fn(|c| ori_math::srgb_to_linear((c as f64 + 0.5) / 255.0)),
    })
}

impl Shading {
    pub fn new(view: &OrthoView) -> Shading {
        let f = &view.frame;
        let l: [f64; 3] = std::array::from_fn(|k| 0.3 * f.u[k] + 0.5 * f.v[k] + f.d[k]);
        let len = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
        Shading {
            light: l.map(|c| c / len),
        }
    }

    /// Shaded 8-bit sRGB colour of a surface point.
    pub fn shade(&self, albedo: [u8; 3], normal: [f32; 3]) -> [u8; 3] {
        let t = tables();
        let ndl = (0..3)
            .map(|k| f64::from(normal[k]) * self.light[k])
            .sum::<f64>();
        let light = AMBIENT + DIFFUSE * ndl.max(0.0);
        albedo.map(|c| {
            let lin = t.decode[c as usize] * light;
            t.thresholds.partition_point(|&th| th <= lin) as u8
        })
    }
}

/// Compare the ORI render `ori` with the mesh render `mesh` of the view `view`.
///
/// # Panics
/// If the renders differ in size.
pub fn compare(view: &OrthoView, mesh: &Render, ori: &Render) -> ViewErrors {
    assert_eq!(mesh.size, ori.size, "renders of different sizes");
    let shading = Shading::new(view);
    let n = mesh.size as usize * mesh.size as usize;
    let (mut union, mut both) = (0u32, 0u32);
    let (mut dif, mut depth) = (0u64, 0.0f64);
    for i in 0..n {
        let (m, o) = (mesh.coverage.get(i), ori.coverage.get(i));
        if !(m || o) {
            continue;
        }
        union += 1;
        let cm = if m {
            shading.shade(mesh.albedo[i], mesh.normal[i])
        } else {
            [0; 3]
        };
        let co = if o {
            shading.shade(ori.albedo[i], ori.normal[i])
        } else {
            [0; 3]
        };
        dif += (0..3)
            .map(|k| u64::from(cm[k].abs_diff(co[k])))
            .sum::<u64>();
        if m && o {
            both += 1;
            depth += f64::from((mesh.depth[i] - ori.depth[i]).abs());
        }
    }
    ViewErrors {
        size: mesh.size,
        mesh_pixels: mesh.coverage.count(),
        ori_pixels: ori.coverage.count(),
        missed: mesh.coverage.count_minus(&ori.coverage),
        extra: ori.coverage.count_minus(&mesh.coverage),
        union_pixels: union,
        p_dif: if union > 0 {
            dif as f64 / f64::from(union)
        } else {
            0.0
        },
        depth_error: if both > 0 {
            depth / f64::from(both)
        } else {
            0.0
        },
    }
}

/// The error picture of one view (the paper's Figure 3): RGB, `size` x `size`, row 0 at the
/// top. Pixels the ORI misses are red, pixels it adds are blue, pixels both cover show the
/// ORI's shaded colour in grey, the background is white.
pub fn error_image(view: &OrthoView, mesh: &Render, ori: &Render) -> Vec<u8> {
    let shading = Shading::new(view);
    let n = mesh.size as usize * mesh.size as usize;
    let mut rgb = Vec::with_capacity(3 * n);
    for i in 0..n {
        let pixel = match (mesh.coverage.get(i), ori.coverage.get(i)) {
            (true, false) => [255, 0, 0],
            (false, true) => [0, 0, 255],
            (false, false) => [255; 3],
            (true, true) => {
                let [r, g, b] = shading.shade(ori.albedo[i], ori.normal[i]);
                let grey = (u32::from(r) * 2 + u32::from(g) * 5 + u32::from(b)) / 8;
                [grey as u8; 3]
            }
        };
        rgb.extend_from_slice(&pixel);
    }
    rgb
}

/// Write [`error_image`] as a PNG file.
pub fn write_error_png(
    path: &Path,
    view: &OrthoView,
    mesh: &Render,
    ori: &Render,
) -> Result<(), String> {
    let rgb = error_image(view, mesh, ori);
    image::save_buffer_with_format(
        path,
        &rgb,
        mesh.size,
        mesh.size,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("{}: {e}", path.display()))
}
