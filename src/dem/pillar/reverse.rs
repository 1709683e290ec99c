//! Where each grain's contact terms go (the per-grain padded layout the pillar's pair
//! slots write and its grain phase sums), rebuilt with every pair list. The build runs
//! in parts of whole chunks, one per thread, between barriers (`count`, `sum`, then
//! `offsets` on one thread, `place`, `reach`): at N = 16,000 it was 0.45 ms a list
//! build on one thread while the others waited, 4 µs of a 165 µs step on two. Any
//! split gives the same layout: a grain's partner slots keep the order of their
//! owners, and the parts are ranges of owners in order.

use std::ops::Range;

/// Grains per chunk: of the reductions over grains (sums per chunk, added in order;
/// threads get whole chunks) and of the terms' layout (one width per chunk).
pub const CHUNK: usize = 32;

/// Where each grain's contact terms go: per grain j, how many slots of the half list
/// name j as the partner (`start`, CSR offsets), and the padded per-grain layout.
#[derive(Debug, Clone, Default)]
pub struct Reverse {
    pub start: Vec<u32>,
    /// Per slot of the list, where its force goes in the per-grain terms (see
    /// `TermSink`): its owner's term and its partner's.
    pub term_own: Vec<u32>,
    pub term_partner: Vec<u32>,
    /// The terms' layout, per [`CHUNK`] of grains: every grain of chunk c has
    /// `width[c]` places (the most terms any of them has; the rest stay +0.0) from
    /// `chunk_base[c]` on, grain after grain.
    pub width: Vec<u32>,
    pub chunk_base: Vec<u32>,
    /// Places in all (real terms and padding).
    pub places: usize,
    /// Per place, the other grain of its term; the grain itself at the padding.
    pub neighbour: Vec<u32>,
    /// Per chunk, the lowest and highest grain among its grains' neighbours and
    /// itself: only grains in that span can unmark one of its grains.
    pub reach: Vec<(u32, u32)>,
    /// The build's scratch, per part: how many of its slots name each grain as the
    /// partner; after `sum`, the rank its first such slot has among that grain's
    /// partner slots, which `place` counts on.
    counts: Vec<Vec<u32>>,
    /// The build's parts: grain ranges of whole chunks, in order.
    parts: Vec<Range<usize>>,
    /// Per part: its partner slots and places (after `sum`), then where they start
    /// (after `offsets`).
    sums: Vec<(u32, u32)>,
}

impl Reverse {
    pub fn build(n: usize, start: &[u32], js: &[u32]) -> Reverse {
        let mut r = Reverse::default();
        r.rebuild(n, start, js);
        r
    }

    /// The layout of the half list `start`, `js` over `n` grains, in this one's buffers
    /// (a rebuild of 16,000 grains' layout in fresh memory spent most of its time
    /// touching new pages): the parts' build with one part.
    pub fn rebuild(&mut self, n: usize, start: &[u32], js: &[u32]) {
        self.begin(n, 1, start, js);
        // SAFETY: one part, on this thread, in the order the build needs.
        unsafe {
            let v = self.view();
            v.count(0, start, js);
            v.sum(0, start);
            self.offsets();
            let v = self.view();
            v.place(0, start, js);
            v.reach(0);
        }
    }

    /// Sizes the buffers for a build of the half list `start`, `js` over `n` grains in
    /// `parts` parts (whole chunks each, as equal as chunks allow). Panics unless the
    /// offsets run from 0 to the slots, ascending: the phases write where they point
    /// unchecked (`count` checks each partner against n).
    pub fn begin(&mut self, n: usize, parts: usize, start: &[u32], js: &[u32]) {
        let slots = js.len();
        assert!(
            start.len() == n + 1
                && start[0] == 0
                && start[n] as usize == slots
                && start.windows(2).all(|w| w[0] <= w[1]),
            "pair list offsets ascend from 0 to its {slots} slots over {n} grains"
        );
        let parts = parts.max(1);
        let chunks = n.div_ceil(CHUNK);
        self.parts = (0..parts)
            .map(|t| (chunks * t / parts * CHUNK).min(n)..(chunks * (t + 1) / parts * CHUNK).min(n))
            .collect();
        self.counts.resize_with(parts, Vec::new);
        self.counts.truncate(parts);
        self.counts.iter_mut().for_each(|c| c.resize(n, 0));
        self.sums.clear();
        self.sums.resize(parts, (0, 0));
        self.start.resize(n + 1, 0);
        self.start[0] = 0;
        self.width.resize(chunks, 0);
        self.chunk_base.resize(chunks, 0);
        self.reach.resize(chunks, (0, 0));
        // Every slot's two places are written by `place`; no need to clear them.
        self.term_own.resize(slots, 0);
        self.term_partner.resize(slots, 0);
    }

