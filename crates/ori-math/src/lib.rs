//! Portable elementary functions.
//!
//! Platform libm implementations of `atan2`, `acos`, ... may differ in the last bit between
//! machines, and the pipeline promises bit-identical artifacts (see `GUIDE.md`,
//! "Determinism"). Every function here uses only IEEE-754 operations that are correctly
//! rounded everywhere (`+ - * /`, `sqrt`), evaluated in `f64` in a fixed order, so the result
//! is the same on every machine. Accuracy is about 1e-8 radians, far below what `f32`
//! geometry needs.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// tan(pi/8): past it, `atan` is reduced around pi/4 to keep the series argument small.
const TAN_PI_8: f64 = 0.414_213_562_373_095_03;

/// arctangent of `t` for `0 <= t <= 1`.
fn atan_unit(t: f64) -> f64 {
    let (base, u) = if t > TAN_PI_8 {
        (FRAC_PI_4, (t - 1.0) / (t + 1.0))
    } else {
        (0.0, t)
    };
    // Taylor series to u^17: |u| <= tan(pi/8) bounds the error by u^19/19 < 1e-8.
    let u2 = u * u;
    let mut sum = 0.0;
    for k in (0..9).rev() {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        sum = sum * u2 + sign / (2 * k + 1) as f64;
    }
    base + u * sum
}

/// Four-quadrant arctangent of `y / x`, in `[-pi, pi]`; `atan2(0, 0)` is 0.
pub fn atan2(y: f64, x: f64) -> f64 {
    if y == 0.0 && x == 0.0 {
        return 0.0;
    }
    let (ay, ax) = (y.abs(), x.abs());
    let a = if ay <= ax {
        atan_unit(ay / ax)
    } else {
        FRAC_PI_2 - atan_unit(ax / ay)
    };
    let a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 { -a } else { a }
}

/// Arccosine, with the argument clamped to `[-1, 1]` so rounding never yields NaN.
pub fn acos(x: f64) -> f64 {
    let x = x.clamp(-1.0, 1.0);
    atan2((1.0 - x * x).sqrt(), x)
}

/// Angle in radians between two non-zero vectors, computed as `atan2(|a x b|, a . b)`, which
/// stays accurate for nearly parallel vectors where `acos` of the dot product does not.
pub fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let cross = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    atan2(cross, dot)
}

/// `x^n` by repeated multiplication (`powi` may lower to different code per target).
fn ipow(x: f64, n: i32) -> f64 {
    (0..n).fold(1.0, |acc, _| acc * x)
}

/// `a^(1/n)` for `a >= 0` by Newton's method from a fixed start, so the iteration count and
/// every rounding are the same on all machines.
fn nth_root(a: f64, n: i32) -> f64 {
    if a == 0.0 {
        return 0.0;
    }
    let mut y = if a > 1.0 { a } else { 1.0 };
    for _ in 0..200 {
        let yn1 = ipow(y, n - 1);
        let next = y - (y * yn1 - a) / (n as f64 * yn1);
        if next >= y {
            break;
        }
        y = next;
    }
    y
}

/// sRGB transfer function, encoded value in `[0, 1]` to linear light.
pub fn srgb_to_linear(c: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.04045 {
        c / 12.92
    } else {
        // x^2.4 = x^2 * (x^2)^(1/5)
        let x = (c + 0.055) / 1.055;
        let x2 = x * x;
        x2 * nth_root(x2, 5)
    }
}

/// Inverse sRGB transfer function, linear light in `[0, 1]` to the encoded value.
pub fn linear_to_srgb(l: f64) -> f64 {
    let l = l.clamp(0.0, 1.0);
    if l <= 0.003_130_8 {
        l * 12.92
    } else {
        // l^(1/2.4) = (l^5)^(1/12)
        1.055 * nth_root(ipow(l, 5), 12) - 0.055
    }
}

/// Natural logarithm of a positive finite `x` (0 gives negative infinity). The exponent is
/// split off through the bit pattern, the mantissa `m` in `[1, 2)` goes through
/// `ln m = 2 atanh((m - 1) / (m + 1))` whose series converges fast for `|s| <= 1/3`.
pub fn ln(x: f64) -> f64 {
    if x == 0.0 {
        return f64::NEG_INFINITY;
    }
    if x.is_nan() || x < 0.0 || x.is_infinite() {
        return f64::NAN;
    }
    let (mut m, mut e) = (x, 0i32);
    if m < f64::MIN_POSITIVE {
        m *= (1u64 << 60) as f64;
        e -= 60;
    }
    let bits = m.to_bits();
    e += ((bits >> 52) & 0x7ff) as i32 - 1023;
    let m = f64::from_bits((bits & !(0x7ff << 52)) | (1023 << 52));
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let mut sum = 0.0;
    for k in (0..20).rev() {
        sum = sum * s2 + 1.0 / (2 * k + 1) as f64;
    }
    e as f64 * std::f64::consts::LN_2 + 2.0 * s * sum
}

