//! Octahedral impostors as engines draw them today (Unreal's ImpostorBaker, Amplify
//! Impostors, Godot's octahedral impostors): an N x N grid of frames whose directions are the
//! grid points of an octahedral map of the sphere (or of the upper hemisphere), each frame an
//! orthographic image with depth. A view draws one quad facing the camera through the
//! bounding sphere's centre; each pixel blends the three frames of the grid triangle that
//! holds the view direction (barycentric weights), reading each frame at the pixel's point on
//! the quad moved once along the view ray to the depth that frame stores there (the per-frame
//! depth offset for parallax). The blended coverage is alpha-tested at one half.

use ori_bake::BakeParams;
use ori_eval::Render;
use ori_mesh::Mesh;
use ori_raster::{OrthoView, dot};
use ori_relief::ReliefMap;

use crate::billboard::{
    PixelBox, PlaneHits, surface_height, texel_at, window_pixels, world_normal,
};
use crate::{Drawn, Primitive, Rival, RivalError, Technique, relief_bytes, within_budget};

/// Which directions the frames cover.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sphere {
    /// All directions (`octahedral`).
    Full,
    /// Directions with `y >= 0` (`hemi-octahedral`, for objects never seen from below).
    Upper,
}

/// Sign with `sign(0) = 1`, so that the map is defined everywhere.
fn sign(x: f64) -> f64 {
    if x < 0.0 { -1.0 } else { 1.0 }
}

impl Sphere {
    /// The point in `[-1, 1]^2` of unit direction `w` (+Y up). Below the horizon the upper
    /// hemisphere's map uses the horizontal direction above `w`.
    pub fn encode(self, w: [f64; 3]) -> [f64; 2] {
        let [x, y, z] = w;
        match self {
            Sphere::Full => {
                let s = x.abs() + y.abs() + z.abs();
                let (a, b) = (x / s, z / s);
                if y >= 0.0 {
                    [a, b]
                } else {
                    [(1.0 - b.abs()) * sign(a), (1.0 - a.abs()) * sign(b)]
                }
            }
            Sphere::Upper => {
                let y = y.max(0.0);
                let s = x.abs() + y + z.abs();
                let (a, b) = if s > 0.0 { (x / s, z / s) } else { (1.0, 0.0) };
                [a + b, a - b]
            }
        }
    }

    /// The unit direction of point `uv` of `[-1, 1]^2`.
    pub fn decode(self, uv: [f64; 2]) -> [f64; 3] {
        let (x, y, z) = match self {
            Sphere::Full => {
                let (a, b) = (uv[0], uv[1]);
                let y = 1.0 - a.abs() - b.abs();
                if y >= 0.0 {
                    (a, y, b)
                } else {
                    ((1.0 - b.abs()) * sign(a), y, (1.0 - a.abs()) * sign(b))
                }
            }
            Sphere::Upper => {
                let (a, b) = ((uv[0] + uv[1]) * 0.5, (uv[0] - uv[1]) * 0.5);
                (a, 1.0 - a.abs() - b.abs(), b)
            }
        };
        ori_raster::normalize([x, y, z])
    }
}

/// An octahedral impostor: `frames` x `frames` relief frames.
pub struct Octahedral {
    sphere: Sphere,
    frames: usize,
    resolution: u32,
    /// Row-major: frame (i, j) at index `j * frames + i`; `None` where not baked yet
    /// ([`Octahedral::bake_for`]).
    maps: Vec<Option<ReliefMap>>,
    centre: [f64; 3],
}

/// The grid point (i, j) of an N x N grid in `[-1, 1]^2`, edges included (as the engines lay
/// their frames out).
fn grid_point(i: usize, j: usize, n: usize) -> [f64; 2] {
    let step = 2.0 / (n - 1) as f64;
    [i as f64 * step - 1.0, j as f64 * step - 1.0]
}

impl Octahedral {
    pub fn bake(
        mesh: &Mesh,
        sphere: Sphere,
        frames: usize,
        resolution: u32,
    ) -> Result<Octahedral, RivalError> {
        Octahedral::bake_for(mesh, sphere, frames, resolution, &[])?.complete(mesh)
    }

