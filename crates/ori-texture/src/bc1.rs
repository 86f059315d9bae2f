//! BC1 encoder: 4-colour blocks, optionally mask-aware.
//!
//! Every candidate pair of quantised endpoints is scored exactly under the decode model of
//! [`crate::decode`]: the four palette colours lie evenly on the segment between the two
//! expanded endpoints, so a texel's nearest colour is its projection on that segment rounded
//! to thirds, and the block error is a sum of squared RGB distances (8-bit units) weighted by
//! the texel's weight: 1 for texels that count, 0 for padding and masked-out texels.
//!
//! - [`Quality::Fast`]: principal axis (power iteration on the covariance), endpoints at the
//!   extreme projections, then one least-squares refit of the endpoints to the selectors.
//! - [`Quality::High`]: least-squares refits until the error stops falling, then a descent
//!   over the quantised endpoints (one 565 step of a component of one endpoint, or of a
//!   channel of both), guided by the exact quadratic model of the error for fixed selectors
//!   and confirmed by exact scoring, so selector changes count too.
//! - Blocks whose counted texels share one colour use an exact per-channel table.

use std::sync::OnceLock;

use rayon::prelude::*;

use crate::image::block_texels;
use crate::lanes::F4;
use crate::{Quality, RgbaImage, TextureError, blocks_along};

/// Encodes an RGB(A) image as BC1 (8 bytes per 4x4 block, blocks row-major); alpha is
/// ignored. With `mask` (one entry per texel, `false` = empty), empty texels do not count
/// in the endpoint fit and may take any colour; a block with no non-empty texel is encoded
/// as if unmasked, so colour dilated into empty texels survives for filtering.
pub fn encode_bc1(
    image: &RgbaImage,
    mask: Option<&[bool]>,
    quality: Quality,
) -> Result<Vec<u8>, TextureError> {
    let (width, height) = (image.width(), image.height());
    if let Some(m) = mask
        && m.len() != width as usize * height as usize
    {
        return Err(TextureError::InvalidInput(format!(
            "mask has {} entries for {width} x {height} texels",
            m.len()
        )));
    }
    let bw = blocks_along(width) as usize;
    let bh = blocks_along(height) as usize;
    let mut out = vec![0u8; bw * bh * 8];
    let data = image.data();
    out.par_chunks_mut(bw * 8)
        .enumerate()
        .for_each(|(by, row)| {
            for (bx, dst) in row.chunks_exact_mut(8).enumerate() {
                let (index, inside) = block_texels(bx as u32, by as u32, width, height);
                let mut texels = Texels::default();
                let mut any = false;
                for k in 0..16 {
                    let p = index[k] * 4;
                    for c in 0..3 {
                        texels.c[c][k] = f32::from(data[p + c]);
                    }
                    let counts = inside[k] && mask.is_none_or(|m| m[index[k]]);
                    texels.w[k] = if counts { 1.0 } else { 0.0 };
                    any |= counts;
                }
                if !any {
                    for k in 0..16 {
                        texels.w[k] = if inside[k] { 1.0 } else { 0.0 };
                    }
                }
                dst.copy_from_slice(&encode_block(&texels, quality));
            }
        });
    Ok(out)
}

/// One block in structure-of-arrays form: colour channels in 8-bit units and weights.
#[derive(Clone, Copy, Default)]
struct Texels {
    c: [[f32; 16]; 3],
    w: [f32; 16],
}

/// Quantised endpoints: (r5, g6, b5) each.
type Endpoints = [[i32; 3]; 2];

/// Largest quantised value per channel.
const MAX_Q: [i32; 3] = [31, 63, 31];

/// The colour, in 8-bit units, of quantised channel value `q` of channel `c`.
#[inline]
fn expand(q: i32, c: usize) -> f32 {
    q as f32 * (255.0 / MAX_Q[c] as f32)
}

#[inline]
fn expand3(q: [i32; 3]) -> [f32; 3] {
    [expand(q[0], 0), expand(q[1], 1), expand(q[2], 2)]
}

