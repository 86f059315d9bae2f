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
    fn angle_between_axes() {
        assert!((angle_between([1.0, 0.0, 0.0], [0.0, 2.0, 0.0]) - FRAC_PI_2).abs() < 1e-12);
        assert!((angle_between([1.0, 0.0, 0.0], [-1.0, 1e-9, 0.0]) - PI).abs() < 1e-8);
        assert_eq!(atan2(0.0, 0.0), 0.0);
    }
}
