//! Projected Length Threshold (ORI paper, 3.4; `GUIDE.md`, "PLT").
//!
//! - [`estimate`]: GC(s0) = the largest coverage error d_i(s0) over the views measured (the
//!   pipeline gives it the held-out directions, each drawn with the subset of its nearest table
//!   entry, `docs/RUNTIME.md`), and PLT = s0^2 / GC(s0) pixels:
//!   the largest on-screen size at which the ORI makes on average at most one coverage error
//!   per pixel row. GC(s0) = 0 gives no finite estimate: the PLT is then reported as *at
//!   least* s0^2 ([`PltValue::AtLeast`]).
//! - [`Plt::recommended_resolution`]: the paper's advice, a texture edge of about 2 x PLT.
//! - [`fits`]: the runtime check, with the projected size defined as the edge of the square
//!   bounding box of the object's screen projection; [`sphere_projected_edge`] and
//!   [`ortho_sphere_edge`] give a conservative stand-in from the bounding sphere.
//! - [`auto_resolution`]: the `auto` texture-resolution mode, as a pure decision function.
//!
//! This crate depends on no pipeline crate, so the runtime renderer can use it.

mod auto;
mod screen;

use ori_artifact::Layout;
use serde::{Deserialize, Serialize};

pub use ori_artifact::DecodeError;

pub use auto::{AutoStep, auto_resolution};
pub use screen::{ortho_sphere_edge, sphere_projected_edge};

/// The PLT of one ORI: the measurement it comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Plt {
    /// Evaluation image edge s0.
    pub s0: u32,
    /// GC(s0): the largest coverage error over the directions, in pixels.
    pub gc: u32,
    /// The direction where it occurs (lowest index on ties); `None` when there is none.
    pub worst_direction: Option<u32>,
}

/// The PLT in pixels, or its lower bound when no error was measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PltValue {
    /// s0^2 / GC(s0).
    Pixels(f64),
    /// GC(s0) = 0: the PLT is at least s0^2 (nothing finer was measured).
    AtLeast(f64),
}

/// GC(s0) and the PLT from the coverage error of each direction (`missed[i]` = d_i(s0), in
/// pixels, with the selected subset).
pub fn estimate(s0: u32, missed: &[u32]) -> Plt {
    let mut worst: Option<(u32, u32)> = None;
    for (i, &m) in missed.iter().enumerate() {
        if m > 0 && worst.is_none_or(|w| m > w.1) {
            worst = Some((i as u32, m));
        }
    }
    Plt {
        s0,
        gc: worst.map_or(0, |w| w.1),
        worst_direction: worst.map(|w| w.0),
    }
}

impl Plt {
    /// PLT = s0^2 / GC(s0), or "at least s0^2" when GC(s0) = 0.
    pub fn value(&self) -> PltValue {
        let s2 = f64::from(self.s0) * f64::from(self.s0);
        if self.gc == 0 {
            PltValue::AtLeast(s2)
        } else {
            PltValue::Pixels(s2 / f64::from(self.gc))
        }
    }

    /// The PLT in pixels to use in decisions: s0^2 / GC, or s0^2 (the proven lower bound)
    /// when GC = 0.
    pub fn pixels(&self) -> f64 {
        match self.value() {
            PltValue::Pixels(p) | PltValue::AtLeast(p) => p,
        }
    }

    /// The texture edge the paper advises for this PLT: the power of two nearest to 2 x PLT
    /// (nearest in ratio; halfway cases go up), at least 1.
    pub fn recommended_resolution(&self) -> u32 {
        nearest_power_of_two(2.0 * self.pixels())
    }

    /// The canonical byte layout (the shared artifact header, then u32 s0, u32 GC, u32 worst
    /// direction or u32::MAX for none; little-endian).
    pub fn encode(&self) -> Vec<u8> {
        let mut w = LAYOUT.writer();
        w.u32(self.s0);
        w.u32(self.gc);
        w.u32(self.worst_direction.unwrap_or(u32::MAX));
        w.finish()
    }

