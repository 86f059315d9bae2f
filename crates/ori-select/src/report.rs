//! Full evaluation of selection rules (the paper's Table 1 and our extra rows): every view
//! rendered from the mesh and from the ORI with the subset each rule picks.

use ori_eval::{Evaluator, Layer, ViewErrors, compare};
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
                    let errors = compare(&view, &mesh, &ori);
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
