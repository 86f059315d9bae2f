//! Masks traced when the subset search first reads them ([`select_with`](crate::select_with)).
//!
//! The grid over an entry's region holds several times the entry's own view, but the search
//! ([`choose_with`]) reads most of it only for the few subsets that can still win, so tracing
//! every candidate there would be mostly wasted.

use std::sync::OnceLock;

use ori_eval::{Evaluator, Mask};
use ori_raster::OrthoView;

use crate::choose::{Choice, EntryMasks, Goals, choose_with};
use crate::rule::Rule;

/// One view of a [`MaskPlan`](crate::MaskPlan): its frame and the mesh's coverage, traced up
/// front, and a slot per listed impostor for its mask.
pub(crate) struct LazyView {
    view: OrthoView,
    reference: Mask,
    impostors: Vec<usize>,
    masks: Vec<OnceLock<Mask>>,
}

impl LazyView {
    pub(crate) fn new(evaluator: &Evaluator<'_>, view: OrthoView, impostors: &[usize]) -> LazyView {
        let reference = evaluator.mesh_coverage(&view);
        LazyView {
            view,
            reference,
            impostors: impostors.to_vec(),
            masks: impostors.iter().map(|_| OnceLock::new()).collect(),
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

    fn reference(&self, view: usize) -> &[u64] {
        self.views[view].reference.words()
    }

    fn candidate(&self, view: usize, bit: usize) -> Option<&[u64]> {
        let v = self.views[view];
        let slot = self.slots[view][bit]?;
        // Entries sharing a view may wait here for each other's mask: the tracing must not
        // run rayon jobs, or a waiting worker could take one that waits on the same cell.
        let mask = v.masks[slot].get_or_init(|| {
            self.evaluator
                .impostor_mask(&v.view, v.impostors[slot], Some(&v.reference))
        });
        Some(mask.words())
    }
}

/// Choose one entry from its own view and its region's views (corners first), tracing masks
/// as the search reads them. The own view and the region's corners are measured for every
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
