//! `[gate]`: the quality a studio requires of every package, per asset through
//! `[[overrides]]`. An asset that misses it still ships its package (the release stays what
//! the build made); it is reported with what it missed, and the build exits 3.

use ori_release::QualityReport;
use serde::Deserialize;

/// `[gate]`: each bound is checked when it is set (none is by default).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GateParams {
    /// Smallest PLT accepted, in pixels (from the worst held-out view).
    pub min_plt_px: Option<f64>,
    /// Largest coverage error accepted at the held-out directions, percent of s0 x s0.
    pub max_coverage_error_percent: Option<f64>,
    /// Most bytes of texture data a package may hold (every node's, for a hierarchy).
    pub max_texture_bytes: Option<u64>,
}

impl GateParams {
    pub fn validate(&self) -> Result<(), String> {
        let bounds = [
            ("gate.min_plt_px", self.min_plt_px),
            (
                "gate.max_coverage_error_percent",
                self.max_coverage_error_percent,
            ),
        ];
        for (key, value) in bounds {
            if let Some(v) = value
                && !(v.is_finite() && v >= 0.0)
            {
                return Err(format!("{key} = {v}: give a number of 0 or more"));
            }
        }
        Ok(())
    }

    /// What a package of this quality and these texture bytes misses of the gate, one line
    /// per bound; empty: it passes.
    pub fn missed(&self, quality: &QualityReport, texture_bytes: u64) -> Vec<String> {
        let mut missed = Vec::new();
        // A PLT that is only a lower bound (no held-out view missed a pixel) is not known to
        // be below anything.
        if let Some(min) = self.min_plt_px
            && !quality.plt_is_lower_bound
            && (quality.plt.is_nan() || quality.plt < min)
        {
            missed.push(format!(
                "PLT {:.1} px is below gate.min_plt_px = {min}",
                quality.plt
            ));
        }
        let error = quality.held_out.coverage_error_max_percent;
        if let Some(max) = self.max_coverage_error_percent
            && error > max
        {
            missed.push(format!(
                "coverage error {error:.3} % at its worst held-out view is above \
                 gate.max_coverage_error_percent = {max}"
            ));
        }
        if let Some(max) = self.max_texture_bytes
            && texture_bytes > max
        {
            missed.push(format!(
                "{texture_bytes} texture bytes are more than gate.max_texture_bytes = {max}"
            ));
        }
        missed
    }
}