    pub fn decode(bytes: &[u8]) -> Result<Plt, DecodeError> {
        let mut r = LAYOUT.reader(bytes)?;
        let (s0, gc, worst) = (r.u32()?, r.u32()?, r.u32()?);
        let plt = Plt {
            s0,
            gc,
            worst_direction: (worst != u32::MAX).then_some(worst),
        };
        if plt.s0 == 0 || (plt.gc == 0) != plt.worst_direction.is_none() {
            return Err(r.error("inconsistent PLT fields"));
        }
        r.finish()?;
        Ok(plt)
    }
}

impl std::fmt::Display for Plt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.value() {
            PltValue::Pixels(p) => write!(f, "{p:.0}"),
            PltValue::AtLeast(p) => write!(f, ">= {p:.0}"),
        }
    }
}

const LAYOUT: Layout = Layout {
    kind: "PLT",
    magic: *b"ORIPLT\0\0",
    version: 1,
};

/// The runtime check: may the ORI be drawn when the edge of the square bounding box of its
/// screen projection is `projected_px` pixels? True when `projected_px <= PLT` (with GC = 0,
/// up to s0^2). Pass [`sphere_projected_edge`] when the exact box is not at hand: it is never
/// smaller, so the check stays on the safe side.
pub fn fits(plt: &Plt, projected_px: f64) -> bool {
    projected_px <= plt.pixels()
}

/// `[plt]` parameters: where the PLT is measured, and the `auto` texture-resolution mode.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PltParams {
    /// Seed of the random half of the held-out directions the PLT is measured at
    /// (`ori_views::held_out_directions`; default 1).
    pub held_out_seed: u64,
    /// Target on-screen size in pixels for `auto` resolution: the smallest power-of-two
    /// texture resolution whose PLT reaches it is chosen (see [`auto_resolution`]).
    pub target_px: u32,
    /// Smallest resolution `auto` may choose (power of two).
    pub min_resolution: u32,
    /// Largest resolution `auto` may choose (power of two).
    pub max_resolution: u32,
}

impl Default for PltParams {
    fn default() -> Self {
        PltParams {
            held_out_seed: 1,
            target_px: 256,
            min_resolution: 32,
            max_resolution: 2048,
        }
    }
}

impl PltParams {
    /// Check every field, with a message that names the key and what it accepts.
    pub fn validate(&self) -> Result<(), String> {
        for (key, v) in [
            ("min_resolution", self.min_resolution),
            ("max_resolution", self.max_resolution),
        ] {
            if !v.is_power_of_two() || !(8..=8192).contains(&v) {
                return Err(format!("plt.{key} = {v} must be a power of two, 8 to 8192"));
            }
        }
        if self.min_resolution > self.max_resolution {
            return Err(format!(
                "plt.min_resolution = {} exceeds plt.max_resolution = {}",
                self.min_resolution, self.max_resolution
            ));
        }
        if self.target_px == 0 {
            return Err("plt.target_px must be at least 1".into());
        }
        Ok(())
    }
}

/// The power of two nearest to `x` in ratio (`x` in `(2^k, 2^(k+1)]` rounds up past
/// `2^k * sqrt 2`); 1 for `x <= 1`, 2^31 at most.
fn nearest_power_of_two(x: f64) -> u32 {
    let mut p = 1u32;
    // Compare squares with 2 p^2 instead of x with p sqrt 2: exact, no square root.
    while p < 1 << 31 && x * x >= 2.0 * f64::from(p) * f64::from(p) {
        p *= 2;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_power_of_two_rounds_in_ratio() {
        assert_eq!(nearest_power_of_two(0.3), 1);
        assert_eq!(nearest_power_of_two(2.0), 2);
        assert_eq!(nearest_power_of_two(540.0), 512);
        assert_eq!(nearest_power_of_two(724.0), 512);
        assert_eq!(nearest_power_of_two(725.0), 1024);
        assert_eq!(nearest_power_of_two(1e30), 1 << 31);
    }
}
