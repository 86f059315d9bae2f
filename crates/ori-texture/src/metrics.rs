//! Quality figures: PSNR for colour and single channels, and the angular error of rebuilt
//! normals next to the floor that 8-bit storage itself imposes.
//!
//! Decoded values are the `[0, 1]` floats of [`crate::decode`], compared with the 8-bit
//! source in 8-bit units without rounding them first. Angles use `ori_math`, so the figures
//! are the same on every machine.

use crate::RgbaImage;

/// PSNR in dB for a mean squared error in 8-bit units (infinite for a perfect match).
pub fn psnr_from_mse(mse: f64) -> f64 {
    if mse <= 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0 * 255.0 / mse).log10()
    }
}

/// RGB PSNR of decoded texels against the reference, over the texels whose mask entry is
/// `true` (all texels without a mask). Panics if the lengths differ.
pub fn psnr_rgb(reference: &RgbaImage, decoded: &[[f32; 4]], mask: Option<&[bool]>) -> f64 {
    let n = reference.width() as usize * reference.height() as usize;
    assert_eq!(decoded.len(), n, "decoded image has the wrong size");
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for (i, (r, d)) in reference.data().chunks_exact(4).zip(decoded).enumerate() {
        if mask.is_some_and(|m| !m[i]) {
            continue;
        }
        for c in 0..3 {
            let e = f64::from(r[c]) - f64::from(d[c]) * 255.0;
            sum += e * e;
        }
        count += 3;
    }
    psnr_from_mse(if count == 0 { 0.0 } else { sum / count as f64 })
}

/// PSNR of one decoded channel against its 8-bit reference. Panics if the lengths differ.
pub fn psnr_channel(reference: &[u8], decoded: &[f32]) -> f64 {
    assert_eq!(
        decoded.len(),
        reference.len(),
        "decoded image has the wrong size"
    );
    let sum: f64 = reference
        .iter()
        .zip(decoded)
        .map(|(&r, &d)| {
            let e = f64::from(r) - f64::from(d) * 255.0;
            e * e
        })
        .sum();
    psnr_from_mse(sum / reference.len().max(1) as f64)
}

/// Distribution of angles, in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngularStats {
    pub mean: f64,
    /// 99th percentile (to the histogram's resolution of 0.001 degree).
    pub p99: f64,
    pub max: f64,
}

/// The unit normal stored as `x, y` in `[-1, 1]`: `z = sqrt(1 - x^2 - y^2)`, and `(x, y)`
/// scaled back onto the unit circle (z = 0) when it lies outside.
pub fn normal_from_xy(x: f64, y: f64) -> [f64; 3] {
    let r2 = x * x + y * y;
    if r2 > 1.0 {
        let r = r2.sqrt();
        [x / r, y / r, 0.0]
    } else {
        [x, y, (1.0 - r2).sqrt()]
    }
}

/// The normal component an 8-bit UNORM value stands for: `2 v / 255 - 1`.
fn snorm(v: f64) -> f64 {
    v * (2.0 / 255.0) - 1.0
}

/// Angles between the normals rebuilt from the 8-bit reference (x, y interleaved) and from
/// the decoded pairs. Panics if the lengths differ.
pub fn normal_angular_error(reference_xy: &[u8], decoded: &[[f32; 2]]) -> AngularStats {
    assert_eq!(
        reference_xy.len(),
        decoded.len() * 2,
        "decoded image has the wrong size"
    );
    let mut hist = Histogram::new();
    for (r, d) in reference_xy.chunks_exact(2).zip(decoded) {
        let a = normal_from_xy(snorm(f64::from(r[0])), snorm(f64::from(r[1])));
        let b = normal_from_xy(f64::from(d[0]) * 2.0 - 1.0, f64::from(d[1]) * 2.0 - 1.0);
        hist.add(ori_math::angle_between(a, b).to_degrees(), 1);
    }
    hist.stats()
}

