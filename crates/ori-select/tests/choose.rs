//! The subset search on hand-made masks: sizes, goal, tie-breaking, ordering.

use ori_eval::Mask;
use ori_select::{Choice, Goals, Rule, ViewMasks, choose, choose_region, own_pixels};

/// A 4 x 4 image whose first `n` pixels the mesh covers.
fn reference(n: usize) -> Mask {
    let mut m = Mask::new(4);
    (0..n).for_each(|i| m.set(i));
    m
}

fn mask(pixels: &[usize]) -> Mask {
    let mut m = Mask::new(4);
    pixels.iter().for_each(|&i| m.set(i));
    m
}

fn masks(candidates: &[(usize, &[usize])]) -> ViewMasks {
    ViewMasks {
        reference: reference(10),
        candidates: candidates.iter().map(|&(i, p)| (i, mask(p))).collect(),
    }
}

fn choice(impostors: &[usize], missed: u32) -> Choice {
    Choice {
        impostors: impostors.to_vec(),
        missed,
    }
}

#[test]
fn the_smallest_size_that_reaches_the_goal_wins() {
    // Candidates closest first: impostor 7, then 3, then 5.
    let vm = masks(&[
        (7, &[0, 1, 2, 3, 4, 5]),
        (3, &[6, 7, 8, 9]),
        (5, &[0, 1, 2, 3, 4, 5, 6, 7]),
    ]);
    // Goal 2: impostor 5 alone misses 2 (8 and 9); the pair {7, 3} misses nothing, but a
    // single impostor reaching the goal wins.
    assert_eq!(choose(&vm, Rule::Best(3), 2), choice(&[5], 2));
    // Goal 0: no single one reaches it; among the pairs {7, 3} and {3, 5} miss nothing;
    // sorted indices [3, 5] < [3, 7], and the list is drawn closest first.
    assert_eq!(choose(&vm, Rule::Best(3), 0), choice(&[3, 5], 0));
    // best:1 looks at the closest candidate only.
    assert_eq!(choose(&vm, Rule::Best(1), 10), choice(&[7], 4));
    // closest:M draws the M closest, whatever they miss.
    assert_eq!(choose(&vm, Rule::Closest(2), 0), choice(&[7, 3], 0));
    assert_eq!(choose(&vm, Rule::Closest(9), 0), choice(&[7, 3, 5], 0));
}

#[test]
fn ties_go_to_lower_impostor_indices() {
    // Two singles miss the same 5 pixels: the lower index (2) wins, though 9 is closer.
    let vm = masks(&[(9, &[0, 1, 2, 3, 4]), (2, &[5, 6, 7, 8, 9])]);
    assert_eq!(choose(&vm, Rule::Best(2), 5), choice(&[2], 5));
}

#[test]
fn without_a_subset_at_the_goal_the_least_error_wins_smaller_on_ties() {
    // Nothing reaches goal 0. {4} misses 2, {4, 8} misses 2 as well (8 adds nothing new to
    // the reference), {4, 1} misses 1: the least error wins over the smaller size.
    let vm = masks(&[(4, &[0, 1, 2, 3, 4, 5, 6, 7]), (8, &[0, 1]), (1, &[8])]);
    assert_eq!(choose(&vm, Rule::Best(3), 0), choice(&[4, 1], 1));
    // With only {4} and {8}: {4} and {4, 8} tie at 2, the smaller wins.
    let vm = masks(&[(4, &[0, 1, 2, 3, 4, 5, 6, 7]), (8, &[0, 1])]);
    assert_eq!(choose(&vm, Rule::Best(2), 0), choice(&[4], 2));
}

#[test]
fn no_facing_impostor_draws_nothing() {
    let vm = ViewMasks {
        reference: reference(10),
        candidates: Vec::new(),
    };
    assert_eq!(choose(&vm, Rule::Best(6), 0), choice(&[], 10));
    assert_eq!(choose(&vm, Rule::Closest(4), 0), choice(&[], 10));
}

fn both(pixels: u32) -> Goals {
    Goals {
        own: pixels,
        edge: pixels,
    }
}

