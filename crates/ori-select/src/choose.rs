//! The subset search of one view: masks in, ordered impostor list out.

use ori_eval::Mask;

use crate::Rule;

/// One view's candidates: the reference coverage and the coverage mask of each of the `M`
/// closest facing impostors, closest first.
#[derive(Clone, Debug)]
pub struct ViewMasks {
    /// Pixels the mesh covers.
    pub reference: Mask,
    /// (impostor index, pixels of `reference` it covers), closest direction first.
    pub candidates: Vec<(usize, Mask)>,
}

/// The chosen impostors of one view.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Choice {
    /// Impostor indices, closest direction first (the drawing order).
    pub impostors: Vec<usize>,
    /// Coverage error d_i(s0) of the subset, in pixels.
    pub missed: u32,
}

/// Choose the impostors of one view: [`choose_region`] with no other views.
pub fn choose(masks: &ViewMasks, rule: Rule, goal: u32) -> Choice {
    choose_region(
        masks,
        &[],
        rule,
        Goals {
            own: goal,
            edge: goal,
        },
    )
}

/// The coverage error a subset may leave, in pixels: in an entry's own view, and in each view
/// at the edge of its region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Goals {
    pub own: u32,
    pub edge: u32,
}

/// Choose the impostors of one table entry, measured in its own view and in the views at the
/// edge of the region of directions it serves (`region`; each must hold a mask for every
/// candidate of `own`, other masks are ignored).
///
/// - `closest:M`: all candidates (the `M` closest facing impostors of `own`).
/// - `best:M`: try every subset of the candidates of size 1, then 2, and so on. A subset
///   reaches the goals when its error in `own` is at most `goals.own` and in every view of
///   `region` at most `goals.edge`; its error is its worst view's coverage error (then, on
///   ties, the sum over the views). The first size at which some subset reaches the goals
///   wins, and within that size the subset with the least error; ties go to the subset whose
///   impostor indices, sorted ascending, are lexicographically smaller. If no subset reaches
///   the goals, the subset with the least error wins, the smaller on ties (then the lower
///   indices).
///
/// Subsets are unions of masks (OR), their error a popcount: nothing is re-rendered. The
/// choice's `missed` is the error in `own`.
pub fn choose_region(own: &ViewMasks, region: &[&ViewMasks], rule: Rule, goals: Goals) -> Choice {
    let k = own.candidates.len().min(rule.m() as usize);
    let views: Vec<Measured<'_>> = std::iter::once(own)
        .chain(region.iter().copied())
        .map(|v| Measured::of(v, own))
        .collect();
    if let Rule::Closest(_) = rule {
        // Up to MAX_CLOSEST candidates: more than a subset's bits hold.
        return Choice {
            impostors: own.candidates[..k].iter().map(|c| c.0).collect(),
            missed: views[0].missed_where(|bit| bit < k),
        };
    }
    // best:M has M <= MAX_BEST, so a subset is a bit set in a u32. Subsets are ordered by
    // (over a goal, error, size, sorted impostor indices): the rule's order within a size
    // and, when no size reaches the goals, over all sizes.
    let all: u32 = if k == 0 { 0 } else { u32::MAX >> (32 - k) };
    let key = |subset: u32| {
        let missed: Vec<u32> = views.iter().map(|v| v.missed(subset)).collect();
        let over = missed[0] > goals.own || missed[1..].iter().any(|&m| m > goals.edge);
        let worst = missed.iter().copied().max().unwrap_or(0);
        let total: u64 = missed.iter().map(|&m| u64::from(m)).sum();
        let mut sorted = indices_of(own, subset);
        sorted.sort_unstable();
        (over, worst, total, subset.count_ones(), sorted, subset)
    };
    let mut overall = None;
    let mut reached = None;
    for size in 1..=k as u32 {
        let best = (1..=all)
            .filter(|s| s.count_ones() == size)
            .map(key)
            .min()
            .expect("a subset of every size up to k");
        if !best.0 {
            reached = Some(best);
            break;
        }
        if overall.as_ref().is_none_or(|o| best < *o) {
            overall = Some(best);
        }
    }
    let chosen = reached.or(overall).map_or(0, |b| b.5);
    Choice {
        impostors: indices_of(own, chosen),
        missed: views[0].missed(chosen),
    }
}

/// One view's masks lined up with the candidates of the entry being chosen.
struct Measured<'a> {
    reference: &'a [u64],
    /// The mask of candidate `bit` of the entry in this view (`None`: none given, nothing
    /// drawn).
    candidates: Vec<Option<&'a [u64]>>,
}

impl<'a> Measured<'a> {
    fn of(view: &'a ViewMasks, own: &ViewMasks) -> Measured<'a> {
        let candidates = own
            .candidates
            .iter()
            .map(|(id, _)| {
                view.candidates
                    .iter()
                    .find(|(i, _)| i == id)
                    .map(|(_, m)| m.words())
            })
            .collect();
        Measured {
            reference: view.reference.words(),
            candidates,
        }
    }

    /// Coverage error of the union of the candidates in bit set `subset`.
    fn missed(&self, subset: u32) -> u32 {
        self.missed_where(|bit| subset >> bit & 1 != 0)
    }

    /// Coverage error of the union of the candidates whose position `chosen` accepts.
    fn missed_where(&self, chosen: impl Fn(usize) -> bool) -> u32 {
        let members: Vec<&[u64]> = self
            .candidates
            .iter()
            .enumerate()
            .filter(|(bit, _)| chosen(*bit))
            .filter_map(|(_, m)| *m)
            .collect();
        self.reference
            .iter()
            .enumerate()
            .map(|(w, &r)| {
                let union = members.iter().fold(0u64, |acc, m| acc | m[w]);
                (r & !union).count_ones()
            })
            .sum()
    }
}

/// Impostor indices of the candidates in bit set `subset`, closest first.
fn indices_of(masks: &ViewMasks, subset: u32) -> Vec<usize> {
    (0..masks.candidates.len())
        .filter(|&bit| subset >> bit & 1 != 0)
        .map(|bit| masks.candidates[bit].0)
        .collect()
}
