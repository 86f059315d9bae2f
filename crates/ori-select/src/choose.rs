//! The subset search of one table entry: masks in, ordered impostor list out.

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

/// The coverage error a subset may leave, in pixels of the entry's own view: in that view,
/// and in each view of its region.
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
///   `region` at most `goals.edge`, a region view's error counted in pixels of `own`
///   ([`own_pixels`]; the region's views may be drawn smaller, `SelectParams::region_scale`);
///   its error is its worst view's coverage error so counted (then, on ties, the sum over the
///   views). The first size at which some subset reaches the goals
///   wins, and within that size the subset with the least error; ties go to the subset whose
///   impostor indices, sorted ascending, are lexicographically smaller. If no subset reaches
///   the goals, the subset with the least error wins, the smaller on ties (then the lower
///   indices).
///
/// Subsets are unions of masks (OR), their error a popcount: nothing is re-rendered. The
/// choice's `missed` is the error in `own`.
pub fn choose_region(own: &ViewMasks, region: &[&ViewMasks], rule: Rule, goals: Goals) -> Choice {
    let ids: Vec<usize> = own.candidates.iter().map(|c| c.0).collect();
    let views = Given(
        std::iter::once(own)
            .chain(region.iter().copied())
            .map(|v| Measured::of(v, &ids))
            .collect(),
    );
    let every = views.0.len();
    choose_with(&views, &ids, rule, goals, every)
}

/// The masks one entry's choice reads, by view (0: the entry's own, then its region) and by
/// candidate (`bit`: the entry's candidate `bit`, closest first), as the errors of unions.
pub(crate) trait EntryMasks {
    fn view_count(&self) -> usize;
    /// The view's edge in pixels.
    fn size(&self, view: usize) -> u32;

    /// Coverage error in `view` of the union of the first `k` candidates that `chosen`
    /// accepts (a candidate with no mask in `view` draws nothing there).
    fn missed_where(&self, view: usize, k: usize, chosen: impl Fn(usize) -> bool) -> u32;

    /// Coverage error in `view` of the union of the candidates in bit set `subset`.
    fn missed(&self, view: usize, subset: u32) -> u32 {
        let bits = 32 - subset.leading_zeros() as usize;
        self.missed_where(view, bits, |bit| subset >> bit & 1 != 0)
    }
}

/// [`choose_region`]'s rule on masks from `masks`, for the first `M` of the candidates `ids`
/// (closest first).
///
/// The views before `bound` (at least the own view) are measured for every subset; the
/// others only for the subsets that can still win, in order of their error in those first
/// views, a lower bound of their error in all of them. So where `masks` traces what the
/// search reads when it is first read, the views beyond `bound` cost only what it reads, and
/// the choice is the same for any `bound`.
pub(crate) fn choose_with(
    masks: &impl EntryMasks,
    ids: &[usize],
    rule: Rule,
    goals: Goals,
    bound: usize,
) -> Choice {
    let ids = &ids[..ids.len().min(rule.m() as usize)];
    let k = ids.len();
    if let Rule::Closest(_) = rule {
        // Up to MAX_CLOSEST candidates: more than a subset's bits hold.
        return Choice {
            impostors: ids.to_vec(),
            missed: masks.missed_where(0, k, |_| true),
        };
    }
    let chosen = search_best(masks, ids, goals, bound);
    Choice {
        impostors: indices_of(ids, chosen),
        missed: masks.missed(0, chosen),
    }
}

/// A subset's error over the views measured so far.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Measure {
    worst: u32,
    total: u64,
    sorted: Vec<usize>,
    subset: u32,
}

impl Measure {
    fn new(ids: &[usize], subset: u32) -> Measure {
        let mut sorted = indices_of(ids, subset);
        sorted.sort_unstable();
        Measure {
            worst: 0,
            total: 0,
            sorted,
            subset,
        }
    }

    fn add(&mut self, missed: u32) {
        self.worst = self.worst.max(missed);
        self.total += u64::from(missed);
    }

    /// What every view not yet measured can only raise.
    fn score(&self) -> (u32, u64) {
        (self.worst, self.total)
    }
}

