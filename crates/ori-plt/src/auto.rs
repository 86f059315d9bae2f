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
//! `reached: false`.

use crate::{Plt, PltParams, nearest_power_of_two};

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
            Some(r) if r >= max => AutoStep::Done {
                resolution: max,
                reached: false,
            },
            Some(r) => AutoStep::Try(r * 2),
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
        // A hopeless one stops at the maximum.
        let (step, tried) = run(&params, |_| plt(10));
        assert_eq!(
            step,
            AutoStep::Done {
                resolution: 4096,
                reached: false
            }
        );
        assert_eq!(tried, [512, 1024, 2048, 4096]);
    }
}