/// `log2(x)` via [`ln`].
pub fn log2(x: f64) -> f64 {
    ln(x) / std::f64::consts::LN_2
}

/// Sine and cosine of `x` radians, `(sin x, cos x)`.
///
/// `x` is reduced to `r` in `[-pi/4, pi/4]` around the nearest multiple `k` of pi/2 with a
/// two-part pi/2 (Cody-Waite: `k * PIO2_HI` is exact for `|k| < 2^20`), then the Taylor series
/// run to `r^17` (sine) and `r^16` (cosine), whose next terms are below 3e-18. The error is
/// about 1e-16 while `|x|` is below about 1.6e6 (`|k| < 2^20`); larger arguments lose
/// accuracy, never determinism.
pub fn sin_cos(x: f64) -> (f64, f64) {
    // pi/2 = PIO2_HI + PIO2_LO, PIO2_HI with its low 20 mantissa bits zero (fdlibm's split).
    const PIO2_HI: f64 = 1.570_796_326_734_125_6;
    const PIO2_LO: f64 = 6.077_100_506_506_192e-11;
    if !x.is_finite() {
        return (f64::NAN, f64::NAN);
    }
    let k = (x * std::f64::consts::FRAC_2_PI).round();
    let r = (x - k * PIO2_HI) - k * PIO2_LO;
    let r2 = r * r;
    // Horner from the highest term: sin r = r (1 - r^2/3! + ...), cos r = 1 - r^2/2! + ...
    let (mut s, mut c) = (0.0, 0.0);
    for n in (0..9).rev() {
        let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
        s = s * r2 + sign / factorial(2 * n + 1);
        c = c * r2 + sign / factorial(2 * n);
    }
    let (s, c) = (r * s, c);
    // Quadrant of k (k mod 4, also for negative k).
    match (k as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `n!` as `f64`, exact for `n <= 22`.
fn factorial(n: u32) -> f64 {
    (2..=n).fold(1.0, |acc, k| acc * k as f64)
}

/// Sine of `x` radians; see [`sin_cos`].
pub fn sin(x: f64) -> f64 {
    sin_cos(x).0
}

/// Cosine of `x` radians; see [`sin_cos`].
pub fn cos(x: f64) -> f64 {
    sin_cos(x).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_matches_libm_over_the_circle() {
        let mut worst: f64 = 0.0;
        for i in 0..=20_000 {
            let t = -PI + 2.0 * PI * i as f64 / 20_000.0;
            let (y, x) = (t.sin() * 3.7, t.cos() * 3.7);
            worst = worst.max((atan2(y, x) - y.atan2(x)).abs());
        }
        assert!(worst < 1e-8, "max error {worst}");
    }

    #[test]
    fn acos_matches_libm_and_clamps() {
        for i in 0..=2_000 {
            let x = -1.0 + i as f64 / 1_000.0;
            assert!((acos(x) - x.acos()).abs() < 1e-7, "acos({x})");
        }
        assert_eq!(acos(1.0000001), 0.0);
        assert!((acos(-1.5) - PI).abs() < 1e-12);
    }

    #[test]
    fn srgb_round_trip_matches_the_formula() {
        for i in 0..=255 {
            let c = i as f64 / 255.0;
            let exact = if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            };
            assert!((srgb_to_linear(c) - exact).abs() < 1e-12, "{i}");
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-9, "{i}");
        }
    }

    #[test]
    fn ln_matches_libm() {
        for &x in &[
            1e-300, 1e-10, 0.1, 0.5, 1.0, 1.5, 2.0, 3.0, 10.0, 12345.678, 1e300,
        ] {
            assert!(
                (ln(x) - x.ln()).abs() <= 1e-14 * x.ln().abs().max(1.0),
                "ln({x})"
            );
        }
        assert!((ln(5e-320) - 5e-320f64.ln()).abs() < 1e-9);
        assert_eq!(ln(0.0), f64::NEG_INFINITY);
        assert!(ln(-1.0).is_nan());
        assert!((log2(1024.0) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn sin_cos_match_libm() {
        let mut worst: f64 = 0.0;
        for i in -20_000..=20_000 {
            let x = i as f64 * 1e-3 * PI;
            let (s, c) = sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst < 1e-15, "max error {worst}");
        for x in [1e-300, 1e-8, 0.1, FRAC_PI_4, 1.0, 12345.678, -98765.4321] {
            assert!(
                (sin(x) - x.sin()).abs() < 1e-12 && (cos(x) - x.cos()).abs() < 1e-12,
                "{x}"
            );
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert!(sin(f64::INFINITY).is_nan() && cos(f64::NAN).is_nan());
    }

    #[test]
    fn angle_between_axes() {
        assert!((angle_between([1.0, 0.0, 0.0], [0.0, 2.0, 0.0]) - FRAC_PI_2).abs() < 1e-12);
        assert!((angle_between([1.0, 0.0, 0.0], [-1.0, 1e-9, 0.0]) - PI).abs() < 1e-8);
        assert_eq!(atan2(0.0, 0.0), 0.0);
    }
}
