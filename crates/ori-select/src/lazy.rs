//! Masks traced where the subset search needs them ([`select_with`](crate::select_with)).
//!
//! The grid over an entry's region holds several times the entry's own view, but the search
//! ([`choose_with`]) reads most of it only for the few subsets that can still win, so tracing
//! every candidate there would be mostly wasted. And a subset's error is the pixels no member
//! covers, so a member is traced only where the others are not known to cover
//! ([`PartialMask::uncover`]): where the closest candidate covers a pixel, the others are
//! seldom traced there.

use std::sync::{Mutex, PoisonError};

use ori_eval::{Evaluator, Mask, PartialMask};
use ori_raster::OrthoView;

use crate::choose::{Choice, EntryMasks, Goals, choose_with};
use crate::rule::Rule;

/// One view of a [`MaskPlan`](crate::MaskPlan): its frame and the mesh's coverage, traced up
/// front, and a slot per listed impostor for what is known of its mask.
pub(crate) struct LazyView {
    view: OrthoView,
    reference: Mask,
    impostors: Vec<usize>,
    masks: Vec<Mutex<Option<PartialMask>>>,
}

impl LazyView {
    pub(crate) fn new(evaluator: &Evaluator<'_>, view: OrthoView, impostors: &[usize]) -> LazyView {
        let reference = evaluator.mesh_coverage(&view);
        LazyView {
            view,
            reference,
            impostors: impostors.to_vec(),
            masks: impostors.iter().map(|_| Mutex::new(None)).collect(),
        }
    }
}

/// The views of one entry, with the slot of each of its candidates in each view.
struct Entry<'a, 'm> {
    evaluator: &'a Evaluator<'m>,
    views: Vec<&'a LazyView>,
    slots: Vec<Vec<Option<usize>>>,
}

impl EntryMasks for Entry<'_, '_> {
    fn view_count(&self) -> usize {
        self.views.len()
    }

    fn size(&self, view: usize) -> u32 {
        self.views[view].view.size
    }

    fn missed_where(&self, view: usize, k: usize, chosen: impl Fn(usize) -> bool) -> u32 {
        let v = self.views[view];
        let members: Vec<usize> = (0..k)
            .filter(|&bit| chosen(bit))
            .filter_map(|bit| self.slots[view][bit])
            .collect();
        // One slot locked at a time, so entries sharing a view never wait on each other in a
        // cycle. The tracing must not run rayon jobs: a waiting worker could take one that
        // waits on the same slot.
        let lock = |slot: usize| v.masks[slot].lock().unwrap_or_else(PoisonError::into_inner);
        let mut open = v.reference.clone();
        for &slot in &members {
            if let Some(known) = lock(slot).as_ref() {
                open.remove(known.covered());
            }
        }
        for &slot in &members {
            if open.count() == 0 {
                break;
            }
            let mut known = lock(slot);
            let known = known.get_or_insert_with(|| PartialMask::new(v.view.size));
            known.uncover(&mut open, |todo| {
                self.evaluator
                    .impostor_mask(&v.view, v.impostors[slot], Some(todo))
            });
        }
        open.count()
    }
}

/// Choose one entry from its own view and its region's views (corners first), tracing masks
/// where the search needs them. The own view and the region's corners are measured for every
/// subset.
pub(crate) fn choose_entry(
    evaluator: &Evaluator<'_>,
    own: &LazyView,
    region: &[&LazyView],
    rule: Rule,
    goals: Goals,
) -> Choice {
    let ids = &own.impostors;
    let views: Vec<&LazyView> = std::iter::once(own).chain(region.iter().copied()).collect();
    let slots = views
        .iter()
        .map(|v| {
            ids.iter()
                .map(|id| v.impostors.iter().position(|i| i == id))
                .collect()
        })
        .collect();
    let entry = Entry {
        evaluator,
        views,
        slots,
    };
    choose_with(&entry, ids, rule, goals, 1 + region.len().min(3))
}
