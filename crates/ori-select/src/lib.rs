//! View-dependent impostor selection (ORI paper, 3.2; `GUIDE.md`, "Selection").
//!
//! For each of the 320 evaluation directions ([`ori_views::evaluation_directions`]) the
//! selection table stores the ordered list of impostors to draw, closest direction first. At
//! runtime the entry of the nearest evaluation direction is used ([`Selection::lookup`]).
//!
//! Rules ([`Rule`]): `closest:M` draws the M closest facing impostors; `best:M` (default
//! `best:8`, goal 0.2 % of s0 x s0) tries the subsets of the M closest facing impostors by
//! size and keeps the first size that reaches the goal, with the guide's tie-breaking
//! ([`choose_region`]). Placement (`ori_place`) makes each view drawable with its 6 closest
//! (below a hierarchy's root, its 8); the two farther candidates serve the corners of an
//! entry's region, whose own closest impostors are often not the entry's.
//!
//! # Each entry serves a region
//! The runtime draws, at any direction, the entry of the nearest evaluation direction, so an
//! entry serves its cell of directions, about its spherical triangle. `best:M` therefore
//! measures a subset in the entry's own view and at directions over the cell
//! ([`SelectParams::regions`]: the points of a grid over the triangle,
//! [`ori_views::evaluation_regions`], that the entry serves, and its cell's corners; at the
//! default `region_steps = 6`, 29 to 31 per entry, 5,922 views in all, most shared by
//! neighbouring entries), and a subset reaches the goal only when it does in its own view
//! (`goal_percent`) and at every one of those (`edge_goal_percent`). The region's views are
//! drawn at `s0 * region_scale` pixels across (default 0.75: 192 at s0 = 256), the same
//! window with fewer pixels to trace, their errors counted in pixels of s0 ([`own_pixels`]).
//! Coarser counts vary more from view to view, so at 0.5 the same goals take a few more
//! impostors per view. The entry's `missed` stays the error in its own view (the table's
//! figures); quality is reported at held-out directions ([`held_out`]).
//!
//! Work (parallel over views, then over entries, collected in order): the [`MaskPlan`] lists
//! the views and the impostors to trace in each; the mesh's coverage of every view is
//! rendered up front, and an impostor's coverage mask in a view only where the subset search
//! needs it, each pixel once ([`select_with`]): a subset's error is the pixels no member
//! covers, so a member is traced only at the pixels the others are not known to cover. The
//! search measures every subset in the entry's own view and its region's corners, and the
//! rest of the grid only for the subsets that can still win, so most masks of the grid are
//! never traced, and the choice is the one a search over every mask makes
//! ([`select_from_masks`], which `--backend gpu` feeds with masks traced on the device).
//! Masks are combined with OR and popcount. Each pixel of a mask has one value whichever
//! thread traces it and an error does not depend on which pixels were traced before, and each
//! entry is chosen by one thread and collected in order, so the table
//! ([`Selection::encode`]) is bit-identical for any number of threads.
//! [`evaluate_rules`] renders full images for the extra measures (inverse coverage, p_dif,
//! depth error) of `cargo xtask eval-table`.
//!
//! # Quality on the Stanford scans
//!
//! With the pipeline's defaults (n = 20 perturbed directions moved by the placement search
//! `ori_place`, 256 x 256 maps, s0 = 256, 16 + 7 steps over the columns the ray crosses,
//! wall threshold 0.25), best:6 at its own 320 directions, chosen at each direction alone,
//! measured with `cargo xtask eval-table`:
//!
//! | model | average | maximum | impostors per view | PLT |
//! |---|---|---|---|---|
//! | armadillo | 0.118 % | 0.200 % | 2.65 | 500 |
//! | Stanford bunny | 0.101 % | 0.200 % | 2.33 | 500 |
//! | paper's armadillo | 0.17 % | 0.37 % | 2.9 | 270 |
//!
//! How the armadillo got there from 0.398 % / 1.242 % / 5.97: conservative edge texels in
//! the bake (0.271 %); the 16 linear steps spent inside each map's occupied volume
//! (0.246 %), then inside the columns the ray crosses (0.150 %, 3.21 impostors per view:
//! grazing rays no longer step over thin parts); the wall threshold raised from 0.125 to
//! 0.25 (0.130 %, 0.362 %, 2.72; the trade-off is in `ori_eval`'s documentation); placement
//! (above). The bunny went from 0.305 % / 1.447 % / 3.63 to 0.151 % / 1.573 % / 2.65 when
//! single-sided meshes began to be drawn as engines draw them, back faces culled (`ori_eval`,
//! "The mesh as an engine draws it"); its worst views then looked up through the holes in
//! the scan's base, past the culled inside, at parts no impostor near them saw. Placement
//! moves impostors until those views are within the goal (with a margin, `[place]
//! goal_scale`).
//!
//! Subsets chosen at one direction did not hold a few degrees away (the held-out worst views
//! lost five to sixteen times the table's), which is why `best:M` now chooses over regions;
//! `ori-pipeline`'s quality tests hold the held-out figures.