    /// Only the frames that views along `directions` blend, the others left to
    /// [`Octahedral::complete`]: enough to draw those views, for a fraction of the bake (a
    /// layout is chosen by a hundred tuning views, which blend a third of a fine grid).
    pub fn bake_for(
        mesh: &Mesh,
        sphere: Sphere,
        frames: usize,
        resolution: u32,
        directions: &[[f64; 3]],
    ) -> Result<Octahedral, RivalError> {
        let technique = technique(sphere);
        if !(2..=64).contains(&frames) {
            return Err(RivalError::Bake {
                technique: technique.name(),
                reason: format!("{frames} x {frames} frames: 2 to 64 per side"),
            });
        }
        let mut octahedral = Octahedral {
            sphere,
            frames,
            resolution,
            maps: vec![None; frames * frames],
            centre: crate::bounding_sphere(mesh, technique)?.0,
        };
        let mut blended = vec![false; frames * frames];
        for &w in directions {
            for (k, weight) in octahedral.blend(w) {
                blended[k] |= weight > 0.0;
            }
        }
        octahedral.bake_frames(mesh, &blended)?;
        Ok(octahedral)
    }

    /// Every frame baked.
    pub fn complete(mut self, mesh: &Mesh) -> Result<Octahedral, RivalError> {
        let missing: Vec<bool> = self.maps.iter().map(Option::is_none).collect();
        self.bake_frames(mesh, &missing)?;
        Ok(self)
    }

    /// Bake the frames marked in `wanted` (one flag per frame).
    fn bake_frames(&mut self, mesh: &Mesh, wanted: &[bool]) -> Result<(), RivalError> {
        let n = self.frames;
        let which: Vec<usize> = (0..n * n).filter(|&k| wanted[k]).collect();
        if which.is_empty() {
            return Ok(());
        }
        let directions: Vec<[f64; 3]> = which
            .iter()
            .map(|&k| self.sphere.decode(grid_point(k % n, k / n, n)))
            .collect();
        let params = BakeParams {
            resolution: self.resolution,
            ..BakeParams::default()
        };
        let maps = ori_bake::bake_any_resolution(mesh, &directions, &params)
            .map_err(|e| RivalError::Bake {
                technique: technique(self.sphere).name(),
                reason: e.to_string(),
            })?
            .maps;
        for (k, map) in which.into_iter().zip(maps) {
            self.maps[k] = Some(map);
        }
        Ok(())
    }

    /// The layouts that fit `budget` within 5 %: (frames per side, frame edge) for grids of
    /// 8 to 32 frames a side (multiples of 4, so that any frame edge makes an atlas of whole
    /// 4 x 4 blocks) with frames at least 16 texels wide.
    pub fn layouts(budget: u64) -> Vec<(usize, u32)> {
        [8usize, 12, 16, 24, 32]
            .into_iter()
            .filter_map(|n| {
                let count = (n * n) as u64;
                let r = crate::edge_for(budget, count, 1, relief_bytes)?;
                let bytes = relief_bytes(count * u64::from(r) * u64::from(r));
                (r >= 16 && within_budget(bytes, budget)).then_some((n, r))
            })
            .collect()
    }

    /// The three frames blended for view direction `w` and their weights.
    fn blend(&self, w: [f64; 3]) -> [(usize, f64); 3] {
        let n = self.frames;
        let uv = self.sphere.encode(w);
        let g = uv.map(|c| ((c + 1.0) * 0.5 * (n - 1) as f64).clamp(0.0, (n - 1) as f64));
        let (i, j) = (
            (g[0].floor() as usize).min(n - 2),
            (g[1].floor() as usize).min(n - 2),
        );
        let (fx, fy) = (g[0] - i as f64, g[1] - j as f64);
        let at = |a: usize, b: usize| b * n + a;
        if fx + fy <= 1.0 {
            [
                (at(i, j), 1.0 - fx - fy),
                (at(i + 1, j), fx),
                (at(i, j + 1), fy),
            ]
        } else {
            [
                (at(i + 1, j + 1), fx + fy - 1.0),
                (at(i, j + 1), 1.0 - fx),
                (at(i + 1, j), 1.0 - fy),
            ]
        }
    }
}

