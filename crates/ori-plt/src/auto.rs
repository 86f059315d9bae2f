//! The `auto` texture-resolution mode: choose the smallest power-of-two relief-map resolution
//! whose PLT reaches a target screen size.
//!
//! The decision is a pure function of the PLTs measured so far, so the build graph drives
//! it: bake and select at the resolution [`auto_resolution`] asks for (each resolution is
//! its own cached job chain: bake -> select -> PLT keyed by the resolution), feed the PLT
//! back, and repeat until it answers [`AutoStep::Done`]. Starting from the paper's advice (a
//! texture edge of about 2 x the target), it halves while the PLT still reaches the target
//! and doubles while it does not, so a typical run measures two or three resolutions.
//!
//! "Smallest" assumes the PLT grows with the resolution (it does, up to measurement noise):
//! the answer is the resolution `r` that reaches the target while `r / 2` does not (or `r` is
//! the minimum). If even the maximum does not reach it, that maximum is returned with
//! `reached: false`; so is a resolution whose double does not raise the PLT by
//! [`PLATEAU_GAIN`] (the PLT has stopped growing: more texels would only cost).

use crate::{Plt, PltParams, nearest_power_of_two};

/// Going up, a doubled resolution must raise the PLT by this factor, or the search stops at
/// the smaller one: past some resolution the coverage error is made of misses that are not
/// texel-sized (grazing rays between linear-search steps, surfaces no impostor sees), and the
/// PLT stays flat (measured on the bunny: 90.6 px at 256, 87.5 at 512, 86.6 at 4096).
pub const PLATEAU_GAIN: f64 = 1.05;

/// What to do next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AutoStep {
    /// Measure the PLT at this resolution and call again with it added.
    Try(u32),
    /// The chosen resolution; `reached` is false when no allowed resolution reaches the target.
    Done { resolution: u32, reached: bool },
}

/// The next step of the `auto` search, given the PLTs measured so far as (resolution, PLT)
/// pairs in any order (resolutions are powers of two within the parameters' range).
pub fn auto_resolution(params: &PltParams, tried: &[(u32, Plt)]) -> AutoStep {
    let target = f64::from(params.target_px);
    let (min, max) = (params.min_resolution, params.max_resolution);
    let reaches = |r: u32| {
        tried
            .iter()
            .find(|(res, _)| *res == r)
            .map(|(_, plt)| plt.pixels() >= target)
    };
    let plt_at = |r: u32| {
        tried
            .iter()
            .find(|(res, _)| *res == r)
            .map(|(_, plt)| plt.pixels())
    };
    let smallest_passing = tried
        .iter()
        .filter(|(_, plt)| plt.pixels() >= target)
        .map(|(r, _)| *r)
        .min();
    match smallest_passing {
        Some(r) if r <= min => AutoStep::Done {
            resolution: r,
            reached: true,
        },
        Some(r) => match reaches(r / 2) {
            Some(false) => AutoStep::Done {
                resolution: r,
                reached: true,
            },
            _ => AutoStep::Try(r / 2),
        },
        None => match tried.iter().map(|(r, _)| *r).max() {
            None => AutoStep::Try(nearest_power_of_two(2.0 * target).clamp(min, max)),
            Some(r) => match (plt_at(r), plt_at(r / 2)) {
                // Doubling no longer pays: the misses left are not texel-sized.
                (Some(big), Some(small)) if big < small * PLATEAU_GAIN => AutoStep::Done {
                    resolution: r / 2,
                    reached: false,
                },
                _ if r >= max => AutoStep::Done {
                    resolution: max,
                    reached: false,
                },
                _ => AutoStep::Try(r * 2),
            },
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plt(pixels: u32) -> Plt {
        // s0 = 256: PLT = 65536 / gc.
        Plt {
            s0: 256,
            gc: 65536 / pixels,
            worst_direction: Some(0),
        }
    }

    /// Run the search against a PLT curve; returns the answer and the resolutions tried.
    fn run(params: &PltParams, curve: impl Fn(u32) -> Plt) -> (AutoStep, Vec<u32>) {
        let mut tried = Vec::new();
        loop {
            match auto_resolution(params, &tried) {
                AutoStep::Try(r) => {
                    assert!(tried.iter().all(|(t, _)| *t != r), "{r} tried twice");
                    tried.push((r, curve(r)));
                }
                done => return (done, tried.iter().map(|t| t.0).collect()),
            }
        }
    }

    #[test]
    fn finds_the_smallest_resolution_that_reaches_the_target() {
        let params = PltParams {
            target_px: 300,
            ..PltParams::default()
        };
        // PLT about resolution: 256 -> 256 < 300, 512 -> 512 >= 300.
        let (step, tried) = run(&params, plt);
        assert_eq!(
            step,
            AutoStep::Done {
                resolution: 512,
                reached: true
            }
        );
        assert_eq!(tried, [512, 256]);
        // A generous curve walks down to the minimum.
        let (step, _) = run(&params, |_| plt(4096));
        assert_eq!(
            step,
            AutoStep::Done {
                resolution: 32,
                reached: true
            }
        );
        // A hopeless one that keeps growing stops at the maximum.
        let (step, tried) = run(&params, |r| plt(r / 64));
        assert_eq!(
            step,
            AutoStep::Done {
                resolution: 2048,
                reached: false
            }
        );
        assert_eq!(tried, [512, 1024, 2048]);
        // A flat one stops after one doubling.
        let (step, tried) = run(&params, |_| plt(10));
        assert_eq!(
            step,
            AutoStep::Done {
                resolution: 512,
                reached: false
            }
        );
        assert_eq!(tried, [512, 1024]);
        // A curve that flattens stops where doubling stops paying.
        let (step, tried) = run(&params, |r| plt(r.min(1024) / 8));
        assert_eq!(
            step,
            AutoStep::Done {
                resolution: 1024,
                reached: false
            }
        );
        assert_eq!(tried, [512, 1024, 2048]);
    }
}
