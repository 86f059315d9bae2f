//! Placement search: move planned impostor directions to where the evaluator shows the
//! coverage error is made.
//!
//! View planning (`ori_views`) places directions by viewpoint entropy, which says how much
//! of the surface a direction sees, not whether the views between impostors can be rebuilt
//! from them. On the Stanford bunny the worst of the 320 evaluation views lost 1.57 % of its
//! pixels: the gap between the ears and the holes in the base are seen by none of the six
//! impostors closest to it. This stage measures instead of guessing: it bakes candidate
//! maps, renders their coverage masks with the CPU evaluator (`ori_eval`, the rule the
//! selection uses) and moves impostors while that lowers the worst view's error.
//!
//! # The search
//! - **Views.** The 320 evaluation directions (the selection table's), then the 162 corners
//!   of the triangles their entries serve (`ori_views::evaluation_corners`): the
//!   directions farthest from every table entry, where the runtime draws a view with
//!   impostors chosen for another. A view the table's directions alone judged drawable can
//!   miss a gap that only shows between them.
//! - **Candidates.** An impostor may move to one of the 320 evaluation directions. A
//!   candidate is baked, with the asset's bake parameters, the first time a move to it is
//!   tried (a map does not depend on which others are baked, and most candidates are never
//!   tried).
//! - **A view's error.** The selection (`best:M`) draws, for a view, a subset of the `M`
//!   closest impostors that face it (`d . w > 0`, closest first, ties in impostor order).
//!   Adding impostors never loses pixels, so the least error a view can reach with its `K`
//!   closest ([`PlaceParams::closest`], at most `M`) is that of all `K` together: the pixels
//!   the mesh covers that none of their masks covers. That is what the search lowers; the
//!   `M - K` farther candidates are left to the selection, for the edges of each entry's
//!   region. Masks are those of `ori_eval::Evaluator::impostor_mask`, traced only at the
//!   pixels an error needs (a candidate where the others drawn with it are not known to
//!   cover), each pixel at most once per (view, candidate) pair, and kept.
//! - **A step.** Take the worst view (most pixels missed; ties: the lower index). Each
//!   impostor among its `K` closest may move to any free candidate within
//!   [`PlaceParams::step_deg`] of where it is. The move that leaves the lowest (worst error,
//!   total error) wins, compared in that order; ties: the earlier impostor, then the earlier
//!   candidate. It is made only if it lowers that pair. A move that leaves any view above
//!   the current worst error cannot. A move changes the drawn impostors of some views only,
//!   and elsewhere its errors are the current ones, so each move's score is bounded from
//!   below as it is measured: in the views it changes, highest current error first, in
//!   batches of 1, 2, 4, ... views. A move is dropped as soon as its bound reaches the
//!   current score or passes the score of a move already measured in full (after the
//!   first batches, the moves with the lowest bounds are): its masks in the other views are
//!   never computed. The moves left are scored in full; the choice is the one of scoring
//!   every move.
//! - **The end.** The search stops when the worst view's error is within the selection's
//!   goal times [`PlaceParams::goal_scale`] (every view measured can then be drawn within the
//!   goal, with a margin for the views between them), when no move helps, or after
//!   [`PlaceParams::max_moves`] moves.
//!
//! Only moves near the worst view are tried: that keeps the number of masks, which is what
//! the search costs, to a few thousand per asset instead of every pair.
//!
//! # Determinism
//! Bakes and masks are computed in parallel and collected in order; every comparison and
//! choice is made sequentially on integer pixel counts. The placed directions are bit-
//! identical for any thread count, and on every machine (directions are copied from
//! `ori_views::evaluation_directions`, never computed here; the views' directions come from
//! `ori_views` too).

use ori_bake::{BakeError, BakeParams, Baker};
use ori_eval::{EvalError, EvalParams, Evaluator, Mask, PartialMask};
use ori_mesh::Mesh;
use ori_raster::OrthoView;
use ori_relief::{ReliefMap, ReliefSet};
use ori_views::{ViewError, ViewPlan};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The most closest impostors a view may be measured with ([`PlaceParams::closest`]).
pub const MAX_CLOSEST: u32 = 16;

