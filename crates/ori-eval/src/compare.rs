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
    /// `starts[j]`: how many thresholds are at most `j / STEPS`, where a search for a value
    /// in `[j / STEPS, (j + 1) / STEPS)` can start.
    starts: [u8; STEPS],
}

/// Cells of [`Tables::starts`] over `[0, 1)`, each narrower than the gap between two
/// thresholds, so that a search takes one step at most.
const STEPS: usize = 4096;

impl Tables {
    /// The 8-bit sRGB code of linear `lin`: the number of thresholds at most `lin`, as a
    /// binary search over them counts it, from the cell's start and at most a step.
    #[inline]
    fn encode(&self, lin: f64) -> u8 {
        // Scaling by a power of two is exact, so the cell's lower end is at most `lin`.
        let cell = lin * STEPS as f64;
        let mut k = if cell >= STEPS as f64 {
            self.starts[STEPS - 1]
        } else if cell >= 0.0 {
            self.starts[cell as usize]
        } else {
            0 // negative or NaN: no threshold is below it
        };
        while let Some(&th) = self.thresholds.get(usize::from(k))
            && th <= lin
        {
            k += 1;
        }
        k
    }
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let thresholds: [f64; 255] =
            std::array::from_fn(|c| ori_math::srgb_to_linear((c as f64 + 0.5) / 255.0));
        Tables {
            decode: std::array::from_fn(|c| ori_math::srgb_to_linear(c as f64 / 255.0)),
            starts: std::array::from_fn(|j| {
                let low = j as f64 / STEPS as f64;
                thresholds.partition_point(|&th| th <= low) as u8
            }),
            thresholds,
        }
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
        albedo.map(|c| t.encode(t.decode[c as usize] * light))
    }
}

/// Compare the ORI render `ori` with the mesh render `mesh` of the view `view`.
///
/// # Panics
/// If the renders differ in size.
pub fn compare(view: &OrthoView, mesh: &Render, ori: &Render) -> ViewErrors {
    ShadedMesh::new(view, mesh).compare(ori)
}

/// A mesh render with its pixels shaded once, to [`compare`] many renders of its view with.
pub struct ShadedMesh<'a> {
    mesh: &'a Render,
    shading: Shading,
    /// The shaded colour of each covered pixel, in pixel order.
    colours: Vec<[u8; 3]>,
}

impl<'a> ShadedMesh<'a> {
    pub fn new(view: &OrthoView, mesh: &'a Render) -> ShadedMesh<'a> {
        let shading = Shading::new(view);
        let colours = mesh
            .coverage
            .ones()
            .map(|i| shading.shade(mesh.albedo[i], mesh.normal[i]))
            .collect();
        ShadedMesh {
            mesh,
            shading,
            colours,
        }
    }

    /// [`compare`] `ori` with the mesh.
    ///
    /// # Panics
    /// If the renders differ in size.
    pub fn compare(&self, ori: &Render) -> ViewErrors {
        let mesh = self.mesh;
        assert_eq!(mesh.size, ori.size, "renders of different sizes");
        let (mut union, mut both) = (0u32, 0u32);
        let (mut dif, mut depth) = (0u64, 0.0f64);
        let mut colours = self.colours.iter();
        let words = mesh.coverage.words().iter().zip(ori.coverage.words());
        for (w, (&m_word, &o_word)) in words.enumerate() {
            let mut either = m_word | o_word;
            while either != 0 {
                let bit = either.trailing_zeros() as usize;
                either &= either - 1;
                let i = w * 64 + bit;
                let (m, o) = (m_word >> bit & 1 != 0, o_word >> bit & 1 != 0);
                union += 1;
                let cm = match m {
                    true => *colours.next().expect("a colour per covered pixel"),
                    false => [0; 3],
                };
                let co = match o {
                    true => self.shading.shade(ori.albedo[i], ori.normal[i]),
                    false => [0; 3],
                };
                dif += (0..3)
                    .map(|k| u64::from(cm[k].abs_diff(co[k])))
                    .sum::<u64>();
                if m && o {
                    both += 1;
                    depth += f64::from((mesh.depth[i] - ori.depth[i]).abs());
                }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn xorshift(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    #[test]
    fn encoding_counts_the_thresholds_as_a_binary_search() {
        let t = tables();
        let search = |lin: f64| t.thresholds.partition_point(|&th| th <= lin) as u8;
        let mut values = vec![0.0, -0.0, -1.0, 1.0, 2.0, f64::NAN, f64::INFINITY];
        values.push(f64::NEG_INFINITY);
        for &th in &t.thresholds {
            values.extend([th, th.next_down(), th.next_up()]);
        }
        for j in 0..=STEPS {
            let low = j as f64 / STEPS as f64;
            values.extend([low, low.next_down(), low.next_up()]);
        }
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..100_000 {
            values.push((xorshift(&mut state) >> 11) as f64 / (1u64 << 53) as f64 * 1.2);
        }
        for lin in values {
            assert_eq!(t.encode(lin), search(lin), "at {lin}");
        }
    }

    #[test]
    fn a_shaded_mesh_compares_as_a_single_comparison() {
        let view = OrthoView::fit(
            ori_raster::Frame::from_direction([0.3, -0.5, 0.8]),
            &[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]],
            32,
            0,
        )
        .unwrap();
        let render = |seed: u64| {
            let mut r = Render::empty(32);
            let mut state = seed;
            for i in 0..32 * 32 {
                let bits = xorshift(&mut state);
                if !bits.is_multiple_of(3) {
                    r.coverage.set(i);
                    r.depth[i] = (bits % 1000) as f32 / 1000.0;
                    r.albedo[i] = [(bits >> 8) as u8, (bits >> 16) as u8, (bits >> 24) as u8];
                    let n = [(bits >> 32) as u8, (bits >> 40) as u8, 128]
                        .map(|c| f32::from(c) / 128.0 - 1.0);
                    r.normal[i] = n;
                }
            }
            r
        };
        let mesh = render(7);
        let shaded = ShadedMesh::new(&view, &mesh);
        for seed in [1, 2, 3] {
            let ori = render(seed);
            let direct = {
                // The definition, pixel by pixel.
                let shading = Shading::new(&view);
                let (mut union, mut dif) = (0u32, 0u64);
                for i in 0..32 * 32 {
                    let (m, o) = (mesh.coverage.get(i), ori.coverage.get(i));
                    if m || o {
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
                    }
                }
                dif as f64 / f64::from(union)
            };
            let errors = shaded.compare(&ori);
            assert_eq!(errors, compare(&view, &mesh, &ori));
            assert_eq!(errors.p_dif, direct);
            assert!(errors.p_dif > 0.0 && errors.depth_error > 0.0);
        }
    }
}
