//! BC4 encoder (one channel) and BC5 (two BC4 channels, for normal x, y).
//!
//! Both block modes are tried: eight values between the endpoints (`r0 > r1`), and six
//! values plus exact 0 and 255 (`r0 <= r1`), which keeps empty depth (255) and black exact
//! beside a smooth range. Candidates are scored exactly under the float decode model of
//! [`crate::decode`]: the interpolated values are evenly spaced, so a value's nearest entry is
//! its position between the endpoints rounded to sevenths (fifths), compared in the 6-value
//! mode against 0 and 255.
//!
//! - Blocks spanning at most 7 values are exact (unit steps from the lowest).
//! - [`Quality::Fast`]: range of the block, one least-squares refit, one pass over the eight
//!   neighbouring endpoint pairs.
//! - [`Quality::High`]: least-squares refits until the error stops falling, then moves to the
//!   best neighbouring endpoint pair until none is better. For BC5 each texel's error is
//!   weighted by its effect on the angle of the rebuilt normal (`z = sqrt(1 - x^2 - y^2)`),
//!   since that, not the channel PSNR, is what shading sees.

use rayon::prelude::*;

use crate::bc1::{round_small, sum16};
use crate::image::block_texels;
use crate::lanes::F4;
use crate::{Quality, TextureError, blocks_along, check_size};

/// Encodes one 8-bit channel (row-major, `width * height` values) as BC4 UNORM: 8 bytes per
/// 4x4 block, blocks row-major.
pub fn encode_bc4(
    values: &[u8],
    width: u32,
    height: u32,
    quality: Quality,
) -> Result<Vec<u8>, TextureError> {
    check_size(width, height, 1, values.len())?;
    Ok(encode_blocks(width, height, 8, |bx, by, dst| {
        let (index, inside) = block_texels(bx, by, width, height);
        let ch = Channel {
            v: index.map(|i| f32::from(values[i])),
            w: inside.map(|b| if b { 1.0 } else { 0.0 }),
        };
        dst.copy_from_slice(&encode_channel(&ch, quality));
    }))
}

/// Encodes two interleaved 8-bit channels (x, y of a normal map: `width * height` pairs) as
/// BC5 UNORM: 16 bytes per block, the x block then the y block.
///
/// The decoded normal is `x = 2 v / 255 - 1` (same for y), `z = sqrt(1 - x^2 - y^2)`.
pub fn encode_bc5(
    xy: &[u8],
    width: u32,
    height: u32,
    quality: Quality,
) -> Result<Vec<u8>, TextureError> {
    check_size(width, height, 2, xy.len())?;
    Ok(encode_blocks(width, height, 16, |bx, by, dst| {
        let (index, inside) = block_texels(bx, by, width, height);
        let mut x = Channel {
            v: index.map(|i| f32::from(xy[2 * i])),
            w: inside.map(|b| if b { 1.0 } else { 0.0 }),
        };
        let mut y = Channel {
            v: index.map(|i| f32::from(xy[2 * i + 1])),
            w: x.w,
        };
        if quality == Quality::High {
            angular_weights(&mut x, &mut y);
        }
        dst[..8].copy_from_slice(&encode_channel(&x, quality));
        dst[8..].copy_from_slice(&encode_channel(&y, quality));
    }))
}

/// Runs `encode(bx, by, block_bytes)` for every block, in parallel over rows of blocks; the
/// output order (and so the bytes) does not depend on the thread count.
fn encode_blocks(
    width: u32,
    height: u32,
    block_bytes: usize,
    encode: impl Fn(u32, u32, &mut [u8]) + Sync,
) -> Vec<u8> {
    let bw = blocks_along(width) as usize;
    let bh = blocks_along(height) as usize;
    let mut out = vec![0u8; bw * bh * block_bytes];
    out.par_chunks_mut(bw * block_bytes)
        .enumerate()
        .for_each(|(by, row)| {
            for (bx, dst) in row.chunks_exact_mut(block_bytes).enumerate() {
                encode(bx as u32, by as u32, dst);
            }
        });
    out
}