mod choose;
mod codec;
mod lazy;
mod report;
mod rule;

use ori_eval::Evaluator;
use ori_mesh::Mesh;
use ori_raster::OrthoView;
use ori_relief::ReliefSet;
use rayon::prelude::*;

use lazy::LazyView;

pub use choose::{Choice, Goals, ViewMasks, choose, choose_region, own_pixels};
pub use ori_artifact::DecodeError;
pub use report::{HeldOut, RuleSummary, RuleView, evaluate_rules, held_out, summarize};
pub use rule::{MAX_BEST, MAX_CLOSEST, RegionShape, Rule, SelectParams};

/// Why selection failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SelectError {
    /// A `[select]` parameter is out of range; the message names the key.
    #[error("invalid selection parameters: {0}")]
    Params(String),
    /// The evaluator could not render a view.
    #[error(transparent)]
    Eval(#[from] ori_eval::EvalError),
    /// The masks given are not those of the rule's [`MaskPlan`].
    #[error("selection needs the masks of {expected} views, got {got}")]
    Masks { expected: usize, got: usize },
    /// A view's masks are not at the size the rule's [`MaskPlan`] draws it.
    #[error("selection needs view {view}'s masks at {expected} x {expected} pixels, got {got}")]
    MaskSize {
        view: usize,
        expected: u32,
        got: u32,
    },
}

/// The selection of one evaluation direction.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Impostor indices to draw, closest direction first.
    pub impostors: Vec<u16>,
    /// Coverage error d_i(s0) of that subset, in pixels.
    pub missed: u32,
}

/// The selection table: the stage's artifact.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// The rule that chose it.
    pub rule: Rule,
    /// The goal it was chosen for (percent of s0 x s0).
    pub goal_percent: f64,
    /// Evaluation image edge.
    pub s0: u32,
    /// Number of impostors in the relief set.
    pub impostor_count: u32,
    /// One entry per evaluation direction, in the order of
    /// [`ori_views::evaluation_directions`].
    pub entries: Vec<Entry>,
}

/// Summary figures of a selection (the rows of the paper's Table 1).
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    /// Coverage error over the directions, in percent of s0 x s0.
    pub min_percent: f64,
    pub max_percent: f64,
    pub avg_percent: f64,
    /// The worst direction (lowest index on ties) and its error in pixels, GC(s0).
    pub worst_direction: usize,
    pub max_missed: u32,
    /// Average impostors per view.
    pub avg_impostors: f64,
    /// `views_by_count[k]`: directions that draw `k` impostors.
    pub views_by_count: Vec<u32>,
}

impl Selection {
    fn of(params: &SelectParams, impostor_count: usize, entries: Vec<Entry>) -> Selection {
        Selection {
            rule: params.rule,
            goal_percent: params.goal_percent,
            s0: params.s0,
            impostor_count: impostor_count as u32,
            entries,
        }
    }

    /// The coverage error of each direction, in pixels.
    pub fn missed(&self) -> Vec<u32> {
        self.entries.iter().map(|e| e.missed).collect()
    }

    /// Summary statistics, reduced in direction order.
    pub fn stats(&self) -> Stats {
        let s2 = f64::from(self.s0) * f64::from(self.s0);
        let pct = |m: u32| 100.0 * f64::from(m) / s2;
        let n = self.entries.len().max(1) as f64;
        let mut worst = (0usize, 0u32);
        let mut min = u32::MAX;
        let (mut sum, mut count) = (0u64, 0u64);
        let mut views_by_count = Vec::new();
        for (i, e) in self.entries.iter().enumerate() {
            if e.missed > worst.1 {
                worst = (i, e.missed);
            }
            min = min.min(e.missed);
            sum += u64::from(e.missed);
            count += e.impostors.len() as u64;
            if views_by_count.len() <= e.impostors.len() {
                views_by_count.resize(e.impostors.len() + 1, 0);
            }
            views_by_count[e.impostors.len()] += 1;
        }
        Stats {
            min_percent: if self.entries.is_empty() {
                0.0
            } else {
                pct(min)
            },
            max_percent: pct(worst.1),
            avg_percent: 100.0 * sum as f64 / s2 / n,
            worst_direction: worst.0,
            max_missed: worst.1,
            avg_impostors: count as f64 / n,
            views_by_count,
        }
    }