#[test]
fn a_region_is_met_at_its_worst_view() {
    // Own view: impostor 7 alone reaches the goal of 2 pixels.
    let own = masks(&[
        (7, &[0, 1, 2, 3, 4, 5, 6, 7, 8]),
        (3, &[0, 1, 2, 3, 4]),
        (5, &[5, 6, 7, 8, 9]),
    ]);
    assert_eq!(choose(&own, Rule::Best(3), 2), choice(&[7], 1));
    // At the region's edge no single impostor reaches the goal; of the pairs, 3 and 5 miss
    // pixel 4 there, 7 and 5 miss nothing anywhere.
    let edge = masks(&[
        (3, &[0, 1, 2, 3]),
        (5, &[0, 5, 6, 7, 8, 9]),
        (7, &[0, 1, 2, 3, 4]),
    ]);
    assert_eq!(
        choose_region(&own, &[&edge], Rule::Best(3), both(2)),
        choice(&[7, 5], 0)
    );
    // A looser goal at the edge lets impostor 7 alone serve the region (5 pixels missed there).
    let loose = Goals { own: 2, edge: 5 };
    assert_eq!(
        choose_region(&own, &[&edge], Rule::Best(3), loose),
        choice(&[7], 1)
    );
    // ... but not when its own view misses more than its goal.
    let strict_own = Goals { own: 0, edge: 5 };
    assert_eq!(
        choose_region(&own, &[&edge], Rule::Best(3), strict_own),
        choice(&[7, 5], 0)
    );
    // A region view drawn at half the size counts each of its pixels four times: there 7
    // alone misses one pixel of four, 4 pixels of the own view's, over the goal of 3.
    let coarse = |pixels: &[usize]| {
        let mut m = Mask::new(2);
        pixels.iter().for_each(|&i| m.set(i));
        m
    };
    let half = ViewMasks {
        reference: coarse(&[0, 1, 2, 3]),
        candidates: vec![
            (3, coarse(&[0])),
            (5, coarse(&[3])),
            (7, coarse(&[0, 1, 2])),
        ],
    };
    let edge_3 = Goals { own: 2, edge: 3 };
    assert_eq!(
        choose_region(&own, &[&half], Rule::Best(3), edge_3),
        choice(&[7, 5], 0)
    );
    let full = ViewMasks {
        reference: reference(4),
        candidates: vec![(3, mask(&[0])), (5, mask(&[3])), (7, mask(&[0, 1, 2]))],
    };
    assert_eq!(
        choose_region(&own, &[&full], Rule::Best(3), edge_3),
        choice(&[7], 1)
    );
    // A mask the edge view lacks draws nothing there; masks of other impostors are ignored.
    let partial = masks(&[
        (9, &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9]),
        (7, &[0, 1, 2, 3, 4, 5, 6, 7, 8]),
    ]);
    assert_eq!(
        choose_region(&own, &[&partial], Rule::Best(3), both(2)),
        choice(&[7], 1)
    );
    // With no region, the region choice is the one-view choice.
    assert_eq!(
        choose_region(&own, &[], Rule::Best(2), both(0)),
        choose(&own, Rule::Best(2), 0)
    );
    // closest:M draws all M whatever the region.
    assert_eq!(
        choose_region(&own, &[&edge], Rule::Closest(2), both(0)),
        choice(&[7, 3], 1)
    );
}

#[test]
fn closest_draws_more_candidates_than_a_subset_has_bits() {
    // 40 facing impostors (a dense set seen by closest:255): all drawn, closest first, none
    // lost to the 32 bits of a best:M subset.
    let pixels: Vec<Vec<usize>> = (0..40).map(|i| vec![i % 10]).collect();
    let candidates: Vec<(usize, &[usize])> = (0..40).map(|i| (100 + i, &pixels[i][..])).collect();
    let vm = masks(&candidates);
    let all: Vec<usize> = (100..140).collect();
    assert_eq!(choose(&vm, Rule::Closest(255), 0), choice(&all, 0));
    // The first 9 leave pixel 9 uncovered.
    let nine: Vec<usize> = (100..109).collect();
    assert_eq!(choose(&vm, Rule::Closest(9), 0), choice(&nine, 1));
}

#[test]
fn a_smaller_view_counts_its_error_in_pixels_of_the_own_view() {
    assert_eq!(own_pixels(5, 256, 256), 5);
    assert_eq!(own_pixels(1, 128, 256), 4);
    // 10 * 256^2 / 192^2 = 17.8, rounded.
    assert_eq!(own_pixels(10, 192, 256), 18);
    // 9 * 16 / 9 = 16 exactly; 1 * 16 / 9 = 1.8 -> 2; a half rounds up: 2 * 9 / 4 = 4.5 -> 5.
    assert_eq!(own_pixels(9, 3, 4), 16);
    assert_eq!(own_pixels(1, 3, 4), 2);
    assert_eq!(own_pixels(2, 2, 3), 5);
    assert_eq!(own_pixels(0, 48, 64), 0);
}