/// The error that storing x, y in 8 bits already implies: for each texel, the angle between
/// the normal at its stored value and normals spread evenly over its quantisation cell (a
/// 4 x 4 grid of sub-cell centres), i.e. the error of an ideal 8-bit encoder.
pub fn normal_quantisation_floor(reference_xy: &[u8]) -> AngularStats {
    // Only 65536 (x, y) pairs exist: count them, then weigh each pair's samples.
    let mut counts = vec![0u64; 65536];
    for r in reference_xy.chunks_exact(2) {
        counts[usize::from(r[0]) << 8 | usize::from(r[1])] += 1;
    }
    let mut hist = Histogram::new();
    let half_step = 1.0 / 255.0; // half of one 8-bit step in normal units (2 / 255)
    for (pair, &count) in counts.iter().enumerate() {
        if count == 0 {
            continue;
        }
        let x = snorm((pair >> 8) as f64);
        let y = snorm((pair & 255) as f64);
        let centre = normal_from_xy(x, y);
        // Sub-cell centres at -3/8, -1/8, 1/8, 3/8 of a step.
        for i in 0..4 {
            for j in 0..4 {
                let dx = f64::from(2 * i - 3) / 4.0 * half_step;
                let dy = f64::from(2 * j - 3) / 4.0 * half_step;
                let n = normal_from_xy(x + dx, y + dy);
                hist.add(ori_math::angle_between(centre, n).to_degrees(), count);
            }
        }
    }
    hist.stats()
}

/// Angles binned at 0.001 degree for the percentile, with exact mean and maximum.
struct Histogram {
    bins: Vec<u64>,
    sum: f64,
    count: u64,
    max: f64,
}

impl Histogram {
    const RESOLUTION: f64 = 0.001;

    fn new() -> Self {
        Histogram {
            bins: vec![0; (180.0 / Self::RESOLUTION) as usize + 2],
            sum: 0.0,
            count: 0,
            max: 0.0,
        }
    }

    fn add(&mut self, degrees: f64, weight: u64) {
        let bin = ((degrees / Self::RESOLUTION) as usize).min(self.bins.len() - 1);
        self.bins[bin] += weight;
        self.sum += degrees * weight as f64;
        self.count += weight;
        self.max = self.max.max(degrees);
    }

    fn stats(&self) -> AngularStats {
        if self.count == 0 {
            return AngularStats {
                mean: 0.0,
                p99: 0.0,
                max: 0.0,
            };
        }
        // Smallest bin upper edge with at least 99% of the samples at or below it.
        let target = (self.count as f64 * 0.99).ceil() as u64;
        let mut seen = 0;
        let mut p99 = self.max;
        for (i, &n) in self.bins.iter().enumerate() {
            seen += n;
            if seen >= target {
                p99 = ((i + 1) as f64 * Self::RESOLUTION).min(self.max);
                break;
            }
        }
        AngularStats {
            mean: self.sum / self.count as f64,
            p99,
            max: self.max,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psnr_of_a_one_step_error_is_48_db() {
        let reference = [10u8, 20, 30, 40];
        let decoded: Vec<f32> = reference
            .iter()
            .map(|&v| (f32::from(v) + 1.0) / 255.0)
            .collect();
        assert!((psnr_channel(&reference, &decoded) - 48.1308).abs() < 1e-3);
        // Only float rounding left: far above any real codec.
        assert!(psnr_channel(&reference, &reference.map(|v| f32::from(v) / 255.0)) > 150.0);
        assert_eq!(psnr_from_mse(0.0), f64::INFINITY);
    }

    #[test]
    fn normals_rebuild_to_unit_length() {
        for (x, y) in [(0.0, 0.0), (0.6, 0.8), (0.9, 0.9), (-0.3, 0.2)] {
            let n = normal_from_xy(x, y);
            assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) - 1.0).abs() < 1e-12);
            assert!(n[2] >= 0.0);
        }
    }

    #[test]
    fn floor_is_a_fraction_of_a_degree_and_grows_at_the_rim() {
        let flat = normal_quantisation_floor(&[128, 128]);
        assert!(flat.mean > 0.05 && flat.mean < 0.3, "{flat:?}");
        let steep = normal_quantisation_floor(&[250, 128]);
        assert!(steep.mean > flat.mean, "{steep:?} vs {flat:?}");
    }
}