/// The nearest quantised value to a colour channel in 8-bit units.
#[inline]
fn quantise(v: f32, c: usize) -> i32 {
    let scaled = v.clamp(0.0, 255.0) * (MAX_Q[c] as f32 / 255.0);
    (scaled + 0.5) as i32
}

#[inline]
fn quantise3(v: [f32; 3]) -> [i32; 3] {
    [quantise(v[0], 0), quantise(v[1], 1), quantise(v[2], 2)]
}

/// Sum of 16 values in a fixed order that vectorises (four lanes, then pairs).
#[inline]
pub(crate) fn sum16(e: &[f32; 16]) -> f32 {
    let mut acc = [0.0f32; 4];
    for j in 0..4 {
        for l in 0..4 {
            acc[l] += e[j * 4 + l];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Rounds a non-negative value below 2^23 to the nearest integer (ties to even) with plain
/// IEEE additions, which vectorise on every x86-64 and give the same result everywhere.
#[inline]
pub(crate) fn round_small(x: f32) -> f32 {
    const MAGIC: f32 = 8_388_608.0;
    (x + MAGIC) - MAGIC
}

/// A block ready for scoring: colours centred on their weighted mean (which keeps the
/// expanded error formula below well conditioned in `f32`), and the sums it needs.
struct Prepared {
    /// Colour minus `mean`, per channel.
    x: [[f32; 16]; 3],
    w: [f32; 16],
    mean: [f32; 3],
    /// Sum of weights.
    wsum: f32,
    /// Weighted sum of the centred colours (zero up to rounding).
    sx: [f32; 3],
    /// Weighted sum of squared centred colours.
    sxx: f32,
}

impl Prepared {
    fn new(t: &Texels) -> Prepared {
        let wsum = sum16(&t.w);
        let mut mean = [0.0f32; 3];
        let mut x = [[0.0f32; 16]; 3];
        let mut sx = [0.0f32; 3];
        let mut sq = [0.0f32; 16];
        for c in 0..3 {
            let mut wx = [0.0f32; 16];
            for i in 0..16 {
                wx[i] = t.w[i] * t.c[c][i];
            }
            mean[c] = sum16(&wx) / wsum;
            for i in 0..16 {
                x[c][i] = t.c[c][i] - mean[c];
                wx[i] = t.w[i] * x[c][i];
                sq[i] += wx[i] * x[c][i];
            }
            sx[c] = sum16(&wx);
        }
        Prepared {
            x,
            w: t.w,
            mean,
            wsum,
            sx,
            sxx: sum16(&sq),
        }
    }

    /// Expanded endpoints relative to the mean, their difference and its squared length.
    #[inline]
    fn segment(&self, q: &Endpoints) -> ([f32; 3], [f32; 3], f32) {
        let a = expand3(q[0]);
        let b = expand3(q[1]);
        let e0 = [
            a[0] - self.mean[0],
            a[1] - self.mean[1],
            a[2] - self.mean[2],
        ];
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        (e0, d, d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    }

    /// Palette position (0..=3, in thirds from `q[0]` to `q[1]`) of each texel's nearest
    /// colour.
    #[inline]
    fn selectors(&self, q: &Endpoints) -> [f32; 16] {
        let (e0, d, dd) = self.segment(q);
        let s = if dd > 0.0 { 3.0 / dd } else { 0.0 };
        let c0 = e0[0] * d[0] + e0[1] * d[1] + e0[2] * d[2];
        std::array::from_fn(|i| {
            let p = self.x[0][i] * d[0] + self.x[1][i] * d[1] + self.x[2][i] * d[2] - c0;
            round_small((p * s).clamp(0.0, 3.0))
        })
    }

    /// Weighted squared error (8-bit units) under endpoints `q`, each texel on its nearest
    /// palette colour, and the quadratic model of how it changes when the endpoints move
    /// while every texel keeps its selector. The error is expanded as
    /// `|x - e0|^2 - 2 f (x - e0).d + f^2 |d|^2` with `f = k / 3`, so the per-texel work is
    /// one dot product, the rounding of `k` and a few sums.
    #[inline]
    fn error_model(&self, q: &Endpoints) -> (f32, Model) {
        let (e0, d, dd) = self.segment(q);
        let s = if dd > 0.0 { 3.0 / dd } else { 0.0 };
        let c0 = e0[0] * d[0] + e0[1] * d[1] + e0[2] * d[2];
        let (d0, d1, d2) = (F4::splat(d[0]), F4::splat(d[1]), F4::splat(d[2]));
        let (c0, s) = (F4::splat(c0), F4::splat(s));
        let zero = F4::splat(0.0);
        let (mut kp, mut kk, mut sk) = (zero, zero, zero);
        let mut kx = [zero; 3];
        for j in 0..4 {
            let x = [
                F4::load(&self.x[0], j),
                F4::load(&self.x[1], j),
                F4::load(&self.x[2], j),
            ];
            let p = x[0] * d0 + x[1] * d1 + x[2] * d2 - c0;
            let k = (p * s).clamp(0.0, 3.0).round_small();
            let wk = F4::load(&self.w, j) * k;
            kp = kp + wk * p;
            kk = kk + wk * k;
            sk = sk + wk;
            for c in 0..3 {
                kx[c] = kx[c] + wk * x[c];
            }
        }
        let (skp, skk) = (kp.sum(), kk.sum());
        let e0x = e0[0] * self.sx[0] + e0[1] * self.sx[1] + e0[2] * self.sx[2];
        let e0e0 = e0[0] * e0[0] + e0[1] * e0[1] + e0[2] * e0[2];
        let err = (self.sxx - 2.0 * e0x + self.wsum * e0e0) - (2.0 / 3.0) * skp + (dd / 9.0) * skk;
        // With f = k / 3 per texel and residual r = e0 + f d - x:
        let (sf, sff) = (sk.sum() / 3.0, skk / 9.0);
        let mut g = [[0.0f32; 3]; 2];
        for c in 0..3 {
            let sr = self.wsum * e0[c] + d[c] * sf - self.sx[c]; // sum w r
            let sfr = e0[c] * sf + d[c] * sff - kx[c].sum() / 3.0; // sum w f r
            g[0][c] = sr - sfr; // sum w (1 - f) r
            g[1][c] = sfr;
        }
        let model = Model {
            g,
            aa: self.wsum - 2.0 * sf + sff,
            ab: sf - sff,
            bb: sff,
            sfx: std::array::from_fn(|c| kx[c].sum() / 3.0),
        };
        (err, model)
    }

    /// Endpoints from the principal axis: the extreme projections of the counted texels.
    fn principal_endpoints(&self) -> [[f32; 3]; 2] {
        // Covariance (upper triangle: rr, rg, rb, gg, gb, bb).
        let pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
        let mut cov = [0.0f32; 6];
        for (n, &(a, b)) in pairs.iter().enumerate() {
            let mut p = [0.0f32; 16];
            for i in 0..16 {
                p[i] = self.w[i] * self.x[a][i] * self.x[b][i];
            }
            cov[n] = sum16(&p);
        }
        let trace = cov[0] + cov[3] + cov[5];
        if trace <= 0.0 {
            return [self.mean, self.mean];
        }
        // Scaled by the trace, the largest eigenvalue lies in [1/3, 1]: iterating needs no
        // renormalisation and stays far from overflow and underflow.
        let inv = 1.0 / trace;
        let m = [
            [cov[0] * inv, cov[1] * inv, cov[2] * inv],
            [cov[1] * inv, cov[3] * inv, cov[4] * inv],
            [cov[2] * inv, cov[4] * inv, cov[5] * inv],
        ];
        // Start from the column of the largest variance.
        let start = if cov[0] >= cov[3] && cov[0] >= cov[5] {
            0
        } else if cov[3] >= cov[5] {
            1
        } else {
            2
        };
        let mut v = m[start];
        for _ in 0..POWER_ITERATIONS {
            v = [
                m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
                m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
                m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
            ];
        }
        let vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        if vv <= 0.0 || !vv.is_finite() {
            return [self.mean, self.mean];
        }
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for i in 0..16 {
            if self.w[i] > 0.0 {
                let p = self.x[0][i] * v[0] + self.x[1][i] * v[1] + self.x[2][i] * v[2];
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        let (lo, hi) = (lo / vv, hi / vv);
        let at = |s: f32| {
            [
                self.mean[0] + s * v[0],
                self.mean[1] + s * v[1],
                self.mean[2] + s * v[2],
            ]
        };
        [at(lo), at(hi)]
    }
}

/// Power iterations for the principal axis; blocks are small and nearly one-dimensional,
/// so a few suffice.
const POWER_ITERATIONS: usize = 4;

/// Best endpoint pair for a block whose counted texels all have colour `rgb`: per channel
/// the pair whose one-third interpolant is nearest (tables built once, exact to the model).
fn single_colour(rgb: [u8; 3]) -> Endpoints {
    let tables = single_colour_tables();
    let mut q = [[0i32; 3]; 2];
    for c in 0..3 {
        let (a, b) = tables[usize::from(c == 1)][usize::from(rgb[c])];
        q[0][c] = i32::from(a);
        q[1][c] = i32::from(b);
    }
    q
}

/// For 5- and 6-bit channels and every byte value: endpoints (a, b) minimising the distance
/// of `(2a + b) / 3` (expanded) to the value.
fn single_colour_tables() -> &'static [[(u8, u8); 256]; 2] {
    static TABLES: OnceLock<[[(u8, u8); 256]; 2]> = OnceLock::new();
    TABLES.get_or_init(|| {
        let mut tables = [[(0u8, 0u8); 256]; 2];
        for (n, table) in tables.iter_mut().enumerate() {
            let c = if n == 0 { 0 } else { 1 };
            for (v, entry) in table.iter_mut().enumerate() {
                let mut best = f32::INFINITY;
                for a in 0..=MAX_Q[c] {
                    for b in 0..=MAX_Q[c] {
                        let value = (2.0 * expand(a, c) + expand(b, c)) / 3.0;
                        let e = (value - v as f32).abs();
                        if e < best {
                            best = e;
                            *entry = (a as u8, b as u8);
                        }
                    }
                }
            }
        }
        tables
    })
}

/// Encodes one block (at least one texel has a non-zero weight).
fn encode_block(t: &Texels, quality: Quality) -> [u8; 8] {
    let first = (0..16).find(|&i| t.w[i] > 0.0).unwrap_or(0);
    let uniform = (0..16).all(|i| t.w[i] == 0.0 || (0..3).all(|c| t.c[c][i] == t.c[c][first]));
    let p = Prepared::new(t);
    let q = if uniform {
        single_colour(std::array::from_fn(|c| t.c[c][first] as u8))
    } else {
        fit(&p, quality)
    };
    pack(&p, &q)
}

/// Searches endpoints for a block with at least two distinct counted colours.
fn fit(p: &Prepared, quality: Quality) -> Endpoints {
    let axis = p.principal_endpoints();
    let mut q = [quantise3(axis[0]), quantise3(axis[1])];
    let (mut err, mut model) = p.error_model(&q);
    let refits = match quality {
        Quality::Fast => 1,
        Quality::High => 8,
    };
    for _ in 0..refits {
        let Some(e) = model.least_squares(p) else {
            break;
        };
        let next = [quantise3(e[0]), quantise3(e[1])];
        if next == q {
            break;
        }
        let (next_err, next_model) = p.error_model(&next);
        if next_err >= err {
            break;
        }
        (q, err, model) = (next, next_err, next_model);
    }
    if quality == Quality::High {
        descend(p, &mut q, err, model);
    }
    q
}

/// The block error as a quadratic function of endpoint moves with fixed selectors:
/// moving endpoint 0 by `u` and endpoint 1 by `v` (8-bit units, per channel) changes it by
/// `sum_c 2 (g0 u + g1 v) + aa u^2 + 2 ab u v + bb v^2`. Re-choosing selectors afterwards
/// can only lower the error, so a move this predicts to help is sure to.
struct Model {
    /// Gradient halves: `sum w (1 - f) r` and `sum w f r` per channel.
    g: [[f32; 3]; 2],
    /// `sum w (1 - f)^2`, `sum w (1 - f) f`, `sum w f^2`.
    aa: f32,
    ab: f32,
    bb: f32,
    /// `sum w f x` per channel (colours centred on the mean).
    sfx: [f32; 3],
}

impl Model {
    /// Least-squares endpoints (unquantised) for the model's selectors, or `None` when they
    /// do not determine two endpoints (all texels on one palette entry).
    fn least_squares(&self, p: &Prepared) -> Option<[[f32; 3]; 2]> {
        let det = self.aa * self.bb - self.ab * self.ab;
        // Relative threshold: the selectors must span at least two palette entries.
        let scale = self.aa + self.bb;
        if det <= 1e-4 * scale * scale || det <= 0.0 {
            return None;
        }
        let inv = 1.0 / det;
        let mut e = [[0.0f32; 3]; 2];
        for c in 0..3 {
            // sum w (1 - f) x and sum w f x.
            let (ax, bx) = (p.sx[c] - self.sfx[c], self.sfx[c]);
            e[0][c] = p.mean[c] + (self.bb * ax - self.ab * bx) * inv;
            e[1][c] = p.mean[c] + (self.aa * bx - self.ab * ax) * inv;
        }
        Some(e)
    }

    /// Predicted change of the error for moving channel `c` by `m` quantisation steps.
    fn change(&self, c: usize, m: [i32; 2]) -> f32 {
        let step = 255.0 / MAX_Q[c] as f32;
        let (u, v) = (m[0] as f32 * step, m[1] as f32 * step);
        2.0 * (self.g[0][c] * u + self.g[1][c] * v)
            + self.aa * u * u
            + 2.0 * self.ab * u * v
            + self.bb * v * v
    }
}

/// Model-guided descent over the quantised endpoints (one 565 step of one component of one
/// endpoint, or of one channel of both). While the fixed-selector model predicts a gain, its
/// best move is a sure gain: take it (one evaluation). Otherwise evaluate the few moves it
/// predicts least harmful, which only re-chosen selectors can make pay; stop when none does.
fn descend(p: &Prepared, q: &mut Endpoints, mut err: f32, mut model: Model) {
    /// Moves evaluated when the model predicts no gain (more: slower, slightly better).
    const TRIES: usize = 4;
    for _ in 0..32 {
        let mut ranked = [(f32::INFINITY, 0usize, [0i32; 2]); 18];
        let mut n = 0;
        for c in 0..3 {
            for step in [-1, 1] {
                for m in [[step, 0], [0, step], [step, step]] {
                    if (0..2).all(|e| (0..=MAX_Q[c]).contains(&(q[e][c] + m[e]))) {
                        ranked[n] = (model.change(c, m), c, m);
                        n += 1;
                    }
                }
            }
        }
        let ranked = &mut ranked[..n];
        // Stable sort on a total order: the same ranking on every machine.
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        let tries = if ranked.first().is_some_and(|r| r.0 < 0.0) {
            1
        } else {
            TRIES
        };
        let mut moved = false;
        for &(_, c, m) in ranked.iter().take(tries) {
            let mut next = *q;
            next[0][c] += m[0];
            next[1][c] += m[1];
            let (next_err, next_model) = p.error_model(&next);
            if next_err < err {
                (*q, err, model) = (next, next_err, next_model);
                moved = true;
                break;
            }
        }
        if !moved {
            break;
        }
    }
}

/// Packs endpoints and each texel's nearest palette entry into a 4-colour block.
fn pack(p: &Prepared, q: &Endpoints) -> [u8; 8] {
    let word = |e: [i32; 3]| ((e[0] << 11) | (e[1] << 5) | e[2]) as u16;
    let (mut w0, mut w1) = (word(q[0]), word(q[1]));
    let mut k = p.selectors(q);
    if w0 < w1 {
        // The 4-colour mode needs c0 > c1: swap the endpoints and mirror the positions.
        std::mem::swap(&mut w0, &mut w1);
        for v in &mut k {
            *v = 3.0 - *v;
        }
    }
    let mut bits = 0u32;
    if w0 != w1 {
        // Position along the segment (thirds from c0) to the BC1 code.
        const CODE: [u32; 4] = [0, 2, 3, 1];
        for (i, &v) in k.iter().enumerate() {
            bits |= CODE[v as usize] << (2 * i);
        }
    }
    // Equal words mean 3-colour mode; every texel then takes code 0 (= c0 = c1).
    let mut out = [0u8; 8];
    out[0..2].copy_from_slice(&w0.to_le_bytes());
    out[2..4].copy_from_slice(&w1.to_le_bytes());
    out[4..8].copy_from_slice(&bits.to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode::decode_bc1_block;

    fn block_of(colours: &[[u8; 3]; 16]) -> Texels {
        let mut t = Texels::default();
        for i in 0..16 {
            for c in 0..3 {
                t.c[c][i] = f32::from(colours[i][c]);
            }
            t.w[i] = 1.0;
        }
        t
    }

    #[test]
    fn single_colours_decode_within_half_a_565_step() {
        for v in [0u8, 1, 7, 100, 128, 200, 254, 255] {
            let t = block_of(&[[v, v / 2, 255 - v]; 16]);
            let decoded = decode_bc1_block(&encode_block(&t, Quality::Fast));
            for px in decoded {
                assert!((px[0] * 255.0 - f32::from(v)).abs() <= 1.5, "{v}: {px:?}");
                assert!(
                    (px[1] * 255.0 - f32::from(v / 2)).abs() <= 1.0,
                    "{v}: {px:?}"
                );
                assert_eq!(px[3], 1.0);
            }
        }
    }

    #[test]
    fn two_colour_block_is_exact_when_representable() {
        // Both colours are exact 565 values: the encoder must find them.
        let a = [expand(3, 0) as u8, expand(10, 1) as u8, expand(20, 2) as u8];
        let b = [expand(30, 0) as u8, expand(50, 1) as u8, expand(1, 2) as u8];
        let mut colours = [a; 16];
        for c in colours.iter_mut().skip(7) {
            *c = b;
        }
        for quality in [Quality::Fast, Quality::High] {
            let block = encode_block(&block_of(&colours), quality);
            assert!(
                u16::from_le_bytes([block[0], block[1]]) > u16::from_le_bytes([block[2], block[3]])
            );
            let decoded = decode_bc1_block(&block);
            for (px, want) in decoded.iter().zip(&colours) {
                for c in 0..3 {
                    assert!((px[c] * 255.0 - f32::from(want[c])).abs() < 1.0);
                }
            }
        }
    }

    #[test]
    fn rounding_trick_matches_round_half_even() {
        for x in [0.0f32, 0.49, 0.5, 1.5, 2.5, 2.51, 3.0] {
            assert_eq!(round_small(x), x.round_ties_even());
        }
    }

    #[test]
    fn model_predicts_the_fixed_selector_error() {
        let mut t = Texels::default();
        for i in 0..16 {
            t.c[0][i] = (i * 13 % 200) as f32;
            t.c[1][i] = (i * 7 % 100 + 50) as f32;
            t.c[2][i] = (255 - i * 11) as f32;
            t.w[i] = if i == 5 { 0.0 } else { 1.0 };
        }
        let p = Prepared::new(&t);
        let q: Endpoints = [[5, 20, 30], [25, 40, 10]];
        let (err, model) = p.error_model(&q);
        let k = p.selectors(&q);
        let fixed = |q: &Endpoints| {
            let (a, b) = (expand3(q[0]), expand3(q[1]));
            let mut e = 0.0f64;
            for i in 0..16 {
                for c in 0..3 {
                    let v = a[c] + k[i] / 3.0 * (b[c] - a[c]) - t.c[c][i];
                    e += f64::from(t.w[i] * v * v);
                }
            }
            e
        };
        assert!((f64::from(err) - fixed(&q)).abs() < 0.1);
        for c in 0..3 {
            for m in [[1, 0], [0, 1], [1, 1], [-1, 0], [0, -1], [-1, -1]] {
                let mut moved = q;
                moved[0][c] += m[0];
                moved[1][c] += m[1];
                let predicted = f64::from(err + model.change(c, m));
                assert!((predicted - fixed(&moved)).abs() < 0.1, "{c} {m:?}");
            }
        }
    }
}