/// The `[place]` section of `pipeline.toml`.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlaceParams {
    /// The most impostor moves the search makes (default 32; 0 turns the search off and keeps
    /// the planned directions, 0 to 1000).
    pub max_moves: u32,
    /// How far one move may take an impostor, in degrees (default 20: the nearest ring of
    /// evaluation directions, which lie 9 to 13 degrees apart; 5 to 90).
    pub step_deg: f64,
    /// How many of its closest facing impostors each evaluation view must be drawable with
    /// within the goal (default 6; 1 to 16, and never more than the selection rule's `M`).
    /// Below `M`, selection keeps the farther candidates for the edges of each entry's region,
    /// where the entry's own closest impostors are not the view's.
    pub closest: u32,
    /// The search stops once the worst view is within the selection's own goal times this
    /// (default 0.75; 0.05 to 1). Below 1 it goes on past the goal: the selection's goal
    /// holds over each entry's whole region, between the directions measured here, and
    /// impostors that leave margin at those let it draw fewer per view.
    pub goal_scale: f64,
}

impl Default for PlaceParams {
    fn default() -> Self {
        PlaceParams {
            max_moves: 32,
            step_deg: 20.0,
            closest: 6,
            goal_scale: 0.75,
        }
    }
}

impl PlaceParams {
    /// Check every field, with a message that names the key and what it accepts.
    pub fn validate(&self) -> Result<(), PlaceError> {
        if self.max_moves > 1000 {
            return Err(PlaceError::Params(format!(
                "place.max_moves = {} is out of range (0 to 1000)",
                self.max_moves
            )));
        }
        if !(5.0..=90.0).contains(&self.step_deg) {
            return Err(PlaceError::Params(format!(
                "place.step_deg = {} is out of range (5 to 90 degrees)",
                self.step_deg
            )));
        }
        if !(1..=MAX_CLOSEST).contains(&self.closest) {
            return Err(PlaceError::Params(format!(
                "place.closest = {} is out of range (1 to {MAX_CLOSEST})",
                self.closest
            )));
        }
        if !(self.goal_scale.is_finite() && (0.05..=1.0).contains(&self.goal_scale)) {
            return Err(PlaceError::Params(format!(
                "place.goal_scale = {} is out of range (0.05 to 1)",
                self.goal_scale
            )));
        }
        Ok(())
    }

    /// The worst view's error, in pixels, at which the search stops, for the selection's own
    /// goal of `goal_pixels`: their product, truncated (as the goals in pixels are).
    fn stop_pixels(&self, goal_pixels: u32) -> u32 {
        (f64::from(goal_pixels) * self.goal_scale).floor() as u32
    }
}

/// How the placed impostors will be baked and selected: the search measures with the same
/// parameters as the stages after it.
#[derive(Clone, Copy, Debug)]
pub struct Measure<'a> {
    /// The bake stage's parameters.
    pub bake: &'a BakeParams,
    /// The evaluator's parameters (s0, search steps, wall threshold) of the selection.
    pub eval: &'a EvalParams,
    /// How many closest facing impostors a view must be drawable with (`[place] closest`,
    /// at most the selection rule's `M`).
    pub closest: usize,
    /// The selection's goal, in pixels of s0 x s0.
    pub goal_pixels: u32,
    /// Item-buffer edge for the entropies of moved directions (`[views] item_buffer_size`).
    pub entropy_size: u32,
    /// When the mesh is a part of a larger model (a hierarchy node), that model: the part is
    /// measured in its own pixels (`ori_eval::Evaluator::part_of`).
    pub whole: Option<ori_eval::Whole<'a>>,
}

/// The placed directions and what the search did.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// The plan with moved directions (and their entropies); same strategy and order.
    pub plan: ViewPlan,
    /// Moves made.
    pub moves: u32,
    /// Pixels the worst view missed with all `K` closest impostors, before and after.
    pub worst_before: u32,
    pub worst_after: u32,
}