    /// The entry of the evaluation direction nearest to `w` (unit, from the object towards
    /// the viewer): largest dot product, lowest index on ties.
    pub fn lookup(&self, w: [f64; 3]) -> &Entry {
        &self.entries[self.nearest(w)]
    }

    /// The index of the entry [`Selection::lookup`] returns. `w` is made unit first (as a
    /// renderer's view direction is), so a direction a few ulps off unit length looks up the
    /// entry its unit vector does.
    pub fn nearest(&self, w: [f64; 3]) -> usize {
        let w = ori_raster::normalize(w);
        // Called once per view the held-out measure draws: the directions are made once.
        static DIRECTIONS: std::sync::OnceLock<Vec<[f64; 3]>> = std::sync::OnceLock::new();
        let dirs = DIRECTIONS.get_or_init(ori_views::evaluation_directions);
        let mut best = (0, f64::NEG_INFINITY);
        for (i, d) in dirs.iter().enumerate().take(self.entries.len()) {
            let dot = d[0] * w[0] + d[1] * w[1] + d[2] * w[2];
            if dot > best.1 {
                best = (i, dot);
            }
        }
        best.0
    }

    /// The canonical byte layout (see `codec.rs`).
    pub fn encode(&self) -> Vec<u8> {
        codec::encode(self)
    }

    pub fn decode(bytes: &[u8]) -> Result<Selection, DecodeError> {
        codec::decode(bytes)
    }
}

/// The views selection measures: the evaluation directions, each with its `M` closest facing
/// impostors (closest first), then for `best:M` the grid over the region each entry serves
/// ([`SelectParams::regions`]), each with every impostor the entries around it may
/// choose (ascending), drawn at `s0 * region_scale`. Computed on the CPU, whichever backend
/// traces.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskPlan {
    /// View directions, in order.
    pub directions: Vec<[f64; 3]>,
    /// The impostors to trace in each view.
    pub impostors: Vec<Vec<usize>>,
    /// Views before this one are the entries' own, drawn at s0; the rest are the regions'.
    pub own_views: usize,
    /// The image edge of the regions' views.
    pub region_size: u32,
    /// Each entry's region: its views, as indices past `own_views` (none for `closest:M`).
    pub regions: Vec<Vec<usize>>,
}

impl MaskPlan {
    pub fn new(evaluator: &Evaluator<'_>, params: &SelectParams) -> MaskPlan {
        let m = params.rule.m() as usize;
        let mut directions = ori_views::evaluation_directions();
        let own_views = directions.len();
        let mut impostors: Vec<Vec<usize>> = directions
            .iter()
            .map(|&w| evaluator.facing(w).into_iter().take(m).collect())
            .collect();
        let mut regions = Vec::new();
        if let Rule::Best(_) = params.rule {
            let grid = params.regions();
            let mut around = vec![Vec::new(); grid.samples.len()];
            for (entry, samples) in grid.of_direction.iter().enumerate() {
                for &s in samples {
                    around[s].extend_from_slice(&impostors[entry]);
                }
            }
            for list in &mut around {
                list.sort_unstable();
                list.dedup();
            }
            directions.extend(grid.samples);
            impostors.extend(around);
            regions = grid.of_direction;
        }
        MaskPlan {
            directions,
            impostors,
            own_views,
            region_size: params.region_size(),
            regions,
        }
    }

    /// The frame of view `k`: the evaluator's, at the region's size past the own views.
    pub fn view(&self, evaluator: &Evaluator<'_>, k: usize) -> Result<OrthoView, SelectError> {
        let view = evaluator.view(self.directions[k])?;
        Ok(if k < self.own_views {
            view
        } else {
            view.with_size(self.region_size)
        })
    }
}

