//! Selection rules and the `[select]` parameters.

use std::fmt;
use std::str::FromStr;

use ori_eval::EvalParams;
use serde::{Deserialize, Serialize};

use crate::SelectError;

/// How the impostors of a view are chosen (ORI paper, 3.2). Written `"closest:M"` or
/// `"best:M"` in `pipeline.toml`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum Rule {
    /// "m closest": the `M` facing impostors closest to the view direction, all drawn.
    Closest(u32),
    /// "i <= m best": the smallest subset of the `M` closest facing impostors whose coverage
    /// error reaches the goal (see [`crate::choose`]).
    Best(u32),
}

/// The directions `best:M` measures an entry's region at (`[select] region_shape`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RegionShape {
    /// The grid over the entry's triangle (`ori_views::evaluation_regions`), as packages that
    /// do not record the key were selected.
    Triangle,
    /// The cell the runtime serves from the entry (`ori_views::EvaluationRegions::to_cells`):
    /// the grid's points it serves and its cell's corners.
    #[default]
    Cell,
}

impl FromStr for RegionShape {
    type Err = SelectError;

    /// The names `pipeline.toml` uses (serde's), so the two cannot drift apart.
    fn from_str(s: &str) -> Result<RegionShape, SelectError> {
        use serde::de::{IntoDeserializer, value::Error};
        RegionShape::deserialize(s.into_deserializer()).map_err(|_: Error| {
            SelectError::Params(format!(
                "select.region_shape = {s:?}: expected \"cell\" or \"triangle\""
            ))
        })
    }
}

/// Largest `M` of `best:M`: 2^M - 1 subsets are tried per view.
pub const MAX_BEST: u32 = 16;
/// The most impostors `closest:M` may draw per view (the selection artifact stores the count
/// in one byte).
pub const MAX_CLOSEST: u32 = 255;

impl Rule {
    /// `M`.
    pub fn m(self) -> u32 {
        match self {
            Rule::Closest(m) | Rule::Best(m) => m,
        }
    }
}

impl fmt::Display for Rule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Rule::Closest(m) => write!(f, "closest:{m}"),
            Rule::Best(m) => write!(f, "best:{m}"),
        }
    }
}

impl FromStr for Rule {
    type Err = SelectError;

    fn from_str(s: &str) -> Result<Rule, SelectError> {
        let bad = || {
            SelectError::Params(format!(
                "select.rule = {s:?}: expected \"closest:M\" (1 <= M <= {MAX_CLOSEST}) or \
                 \"best:M\" (1 <= M <= {MAX_BEST})"
            ))
        };
        let (kind, m) = s.split_once(':').ok_or_else(bad)?;
        let m: u32 = m.parse().map_err(|_| bad())?;
        match kind {
            "closest" if (1..=MAX_CLOSEST).contains(&m) => Ok(Rule::Closest(m)),
            "best" if (1..=MAX_BEST).contains(&m) => Ok(Rule::Best(m)),
            _ => Err(bad()),
        }
    }
}

impl TryFrom<String> for Rule {
    type Error = SelectError;

    fn try_from(s: String) -> Result<Rule, SelectError> {
        s.parse()
    }
}

impl From<Rule> for String {
    fn from(r: Rule) -> String {
        r.to_string()
    }
}

/// Parameters of selection; the `[select]` section of `pipeline.toml` deserialises into it.
/// The rendering keys are those of the runtime rule, so they must match the runtime's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SelectParams {
    /// `"best:8"` (default) or `"closest:M"`.
    pub rule: Rule,
    /// Coverage-error goal of `best:M` in an entry's own view, in percent of s0 x s0
    /// (default 0.2).
    pub goal_percent: f64,
    /// Coverage-error goal of `best:M` at the grid of directions over the region an entry
    /// serves, `ori_views::evaluation_regions` (default 0.29; `goal_percent` to 100).
    pub edge_goal_percent: f64,
    /// Steps along each edge of an entry's triangle between the directions `best:M` measures
    /// its region at (default 6: 27 directions per entry; 2: its corners and edge midpoints;
    /// 1 to 8).
    pub region_steps: u32,
    /// Where an entry's region is measured: `"cell"` (default), the directions the runtime
    /// serves from it, or `"triangle"`, the grid over its triangle alone.
    pub region_shape: RegionShape,
    /// The region's directions are measured at `s0 * region_scale` pixels across, rounded
    /// (default 0.75; 0.25 to 1), their coverage errors counted in pixels of s0.
    pub region_scale: f64,
    /// Evaluation image edge s0 (default 256).
    pub s0: u32,
    /// Linear-search steps of the runtime rule (default 16).
    pub linear_steps: u32,
    /// Binary-search steps of the runtime rule (default 7).
    pub binary_steps: u32,
    /// Vertical-wall threshold of the runtime rule, fraction of an impostor's depth range
    /// (default 0.25).
    pub wall_threshold: f64,
}

