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

/// Choose the impostors of one view.
///
/// - `closest:M`: all candidates (the `M` closest facing impostors).
/// - `best:M`: try every subset of the candidates of size 1, then 2, and so on; the first size
///   at which some subset has coverage error `<= goal` wins, and within that size the subset
///   with the least error; ties go to the subset whose impostor indices, sorted ascending,
///   are lexicographically smaller. If no subset reaches the goal, the subset with the least
///   error wins, the smaller on ties (then the lower indices).
///
/// Subsets are unions of masks (OR), their error a popcount: nothing is re-rendered.
pub fn choose(masks: &ViewMasks, rule: Rule, goal: u32) -> Choice {
    let k = masks.candidates.len().min(rule.m() as usize);
    let all: u32 = if k == 0 { 0 } else { u32::MAX >> (32 - k) };
    let chosen = match rule {
        Rule::Closest(_) => all,
        Rule::Best(_) => {
            // Subsets ordered by (error, size, sorted impostor indices): the rule's order
            // within a size and, when no size reaches the goal, over all sizes.
            let key = |subset: u32| {
                let mut sorted = indices_of(masks, subset);
                sorted.sort_unstable();
                (
                    missed_of(masks, subset),
                    subset.count_ones(),
                    sorted,
                    subset,
                )
            };
            let mut overall = None;
            let mut reached = None;
            for size in 1..=k as u32 {
                let best = (1..=all)
                    .filter(|s| s.count_ones() == size)
                    .map(key)
                    .min()
                    .expect("a subset of every size up to k");
                if best.0 <= goal {
                    reached = Some(best);
                    break;
                }
                if overall.as_ref().is_none_or(|o| best < *o) {
                    overall = Some(best);
                }
            }
            reached.or(overall).map_or(0, |b| b.3)
        }
    };
    Choice {
        impostors: indices_of(masks, chosen),
        missed: missed_of(masks, chosen),
    }
}

/// Coverage error of the union of the candidates in bit set `subset`.
fn missed_of(masks: &ViewMasks, subset: u32) -> u32 {
    let members: Vec<&[u64]> = masks
        .candidates
        .iter()
        .enumerate()
        .filter(|(bit, _)| subset >> bit & 1 != 0)
        .map(|(_, (_, m))| m.words())
        .collect();
    masks
        .reference
        .words()
        .iter()
        .enumerate()
        .map(|(w, &r)| {
            let union = members.iter().fold(0u64, |acc, m| acc | m[w]);
            (r & !union).count_ones()
        })
        .sum()
}

/// Impostor indices of the candidates in bit set `subset`, closest first.
fn indices_of(masks: &ViewMasks, subset: u32) -> Vec<usize> {
    (0..masks.candidates.len())
        .filter(|&bit| subset >> bit & 1 != 0)
        .map(|bit| masks.candidates[bit].0)
        .collect()
}