/// Why placement failed.
#[derive(Debug, thiserror::Error)]
pub enum PlaceError {
    /// A `[place]` parameter is out of range; the message names the key.
    #[error("invalid placement parameters: {0}")]
    Params(String),
    #[error("placement bake: {0}")]
    Bake(#[from] BakeError),
    #[error("placement evaluation: {0}")]
    Eval(#[from] EvalError),
    #[error("placement: {0}")]
    Views(#[from] ViewError),
}

/// Move the directions of `plan` as described in the crate documentation.
pub fn place(
    mesh: &Mesh,
    plan: &ViewPlan,
    measure: &Measure<'_>,
    params: &PlaceParams,
) -> Result<Placement, PlaceError> {
    place_scored(mesh, plan, measure, params, Scoring::Screened)
}

/// How the moves of a step are scored: `Screened` is what [`place`] does; `Every` measures
/// every move in every view, the definition the screening must match.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scoring {
    Screened,
    #[cfg_attr(not(test), allow(dead_code))]
    Every,
}

fn place_scored(
    mesh: &Mesh,
    plan: &ViewPlan,
    measure: &Measure<'_>,
    params: &PlaceParams,
    scoring: Scoring,
) -> Result<Placement, PlaceError> {
    params.validate()?;
    if params.max_moves == 0 || plan.directions.is_empty() {
        return Ok(Placement {
            plan: plan.clone(),
            moves: 0,
            worst_before: 0,
            worst_after: 0,
        });
    }
    let table = ori_views::evaluation_directions();
    let mut candidates = plan.directions.clone();
    candidates.extend(&table);
    // The table's views, then the corners of the triangles their entries serve.
    let mut measured = table;
    measured.extend(ori_views::evaluation_corners());
    // One baker for every candidate baked, so that textures are decoded once.
    let baker = Baker::new(mesh);
    let planned = baker.bake(&plan.directions, measure.bake)?;
    let evaluator = Evaluator::new(mesh, &planned, measure.eval)?.part_of(measure.whole);
    let views: Vec<OrthoView> = measured
        .iter()
        .map(|&w| evaluator.view(w))
        .collect::<Result<_, _>>()?;
    let references: Vec<Mask> = views
        .par_iter()
        .map(|v| evaluator.mesh_coverage(v))
        .collect();
    drop(evaluator);
    let mut baked: Vec<Option<ReliefMap>> = planned.maps.into_iter().map(Some).collect();
    baked.resize(candidates.len(), None);
    let mut search = Search {
        mesh,
        baker,
        measure,
        candidates: &candidates,
        measured: &measured,
        baked,
        views: &views,
        references: &references,
        masks: vec![None; measured.len() * candidates.len()],
    };

    let step_cos = ori_math::sin_cos(params.step_deg * (std::f64::consts::PI / 180.0)).1;
    let mut chosen: Vec<usize> = (0..plan.directions.len()).collect();
    let all: Vec<usize> = (0..views.len()).collect();
    search.fill(&[&chosen], &all)?;
    let mut errors = search.errors(&chosen);
    let worst_before = errors.iter().copied().max().unwrap_or(0);
    let mut current = score(&errors);
    let mut moves = 0;
    let stop = params.stop_pixels(measure.goal_pixels);
    while moves < params.max_moves {
        let worst = worst_view(&errors);
        if errors[worst] <= stop {
            break;
        }
        let near = search.drawn(&chosen, worst);
        let trials: Vec<Vec<usize>> = (0..chosen.len())
            .filter(|i| near.contains(&chosen[*i]))
            .flat_map(|i| {
                let here = candidates[chosen[i]];
                let (chosen, candidates) = (&chosen, &candidates);
                (plan.directions.len()..candidates.len())
                    .filter(move |c| !chosen.contains(c) && dot(candidates[*c], here) >= step_cos)
                    .map(move |c| {
                        let mut trial = chosen.clone();
                        trial[i] = c;
                        trial
                    })
            })
            .collect();
        let survivors = match scoring {
            Scoring::Screened => search.screen(&chosen, &trials, &errors)?,
            Scoring::Every => {
                let sets: Vec<&[usize]> = trials.iter().map(|t| &t[..]).collect();
                search.fill(&sets, &all)?;
                (0..trials.len()).collect()
            }
        };
        let mut measured: Vec<Vec<u32>> = survivors
            .par_iter()
            .map(|&k| search.errors(&trials[k]))
            .collect();
        // Sequential, in trial order: the first of equal scores wins.
        let mut best: Option<(usize, (u32, u64))> = None;
        for (i, e) in measured.iter().enumerate() {
            let s = score(e);
            if s < best.map_or(current, |b| b.1) {
                best = Some((i, s));
            }
        }
        let Some((best, best_score)) = best else {
            break;
        };
        chosen.clone_from(&trials[survivors[best]]);
        current = best_score;
        errors = measured.swap_remove(best);
        moves += 1;
    }

    let mut placed = plan.clone();
    for (slot, &c) in chosen.iter().enumerate() {
        if c != slot {
            placed.directions[slot] = candidates[c];
            placed.entropies[slot] =
                ori_views::viewpoint_entropy(mesh, candidates[c], measure.entropy_size)?;
        }
    }
    Ok(Placement {
        plan: placed,
        moves,
        worst_before,
        worst_after: current.0,
    })
}

/// (worst error, total error) of a set: what the search lowers, compared in that order.
fn score(errors: &[u32]) -> (u32, u64) {
    let worst = errors.iter().copied().max().unwrap_or(0);
    (worst, errors.iter().map(|&e| u64::from(e)).sum())
}

/// The view with the most missed pixels; ties: the lower index.
fn worst_view(errors: &[u32]) -> usize {
    let mut worst = 0;
    for (v, &e) in errors.iter().enumerate() {
        if e > errors[worst] {
            worst = v;
        }
    }
    worst
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// One view's share of a [`Search::fill`]: the drawn sets whose errors it settles, in
/// order, and what is known of the masks of the candidates they draw.
struct ViewWork {
    view: usize,
    sets: Vec<Vec<usize>>,
    known: Vec<(usize, PartialMask)>,
}

/// The measured state of a search: candidate maps and the masks computed so far.
struct Search<'a> {
    mesh: &'a Mesh,
    baker: Baker,
    measure: &'a Measure<'a>,
    /// The planned directions, then the evaluation directions.
    candidates: &'a [[f64; 3]],
    /// The directions of the views measured (see [`place`]).
    measured: &'a [[f64; 3]],
    /// Each candidate's map, baked the first time a mask of it is needed (its map does not
    /// depend on which others are baked).
    baked: Vec<Option<ReliefMap>>,
    views: &'a [OrthoView],
    /// The mesh's coverage of each view.
    references: &'a [Mask],
    /// `masks[view * candidates.len() + candidate]`: what is known of the candidate's mask
    /// in the view, within the view's reference (traced only where an error needed it).
    masks: Vec<Option<PartialMask>>,
}

impl Search<'_> {
    /// The candidates a view draws from when impostor `i` is at candidate `chosen[i]`: the
    /// `closest` facing ones, closest first, ties in impostor order (as the selection).
    fn drawn(&self, chosen: &[usize], view: usize) -> Vec<usize> {
        let w = self.measured[view];
        let mut facing: Vec<(f64, usize)> = chosen
            .iter()
            .map(|&c| (dot(self.candidates[c], w), c))
            .filter(|&(d, _)| d > 0.0)
            .collect();
        // Stable: equal dot products keep impostor order.
        facing.sort_by(|a, b| b.0.total_cmp(&a.0));
        facing.truncate(self.measure.closest);
        facing.into_iter().map(|(_, c)| c).collect()
    }

    fn slot(&self, view: usize, candidate: usize) -> usize {
        view * self.candidates.len() + candidate
    }

    /// Whether the masks kept settle the error of `view` drawn with `drawn`: each pixel of
    /// the reference is known to be covered by one of them or traced for all of them.
    fn settled(&self, view: usize, drawn: &[usize]) -> bool {
        let open = self.open(view, drawn);
        drawn
            .iter()
            .all(|&c| match &self.masks[self.slot(view, c)] {
                Some(known) => open.count_minus(known.traced()) == 0,
                None => open.count() == 0,
            })
    }

    /// The reference's pixels of `view` that none of `drawn` is known to cover.
    fn open(&self, view: usize, drawn: &[usize]) -> Mask {
        let mut open = self.references[view].clone();
        for &c in drawn {
            if let Some(known) = &self.masks[self.slot(view, c)] {
                open.remove(known.covered());
            }
        }
        open
    }

    /// Trace what the errors of `sets` in `views` need and the masks kept do not settle
    /// (views in parallel, each view's sets in order), baking the candidates they draw first.
    /// A candidate is traced only where the others drawn with it are not known to cover
    /// ([`PartialMask::uncover`]), each pixel at most once.
    fn fill(&mut self, sets: &[&[usize]], views: &[usize]) -> Result<(), PlaceError> {
        // The (view, drawn candidates) pairs not settled, in view order.
        let mut todo: Vec<(usize, Vec<usize>)> = Vec::new();
        for &view in views {
            for chosen in sets {
                let drawn = self.drawn(chosen, view);
                if !self.settled(view, &drawn) {
                    todo.push((view, drawn));
                }
            }
        }
        todo.sort_unstable();
        todo.dedup();
        if todo.is_empty() {
            return Ok(());
        }
        let mut wanted: Vec<usize> = todo.iter().flat_map(|(_, d)| d.iter().copied()).collect();
        wanted.sort_unstable();
        wanted.dedup();
        let unbaked: Vec<usize> = wanted
            .iter()
            .copied()
            .filter(|&c| self.baked[c].is_none())
            .collect();
        let directions: Vec<[f64; 3]> = unbaked.iter().map(|&c| self.candidates[c]).collect();
        if !directions.is_empty() {
            let maps = self.baker.bake(&directions, self.measure.bake)?.maps;
            for (c, map) in unbaked.into_iter().zip(maps) {
                self.baked[c] = Some(map);
            }
        }
        // Each view's pairs with the masks of the candidates they draw, taken out of the
        // search so that the views can be traced in parallel, and put back below.
        let mut groups: Vec<ViewWork> = Vec::new();
        for (view, drawn) in todo {
            if groups.last().is_none_or(|g| g.view != view) {
                groups.push(ViewWork {
                    view,
                    sets: Vec::new(),
                    known: Vec::new(),
                });
            }
            let group = groups.last_mut().expect("pushed above");
            for &c in &drawn {
                if !group.known.iter().any(|(k, _)| *k == c) {
                    let (size, slot) = (self.views[view].size, self.slot(view, c));
                    let kept = self.masks[slot].take();
                    group
                        .known
                        .push((c, kept.unwrap_or_else(|| PartialMask::new(size))));
                }
            }
            group.sets.push(drawn);
        }
        // The evaluator gets only the maps this fill traces (moved out and back, not copied),
        // so its per-map set-up is not redone for every map at every move.
        let set = ReliefSet {
            maps: wanted
                .iter()
                .map(|&c| self.baked[c].take().expect("baked above"))
                .collect(),
        };
        let (views, references) = (self.views, self.references);
        let made = Evaluator::new(self.mesh, &set, self.measure.eval).map(|evaluator| {
            groups.par_iter_mut().for_each(|group| {
                let (view, reference) = (&views[group.view], &references[group.view]);
                for drawn in &group.sets {
                    let mut open = reference.clone();
                    for (_, known) in group.known.iter().filter(|(c, _)| drawn.contains(c)) {
                        open.remove(known.covered());
                    }
                    for &c in drawn {
                        let map = wanted.binary_search(&c).expect("a wanted candidate");
                        let known = group.known.iter_mut().find(|(k, _)| *k == c);
                        let (_, known) = known.expect("taken above");
                        known.uncover(&mut open, |pixels| {
                            evaluator.impostor_mask(view, map, Some(pixels))
                        });
                    }
                }
            })
        });
        for (&c, map) in wanted.iter().zip(set.maps) {
            self.baked[c] = Some(map);
        }
        for group in groups {
            for (c, known) in group.known {
                let slot = self.slot(group.view, c);
                self.masks[slot] = Some(known);
            }
        }
        made?;
        Ok(())
    }

    /// Per view, the pixels the mesh covers that none of its drawn candidates covers. The
    /// masks must have been filled.
    fn errors(&self, chosen: &[usize]) -> Vec<u32> {
        (0..self.views.len())
            .map(|view| self.error(chosen, view))
            .collect()
    }

    fn error(&self, chosen: &[usize], view: usize) -> u32 {
        let drawn = self.drawn(chosen, view);
        debug_assert!(self.settled(view, &drawn), "masks filled before errors");
        self.open(view, &drawn).count()
    }

    /// The trials (indices into `trials`, in order) that can still win, with all their masks
    /// filled. A trial changes the drawn candidates of some views only; in the others its
    /// error is the current one (`errors`), known without a mask. The highest and the sum of
    /// a trial's errors over the views measured so far and the unchanged ones bound its score
    /// from below, so a trial is dropped as soon as that bound reaches the current score (it
    /// must score lower to be chosen) or passes the score of a trial measured in full (equals
    /// it, for a later trial: the earlier wins ties). Changed views are measured in order of
    /// their current `errors`, highest first, in growing batches; after the first few, the
    /// trials with the lowest bounds are measured in full, and their scores usually drop most
    /// of the others before their masks in the other views are computed.
    fn screen(
        &mut self,
        chosen: &[usize],
        trials: &[Vec<usize>],
        errors: &[u32],
    ) -> Result<Vec<usize>, PlaceError> {
        let current = score(errors);
        // Probes cost a trial's masks in every view it changes: after the first three batches
        // the bounds rank the trials well enough, and more probes rarely drop more (bench place).
        const PROBE_AFTER_VIEWS: usize = 7;
        const MAX_PROBES: usize = 2;
        let mut order: Vec<usize> = (0..self.views.len()).collect();
        order.sort_by_key(|&v| (std::cmp::Reverse(errors[v]), v));
        let now: Vec<Vec<usize>> = (0..self.views.len())
            .map(|v| self.drawn(chosen, v))
            .collect();
        // changed[k][v]: whether trial k draws other candidates than `chosen` in view v (as
        // ordered lists; a trial swaps one candidate for one not chosen, so the same as sets).
        let changed: Vec<Vec<bool>> = trials
            .par_iter()
            .map(|t| {
                (0..self.views.len())
                    .map(|v| self.drawn(t, v) != now[v])
                    .collect()
            })
            .collect();
        // Lower bounds of each trial's (worst error, total error).
        let mut bounds: Vec<(u32, u64)> = changed
            .iter()
            .map(|changes| {
                let unchanged = (0..errors.len())
                    .filter(|&v| !changes[v])
                    .map(|v| errors[v]);
                unchanged.fold((0, 0), |(w, t), e| (w.max(e), t + u64::from(e)))
            })
            .collect();
        // The lowest score of a trial measured in full, and that trial.
        let mut best: Option<((u32, u64), usize)> = None;
        let can_win = |bound: (u32, u64), k: usize, best: Option<((u32, u64), usize)>| {
            bound < current
                && best.is_none_or(|(score, lead)| bound < score || (bound == score && k <= lead))
        };
        let mut alive: Vec<usize> = (0..trials.len())
            .filter(|&k| can_win(bounds[k], k, best))
            .collect();
        let mut probes = 0;
        let mut start = 0;
        let mut batch = 1;
        while start < order.len() && !alive.is_empty() {
            let views = &order[start..(start + batch).min(order.len())];
            let sets: Vec<&[usize]> = alive.iter().map(|&k| &trials[k][..]).collect();
            self.fill(&sets, views)?;
            let measured: Vec<(u32, u64)> = alive
                .par_iter()
                .map(|&k| {
                    let own = views.iter().filter(|&&v| changed[k][v]);
                    let e = own.map(|&v| self.error(&trials[k], v));
                    e.fold((0, 0), |(w, t), e| (w.max(e), t + u64::from(e)))
                })
                .collect();
            for (&k, (w, t)) in alive.iter().zip(measured) {
                bounds[k] = (bounds[k].0.max(w), bounds[k].1 + t);
            }
            start += views.len();
            batch *= 2;
            if probes < MAX_PROBES && start >= PROBE_AFTER_VIEWS && start < order.len() {
                let lead = alive
                    .iter()
                    .copied()
                    .filter(|&k| best.is_none_or(|(_, lead)| lead != k))
                    .min_by_key(|&k| (bounds[k], k));
                if let Some(lead) = lead {
                    probes += 1;
                    self.fill(&[&trials[lead][..]], &order[start..])?;
                    let score = score(&self.errors(&trials[lead]));
                    if best.is_none_or(|b| (score, lead) < b) {
                        best = Some((score, lead));
                    }
                }
            }
            alive.retain(|&k| can_win(bounds[k], k, best));
        }
        Ok(alive)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screening_moves_chooses_what_scoring_every_move_chooses() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/models/stanford/bunny/bunny_npm_lowres.obj"
        );
        let mesh = ori_mesh::load_file(path.as_ref(), &Default::default())
            .expect("bunny")
            .mesh;
        let plan = ori_views::plan_views(&mesh, &Default::default()).expect("plan");
        let bake = BakeParams {
            resolution: 64,
            ..Default::default()
        };
        let eval = EvalParams {
            s0: 96,
            ..Default::default()
        };
        let measure = Measure {
            bake: &bake,
            eval: &eval,
            closest: 6,
            goal_pixels: 4,
            entropy_size: 96,
            whole: None,
        };
        let params = PlaceParams {
            max_moves: 6,
            ..Default::default()
        };
        let screened = place_scored(&mesh, &plan, &measure, &params, Scoring::Screened).unwrap();
        let every = place_scored(&mesh, &plan, &measure, &params, Scoring::Every).unwrap();
        assert!(screened.moves >= 2, "{} moves", screened.moves);
        assert_eq!(screened, every);
    }
}