/// Scales each texel's weight by how much an error in that channel turns the normal: with
/// `dz = -(x dx + y dy) / z`, the angle grows as `sqrt(dx^2 + dy^2 + dz^2)`, so an x error
/// counts `1 + x^2 / z^2` times (the cross term is left out to keep the channels separate).
fn angular_weights(x: &mut Channel, y: &mut Channel) {
    for i in 0..16 {
        let nx = x.v[i] * (2.0 / 255.0) - 1.0;
        let ny = y.v[i] * (2.0 / 255.0) - 1.0;
        // Clamp z^2 so texels at the rim (z ~ 0) weigh a lot but stay finite.
        let zz = (1.0 - nx * nx - ny * ny).max(0.04);
        x.w[i] *= 1.0 + nx * nx / zz;
        y.w[i] *= 1.0 + ny * ny / zz;
    }
}

/// One channel of a block: values in 8-bit units and weights (0 for padding).
#[derive(Clone, Copy)]
struct Channel {
    v: [f32; 16],
    w: [f32; 16],
}

/// The block modes.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Mode {
    /// `r0 > r1`: eight values from `lo` to `hi`.
    Eight,
    /// `r0 <= r1`: six values from `lo` to `hi`, and 0 and 255.
    Six,
}

impl Mode {
    /// Intervals between the endpoints.
    fn steps(self) -> f32 {
        match self {
            Mode::Eight => 7.0,
            Mode::Six => 5.0,
        }
    }
}

/// A channel ready for scoring: the squared distance of each value to the nearer of 0 and
/// 255 (what the 6-value mode's extra entries cost) is computed once.
struct Prepared {
    ch: Channel,
    extremes: [f32; 16],
}

impl Prepared {
    fn new(ch: &Channel) -> Prepared {
        Prepared {
            ch: *ch,
            extremes: ch.v.map(|v| {
                let top = 255.0 - v;
                (v * v).min(top * top)
            }),
        }
    }

    /// Weighted squared error with endpoints `lo <= hi` in `mode`, each value taking its
    /// nearest palette entry.
    #[inline]
    fn error(&self, mode: Mode, lo: i32, hi: i32) -> f32 {
        let n = mode.steps();
        let (lo, d) = (lo as f32, (hi - lo) as f32);
        let s = F4::splat(if d > 0.0 { n / d } else { 0.0 });
        let (lo, step) = (F4::splat(lo), F4::splat(d / n));
        let mut acc = F4::splat(0.0);
        for j in 0..4 {
            let v = F4::load(&self.ch.v, j);
            let k = ((v - lo) * s).clamp(0.0, n).round_small();
            let r = v - (lo + k * step);
            let mut e = r * r;
            if mode == Mode::Six {
                e = e.min(F4::load(&self.extremes, j));
            }
            acc = acc + F4::load(&self.ch.w, j) * e;
        }
        acc.sum()
    }
}

/// Palette position of each value: `0..=n` between the endpoints, `-1` for 0 and `-2` for
/// 255 (6-value mode only).
fn positions(ch: &Channel, mode: Mode, lo: i32, hi: i32) -> [i32; 16] {
    let n = mode.steps();
    let (lo, d) = (lo as f32, (hi - lo) as f32);
    let s = if d > 0.0 { n / d } else { 0.0 };
    let step = d / n;
    std::array::from_fn(|i| {
        let v = ch.v[i];
        let k = round_small(((v - lo) * s).clamp(0.0, n));
        let r = v - (lo + k * step);
        if mode == Mode::Six {
            let (e, zero, top) = (r * r, v * v, (255.0 - v) * (255.0 - v));
            if zero < e && zero <= top {
                return -1;
            }
            if top < e && top < zero {
                return -2;
            }
        }
        k as i32
    })
}