fn technique(sphere: Sphere) -> Technique {
    match sphere {
        Sphere::Full => Technique::Octahedral,
        Sphere::Upper => Technique::HemiOctahedral,
    }
}

/// Frames whose direction is this close to the view plane are read without parallax.
const MIN_PARALLAX_COS: f64 = 0.05;

impl Rival for Octahedral {
    fn technique(&self) -> Technique {
        technique(self.sphere)
    }

    fn bytes(&self) -> u64 {
        relief_bytes((self.frames * self.frames) as u64 * u64::from(self.resolution).pow(2))
    }

    fn layout(&self) -> String {
        let r = self.resolution;
        format!("{0} x {0} frames of {r} x {r}", self.frames)
    }

    fn primitive(&self) -> Primitive {
        Primitive::Quads
    }

    fn draw(&self, view: &OrthoView) -> Result<Drawn, RivalError> {
        let w = view.frame.d;
        let frames = self.blend(w);
        let mut render = Render::empty(view.size);
        // Per frame blended: where each pixel's ray meets the plane the lookup starts from
        // (the frame's through the centre, or the quad's where the ray runs along the frame),
        // in texel coordinates, with its heights along the frame's and the view's directions;
        // and how far the texel coordinates move per unit of the parallax step along the ray.
        let mut lookups = Vec::with_capacity(frames.len());
        for &(k, weight) in frames.iter().filter(|&&(_, weight)| weight > 0.0) {
            let Some(map) = &self.maps[k] else {
                return Err(RivalError::Bake {
                    technique: self.technique().name(),
                    reason: format!("frame {k} is drawn but was not baked"),
                });
            };
            let d = map.view.frame.d;
            let wd = dot(w, d);
            let parallax = wd > MIN_PARALLAX_COS;
            let start = if parallax { d } else { w };
            let Some(hits) = PlaneHits::new(view, self.centre, start, |p| {
                let [x, y, _] = map.view.project(p);
                [x, y, dot(p, d), dot(p, w)]
            }) else {
                continue;
            };
            let [wx, wy, _] = map.view.project(w);
            let [ox, oy, _] = map.view.project([0.0; 3]);
            let step = [wx - ox, wy - oy, dot(w, w)];
            lookups.push((map, weight, wd, parallax.then_some(step), hits));
        }
        // Only where a frame's first lookup can find a texel (its window on the plane the
        // lookup starts from); every pixel when a frame is read without parallax.
        let pixels = lookups
            .iter()
            .map(|(map, _, _, parallax, _)| match parallax {
                Some(_) => {
                    window_pixels(view, map, self.centre, PixelBox::whole(map.size() as usize))
                }
                None => PixelBox::whole(view.size as usize),
            })
            .fold(PixelBox::empty(), PixelBox::union);
        for (x, y, i) in pixels.pixels(view.size) {
            let (mut alpha, mut colour, mut normal, mut height) = (0.0, [0.0; 3], [0.0; 3], 0.0);
            for (map, weight, wd, parallax, hits) in &lookups {
                let [tx, ty, along_d, along_w] = hits.at(x, y);
                let Some(t0) = texel_at(map, tx, ty) else {
                    continue;
                };
                // Moved once along the ray to the depth the frame stores there.
                let (t, h) = match parallax {
                    Some([sx, sy, sw]) => {
                        let s = (along_d - surface_height(map, t0)) / wd;
                        match texel_at(map, tx - s * sx, ty - s * sy) {
                            Some(t) => (t, along_w - s * sw),
                            None => continue,
                        }
                    }
                    None => (t0, along_w),
                };
                alpha += weight;
                let nm = world_normal(map, t);
                for c in 0..3 {
                    colour[c] += weight * f64::from(map.albedo[t][c]);
                    normal[c] += weight * f64::from(nm[c]);
                }
                height += weight * h;
            }
            if alpha < 0.5 {
                continue;
            }
            render.coverage.set(i);
            render.depth[i] = view.depth_of_height(height / alpha) as f32;
            render.albedo[i] = colour.map(|c| (c / alpha).round().clamp(0.0, 255.0) as u8);
            let normal = ori_raster::normalize(normal);
            render.normal[i] = normal.map(|c| c as f32);
        }
        Ok(Drawn { render, count: 1 })
    }
}