    /// The parts `begin` made.
    pub fn parts(&self) -> &[Range<usize>] {
        &self.parts
    }

    /// Between `sum` and `place`, on one thread: where each part's partner slots and
    /// places start, the chunks' bases, and the places in all (`neighbour` sized).
    pub fn offsets(&mut self) {
        let (mut slots, mut places) = (0u32, 0u32);
        for (t, s) in self.sums.iter_mut().enumerate() {
            let (part_slots, part_places) = *s;
            *s = (slots, places);
            for c in self.parts[t].start / CHUNK..self.parts[t].end.div_ceil(CHUNK) {
                self.chunk_base[c] += places;
            }
            slots += part_slots;
            places += part_places;
        }
        self.places = places as usize;
        // Every place is written by `place` (a term or padding).
        self.neighbour.resize(self.places, 0);
    }

    /// Raw views of the buffers for the parts' phases, valid until the next `begin`
    /// or `offsets`.
    pub fn view(&mut self) -> ReverseView {
        ReverseView {
            n: self.start.len().saturating_sub(1),
            counts: self.counts.iter_mut().map(|c| c.as_mut_ptr()).collect(),
            parts: self.parts.clone(),
            sums: self.sums.as_mut_ptr(),
            start: self.start.as_mut_ptr(),
            term_own: self.term_own.as_mut_ptr(),
            term_partner: self.term_partner.as_mut_ptr(),
            width: self.width.as_mut_ptr(),
            chunk_base: self.chunk_base.as_mut_ptr(),
            neighbour: self.neighbour.as_mut_ptr(),
            reach: self.reach.as_mut_ptr(),
        }
    }

    /// Grain i's places in the per-grain term array, its chunk's width of them (its
    /// terms, then padding).
    pub fn places_of(&self, i: usize) -> Range<usize> {
        let (c, w) = (i / CHUNK, self.width[i / CHUNK] as usize);
        let from = self.chunk_base[c] as usize + (i % CHUNK) * w;
        from..from + w
    }

    /// Grain i's terms in the per-grain term array (the padding after them excluded).
    pub fn terms_of(&self, start: &[u32], i: usize) -> Range<usize> {
        let count = start[i + 1] - start[i] + self.start[i + 1] - self.start[i];
        let from = self.places_of(i).start;
        from..from + count as usize
    }

    /// The places of part `t`'s chunks (after `offsets`).
    pub fn places_of_part(&self, t: usize) -> Range<usize> {
        let r = &self.parts[t];
        if r.is_empty() {
            return 0..0;
        }
        let last = r.end - 1;
        self.places_of(r.start).start..self.places_of(last).end
    }
}

/// Pointers into a [`Reverse`] under construction, shared by the threads that build
/// its parts; each phase of part t writes only what the phase's notes give to part t.
#[derive(Clone)]
pub struct ReverseView {
    /// The grains `begin` sized the buffers for.
    n: usize,
    counts: Vec<*mut u32>,
    parts: Vec<Range<usize>>,
    sums: *mut (u32, u32),
    start: *mut u32,
    term_own: *mut u32,
    term_partner: *mut u32,
    width: *mut u32,
    chunk_base: *mut u32,
    neighbour: *mut u32,
    reach: *mut (u32, u32),
}

// SAFETY: the threads of one build share the view; its phases' notes say which
// elements each part writes (disjoint between parts) and the barriers between the
// phases order every write before any read of it.
unsafe impl Send for ReverseView {}
unsafe impl Sync for ReverseView {}