/// Least-squares endpoints for fixed positions (values on 0 / 255 left out), rounded and
/// ordered; `None` if fewer than two positions are in use.
fn least_squares(ch: &Channel, mode: Mode, pos: &[i32; 16]) -> Option<(i32, i32)> {
    let n = mode.steps();
    let mut terms = [[0.0f32; 16]; 5];
    for i in 0..16 {
        if pos[i] < 0 {
            continue;
        }
        let b = pos[i] as f32 / n;
        let a = 1.0 - b;
        let w = ch.w[i];
        terms[0][i] = w * a * a;
        terms[1][i] = w * a * b;
        terms[2][i] = w * b * b;
        terms[3][i] = w * a * ch.v[i];
        terms[4][i] = w * b * ch.v[i];
    }
    let [saa, sab, sbb, sax, sbx] = terms.map(|t| sum16(&t));
    let det = saa * sbb - sab * sab;
    if det <= 1e-4 * (saa + sbb) * (saa + sbb) || det <= 0.0 {
        return None;
    }
    let lo = (sbb * sax - sab * sbx) / det;
    let hi = (saa * sbx - sab * sax) / det;
    let lo = round_small(lo.clamp(0.0, 255.0)) as i32;
    let hi = round_small(hi.clamp(0.0, 255.0)) as i32;
    Some((lo.min(hi), lo.max(hi)))
}

/// The best endpoints found so far for one mode.
#[derive(Clone, Copy)]
struct Fit {
    mode: Mode,
    lo: i32,
    hi: i32,
    err: f32,
}

impl Fit {
    fn new(p: &Prepared, mode: Mode, lo: i32, hi: i32) -> Fit {
        Fit {
            mode,
            lo,
            hi,
            err: p.error(mode, lo, hi),
        }
    }

    /// Keeps (lo, hi) if valid for the mode and better; says whether it was kept.
    fn offer(&mut self, p: &Prepared, lo: i32, hi: i32) -> bool {
        let valid = 0 <= lo && lo <= hi && hi <= 255 && (self.mode == Mode::Six || lo < hi);
        if !valid || (lo, hi) == (self.lo, self.hi) {
            return false;
        }
        let err = p.error(self.mode, lo, hi);
        if err < self.err {
            (self.lo, self.hi, self.err) = (lo, hi, err);
            true
        } else {
            false
        }
    }

    /// Least-squares refits until the error stops falling.
    fn refit(&mut self, p: &Prepared, rounds: usize) {
        for _ in 0..rounds {
            let pos = positions(&p.ch, self.mode, self.lo, self.hi);
            match least_squares(&p.ch, self.mode, &pos) {
                Some((lo, hi)) if self.offer(p, lo, hi) => {}
                _ => break,
            }
        }
    }

    /// Tries every pair within one step of the best, recentring while it moves (at most
    /// `rounds` times).
    fn search(&mut self, p: &Prepared, rounds: usize) {
        for _ in 0..rounds {
            let (lo0, hi0) = (self.lo, self.hi);
            let mut moved = false;
            for dl in -1..=1 {
                for dh in -1..=1 {
                    moved |= self.offer(p, lo0 + dl, hi0 + dh);
                }
            }
            if !moved {
                break;
            }
        }
    }
}