impl Default for SelectParams {
    fn default() -> Self {
        let e = EvalParams::default();
        SelectParams {
            rule: Rule::Best(8),
            goal_percent: 0.2,
            edge_goal_percent: 0.29,
            region_steps: 6,
            region_shape: RegionShape::Cell,
            region_scale: 0.75,
            s0: e.s0,
            linear_steps: e.linear_steps,
            binary_steps: e.binary_steps,
            wall_threshold: e.wall_threshold,
        }
    }
}

impl SelectParams {
    /// Check every field, with a message that names the key and what it accepts.
    pub fn validate(&self) -> Result<(), SelectError> {
        if let Rule::Best(m) = self.rule
            && !(1..=MAX_BEST).contains(&m)
        {
            return Err(SelectError::Params(format!(
                "select.rule = \"best:{m}\": M must be 1 to {MAX_BEST}"
            )));
        }
        if let Rule::Closest(m) = self.rule
            && m > MAX_CLOSEST
        {
            return Err(SelectError::Params(format!(
                "select.rule = \"closest:{m}\": M must be 1 to {MAX_CLOSEST}"
            )));
        }
        if self.rule.m() == 0 {
            return Err(SelectError::Params(
                "select.rule: M must be at least 1".into(),
            ));
        }
        if !(0.0..=100.0).contains(&self.goal_percent) {
            return Err(SelectError::Params(format!(
                "select.goal_percent = {} must be 0 to 100",
                self.goal_percent
            )));
        }
        if !(self.goal_percent..=100.0).contains(&self.edge_goal_percent) {
            return Err(SelectError::Params(format!(
                "select.edge_goal_percent = {} must be select.goal_percent ({}) to 100",
                self.edge_goal_percent, self.goal_percent
            )));
        }
        if !(1..=8).contains(&self.region_steps) {
            return Err(SelectError::Params(format!(
                "select.region_steps = {} must be 1 to 8",
                self.region_steps
            )));
        }
        if !(0.25..=1.0).contains(&self.region_scale) {
            return Err(SelectError::Params(format!(
                "select.region_scale = {} must be 0.25 to 1",
                self.region_scale
            )));
        }
        self.eval_params()
            .validate()
            .map_err(|e| SelectError::Params(format!("select: {e}")))
    }

    /// The evaluator's parameters (fragment priority does not change coverage, so it is not
    /// a selection parameter).
    pub fn eval_params(&self) -> EvalParams {
        EvalParams {
            s0: self.s0,
            linear_steps: self.linear_steps,
            binary_steps: self.binary_steps,
            wall_threshold: self.wall_threshold,
            ..EvalParams::default()
        }
    }

    /// The goal as a pixel count: a subset reaches it when its coverage error is at most
    /// `floor(goal_percent / 100 * s0^2)` pixels.
    pub fn goal_pixels(&self) -> u32 {
        goal_pixels(self.goal_percent, self.s0)
    }

    /// The region's goal as a pixel count, likewise.
    pub fn edge_goal_pixels(&self) -> u32 {
        goal_pixels(self.edge_goal_percent, self.s0)
    }

    /// Both goals, as pixel counts.
    pub fn goals(&self) -> crate::Goals {
        crate::Goals {
            own: self.goal_pixels(),
            edge: self.edge_goal_pixels(),
        }
    }

    /// The edge of the region's views, in pixels.
    pub fn region_size(&self) -> u32 {
        ((f64::from(self.s0) * self.region_scale).round() as u32).max(1)
    }

    /// The directions `best:M` measures each entry's region at ([`RegionShape`]).
    pub fn regions(&self) -> ori_views::EvaluationRegions {
        let grid = ori_views::evaluation_regions(self.region_steps as usize);
        match self.region_shape {
            RegionShape::Triangle => grid,
            RegionShape::Cell => grid.to_cells(),
        }
    }
}

pub(crate) fn goal_pixels(goal_percent: f64, s0: u32) -> u32 {
    let s2 = f64::from(s0) * f64::from(s0);
    // Truncation is floor for the non-negative values validation allows.
    (goal_percent / 100.0 * s2) as u32
}