impl ReverseView {
    /// Part t's grains.
    pub fn part(&self, t: usize) -> Range<usize> {
        self.parts[t].clone()
    }

    fn chunks(&self, t: usize) -> Range<usize> {
        let r = &self.parts[t];
        r.start / CHUNK..r.end.div_ceil(CHUNK)
    }

    /// Part t's count of the slots that name each grain as the partner (writes part
    /// t's counts only).
    ///
    /// # Safety
    /// After `begin`, before `sum`; no other call for part t at the same time; `start`
    /// and `js` are the list `begin` checked.
    pub unsafe fn count(&self, t: usize, start: &[u32], js: &[u32]) {
        let r = self.parts[t].clone();
        // SAFETY: part t's counts, n long (`begin`), are this call's alone.
        let counts = unsafe { std::slice::from_raw_parts_mut(self.counts[t], self.n) };
        counts.fill(0);
        for &j in &js[start[r.start] as usize..start[r.end] as usize] {
            counts[j as usize] += 1;
        }
    }

    /// For the grains of part t: their partner slots in all (`start[g + 1]`, summed
    /// from the part's first grain), each part's first rank among them (in every
    /// part's counts), the widths of the part's chunks, and their bases from the
    /// part's first place; the part's totals into `sums[t]`.
    ///
    /// # Safety
    /// After every part's `count`, before `offsets`; writes the part's grains' entries
    /// of every part's counts and of `start` (shifted by one), its chunks' widths and
    /// bases, and `sums[t]`.
    pub unsafe fn sum(&self, t: usize, start: &[u32]) {
        let r = self.parts[t].clone();
        let (mut slots, mut places) = (0u32, 0u32);
        for c in self.chunks(t) {
            let grains = c * CHUNK..((c + 1) * CHUNK).min(r.end);
            let mut w = 0;
            for g in grains.clone() {
                let mut partner = 0u32;
                for &p in &self.counts {
                    // SAFETY: grain g of this part: only this call touches entry g.
                    unsafe {
                        let e = p.add(g);
                        let k = *e;
                        *e = partner;
                        partner += k;
                    }
                }
                slots += partner;
                // SAFETY: start[g + 1] for this part's grain g.
                unsafe { *self.start.add(g + 1) = slots };
                w = w.max(start[g + 1] - start[g] + partner);
            }
            // SAFETY: this part's chunk c.
            unsafe {
                *self.width.add(c) = w;
                *self.chunk_base.add(c) = places;
            }
            places += w * grains.len() as u32;
        }
        // SAFETY: this part's totals.
        unsafe { *self.sums.add(t) = (slots, places) };
    }

    /// Part t's slots placed: each slot's two places, the neighbour at each, the
    /// padding of the part's grains, and `start` shifted to the part's first partner
    /// slot.
    ///
    /// # Safety
    /// After `offsets` (and a view taken after it), before `reach`; writes the part's
    /// grains' `start` entries (shifted by one), its slots' places, its counts, and
    /// the neighbour at its slots' two places and at its grains' padding: every
    /// place is one slot's or one grain's padding, so no two parts write one.
    pub unsafe fn place(&self, t: usize, start: &[u32], js: &[u32]) {
        let r = self.parts[t].clone();
        // SAFETY: the chunks' widths and bases are final (`offsets`), read only.
        let base = |g: usize| unsafe {
            *self.chunk_base.add(g / CHUNK) + (g % CHUNK) as u32 * *self.width.add(g / CHUNK)
        };
        // SAFETY: `sums[t]` is final, read only.
        let (slot0, _) = unsafe { *self.sums.add(t) };
        let counts = self.counts[t];
        let mut before = 0u32;
        for g in r.clone() {
            // SAFETY: start[g + 1] of this part's grain; the width of its chunk.
            unsafe {
                let e = self.start.add(g + 1);
                let partner = *e - before;
                before = *e;
                *e += slot0;
                let own = start[g + 1] - start[g];
                let from = base(g) + own + partner;
                let to = base(g) + *self.width.add(g / CHUNK);
                for m in from..to {
                    *self.neighbour.add(m as usize) = g as u32;
                }
            }
        }
        for i in r {
            let slots = start[i] as usize..start[i + 1] as usize;
            for (k, &j) in slots.clone().zip(&js[slots]) {
                let j = j as usize;
                // SAFETY: slot k is this part's; the partner place is the next rank
                // of part t's slots among j's (its count, this part's alone).
                unsafe {
                    let rank = counts.add(j);
                    let own = base(i) + k as u32 - start[i];
                    let partner = base(j) + start[j + 1] - start[j] + *rank;
                    *rank += 1;
                    *self.term_own.add(k) = own;
                    *self.term_partner.add(k) = partner;
                    *self.neighbour.add(own as usize) = j as u32;
                    *self.neighbour.add(partner as usize) = i as u32;
                }
            }
        }
    }