/// The masks of one view: the mesh's coverage in `view` and, for each of `impostors` in order,
/// the pixels of that coverage it draws.
pub fn view_masks(evaluator: &Evaluator<'_>, view: &OrthoView, impostors: &[usize]) -> ViewMasks {
    let reference = evaluator.mesh_coverage(view);
    let candidates = impostors
        .iter()
        .map(|&i| (i, evaluator.impostor_mask(view, i, Some(&reference))))
        .collect();
    ViewMasks {
        reference,
        candidates,
    }
}

/// [`view_masks`] for every view of `plan`, in parallel, in order.
pub fn all_view_masks(
    evaluator: &Evaluator<'_>,
    plan: &MaskPlan,
) -> Result<Vec<ViewMasks>, SelectError> {
    (0..plan.directions.len())
        .into_par_iter()
        .map(|k| {
            let view = plan.view(evaluator, k)?;
            Ok(view_masks(evaluator, &view, &plan.impostors[k]))
        })
        .collect()
}

/// The selection from the masks of the views of a [`MaskPlan`] for `params.rule`, in order.
pub fn select_from_masks(
    masks: &[ViewMasks],
    params: &SelectParams,
    impostor_count: usize,
) -> Result<Selection, SelectError> {
    params.validate()?;
    let count = ori_views::evaluation_directions().len();
    let regions = region_samples(params);
    let expected = count + regions.iter().flatten().max().map_or(0, |&s| s + 1);
    if masks.len() != expected {
        return Err(SelectError::Masks {
            expected,
            got: masks.len(),
        });
    }
    for (k, m) in masks.iter().enumerate() {
        let size = if k < count {
            params.s0
        } else {
            params.region_size()
        };
        if m.reference.size() != size {
            return Err(SelectError::MaskSize {
                view: k,
                expected: size,
                got: m.reference.size(),
            });
        }
    }
    let goals = params.goals();
    let entries = choose_entries(masks, &regions, |own, region| {
        choose_region(own, region, params.rule, goals)
    });
    Ok(Selection::of(params, impostor_count, entries))
}

/// For each evaluation direction, its region's views (`best:M`; none for `closest:M`) as
/// indices into [`SelectParams::regions`]' samples, the triangle's corners first.
fn region_samples(params: &SelectParams) -> Vec<Vec<usize>> {
    match params.rule {
        Rule::Best(_) => params.regions().of_direction,
        Rule::Closest(_) => Vec::new(),
    }
}

/// Each entry chosen by `choose` from its own view and its region's, in parallel, in order.
/// `views` are in a [`MaskPlan`]'s order: the evaluation directions, then the region samples
/// that `regions` (a [`MaskPlan`]'s) index.
fn choose_entries<T: Sync>(
    views: &[T],
    regions: &[Vec<usize>],
    choose: impl Fn(&T, &[&T]) -> Choice + Sync,
) -> Vec<Entry> {
    let count = ori_views::evaluation_directions().len();
    (0..count)
        .into_par_iter()
        .map(|e| {
            let region: Vec<&T> = regions
                .get(e)
                .map_or(&[][..], |r| &r[..])
                .iter()
                .map(|&s| &views[count + s])
                .collect();
            let c = choose(&views[e], &region);
            Entry {
                impostors: c.impostors.iter().map(|&i| i as u16).collect(),
                missed: c.missed,
            }
        })
        .collect()
}

/// Select the impostors of `mesh`'s relief set for each of the 320 evaluation directions.
pub fn select(
    mesh: &Mesh,
    set: &ReliefSet,
    params: &SelectParams,
) -> Result<Selection, SelectError> {
    params.validate()?;
    select_with(&Evaluator::new(mesh, set, &params.eval_params())?, params)
}

/// [`select`] measured by `evaluator`, made with `params.eval_params()` (e.g. one that
/// measures a part of a larger model, `Evaluator::part_of`).
pub fn select_with(
    evaluator: &Evaluator<'_>,
    params: &SelectParams,
) -> Result<Selection, SelectError> {
    params.validate()?;
    let plan = MaskPlan::new(evaluator, params);
    let views: Vec<LazyView> = (0..plan.directions.len())
        .into_par_iter()
        .map(|k| {
            Ok(LazyView::new(
                evaluator,
                plan.view(evaluator, k)?,
                &plan.impostors[k],
            ))
        })
        .collect::<Result<_, SelectError>>()?;
    let goals = params.goals();
    let entries = choose_entries(&views, &plan.regions, |own, region| {
        lazy::choose_entry(evaluator, own, region, params.rule, goals)
    });
    Ok(Selection::of(params, evaluator.set().maps.len(), entries))
}