/// `best:M`'s subset (a bit set over `ids`), in [`choose_region`]'s order.
fn search_best(masks: &impl EntryMasks, ids: &[usize], goals: Goals, bound: usize) -> u32 {
    let k = ids.len();
    let views = masks.view_count();
    let bound = bound.clamp(1, views);
    let goal = |view: usize| if view == 0 { goals.own } else { goals.edge };
    let count = |view: usize, subset: u32| {
        own_pixels(masks.missed(view, subset), masks.size(view), masks.size(0))
    };
    // best:M has M <= MAX_BEST, so a subset is a bit set in a u32.
    let all: u32 = if k == 0 { 0 } else { u32::MAX >> (32 - k) };
    // Measures `m` in the views before the bound; false once one is over its goal.
    let within_goals = |m: &mut Measure| {
        (0..bound).all(|view| {
            let missed = count(view, m.subset);
            m.add(missed);
            missed <= goal(view)
        })
    };
    for size in 1..=k as u32 {
        let mut open: Vec<Measure> = (1..=all)
            .filter(|s| s.count_ones() == size)
            .map(|subset| Measure::new(ids, subset))
            .filter_map(|mut m| within_goals(&mut m).then_some(m))
            .collect();
        open.sort_unstable();
        let mut best: Option<Measure> = None;
        'open: for mut m in open {
            if best.as_ref().is_some_and(|b| m.score() > b.score()) {
                break;
            }
            for view in bound..views {
                let missed = count(view, m.subset);
                m.add(missed);
                if missed > goal(view) || best.as_ref().is_some_and(|b| m.score() > b.score()) {
                    continue 'open;
                }
            }
            if best.as_ref().is_none_or(|b| m < *b) {
                best = Some(m);
            }
        }
        if let Some(b) = best {
            return b.subset;
        }
    }
    // No subset reaches the goals: the least error over all views, the smaller on ties, then
    // the lower indices. A union only grows, so in every view no subset misses fewer pixels
    // than all the candidates together: the least (worst, total) error is theirs, and a
    // subset has it exactly when it misses as few as they do in every view. So the smallest
    // such subset wins (all of them when no smaller one does), and a subset is dropped at
    // the first view where it misses more: a lazy source traces the masks of later views
    // only for the subsets still in the running, which on models whose goals are out of
    // reach is most of the search.
    let mut least: Vec<Option<u32>> = vec![None; views];
    let mut ties = |subset: u32| {
        (0..views).all(|view| {
            let floor = *least[view].get_or_insert_with(|| masks.missed(view, all));
            masks.missed(view, subset) == floor
        })
    };
    for size in 1..k as u32 {
        let tied = (1..=all)
            .filter(|s| s.count_ones() == size)
            .filter(|&s| ties(s))
            .min_by_key(|&s| Measure::new(ids, s).sorted);
        if let Some(subset) = tied {
            return subset;
        }
    }
    all
}

/// `missed` pixels of a view `size` pixels across counted in pixels of a view `own` across:
/// `missed * own^2 / size^2`, rounded half up (exact where `size` divides `own`, so `missed`
/// itself at the same size).
pub fn own_pixels(missed: u32, size: u32, own: u32) -> u32 {
    let (a, b) = (u64::from(own).pow(2), u64::from(size.max(1)).pow(2));
    u32::try_from((u64::from(missed) * a + b / 2) / b).unwrap_or(u32::MAX)
}

/// Masks given in full ([`choose_region`]).
struct Given<'a>(Vec<Measured<'a>>);

/// One view's masks lined up with the candidates of the entry being chosen.
struct Measured<'a> {
    size: u32,
    reference: &'a [u64],
    candidates: Vec<Option<&'a [u64]>>,
}

impl<'a> Measured<'a> {
    fn of(view: &'a ViewMasks, ids: &[usize]) -> Measured<'a> {
        let candidates = ids
            .iter()
            .map(|id| {
                view.candidates
                    .iter()
                    .find(|(i, _)| i == id)
                    .map(|(_, m)| m.words())
            })
            .collect();
        Measured {
            size: view.reference.size(),
            reference: view.reference.words(),
            candidates,
        }
    }
}

impl Given<'_> {
    /// The mask of candidate `bit` in `view`; `None`: none given, nothing drawn.
    fn candidate(&self, view: usize, bit: usize) -> Option<&[u64]> {
        self.0[view].candidates[bit]
    }
}