    /// The reach of part t's chunks.
    ///
    /// # Safety
    /// After every part's `place`; writes the part's chunks' reach.
    pub unsafe fn reach(&self, t: usize) {
        let r = self.parts[t].clone();
        for c in self.chunks(t) {
            let grains = (c * CHUNK) as u32..((c + 1) * CHUNK).min(r.end) as u32;
            // SAFETY: the chunk's places, written by `place`, read only now.
            unsafe {
                let from = *self.chunk_base.add(c) as usize;
                let len = *self.width.add(c) as usize * grains.len();
                let nb = std::slice::from_raw_parts(self.neighbour.add(from), len);
                let lo = nb.iter().copied().fold(grains.start, u32::min);
                let hi = nb.iter().copied().fold(grains.end - 1, u32::max);
                *self.reach.add(c) = (lo, hi);
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// start, term_own, term_partner, width, chunk_base, neighbour, reach.
    type Layout = (
        Vec<u32>,
        Vec<u32>,
        Vec<u32>,
        Vec<u32>,
        Vec<u32>,
        Vec<u32>,
        Vec<(u32, u32)>,
    );

    /// The layout as first written, one grain after another: the reference every
    /// split must give.
    fn reference(n: usize, start: &[u32], js: &[u32]) -> Layout {
        let mut rs = vec![0u32; n + 1];
        for &j in js {
            rs[j as usize + 1] += 1;
        }
        for k in 0..n {
            rs[k + 1] += rs[k];
        }
        let count = |g: usize| start[g + 1] - start[g] + rs[g + 1] - rs[g];
        let chunks = n.div_ceil(CHUNK);
        let (mut width, mut chunk_base, mut places) = (vec![], vec![], 0u32);
        for c in 0..chunks {
            let grains = c * CHUNK..((c + 1) * CHUNK).min(n);
            let w = grains.clone().map(count).max().unwrap_or(0);
            chunk_base.push(places);
            width.push(w);
            places += w * grains.len() as u32;
        }
        let base = |g: usize| chunk_base[g / CHUNK] + (g % CHUNK) as u32 * width[g / CHUNK];
        let mut neighbour = vec![0u32; places as usize];
        for g in 0..n {
            let from = base(g) as usize;
            neighbour[from..from + width[g / CHUNK] as usize].fill(g as u32);
        }
        let (mut own, mut partner, mut seen) = (vec![0; js.len()], vec![0; js.len()], vec![0; n]);
        for i in 0..n {
            for k in start[i] as usize..start[i + 1] as usize {
                let j = js[k] as usize;
                own[k] = base(i) + k as u32 - start[i];
                partner[k] = base(j) + start[j + 1] - start[j] + seen[j];
                neighbour[own[k] as usize] = j as u32;
                neighbour[partner[k] as usize] = i as u32;
                seen[j] += 1;
            }
        }
        let reach = (0..chunks)
            .map(|c| {
                let grains = (c * CHUNK) as u32..((c + 1) * CHUNK).min(n) as u32;
                let p = chunk_base[c] as usize
                    ..chunk_base[c] as usize + width[c] as usize * grains.len();
                let nb = &neighbour[p];
                (
                    nb.iter().copied().fold(grains.start, u32::min),
                    nb.iter().copied().fold(grains.end - 1, u32::max),
                )
            })
            .collect();
        (rs, own, partner, width, chunk_base, neighbour, reach)
    }

    /// A half list of `n` grains: each grain's partners, ascending, among the next
    /// 80 (some far, as across a thread boundary), from a fixed-seed generator; with
    /// `far_one_in` > 0, one partner in that many anywhere ahead instead.
    pub(crate) fn half_list(n: usize, seed: u64, far_one_in: usize) -> (Vec<u32>, Vec<u32>) {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as usize
        };
        let (mut start, mut js) = (vec![0u32], vec![]);
        for i in 0..n {
            let mut p: Vec<u32> = (0..next() % 7)
                .map(|_| {
                    let ahead = if far_one_in > 0 && next() % far_one_in == 0 {
                        n.max(1)
                    } else {
                        80
                    };
                    (i + 1 + next() % ahead).min(n.max(1) - 1) as u32
                })
                .filter(|&j| j as usize > i)
                .collect();
            p.sort_unstable();
            p.dedup();
            js.extend(p);
            start.push(js.len() as u32);
        }
        (start, js)
    }

    /// The parts' build, the phases run part after part as the threads would.
    fn in_parts(r: &mut Reverse, n: usize, parts: usize, start: &[u32], js: &[u32]) {
        r.begin(n, parts, start, js);
        // SAFETY: one thread; each phase for every part before the next phase.
        unsafe {
            let v = r.view();
            (0..parts).for_each(|t| v.count(t, start, js));
            (0..parts).for_each(|t| v.sum(t, start));
            r.offsets();
            let v = r.view();
            // The later parts first: nothing may depend on their order.
            (0..parts).rev().for_each(|t| v.place(t, start, js));
            (0..parts).for_each(|t| v.reach(t));
        }
    }

    #[test]
    fn every_split_gives_the_layout_built_grain_after_grain() {
        for (n, seed) in [(0, 1), (1, 2), (31, 3), (70, 4), (1000, 5), (4133, 6)] {
            let (start, js) = half_list(n, seed, 0);
            assert!(n < 1000 || js.len() > 2 * n, "a list worth the name");
            let want = reference(n, &start, &js);
            // One set of buffers for every split, so stale entries would show.
            let mut r = Reverse::default();
            for parts in [1, 2, 3, 5, 8] {
                in_parts(&mut r, n, parts, &start, &js);
                let got = (
                    r.start.clone(),
                    r.term_own.clone(),
                    r.term_partner.clone(),
                    r.width.clone(),
                    r.chunk_base.clone(),
                    r.neighbour.clone(),
                    r.reach.clone(),
                );
                assert_eq!(got, want, "{n} grains in {parts} parts");
                assert_eq!(r.places, want.5.len());
                let covered: usize = (0..parts).map(|t| r.places_of_part(t).len()).sum();
                assert_eq!(covered, r.places, "the parts' places cover the terms");
            }
            r.rebuild(n, &start, &js);
            assert_eq!(
                (&r.start, &r.term_partner, &r.neighbour),
                (&want.0, &want.2, &want.5)
            );
        }
    }

    #[test]
    fn a_list_whose_offsets_do_not_fit_is_refused_before_anything_is_written() {
        let bad: [(usize, &[u32], &[u32]); 4] = [
            // Offsets for one grain more than there are.
            (0, &[0, 1], &[0]),
            // Not from 0.
            (2, &[1, 1, 1], &[1]),
            // Past the slots.
            (2, &[0, 2, 2], &[1]),
            // Descending.
            (3, &[0, 2, 1, 2], &[1, 2]),
        ];
        for (n, start, js) in bad {
            let r = std::panic::catch_unwind(|| Reverse::build(n, start, js));
            let msg = r.expect_err("refused").downcast::<String>().unwrap();
            assert!(msg.contains("offsets ascend"), "{msg}");
        }
        // A partner beyond the grains: refused as it is counted.
        let r = std::panic::catch_unwind(|| Reverse::build(2, &[0, 1, 1], &[5]));
        assert!(r.is_err());
    }
}
