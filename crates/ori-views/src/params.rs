//! The `[views]` section of `pipeline.toml`.

use serde::{Deserialize, Serialize};

use crate::ViewError;
use crate::directions::REGULAR_COUNTS;

/// How the impostor directions are chosen (ORI paper, section 3.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Strategy {
    /// (a) Regularly spaced: the axis box (6) or an icosahedron set (20, 80, ...).
    Regular,
    /// (b) Guaranteed minimal sampling: the `count` directions of highest viewpoint entropy
    /// among the 320 evaluation directions.
    #[serde(rename = "minimal")]
    MinimalSampling,
    /// (c) Information-based perturbation: each regular direction moves to the direction of
    /// highest entropy within `search_radius_deg` of it.
    #[default]
    Perturbed,
}

impl Strategy {
    /// The name used in `pipeline.toml`.
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Regular => "regular",
            Strategy::MinimalSampling => "minimal",
            Strategy::Perturbed => "perturbed",
        }
    }
}

/// Parameters of view planning; `[views]` in `pipeline.toml` deserialises into it directly.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ViewParams {
    /// `"regular"`, `"minimal"` or `"perturbed"` (default).
    pub strategy: Strategy,
    /// Number of impostors n (default 20). Regular and perturbed: the size of a regular set,
    /// 6 (axis box), 20, 80, 320, 1280 or 5120 (icosahedron levels 0-4). Minimal: 1 to 320.
    pub count: usize,
    /// Edge in pixels of the item buffer viewpoint entropy is measured on (default 128,
    /// 16 to 4096). 128 suffices: on the Stanford scans every perturbed direction chosen at
    /// 128 also beats its unperturbed one when measured at 512. The cost is mostly per
    /// triangle, so larger buffers buy little accuracy for their time.
    pub item_buffer_size: u32,
    /// Perturbed only: how far, in degrees, a regular direction may move (default 4, the
    /// paper's value; 0 to 90).
    pub search_radius_deg: f64,
}

impl Default for ViewParams {
    fn default() -> Self {
        ViewParams {
            strategy: Strategy::Perturbed,
            count: 20,
            item_buffer_size: 128,
            search_radius_deg: 4.0,
        }
    }
}

/// Number of candidate directions of the minimal-sampling strategy (the evaluation set).
pub(crate) const MINIMAL_CANDIDATES: usize = 320;

impl ViewParams {
    /// Check every field, with a message that names the key and what it accepts.
    pub fn validate(&self) -> Result<(), ViewError> {
        let bad = |msg: String| Err(ViewError::Params(msg));
        match self.strategy {
            Strategy::Regular | Strategy::Perturbed if !REGULAR_COUNTS.contains(&self.count) => {
                return bad(format!(
                    "views.count = {} has no regularly spaced direction set for strategy \
                     \"{}\"; use 6, 20, 80, 320, 1280 or 5120 (or strategy \"minimal\", which \
                     takes any count from 1 to {MINIMAL_CANDIDATES})",
                    self.count,
                    self.strategy.name()
                ));
            }
            Strategy::MinimalSampling if !(1..=MINIMAL_CANDIDATES).contains(&self.count) => {
                return bad(format!(
                    "views.count = {} is out of range for strategy \"minimal\": it picks 1 to \
                     {MINIMAL_CANDIDATES} of the {MINIMAL_CANDIDATES} evaluation directions",
                    self.count
                ));
            }
            _ => {}
        }
        if !(16..=4096).contains(&self.item_buffer_size) {
            return bad(format!(
                "views.item_buffer_size = {} is out of range (16 to 4096 pixels)",
                self.item_buffer_size
            ));
        }
        if !(0.0..=90.0).contains(&self.search_radius_deg) {
            return bad(format!(
                "views.search_radius_deg = {} is out of range (0 to 90 degrees)",
                self.search_radius_deg
            ));
        }
        Ok(())
    }
}