impl EntryMasks for Given<'_> {
    fn view_count(&self) -> usize {
        self.0.len()
    }

    fn size(&self, view: usize) -> u32 {
        self.0[view].size
    }

    fn missed_where(&self, view: usize, k: usize, chosen: impl Fn(usize) -> bool) -> u32 {
        let members: Vec<&[u64]> = (0..k)
            .filter(|&bit| chosen(bit))
            .filter_map(|bit| self.candidate(view, bit))
            .collect();
        self.0[view]
            .reference
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
fn indices_of(ids: &[usize], subset: u32) -> Vec<usize> {
    (0..ids.len())
        .filter(|&bit| subset >> bit & 1 != 0)
        .map(|bit| ids[bit])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small portable generator (xorshift64*), so the cases are the same everywhere.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }

        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
    }

    /// A `size` x `size` mask of pixels each set with probability `percent`.
    fn random_mask(rng: &mut Rng, size: u32, percent: u64) -> Mask {
        let mut m = Mask::new(size);
        (0..(size * size) as usize)
            .filter(|_| rng.below(100) < percent)
            .for_each(|i| m.set(i));
        m
    }

    /// Counts the masks read, as the lazy source traces them.
    struct Counted<'a>(
        Given<'a>,
        std::cell::RefCell<std::collections::BTreeSet<(usize, usize)>>,
    );

    impl EntryMasks for Counted<'_> {
        fn view_count(&self) -> usize {
            self.0.view_count()
        }
        fn size(&self, view: usize) -> u32 {
            self.0.size(view)
        }
        fn missed_where(&self, view: usize, k: usize, chosen: impl Fn(usize) -> bool) -> u32 {
            let mut read = self.1.borrow_mut();
            for bit in (0..k).filter(|&bit| chosen(bit)) {
                if self.0.candidate(view, bit).is_some() {
                    read.insert((view, bit));
                }
            }
            self.0.missed_where(view, k, chosen)
        }
    }

    /// The search as first written, every subset measured in every view: the oracle.
    fn exhaustive(views: &[ViewMasks], ids: &[usize], goals: Goals) -> u32 {
        let missed = |v: &ViewMasks, subset: u32| {
            let mut union = Mask::new(v.reference.size());
            for (bit, id) in ids.iter().enumerate() {
                let mask = v.candidates.iter().find(|(i, _)| i == id);
                if let (true, Some((_, m))) = (subset >> bit & 1 != 0, mask) {
                    union.union_with(m);
                }
            }
            v.reference.count_minus(&union)
        };
        let key = |subset: u32| {
            let missed: Vec<u32> = views
                .iter()
                .map(|v| own_pixels(missed(v, subset), v.reference.size(), 4))
                .collect();
            let over = missed[0] > goals.own || missed[1..].iter().any(|&m| m > goals.edge);
            let worst = missed.iter().copied().max().unwrap_or(0);
            let total: u64 = missed.iter().map(|&m| u64::from(m)).sum();
            let mut sorted = indices_of(ids, subset);
            sorted.sort_unstable();
            (over, worst, total, subset.count_ones(), sorted, subset)
        };
        let k = ids.len();
        let all: u32 = if k == 0 { 0 } else { u32::MAX >> (32 - k) };
        let mut overall = None;
        for size in 1..=k as u32 {
            let best = (1..=all)
                .filter(|s| s.count_ones() == size)
                .map(key)
                .min()
                .expect("a subset of every size");
            if !best.0 {
                return best.5;
            }
            if overall.as_ref().is_none_or(|o| best < *o) {
                overall = Some(best);
            }
        }
        overall.map_or(0, |b| b.5)
    }

    #[test]
    fn the_search_chooses_what_measuring_every_subset_everywhere_chooses() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let (mut reached, mut missed_goals, mut skipped) = (0, 0, 0);
        for case in 0..3000 {
            let k = rng.below(9) as usize;
            let ids: Vec<usize> = (0..k).map(|i| 20 - 2 * i - rng.below(2) as usize).collect();
            let mut views = Vec::new();
            for view in 0..1 + rng.below(9) {
                // Region views are drawn at the own view's size or smaller.
                let size = if view > 0 { 2 + rng.below(3) as u32 } else { 4 };
                let reference = random_mask(&mut rng, size, 90);
                let mut candidates = Vec::new();
                for &i in &ids {
                    // Now and then a view lacks a candidate's mask: it draws nothing there.
                    if rng.below(10) > 0 {
                        candidates.push((i, random_mask(&mut rng, size, 55)));
                    }
                }
                views.push(ViewMasks {
                    reference,
                    candidates,
                });
            }
            let goals = Goals {
                own: rng.below(4) as u32,
                edge: rng.below(6) as u32,
            };
            let given = || Given(views.iter().map(|v| Measured::of(v, &ids)).collect());
            let every = views.len();
            let oracle = exhaustive(&views, &ids, goals);
            let expected = Choice {
                impostors: indices_of(&ids, oracle),
                missed: given().missed(0, oracle),
            };
            for bound in 1..=every {
                let counted = Counted(given(), Default::default());
                let got = choose_with(&counted, &ids, Rule::Best(8), goals, bound);
                assert_eq!(got, expected, "case {case}, bound {bound}");
                let read = counted.1.borrow().len();
                let present = (0..every)
                    .flat_map(|v| (0..k).map(move |b| (v, b)))
                    .filter(|&(v, b)| counted.0.candidate(v, b).is_some())
                    .count();
                if read < present {
                    skipped += 1;
                }
            }
            let closest = choose_with(&given(), &ids, Rule::Closest(8), goals, 1);
            assert_eq!(closest.impostors, ids, "case {case}");
            assert_eq!(closest.missed, given().missed_where(0, k, |_| true));
            let reaches = |s: u32| {
                (0..every).all(|v| {
                    let goal = if v == 0 { goals.own } else { goals.edge };
                    let size = views[v].reference.size();
                    own_pixels(given().missed(v, s), size, 4) <= goal
                })
            };
            if k > 0 {
                if (1..=u32::MAX >> (32 - k)).any(reaches) {
                    reached += 1;
                } else {
                    missed_goals += 1;
                }
            }
        }
        // Both outcomes occur, and a narrower bound saves reads.
        assert!(reached > 300, "{reached} reached the goals");
        assert!(missed_goals > 300, "{missed_goals} did not");
        assert!(skipped > 1000, "{skipped} searches read fewer masks");
    }
}
