//! Surface attributes at a rasterized sample: base colour (factor x texture x vertex colour,
//! in linear space, texture filtered for minification) and the shading normal.

use ori_mesh::{Mesh, Texture, Wrap};

/// sRGB code -> linear value, from the portable transfer function (same on every machine).
pub(crate) fn srgb_decode_table() -> [f32; 256] {
    std::array::from_fn(|i| ori_math::srgb_to_linear(i as f64 / 255.0) as f32)
}

/// Linear value -> nearest sRGB code (rounding in sRGB space), by binary search over the
/// decision thresholds of the portable transfer function.
pub(crate) struct SrgbEncoder {
    thresholds: [f32; 255],
    /// A first guess per 1/4096 of the linear range, corrected against the thresholds.
    guess: Vec<u8>,
}

const GUESS_STEPS: usize = 4096;

impl SrgbEncoder {
    pub fn new() -> SrgbEncoder {
        let thresholds: [f32; 255] =
            std::array::from_fn(|c| ori_math::srgb_to_linear((c as f64 + 0.5) / 255.0) as f32);
        let guess = (0..=GUESS_STEPS)
            .map(|i| {
                let l = i as f32 / GUESS_STEPS as f32;
                thresholds.partition_point(|&t| t <= l) as u8
            })
            .collect();
        SrgbEncoder { thresholds, guess }
    }

    /// The number of thresholds at or below `linear`: exactly what a binary search gives.
    pub fn encode(&self, linear: f32) -> u8 {
        if linear.is_nan() || linear <= 0.0 {
            return 0;
        }
        if linear >= 1.0 {
            return 255;
        }
        let mut code = self.guess[(linear * GUESS_STEPS as f32) as usize] as usize;
        while code < 255 && self.thresholds[code] <= linear {
            code += 1;
        }
        while code > 0 && self.thresholds[code - 1] > linear {
            code -= 1;
        }
        code as u8
    }
}

/// One level of a texture's mip chain, linear RGBA.
struct Level {
    width: usize,
    height: usize,
    texels: Vec<[f32; 4]>,
}

/// A base-colour texture as a mip chain in linear space (alpha stays linear).
pub(crate) struct MipChain {
    levels: Vec<Level>,
    wrap_s: Wrap,
    wrap_t: Wrap,
}

impl MipChain {
    pub fn new(texture: &Texture, decode: &[f32; 256]) -> MipChain {
        let mut levels = vec![Level {
            width: texture.width as usize,
            height: texture.height as usize,
            texels: texture
                .rgba8
                .chunks_exact(4)
                .map(|p| {
                    [
                        decode[p[0] as usize],
                        decode[p[1] as usize],
                        decode[p[2] as usize],
                        f32::from(p[3]) / 255.0,
                    ]
                })
                .collect(),
        }];
        while let Some(last) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
            let (w, h) = (last.width.div_ceil(2), last.height.div_ceil(2));
            let mut texels = Vec::with_capacity(w * h);
            for y in 0..h {
                for x in 0..w {
                    let mut sum = [0.0f32; 4];
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let sx = (2 * x + dx).min(last.width - 1);
                        let sy = (2 * y + dy).min(last.height - 1);
                        let t = last.texels[sy * last.width + sx];
                        for k in 0..4 {
                            sum[k] += t[k];
                        }
                    }
                    texels.push(sum.map(|s| s * 0.25));
                }
            }
            levels.push(Level {
                width: w,
                height: h,
                texels,
            });
        }
        MipChain {
            levels,
            wrap_s: texture.wrap_s,
            wrap_t: texture.wrap_t,
        }
    }

    /// Texels of level 0 per unit of UV area.
    pub fn texel_density(&self) -> f64 {
        (self.levels[0].width * self.levels[0].height) as f64
    }

    /// The level whose texels are about one sample wide, given texels of level 0 per sample
    /// area (`ratio`). Nearest level, chosen by comparing with powers of 4 (no logarithm).
    pub fn level_for(&self, ratio: f64) -> usize {
        let mut level = 0;
        // Level l is right while ratio < 4^l * 2 (the geometric midpoint between levels).
        let mut bound = 2.0;
        while ratio >= bound && level + 1 < self.levels.len() {
            level += 1;
            bound *= 4.0;
        }
        level
    }

    /// Bilinear sample of `level` at `uv` (glTF convention, v down the image).
    pub fn sample(&self, level: usize, uv: [f32; 2]) -> [f32; 4] {
        let l = &self.levels[level];
        let x = uv[0] * l.width as f32 - 0.5;
        let y = uv[1] * l.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return l.texels[0];
        }
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = (x - fx, y - fy);
        let (ix, iy) = (fx as i64, fy as i64);
        let at = |i: i64, j: i64| {
            let i = wrap(i, l.width, self.wrap_s);
            let j = wrap(j, l.height, self.wrap_t);
            l.texels[j * l.width + i]
        };
        let (a, b, c, d) = (
            at(ix, iy),
            at(ix + 1, iy),
            at(ix, iy + 1),
            at(ix + 1, iy + 1),
        );
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * tx;
            let bottom = c[k] + (d[k] - c[k]) * tx;
            top + (bottom - top) * ty
        })
    }
}

fn wrap(i: i64, n: usize, mode: Wrap) -> usize {
    let n = n as i64;
    let r = match mode {
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::MirroredRepeat => {
            let p = i.rem_euclid(2 * n);
            if p < n { p } else { 2 * n - 1 - p }
        }
    };
    r as usize
}

/// A mesh's base-colour textures, decoded to linear and mipmapped once for every bake of the
/// mesh, or of another with the same materials (a part of it).
pub struct Textures {
    /// Per texture of the mesh; `None` for those no material reads as its base colour.
    mips: Vec<Option<MipChain>>,
}

