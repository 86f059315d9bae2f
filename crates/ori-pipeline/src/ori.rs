//! One ORI from a mesh and its parameters, as a flat list of named steps:
//!
//! 1. views: plan the impostor directions (`ori_views`);
//! 2. place: move them where the evaluator shows they are needed (`ori_place`);
//! 3. bake: render a relief map per direction (`ori_bake`);
//! 4. select: the per-view selection table (`ori_select`);
//! 5. plt: the runtime rule at the held-out directions, and from its worst view GC(s0) and
//!    the projected length threshold (`ori_plt`).
//!
//! The build graph runs each step as its own cached job (`stages`), calling the step functions
//! here; `eval-table` and the benches call [`build_maps`] or [`build_ori`] whole. Either way
//! the same parameters give the same bytes.

use std::time::{Duration, Instant};

use ori_bake::BakeParams;
use ori_eval::{EvalParams, Evaluator, Whole};
use ori_mesh::Mesh;
use ori_place::{Measure, PlaceError, PlaceParams, Placement};
use ori_plt::Plt;
use ori_relief::ReliefSet;
use ori_select::{HeldOut, SelectParams, Selection};
use ori_views::{ViewParams, ViewPlan};
use serde::{Deserialize, Serialize};

/// Every parameter that shapes an ORI's maps, table and PLT.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OriParams {
    pub views: ViewParams,
    pub place: PlaceParams,
    pub bake: BakeParams,
    pub select: SelectParams,
}

/// Which step failed, and why.
#[derive(Debug, thiserror::Error)]
pub enum OriError {
    #[error("views: {0}")]
    Views(#[from] ori_views::ViewError),
    #[error("place: {0}")]
    Place(#[from] PlaceError),
    #[error("bake: {0}")]
    Bake(#[from] ori_bake::BakeError),
    #[error("select: {0}")]
    Select(#[from] ori_select::SelectError),
}

/// What placement reads of the selection's parameters (its result depends on these and on
/// nothing else of `[select]`: it measures the table's views and their corners, not the
/// region's grid or goal, so tuning those does not place again).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlacementGoal {
    /// The evaluator's parameters (s0 and the runtime rule).
    pub eval: EvalParams,
    /// The most impostors the rule draws (its `M`).
    pub most_drawn: u32,
    /// The own-view goal, in pixels of s0 x s0.
    pub goal_pixels: u32,
}

impl PlacementGoal {
    pub fn of(select: &SelectParams) -> PlacementGoal {
        PlacementGoal {
            eval: select.eval_params(),
            most_drawn: select.rule.m(),
            goal_pixels: select.goal_pixels(),
        }
    }
}

/// Step 2: placement, measured with the bake and the selection that come after it (the
/// result depends on them) and the views' item-buffer size for entropies; `whole` when `mesh`
/// is a part of a larger model (a hierarchy node, measured in its own pixels).
pub fn place(
    mesh: &Mesh,
    plan: &ViewPlan,
    place: &PlaceParams,
    bake: &BakeParams,
    goal: &PlacementGoal,
    item_buffer_size: u32,
    whole: Option<Whole<'_>>,
) -> Result<Placement, PlaceError> {
    let measure = Measure {
        bake,
        eval: &goal.eval,
        closest: place.closest.min(goal.most_drawn) as usize,
        goal_pixels: goal.goal_pixels,
        entropy_size: item_buffer_size,
        whole,
    };
    ori_place::place(mesh, plan, &measure, place)
}

/// Step 4 for a part of a larger model (`whole`, a hierarchy node): the selection measured in
/// the part's own pixels; `ori_select::select` otherwise.
pub fn select(
    mesh: &Mesh,
    set: &ReliefSet,
    select: &SelectParams,
    whole: Option<Whole<'_>>,
) -> Result<Selection, ori_select::SelectError> {
    ori_select::select_with(&evaluator(mesh, set, select, whole)?, select)
}

/// The evaluator of the selection's parameters, of a part of `whole` when given.
pub fn evaluator<'a>(
    mesh: &'a Mesh,
    set: &'a ReliefSet,
    select: &SelectParams,
    whole: Option<Whole<'a>>,
) -> Result<Evaluator<'a>, ori_eval::EvalError> {
    Ok(Evaluator::new(mesh, set, &select.eval_params())?.part_of(whole))
}

/// Step 5a: the runtime rule (each view draws its nearest entry's subset) measured at the
/// held-out directions of `seed`, with the evaluator of the selection (of a part of `whole`
/// when given).
pub fn held_out(
    mesh: &Mesh,
    set: &ReliefSet,
    selection: &Selection,
    select: &SelectParams,
    seed: u64,
    whole: Option<Whole<'_>>,
) -> Result<HeldOut, ori_select::SelectError> {
    let evaluator = evaluator(mesh, set, select, whole)?;
    let subset = |w: [f64; 3]| {
        let entry = selection.lookup(w);
        entry.impostors.iter().map(|&i| usize::from(i)).collect()
    };
    ori_select::held_out(&evaluator, &ori_views::held_out_directions(seed), &subset)
}

/// Step 5b: the PLT from the held-out measure's worst view (GC(s0) there).
pub fn plt(held_out: &HeldOut) -> Plt {
    ori_plt::estimate(held_out.s0, &held_out.missed())
}

/// How long each step took.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepTimes {
    pub views: Duration,
    pub place: Duration,
    pub bake: Duration,
    pub select: Duration,
}

/// Steps 1-3: the placed plan and its relief maps.
#[derive(Clone, Debug)]
pub struct Maps {
    pub placement: Placement,
    pub set: ReliefSet,
    pub times: StepTimes,
}

/// Steps 1-3: plan, place and bake.
pub fn build_maps(mesh: &Mesh, params: &OriParams) -> Result<Maps, OriError> {
    let mut times = StepTimes::default();
    let start = Instant::now();
    let planned = ori_views::plan_views(mesh, &params.views)?;
    times.views = start.elapsed();
    let start = Instant::now();
    let placement = place(
        mesh,
        &planned,
        &params.place,
        &params.bake,
        &PlacementGoal::of(&params.select),
        params.views.item_buffer_size,
        None,
    )?;
    times.place = start.elapsed();
    let start = Instant::now();
    let set = ori_bake::bake(mesh, &placement.plan.directions, &params.bake)?;
    times.bake = start.elapsed();
    Ok(Maps {
        placement,
        set,
        times,
    })
}

/// A whole ORI: its maps, selection table, held-out measure and PLT.
#[derive(Clone, Debug)]
pub struct Ori {
    pub maps: Maps,
    pub selection: Selection,
    /// At the held-out directions of the default seed.
    pub held_out: HeldOut,
    pub plt: Plt,
}

/// All five steps.
pub fn build_ori(mesh: &Mesh, params: &OriParams) -> Result<Ori, OriError> {
    let mut maps = build_maps(mesh, params)?;
    let start = Instant::now();
    let selection = ori_select::select(mesh, &maps.set, &params.select)?;
    maps.times.select = start.elapsed();
    let held_out = held_out(
        mesh,
        &maps.set,
        &selection,
        &params.select,
        ori_views::DEFAULT_HELD_OUT_SEED,
        None,
    )?;
    let plt = plt(&held_out);
    Ok(Ori {
        maps,
        selection,
        held_out,
        plt,
    })
}
