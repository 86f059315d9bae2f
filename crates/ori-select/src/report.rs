//! Full evaluation of selection rules (the paper's Table 1 and our extra rows): every view
//! rendered from the mesh and from the ORI with the subset each rule picks.

use ori_eval::{Evaluator, Layer, ShadedMesh, ViewErrors};
use rayon::prelude::*;

use crate::{Rule, SelectError, ViewMasks, choose};

/// One rule's chosen subset and its errors in one view.
#[derive(Clone, Debug, PartialEq)]
pub struct RuleView {
    /// Impostors drawn, closest direction first.
    pub impostors: Vec<usize>,
    pub errors: ViewErrors,
}

/// Evaluate `rules` (sharing each view's renders) for every direction of `directions`, in
/// parallel over directions, in order: `result[d][r]` is rule `r` in direction `d`.
pub fn evaluate_rules(
    evaluator: &Evaluator<'_>,
    directions: &[[f64; 3]],
    rules: &[Rule],
    goal: u32,
) -> Result<Vec<Vec<RuleView>>, SelectError> {
    let m = rules.iter().map(|r| r.m() as usize).max().unwrap_or(0);
    directions
        .par_iter()
        .map(|&w| {
            let view = evaluator.view(w)?;
            let mesh = evaluator.render_mesh(&view)?;
            let shaded = ShadedMesh::new(&view, &mesh);
            let layers: Vec<Layer> = evaluator
                .facing(w)
                .into_iter()
                .take(m)
                .map(|i| evaluator.layer(&view, i, None))
                .collect();
            let masks = ViewMasks {
                reference: mesh.coverage.clone(),
                candidates: layers
                    .iter()
                    .map(|l| (l.impostor(), l.mask().clone()))
                    .collect(),
            };
            Ok(rules
                .iter()
                .map(|&rule| {
                    let c = choose(&masks, rule, goal);
                    let chosen: Vec<&Layer> = c
                        .impostors
                        .iter()
                        .map(|&i| layers.iter().find(|l| l.impostor() == i).expect("a layer"))
                        .collect();
                    let ori = evaluator.compose(&view, &chosen);
                    let errors = shaded.compare(&ori);
                    debug_assert_eq!(errors.missed, c.missed);
                    RuleView {
                        impostors: c.impostors,
                        errors,
                    }
                })
                .collect())
        })
        .collect()
}

/// Averages of one rule over all directions.
#[derive(Clone, Debug, PartialEq)]
pub struct RuleSummary {
    pub rule: Rule,
    /// Coverage error, percent of s0 x s0.
    pub min_percent: f64,
    pub max_percent: f64,
    pub avg_percent: f64,
    /// GC(s0), pixels.
    pub max_missed: u32,
    pub avg_impostors: f64,
    /// Inverse coverage, percent of s0 x s0.
    pub avg_extra_percent: f64,
    pub max_extra_percent: f64,
    /// Mean p_dif (0 to 765) and depth error over the directions.
    pub avg_p_dif: f64,
    pub avg_depth_error: f64,
}

/// Summaries of `evaluate_rules` output per rule, reduced in direction order.
pub fn summarize(rules: &[Rule], views: &[Vec<RuleView>]) -> Vec<RuleSummary> {
    let n = views.len().max(1) as f64;
    rules
        .iter()
        .enumerate()
        .map(|(r, &rule)| {
            let mut s = RuleSummary {
                rule,
                min_percent: f64::INFINITY,
                max_percent: 0.0,
                avg_percent: 0.0,
                max_missed: 0,
                avg_impostors: 0.0,
                avg_extra_percent: 0.0,
                max_extra_percent: 0.0,
                avg_p_dif: 0.0,
                avg_depth_error: 0.0,
            };
            for v in views {
                let e = &v[r].errors;
                s.min_percent = s.min_percent.min(e.missed_percent());
                s.max_percent = s.max_percent.max(e.missed_percent());
                s.max_missed = s.max_missed.max(e.missed);
                s.avg_percent += e.missed_percent() / n;
                s.avg_impostors += v[r].impostors.len() as f64 / n;
                s.avg_extra_percent += e.extra_percent() / n;
                s.max_extra_percent = s.max_extra_percent.max(e.extra_percent());
                s.avg_p_dif += e.p_dif / n;
                s.avg_depth_error += e.depth_error / n;
            }
            if views.is_empty() {
                s.min_percent = 0.0;
            }
            s
        })
        .collect()
}

/// Coverage error of the runtime rule at directions no table entry was chosen at.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOut {
    /// Per direction, in order: pixels missed (of s0 x s0) and impostors drawn.
    pub views: Vec<(u32, usize)>,
    pub s0: u32,
}

impl HeldOut {
    /// The figures of the first `count` directions (e.g. the 1280 regular ones).
    pub fn first(&self, count: usize) -> HeldOut {
        HeldOut {
            views: self.views[..count.min(self.views.len())].to_vec(),
            s0: self.s0,
        }
    }

    fn percent(&self, pixels: f64) -> f64 {
        100.0 * pixels / f64::from(self.s0 * self.s0)
    }

    /// The worst view's coverage error, percent of s0 x s0.
    pub fn max_percent(&self) -> f64 {
        self.percent(f64::from(self.worst_missed()))
    }

    /// Each view's missed pixels, in order.
    pub fn missed(&self) -> Vec<u32> {
        self.views.iter().map(|v| v.0).collect()
    }

    /// The canonical byte layout (see `codec.rs`).
    pub fn encode(&self) -> Vec<u8> {
        crate::codec::encode_held_out(self)
    }

    pub fn decode(bytes: &[u8]) -> Result<HeldOut, ori_artifact::DecodeError> {
        crate::codec::decode_held_out(bytes)
    }

    /// The worst view's missed pixels.
    pub fn worst_missed(&self) -> u32 {
        self.views.iter().map(|v| v.0).max().unwrap_or(0)
    }

    /// The mean coverage error, percent of s0 x s0.
    pub fn avg_percent(&self) -> f64 {
        let total: f64 = self.views.iter().map(|v| f64::from(v.0)).sum();
        self.percent(total / self.views.len().max(1) as f64)
    }

    /// The mean number of impostors drawn per view.
    pub fn avg_impostors(&self) -> f64 {
        let total: usize = self.views.iter().map(|v| v.1).sum();
        total as f64 / self.views.len().max(1) as f64
    }
}

/// The runtime rule at `directions`: each view draws the impostors `subset(w)` names (the
/// table entry nearest to `w`) and is compared with the mesh's coverage.
pub fn held_out(
    evaluator: &Evaluator<'_>,
    directions: &[[f64; 3]],
    subset: &(dyn Fn([f64; 3]) -> Vec<usize> + Sync),
) -> Result<HeldOut, SelectError> {
    let views = directions
        .par_iter()
        .map(|&w| {
            let view = evaluator.view(w)?;
            let mut missed = evaluator.mesh_coverage(&view);
            let impostors = subset(w);
            // Each impostor is traced only where the ones before it left pixels uncovered: a
            // pixel's coverage does not depend on which others are traced.
            for &i in &impostors {
                missed.remove(&evaluator.impostor_mask(&view, i, Some(&missed)));
            }
            Ok((missed.count(), impostors.len()))
        })
        .collect::<Result<_, SelectError>>()?;
    Ok(HeldOut {
        views,
        s0: evaluator.params().s0,
    })
}