/// Encodes one channel of one block (at least one texel has a non-zero weight).
fn encode_channel(ch: &Channel, quality: Quality) -> [u8; 8] {
    let (mut min, mut max) = (255i32, 0i32);
    for i in 0..16 {
        if ch.w[i] > 0.0 {
            min = min.min(ch.v[i] as i32);
            max = max.max(ch.v[i] as i32);
        }
    }
    let p = Prepared::new(ch);
    if max - min <= 7 {
        // Unit steps cover the range exactly: eight values from lo, or (one value) the
        // 6-value mode with both endpoints on it.
        let fit = if min == max {
            Fit::new(&p, Mode::Six, min, max)
        } else {
            let lo = min.min(248);
            Fit::new(&p, Mode::Eight, lo, lo + 7)
        };
        return pack(ch, &fit);
    }
    let high = quality == Quality::High;
    let (refits, rounds) = if high { (8, 16) } else { (1, 1) };
    let mut best = Fit::new(&p, Mode::Eight, min, max);
    best.refit(&p, refits);
    best.search(&p, rounds);

    // The 6-value mode pays off when some values sit at (or near) 0 or 255: fit the
    // interpolated range to the others. `High` also tries leaving out only exact 0 and 255.
    let near = if high { 24 } else { 8 };
    if min <= near || max >= 255 - near {
        let cuts: &[i32] = if high { &[near, 0] } else { &[near] };
        for &cut in cuts {
            let (mut lo, mut hi) = (255i32, 0i32);
            for i in 0..16 {
                let v = ch.v[i] as i32;
                if ch.w[i] > 0.0 && v > cut && v < 255 - cut {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            if lo > hi {
                // Everything is near 0 or 255: let the refit start from the whole range.
                (lo, hi) = (min, max);
            }
            let mut six = Fit::new(&p, Mode::Six, lo, hi);
            six.refit(&p, refits);
            six.search(&p, rounds);
            if six.err < best.err {
                best = six;
            }
        }
    }
    pack(ch, &best)
}

/// Writes the block: endpoints in the order that selects the mode, then 3-bit codes.
fn pack(ch: &Channel, fit: &Fit) -> [u8; 8] {
    let pos = positions(ch, fit.mode, fit.lo, fit.hi);
    let (r0, r1, codes): (i32, i32, [u64; 16]) = match fit.mode {
        // r0 = hi > r1 = lo; position k (sevenths up from lo) is code 1, 7, 6, ..., 2, 0.
        Mode::Eight => {
            const CODE: [u64; 8] = [1, 7, 6, 5, 4, 3, 2, 0];
            (fit.hi, fit.lo, pos.map(|k| CODE[k as usize]))
        }
        // r0 = lo <= r1 = hi; position k (fifths up from lo) is code 0, 2, 3, 4, 5, 1;
        // 0 is code 6 and 255 code 7.
        Mode::Six => {
            const CODE: [u64; 6] = [0, 2, 3, 4, 5, 1];
            let codes = pos.map(|k| match k {
                -1 => 6,
                -2 => 7,
                k => CODE[k as usize],
            });
            (fit.lo, fit.hi, codes)
        }
    };
    let mut bits = 0u64;
    for (i, &c) in codes.iter().enumerate() {
        bits |= c << (3 * i);
    }
    let mut out = [0u8; 8];
    out[0] = r0 as u8;
    out[1] = r1 as u8;
    out[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decode::decode_bc4_block;

    fn channel(values: [u8; 16]) -> Channel {
        Channel {
            v: values.map(f32::from),
            w: [1.0; 16],
        }
    }

    fn max_error(values: [u8; 16], quality: Quality) -> f32 {
        let block = encode_channel(&channel(values), quality);
        let decoded = decode_bc4_block(&block);
        values
            .iter()
            .zip(decoded)
            .map(|(&v, d)| (f32::from(v) - d * 255.0).abs())
            .fold(0.0, f32::max)
    }

    #[test]
    fn eight_evenly_spaced_values_are_exact() {
        let values = std::array::from_fn(|i| (10 + 7 * (i % 8)) as u8);
        for q in [Quality::Fast, Quality::High] {
            assert!(max_error(values, q) < 1e-3, "{q:?}");
        }
    }

    #[test]
    fn empty_depth_stays_exactly_255_beside_a_ramp() {
        let mut values = [255u8; 16];
        for (i, v) in values.iter_mut().enumerate().take(10) {
            *v = 100 + 5 * i as u8;
        }
        for q in [Quality::Fast, Quality::High] {
            let block = encode_channel(&channel(values), q);
            assert!(block[0] <= block[1], "6-value mode expected");
            let decoded = decode_bc4_block(&block);
            for i in 10..16 {
                assert_eq!(decoded[i], 1.0);
            }
            // Six values over 100..=145 are 9 apart: nothing is further than 4.5 from one.
            assert!(max_error(values, q) <= 4.5, "{q:?}");
        }
    }

    #[test]
    fn constant_block_is_exact() {
        for v in [0u8, 1, 128, 254, 255] {
            assert_eq!(max_error([v; 16], Quality::Fast), 0.0);
        }
    }
}