impl Textures {
    pub fn new(mesh: &Mesh) -> Textures {
        let decode = srgb_decode_table();
        let used: Vec<bool> = (0..mesh.textures.len())
            .map(|t| {
                mesh.materials
                    .iter()
                    .any(|m| m.base_color_texture == Some(t as u32))
            })
            .collect();
        Textures {
            mips: mesh
                .textures
                .iter()
                .zip(used)
                .map(|(t, used)| used.then(|| MipChain::new(t, &decode)))
                .collect(),
        }
    }

    /// The mip chain of texture `t`, when a material reads it as its base colour.
    pub(crate) fn mips(&self, t: u32) -> Option<&MipChain> {
        self.mips.get(t as usize)?.as_ref()
    }
}

/// Everything needed to shade samples of one mesh.
pub(crate) struct Shader<'m> {
    pub mesh: &'m Mesh,
    pub textures: &'m Textures,
}

impl<'m> Shader<'m> {
    fn uv(&self, tri: u32, bary: [f32; 3]) -> [f32; 2] {
        match &self.mesh.uvs {
            Some(uvs) => {
                let t = self.mesh.triangles[tri as usize];
                let mut uv = [0.0f32; 2];
                for k in 0..3 {
                    let c = uvs[t[k] as usize];
                    uv[0] += bary[k] * c[0];
                    uv[1] += bary[k] * c[1];
                }
                uv
            }
            None => [0.0; 2],
        }
    }

    /// Linear RGBA base colour of triangle `tri` at `bary`, the texture read at `level`.
    pub fn base_color(&self, tri: u32, bary: [f32; 3], level: usize) -> [f32; 4] {
        let material = &self.mesh.materials[self.mesh.triangle_materials[tri as usize] as usize];
        let mut c = material.base_color_factor;
        if let Some(mip) = material
            .base_color_texture
            .and_then(|t| self.textures.mips(t))
        {
            let s = mip.sample(level.min(mip.levels.len() - 1), self.uv(tri, bary));
            for k in 0..4 {
                c[k] *= s[k];
            }
        }
        if let Some(colors) = &self.mesh.colors {
            let t = self.mesh.triangles[tri as usize];
            let mut v = [0.0f32; 4];
            for k in 0..3 {
                let col = colors[t[k] as usize];
                for ch in 0..4 {
                    v[ch] += bary[k] * col[ch];
                }
            }
            for k in 0..4 {
                c[k] *= v[k];
            }
        }
        c.map(|x| {
            if x.is_finite() {
                x.clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
    }

    /// Whether an alpha-tested (MASK) sample is kept: alpha from level 0, so holes stay sharp.
    pub fn alpha_keeps(&self, tri: u32, bary: [f32; 3]) -> bool {
        let material = &self.mesh.materials[self.mesh.triangle_materials[tri as usize] as usize];
        self.base_color(tri, bary, 0)[3] >= material.alpha_cutoff
    }

    /// Texels of level 0 per unit UV area for the triangle's texture, times the triangle's UV
    /// area: divide by its area in samples to get the minification ratio.
    pub fn texel_area(&self, tri: u32) -> Option<f64> {
        let material = &self.mesh.materials[self.mesh.triangle_materials[tri as usize] as usize];
        let t = material.base_color_texture?;
        let uvs = self.mesh.uvs.as_ref()?;
        let [a, b, c] = self.mesh.triangles[tri as usize].map(|i| uvs[i as usize].map(f64::from));
        let area = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs();
        Some(area * self.textures.mips(t)?.texel_density())
    }

    /// Unit shading normal at the sample, turned to the side of the surface the viewer sees.
    pub fn normal(&self, tri: u32, bary: [f32; 3], toward_viewer: [f64; 3]) -> [f64; 3] {
        let t = self.mesh.triangles[tri as usize];
        let mut g = ori_mesh::face_normal(&self.mesh.positions, t);
        if dot(g, toward_viewer) < 0.0 {
            g = g.map(|x| -x); // the back of the face is what is seen
        }
        let mut n = [0.0f64; 3];
        for k in 0..3 {
            let vn = self.mesh.normals[t[k] as usize];
            for c in 0..3 {
                n[c] += f64::from(bary[k]) * f64::from(vn[c]);
            }
        }
        // Shading normals pointing into the seen side (inverted normals, back faces of
        // double-sided cards) are flipped to it.
        if dot(n, g) < 0.0 {
            n = n.map(|x| -x);
        }
        let len = dot(n, n).sqrt();
        if len > 0.0 && len.is_finite() {
            n.map(|x| x / len)
        } else {
            let gl = dot(g, g).sqrt();
            if gl > 0.0 {
                g.map(|x| x / gl)
            } else {
                toward_viewer
            }
        }
    }
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoder_inverts_the_decoder() {
        let decode = srgb_decode_table();
        let enc = SrgbEncoder::new();
        for c in 0..=255u8 {
            assert_eq!(enc.encode(decode[c as usize]), c);
        }
        assert_eq!(enc.encode(-1.0), 0);
        assert_eq!(enc.encode(2.0), 255);
        assert_eq!(enc.encode(f32::NAN), 0);
        for i in 0..=100_000 {
            let l = i as f32 / 100_000.0;
            assert_eq!(
                enc.encode(l) as usize,
                enc.thresholds.partition_point(|&t| t <= l)
            );
        }
    }

    #[test]
    fn wrap_modes() {
        assert_eq!(wrap(-1, 4, Wrap::Repeat), 3);
        assert_eq!(wrap(-1, 4, Wrap::MirroredRepeat), 0);
        assert_eq!(wrap(5, 4, Wrap::MirroredRepeat), 2);
        assert_eq!(wrap(9, 4, Wrap::ClampToEdge), 3);
    }
}
