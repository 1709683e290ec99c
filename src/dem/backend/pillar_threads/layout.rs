//! The terms' layout for a new pair list, built in parts on every thread (see
//! `Reverse`): with it, the slots' owners and the zeroed terms. On one thread the
//! same phases run one after another (`PillarSim::sync_list_buffers`).

use crate::dem::backend::simd::Quad;
use crate::dem::pillar::PillarSim;
use crate::dem::pillar::reverse::ReverseView;
use std::ops::Range;

/// A layout build under way: raw views of the list (read only until it ends) and of
/// the buffers each part writes. Made and remade by the first thread between the
/// phases, while the others wait.
pub(crate) struct LayoutBuild {
    rev: ReverseView,
    start: *const u32,
    js: *const u32,
    n: usize,
    slots: usize,
    owner: *mut u32,
    terms: *mut Quad,
    /// Per part, its chunks' places (after `PillarSim::layout_offsets`).
    places: Vec<Range<usize>>,
}

// SAFETY: shared by the threads of one build; each phase's notes say what part t
// writes (disjoint between parts), and barriers order the phases.
unsafe impl Sync for LayoutBuild {}

impl LayoutBuild {
    /// SAFETY (for the slices): the list outlives the build and is not written during it.
    fn list(&self) -> (&[u32], &[u32]) {
        unsafe {
            (
                std::slice::from_raw_parts(self.start, self.n + 1),
                std::slice::from_raw_parts(self.js, self.slots),
            )
        }
    }

    /// Part t's partner counts, and the owner of each of its slots.
    ///
    /// # Safety
    /// After `begin_layout` (whose `Reverse::begin` checked the list's offsets); once
    /// per part; no other phase at the same time.
    pub(crate) unsafe fn count(&self, t: usize) {
        let (start, js) = self.list();
        let r = self.rev.part(t);
        let s0 = start[r.start];
        // SAFETY: part t's grains' slots, this call's alone, within the owners
        // (`begin_layout` sized them to the slots the checked offsets end at).
        let owner = unsafe {
            std::slice::from_raw_parts_mut(
                self.owner.add(s0 as usize),
                (start[r.end] - s0) as usize,
            )
        };
        for i in r.clone() {
            owner[(start[i] - s0) as usize..(start[i + 1] - s0) as usize].fill(i as u32);
        }
        // SAFETY: as `count` asks.
        unsafe { self.rev.count(t, start, js) };
    }

    /// # Safety
    /// After every part's `count`; once per part.
    pub(crate) unsafe fn sum(&self, t: usize) {
        // SAFETY: as `sum` asks.
        unsafe { self.rev.sum(t, self.list().0) };
    }

    /// Part t's slots placed and its chunks' terms zeroed.
    ///
    /// # Safety
    /// After `layout_offsets`; once per part.
    pub(crate) unsafe fn place(&self, t: usize) {
        let (start, js) = self.list();
        let p = self.places[t].clone();
        // SAFETY: part t's chunks' places in the terms, sized by `layout_offsets`.
        unsafe {
            std::slice::from_raw_parts_mut(self.terms.add(p.start), p.len()).fill(Quad::default());
            self.rev.place(t, start, js);
        }
    }

    /// # Safety
    /// After every part's `place`; once per part.
    pub(crate) unsafe fn reach(&self, t: usize) {
        // SAFETY: as `reach` asks.
        unsafe { self.rev.reach(t) };
    }
}

impl PillarSim {
    /// Begins the layout of the current list in `parts` parts, when the slots'
    /// buffers do not hold it (after a rebuild, or buffers sized for another list);
    /// `None` when they do.
    pub(crate) fn begin_layout(&mut self, parts: usize) -> Option<LayoutBuild> {
        let (n, slots) = (self.grains.len(), self.list.len());
        let b = &mut self.scratch.buffers;
        if b.reverse.start.len() != n + 1
            || b.terms.len() != b.reverse.places
            || b.reverse.term_own.len() != slots
            || b.owner.len() != slots
        {
            b.slots_valid = false;
        }
        if b.slots_valid {
            return None;
        }
        let l = &self.list;
        // In the last layout's buffers: fresh pages cost more than the work. (This
        // checks the offsets, on this thread before any part writes by them.)
        b.reverse.begin(n, parts, &l.start, &l.j);
        b.owner.resize(slots, 0);
        Some(LayoutBuild {
            rev: b.reverse.view(),
            start: l.start.as_ptr(),
            js: l.j.as_ptr(),
            n,
            slots,
            owner: b.owner.as_mut_ptr(),
            terms: b.terms.as_mut_ptr(),
            places: Vec::new(),
        })
    }

    /// Between the parts' `sum` and `place`, on one thread: the parts' offsets, the
    /// terms sized, and `build`'s views renewed.
    pub(crate) fn layout_offsets(&mut self, build: &mut LayoutBuild) {
        let b = &mut self.scratch.buffers;
        b.reverse.offsets();
        // Only new places are written here; `place` zeroes each part's.
        b.terms.resize(b.reverse.places, Quad::default());
        build.places = (0..b.reverse.parts().len())
            .map(|t| b.reverse.places_of_part(t))
            .collect();
        build.rev = b.reverse.view();
        build.terms = b.terms.as_mut_ptr();
    }

    /// Per-slot buffers and the reverse index for the current list, built on this
    /// thread if the buffers do not hold it; then the checks the kernels rely on.
    pub(super) fn sync_list_buffers(&mut self) {
        if let Some(mut build) = self.begin_layout(1) {
            // SAFETY: one thread, the phases in order.
            unsafe {
                build.count(0);
                build.sum(0);
                self.layout_offsets(&mut build);
                build.place(0);
                build.reach(0);
            }
        }
        self.end_layout();
    }

    /// After a layout build (or none): the indices the kernels use unchecked,
    /// checked; the force snapshot's buffers sized.
    pub(super) fn end_layout(&mut self) {
        let (n, slots) = (self.grains.len(), self.list.len());
        let b = &mut self.scratch.buffers;
        // The largest index of each (a fold without early exit, which vectorises).
        let top = |v: &[u32]| v.iter().fold(0, |a: u32, &b| a.max(b)) as usize;
        // The AVX2 pair kernel indexes grains without bounds checks: every list index
        // is checked here, after each rebuild and at the start of each `advance`.
        assert!(
            b.owner.len() == slots && (slots == 0 || top(&b.owner) < n && top(&self.list.j) < n),
            "pair list indices within the grains"
        );
        // So are the places the pair kernels write each slot's terms.
        let r = &b.reverse;
        assert!(
            r.term_own.len() == slots
                && r.term_partner.len() == slots
                && (slots == 0
                    || top(&r.term_own) < b.terms.len() && top(&r.term_partner) < b.terms.len()),
            "term places within the terms"
        );
        let rec = self.record.is_some();
        let want = if rec { slots } else { 0 };
        b.rec_fn.resize(want, 0.0);
        b.rec_ft.resize(want, 0.0);
        b.rec_touch.resize(want, false);
        // Per grain; zeroed for each snapshot (only touching grains are written).
        b.rec_bar.clear();
        b.rec_bar.resize(if rec { n } else { 0 }, 0.0);
    }
}
