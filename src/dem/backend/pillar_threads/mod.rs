//! Running pillar steps on several threads (or one): the phases of `pillar_phases`,
//! separated by a barrier (`barrier`), with the few serial parts (the pair-list
//! rebuild's grid and joining, totals, force snapshots) on the first thread; the
//! rebuild's listing and the terms' layout (`layout`), most of its work, run on every
//! thread. A step of N = 1000 grains is tens of
//! microseconds, far below what waking a thread pool costs, so the threads live for a
//! whole `advance` call. Shares of grains follow the measured work; a run whose waits
//! keep being long (a busy machine) finishes on one thread. The numbers never depend on
//! any of this. The unsafe plumbing is in `pillar_arrays`.

use crate::dem::backend::barrier::{MAX_SPIN, PoisonOnPanic, SpinBarrier};
use crate::dem::backend::simd::{Pos, Quad};
use crate::dem::base::verlet::{Boundary, PendingBuild};
use crate::dem::pillar::{PillarSim, top_y_at};
pub mod arrays;
mod layout;

use crate::dem::backend::pillar_threads::arrays::{
    SendPtr, Shared, Slots, StepLaws, parity_half, phase_grains, phase_kick, phase_pack,
    phase_pairs,
};
use crate::dem::backend::pillar_threads::layout::LayoutBuild;
use crate::dem::pillar::phases::CHUNK;
use crate::stats::median_select;
use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// A value alone in its cache line (two, against the adjacent-line prefetcher).
#[repr(align(128))]
struct Line<T>(T);

/// Over each window of steps, more long waits than this send the rest of an `advance`
/// call to one thread.
const FALLBACK_WINDOW: u64 = 64;
const FALLBACK_LONG_WAITS: usize = 16;
/// Work of two neighbouring threads within this fraction of each other is balanced:
/// 10 % left thread 0 of two waiting 25 µs of a 190 µs step at N = 16,000, where a
/// chunk (32 grains) is under 1 % of a thread's work. In small pillars (N = 1000: a
/// chunk is 6-10 % of a thread's work) the rounding to whole chunks decides instead:
/// a boundary moves only when the move is half a chunk or more.
const BALANCE_BAND: f64 = 0.02;
/// Timed steps between two rebalances: each thread's work in each is kept (one slot
/// per timed step of the window), so that the rebalance can take medians.
const SAMPLES: usize = 8;
/// Grains a thread from which the shares are rebalanced often (`rebalance_every`).
const LARGE_SHARE: usize = 2048;

/// Steps between rebalances of the threads' shares, for `n` grains on `threads`;
/// a timed step (for the rebalance) every `SAMPLES`-th of that. A share of
/// `LARGE_SHARE` grains or more: every 8 steps, each one timed. At N = 16,000 on two
/// threads the work moves between the shares by tens of microseconds a step within a
/// few tens of steps (a region of the pillar wakes up and settles again; measured step
/// by step in a `bench dem` run, 2026-11-29), which a rebalance every 128 steps
/// followed late: the threads waited 15–18 µs a step at the kick barrier, 9–13 µs
/// rebalancing every 8 (a rebalance is a step with a short serial part, about nothing
/// at this size since `export_points` starts at the chunks' reach). Smaller pillars
/// keep 128: a step of 1000 grains on two threads is a few microseconds, and each
/// timing a few clock reads. One thread keeps 128 too (its share never moves).
pub(crate) fn rebalance_every(n: usize, threads: usize) -> u64 {
    // Multiples of `SAMPLES`, so that a timed step comes every 1 or 16 steps.
    if threads > 1 && n / threads >= LARGE_SHARE {
        SAMPLES as u64
    } else {
        16 * SAMPLES as u64
    }
}
/// Fewer timed steps than this in which both neighbours were timed: no move.
const MIN_SAMPLES: usize = 3;
/// The fraction of the measured imbalance a rebalance removes.
const BALANCE_GAIN: f64 = 0.75;

impl PillarSim {
    /// Threads an `advance` uses: the `threads` setting, or (0) one per core
    /// (`RAYON_NUM_THREADS` when set) up to one per 256 grains (fewer grains per thread cost more in waiting than they save).
    pub fn threads_for_run(&self) -> usize {
        let n = self.grains.len();
        crate::dem::backend::threads_for(self.scratch.threads, n / 256, n)
    }

    /// Advance `steps` time steps δt (see `step`), on `threads_for_run()` threads; the
    /// result does not depend on the thread count.
    pub fn advance(&mut self, steps: u64) {
        self.advance_with(steps, self.threads_for_run());
    }

    /// As [`PillarSim::advance`] on `threads` threads.
    pub fn advance_with(&mut self, steps: u64, threads: usize) {
        let threads = threads.clamp(1, self.grains.len().max(1));
        if steps == 0 {
            return;
        }
        self.prepare(threads);
        let barrier = SpinBarrier::new(threads);
        let shared = Shared(UnsafeCell::new(self.arrays(true)));
        // A list rebuild under way, begun by thread 0 in a slow step's serial part.
        let rebuild: Shared<Option<PendingBuild>> = Shared(UnsafeCell::new(None));
        // Its terms' layout under way, begun by thread 0 once the list is joined.
        let layout: Shared<Option<LayoutBuild>> = Shared(UnsafeCell::new(None));
        let laws = StepLaws::of(self);
        // The frozen skip of a fast step: the terms always hold the list's forces there
        // (fast steps never rebuild it).
        let freeze = self.frozen_skip_allowed();
        let record = self.record.is_some();
        let no_fallback = threads == 1 || self.scratch.no_fallback;
        let every = rebalance_every(self.grains.len(), threads);
        let time_every = every / SAMPLES as u64;
        #[cfg(test)]
        let pause_us = self.scratch.pause_after_barrier_us;
        let sim: *mut PillarSim = self;
        let sim = SendPtr(sim);
        // Steps done, and a request (from thread 0) to finish on one thread: on a machine
        // busy with other work each barrier can cost a scheduler time slice.
        let done = AtomicU64::new(0);
        let fall_back = Line(AtomicBool::new(false));
        // This step's frozen marking, decided by thread 0 at the start of a fast step's
        // pairs and published with its `exported` flag. Each in a cache line of its
        // own: thread 0 writes this every fast step, and `fall_back` is read by every
        // thread every step (a shared line would cross cores twice a step).
        let mark_now = Line(AtomicBool::new(false));
        // Per thread: the last step whose slots reaching later threads' grains it has
        // computed (`Slots::Exports`).
        let exported: Vec<Line<AtomicU64>> =
            (0..threads).map(|_| Line(AtomicU64::new(0))).collect();
        // SAFETY: read before any thread starts.
        let first = unsafe { (*sim.get()).step };
        // A step: the kick; a barrier; the pair slots; the grain phase. Threads meet
        // once a step. Every thread decides from the same numbers (after the barrier)
        // whether a step is *slow*: the first, one that rebalances or whose list must
        // be rebuilt, or any with a force snapshot. A slow step has a serial part on
        // thread 0 (last step's totals, the rebuild, the shares, this step's views)
        // and a second barrier; when the list is rebuilt, the serial part begins the
        // build before that barrier, every thread lists its part of the pairs after
        // it, thread 0 joins the parts, and every thread builds its part of the terms'
        // layout in four phases (thread 0 alone between the second and third), a
        // barrier after each: ten barriers in all, a few microseconds against the
        // milliseconds of a rebuild. On the other steps thread 0 folds last step's
        // totals in at the start of its pairs. No barrier follows the pairs: partners follow their
        // owner in index order, so a thread's grains get terms only from its own slots
        // and from earlier threads' `Exports` slots, which those compute first and
        // flag; a thread then waits only for the earlier threads' flags (thread 0 for
        // none), and a thread's grain phase and next kick touch only its own grains,
        // which no later slot of this step reads (a thread's `Rest` slots reach only
        // its own grains).
        let body = |t: usize| {
            let _poison = PoisonOnPanic(&barrier);
            let mut spin = MAX_SPIN;
            let mut completed = 0u64;
            let mut last_check = 0u64;
            // SAFETY: published before any thread starts; republished only in the serial
            // parts, while every other thread waits.
            let mut a = unsafe { *shared.get() };
            // One phase of the layout under way on this thread's part, then a barrier.
            let layout_part = |phase: unsafe fn(&LayoutBuild, usize), spin: &mut u32| {
                // SAFETY: thread 0 writes the cell only while every thread waits at a
                // barrier, and each phase runs once per part between two of them.
                if let Some(l) = unsafe { &*layout.get() } {
                    unsafe { phase(l, t) };
                }
                barrier.wait(t, spin);
            };
            for k in 0..steps {
                // Set by thread 0 in a serial part; every thread has passed a barrier
                // since, so all stop at the same step.
                if fall_back.0.load(Ordering::Relaxed) {
                    break;
                }
                // The step count during this step's forces, and its parity.
                let step = first + k + 1;
                let parity = (step % 2) as usize;
                // Timed steps fill the window's slots (see `SAMPLES`) in step order.
                let timed = step.is_multiple_of(time_every);
                let slot = t * SAMPLES + (step / time_every) as usize % SAMPLES;
                // SAFETY: see the module notes; serial parts run on thread 0 while the
                // others wait at a barrier holding no references; a fast step's
                // bookkeeping on thread 0 touches no array the phases use.
                unsafe {
                    let clock = timed.then(Instant::now);
                    let m = phase_kick(&a, t, laws.dt, parity);
                    // This step's half: with one barrier a step, a thread may kick the
                    // next step (writing the other half) while another still decides
                    // this one from these numbers.
                    let moves = parity_half(threads, parity);
                    a.moved2.part(moves.start + t..moves.start + t + 1)[0] = m;
                    let mut work = clock.map_or(0.0, |c| c.elapsed().as_secs_f64());
                    barrier.wait(t, &mut spin);
                    // Tests: the last thread pauses here, as if descheduled.
                    #[cfg(test)]
                    if pause_us > 0 && t + 1 == threads {
                        std::thread::sleep(std::time::Duration::from_micros(pause_us));
                    }
                    let slow = k == 0
                        || record
                        || step.is_multiple_of(every)
                        || strayed(a.moved2.view(moves), a.skin)
                        || step >= a.near_bar_until;
                    if slow {
                        if t == 0 {
                            let s = &mut *sim.get();
                            if k > 0 {
                                s.serial_after(true, 1 - parity);
                                if !no_fallback && k >= last_check + FALLBACK_WINDOW {
                                    last_check = k;
                                    if barrier.long_waits.swap(0, Ordering::Relaxed)
                                        > FALLBACK_LONG_WAITS
                                    {
                                        fall_back.0.store(true, Ordering::Relaxed);
                                    }
                                }
                            }
                            *rebuild.get() = s.begin_rebuild(parity, threads);
                            if (*rebuild.get()).is_none() {
                                s.end_step(every);
                                *shared.get() = s.arrays(true);
                            }
                        }
                        barrier.wait(t, &mut spin);
                        // A rebuild's listing, a part of the grains on each thread (the
                        // list is the same for any split), between two barriers: no
                        // thread writes the cell or the simulation until every thread
                        // has listed its part.
                        if (*rebuild.get()).is_some() {
                            if let Some(plan) = &*rebuild.get() {
                                let s = &*sim.get();
                                let g = &s.grains;
                                s.list.list_part(plan, t, &g.x, &g.y, &g.radius);
                            }
                            barrier.wait(t, &mut spin);
                            // The list joined, then its terms' layout in parts
                            // (`layout`), a barrier after each phase; thread 0 alone
                            // between them.
                            if t == 0 {
                                let s = &mut *sim.get();
                                if let Some(plan) = (*rebuild.get()).take() {
                                    s.finish_list(plan);
                                }
                                *layout.get() = s.begin_layout(threads);
                            }
                            barrier.wait(t, &mut spin);
                            if (*layout.get()).is_some() {
                                layout_part(LayoutBuild::count, &mut spin);
                                layout_part(LayoutBuild::sum, &mut spin);
                                if t == 0
                                    && let Some(l) = (*layout.get()).as_mut()
                                {
                                    (*sim.get()).layout_offsets(l);
                                }
                                barrier.wait(t, &mut spin);
                                layout_part(LayoutBuild::place, &mut spin);
                                layout_part(LayoutBuild::reach, &mut spin);
                                // Every thread has read the cell for the last time.
                                if t == 0 {
                                    *layout.get() = None;
                                }
                            }
                            if t == 0 {
                                let s = &mut *sim.get();
                                s.after_layout();
                                s.end_step(every);
                                *shared.get() = s.arrays(true);
                            }
                            barrier.wait(t, &mut spin);
                        }
                        a = *shared.get();
                    } else {
                        a = a.with_flags(freeze, false);
                    }
                    let clock = timed.then(Instant::now);
                    let own_mark = (!slow && t == 0).then(|| {
                        let m = fast_bookkeeping(sim.get(), freeze, 1 - parity);
                        mark_now.0.store(m, Ordering::Relaxed);
                        m
                    });
                    phase_pairs(&a, t, &laws, parity, Slots::Exports);
                    exported[t].0.store(step, Ordering::Release);
                    phase_pairs(&a, t, &laws, parity, Slots::Rest);
                    if let Some(c) = clock {
                        work += c.elapsed().as_secs_f64();
                    }
                    for e in &exported[..t] {
                        barrier.wait_for(&e.0, step, &mut spin);
                    }
                    if !slow {
                        // Published by thread 0's flag, which this thread has seen.
                        let mark = own_mark.unwrap_or_else(|| mark_now.0.load(Ordering::Relaxed));
                        a = a.with_flags(freeze, mark);
                    }
                    let clock = timed.then(Instant::now);
                    phase_grains(&a, t, &laws, step, parity);
                    if let Some(c) = clock {
                        work += c.elapsed().as_secs_f64();
                        a.busy.part(slot..slot + 1)[0] = work;
                    }
                }
                completed += 1;
            }
            if t == 0 {
                done.store(completed, Ordering::Relaxed);
            }
        };
        if threads == 1 {
            body(0);
        } else {
            std::thread::scope(|sc| {
                let mut handles = vec![std::thread::current()];
                for t in 1..threads {
                    let body = &body;
                    handles.push(sc.spawn(move || body(t)).thread().clone());
                }
                let _ = barrier.handles.set(handles);
                body(0);
            });
        }
        // The last step's totals (the next step would have folded them in).
        let done = done.load(Ordering::Relaxed);
        if done > 0 {
            self.serial_after(true, (self.step % 2) as usize);
        }
        let left = steps - done;
        if left > 0 {
            self.scratch.fallbacks += 1;
            self.advance_with(left, 1);
        }
    }

    /// Forces and accelerations at the current state without moving anything (contact
    /// history advances by δt × the current slip, so use on a copy or at rest).
    pub fn refresh_forces(&mut self) {
        self.prepare(1);
        self.scratch.frozen.iter_mut().for_each(|f| *f = false);
        let a = self.arrays(false);
        let laws = StepLaws::of(self);
        let parity = (self.step % 2) as usize;
        // SAFETY: one thread; the arrays outlive the calls.
        unsafe {
            phase_pack(&a);
            phase_pairs(&a, 0, &laws, parity, Slots::Exports);
            phase_pairs(&a, 0, &laws, parity, Slots::Rest);
            phase_grains(&a, 0, &laws, self.step, parity);
        }
        self.serial_after(false, parity);
    }

    /// Sizes every buffer for `threads` threads.
    fn prepare(&mut self, threads: usize) {
        let n = self.grains.len();
        let sub = self.substrate();
        self.scratch
            .consts
            .refresh(&self.grains, &sub, self.params.dt);
        let sc = &mut self.scratch;
        // Two halves, this step's and the next's (see `advance_with`).
        sc.resting.resize(2 * n, false);
        sc.frozen.resize(n, false);
        let b = &mut sc.buffers;
        let chunks = n.div_ceil(CHUNK);
        b.bar_sums.resize(chunks, [0.0; 3]);
        b.near_bar.resize(chunks, true);
        b.power.resize(chunks, [0.0; 2]);
        // One half per step parity (see `advance_with`).
        b.moved2 = vec![0.0; 2 * threads];
        // One half per step parity (see `fast_bookkeeping`).
        b.skipped = vec![0; 2 * threads];
        b.frozen_count = vec![0; 2 * threads];
        // Per thread, its work in each timed step of the window (0: not timed), kept
        // from one call to the next (runs that write frames often advance a few
        // steps a call) unless the split changes.
        if b.busy.len() != threads * SAMPLES {
            b.busy = vec![0.0; threads * SAMPLES];
        }
        b.pow_t.resize(n, 0.0);
        b.pow_r.resize(n, 0.0);
        b.packed_state.resize(n, Quad::default());
        b.packed_spin.resize(n, Pos::default());
        self.sync_list_buffers();
        let b = &self.scratch.buffers;
        // Ascending from 0 to n, or threads' ranges would overlap.
        let fits = |v: &Vec<usize>| {
            v.len() == threads + 1
                && v[0] == 0
                && v.last() == Some(&n)
                && v.windows(2).all(|w| w[0] <= w[1])
        };
        if !fits(&b.bounds) {
            self.balance(threads);
        }
        // Kept from the list's build while the list and the bars are the ones it was
        // made for, so the rebuilds come at the same steps however a run is split
        // into calls.
        if self.scratch.buffers.near_bar_key != Some(self.near_bar_key()) {
            self.mark_near_bars(self.step + 1);
        }
    }

    fn near_bar_key(&self) -> (u64, [u64; 4]) {
        let p = &self.params;
        (
            self.list.builds,
            [self.top_y0, self.bottom_y, p.bar_speed, p.dt].map(f64::to_bits),
        )
    }

    /// Which chunks hold a grain that may touch a bar from the forces of step `from`
    /// until the list's next rebuild, and the step at which that rebuild must come
    /// (`StepBuffers::near_bar`, `near_bar_until`). A grain moves at most half the
    /// list's skin from where the list was built before the list is rebuilt, and the
    /// top bar is allowed half the skin of travel from `from`: a grain further than
    /// its radius and the whole skin (with room to spare) from both bars cannot touch
    /// either. Without a built list every chunk is near.
    fn mark_near_bars(&mut self, from: u64) {
        let n = self.grains.len();
        let (top, bottom) = (
            top_y_at(self.top_y0, self.params.bar_speed, self.params.dt, from),
            self.bottom_y,
        );
        let key = self.near_bar_key();
        let l = &self.list;
        let b = &mut self.scratch.buffers;
        b.near_bar_key = Some(key);
        b.near_bar.resize(n.div_ceil(CHUNK), true);
        if l.y_ref.len() != n || self.scratch.all_bar_chunks {
            b.near_bar.fill(true);
            b.near_bar_until = u64::MAX;
            return;
        }
        let reach = 1.5 * l.skin;
        let r = &self.grains.radius;
        for (c, near) in b.near_bar.iter_mut().enumerate() {
            let grains = c * CHUNK..((c + 1) * CHUNK).min(n);
            *near = grains
                .into_iter()
                .any(|i| top - l.y_ref[i] < r[i] + reach || l.y_ref[i] - bottom < r[i] + reach);
        }
        let travel = self.params.bar_speed.abs() * self.params.dt;
        b.near_bar_until = if travel > 0.0 {
            from.saturating_add(((0.5 * l.skin / travel) as u64).max(1))
        } else {
            u64::MAX
        };
    }

    /// Split the grains into `threads` runs of whole chunks, equal in number (any split
    /// gives the same numbers; `rebalance` then follows the measured work).
    fn balance(&mut self, threads: usize) {
        let n = self.grains.len();
        let chunks = n.div_ceil(CHUNK);
        let b = &mut self.scratch.buffers;
        b.bounds = (0..=threads)
            .map(|t| (chunks * t / threads * CHUNK).min(n))
            .collect();
        b.busy.iter_mut().for_each(|w| *w = 0.0);
    }

    /// Move each boundary between two threads towards the one that worked less since
    /// the last call, by most of the measured imbalance (`shift_bounds`; frozen grains
    /// cost little and gather at the bottom, so equal shares of grains are unequal
    /// shares of work).
    fn rebalance(&mut self) {
        let n = self.grains.len();
        let b = &mut self.scratch.buffers;
        shift_bounds(&mut b.bounds, &mut b.busy, n);
    }

    /// Thread 0 between the kick and the forces: the list's rebuild test (on the
    /// threads' moves in the `parity` half), and when it must be rebuilt, its build
    /// begun in `parts` parts, one for each thread to list.
    fn begin_rebuild(&mut self, parity: usize, parts: usize) -> Option<PendingBuild> {
        let threads = self.scratch.buffers.moved2.len() / 2;
        let moved2 = &self.scratch.buffers.moved2[parity_half(threads, parity)];
        let moved2 = moved2.iter().fold(0.0, |a: f64, &b| a.max(b));
        if !(strayed(&[moved2], self.list.skin)
            || self.list.x_ref.len() != self.grains.len()
            || self.step + 1 >= self.scratch.buffers.near_bar_until)
        {
            return None;
        }
        if self.list.x_ref.len() == self.grains.len() {
            let ratio = moved2.sqrt() / (0.5 * self.list.skin);
            self.scratch.rebuild_overshoot = self.scratch.rebuild_overshoot.max(ratio);
        }
        let since = self
            .scratch
            .last_build
            .and_then(|b| self.step.checked_sub(b));
        self.list.skin = crate::dem::pillar::adapt_skin(self.list.skin, self.params.d_large, since);
        self.scratch.last_build = Some(self.step);
        let g = &self.grains;
        Some(
            self.list
                .begin_build(&g.x, &g.y, &g.radius, Boundary::Open, parts),
        )
    }

    /// A rebuilt list joined from its parts; its slots' buffers no longer hold it.
    fn finish_list(&mut self, plan: PendingBuild) {
        let g = &self.grains;
        self.list.finish_build(plan, &g.x, &g.y);
        self.scratch.buffers.slots_valid = false;
    }

    /// After a rebuilt list's layout (every thread's parts): its checks, and the
    /// chunks near a bar.
    fn after_layout(&mut self) {
        self.end_layout();
        self.mark_near_bars(self.step + 1);
    }

    /// The end of a slow step's serial part on thread 0: the step counted, and the
    /// shares rebalanced when it is time (every `every` steps: the call's
    /// `rebalance_every`, the cadence of its slow steps).
    fn end_step(&mut self, every: u64) {
        self.step += 1;
        if self.step.is_multiple_of(every) {
            self.rebalance();
        }
    }

    /// Thread 0 after the forces of a step whose per-thread counts are in the `parity`
    /// halves: totals in chunk order, the output interval's sums, the force snapshot.
    fn serial_after(&mut self, kick: bool, parity: usize) {
        self.scratch.buffers.slots_valid = true;
        // SAFETY: `self` is borrowed whole, so nothing else touches these fields.
        unsafe { fold_totals(self, kick, parity) };
        if let Some(rec) = self.record.as_mut() {
            let n = self.grains.len();
            *rec = crate::dem::base::forces::ContactRecord::zeroed(n);
            let b = &self.scratch.buffers;
            rec.f_bar.copy_from_slice(&b.rec_bar);
            for i in 0..n {
                for k in self.list.start[i] as usize..self.list.start[i + 1] as usize {
                    if b.rec_touch[k] {
                        for m in [i, self.list.j[k] as usize] {
                            rec.f_n[m] += b.rec_fn[k];
                            rec.f_t[m] += b.rec_ft[k];
                            rec.contacts[m] += 1;
                        }
                    }
                }
            }
        }
    }
}

/// Whether some grain has moved more than half the list's `skin` (m) since the build,
/// given each thread's largest squared move `moved2` (m²): the list must be rebuilt.
/// Every thread asks this of the same numbers, so all take the same path.
fn strayed(moved2: &[f64], skin: f64) -> bool {
    let half = 0.5 * skin;
    moved2.iter().any(|&m| m > half * half)
}

/// Last step's totals (bar forces and power in chunk order, the counts of the
/// `parity` halves) into the simulation and its output interval (with `kick`), and the
/// frozen marking's next choice. Touches only the fields it names, through `sim`.
///
/// # Safety
/// No other thread touches those fields, nor the `parity` halves of the counts or the
/// chunk sums, while this runs.
unsafe fn fold_totals(sim: *mut PillarSim, kick: bool, parity: usize) {
    unsafe {
        let n = (*sim).grains.len();
        let bar_sums: &[[f64; 3]] = &(*sim).scratch.buffers.bar_sums;
        let power: &[[f64; 2]] = &(*sim).scratch.buffers.power;
        let mut tot = [0.0; 3];
        for s in bar_sums {
            for (t, v) in tot.iter_mut().zip(s) {
                *t += v;
            }
        }
        let (mut p_t, mut p_r) = (0.0, 0.0);
        for p in power {
            p_t += p[0];
            p_r += p[1];
        }
        [
            (*sim).top_force,
            (*sim).bottom_force,
            (*sim).bar_shear_force,
        ] = tot;
        let skipped: &mut Vec<u64> = &mut (*sim).scratch.buffers.skipped;
        let half = parity_half(skipped.len() / 2, parity);
        let skipped = &mut skipped[half.clone()];
        (*sim).scratch.skipped_pairs += skipped.iter().sum::<u64>();
        skipped.fill(0);
        let frozen_count: &mut Vec<usize> = &mut (*sim).scratch.buffers.frozen_count;
        let frozen_count = &mut frozen_count[half];
        let frozen = frozen_count.iter().sum::<usize>();
        frozen_count.fill(0);
        (*sim).scratch.frozen_grain_steps += frozen as u64;
        (*sim).scratch.marking.after(frozen, n);
        if kick {
            let iv = &mut (*sim).interval;
            iv.steps += 1;
            iv.top_force += (*sim).top_force;
            iv.bottom_force += (*sim).bottom_force;
            iv.substrate_power += p_t;
            iv.substrate_power_rot += p_r;
        }
    }
}

/// Thread 0's part of a fast step (no rebuild, no snapshot, no rebalance), run while
/// the pair phase runs: last step's totals (counts in the `parity` halves), the step
/// count, and whether this step marks frozen grains (returned; `freeze` is whether
/// the skip is on at all). The same as the serial part of a slow step would do.
///
/// # Safety
/// Thread 0 between the kick barrier and the pair barrier of a fast step: the other
/// threads hold no reference to the simulation (only `Arrays` views and `StepLaws`)
/// and write only this step's halves of the counts.
unsafe fn fast_bookkeeping(sim: *mut PillarSim, freeze: bool, parity: usize) -> bool {
    unsafe {
        // Written only when it changes: the flag shares a cache line with the reverse
        // index the other threads read in every phase.
        if !(*sim).scratch.buffers.slots_valid {
            (*sim).scratch.buffers.slots_valid = true;
        }
        fold_totals(sim, true, parity);
        (*sim).step += 1;
        let marking = &mut (*sim).scratch.marking;
        let mark = freeze && marking.now;
        marking.marked = mark;
        mark
    }
}

/// One step of [`PillarSim::rebalance`] for one split, from `busy`: each thread's work
/// in each timed step of the window (`SAMPLES` a thread, 0 where not timed), which it
/// clears. Each boundary moves by `BALANCE_GAIN` of the grains that would even out
/// its two threads' work, in whole chunks. The imbalance is the median over the
/// timed steps of the difference of the two threads' work in the same step, and the
/// busier side's cost per grain its median work over its grains: the work moves as
/// the pillar flows and grains freeze (by 30 % between two threads within 2000 steps
/// at N = 16,000, measured), and one step in which a thread was descheduled (tens of
/// microseconds, against a few of imbalance) swung a sum of the timings, and the
/// boundary with it, the wrong way.
fn shift_bounds(bounds: &mut [usize], busy: &mut [f64], n: usize) {
    let window = |t: usize| &busy[t * SAMPLES..(t + 1) * SAMPLES];
    for t in 1..bounds.len() - 1 {
        let (l, r) = (window(t - 1), window(t));
        let both = || l.iter().zip(r).filter(|&(&a, &b)| a > 0.0 && b > 0.0);
        if both().count() < MIN_SAMPLES {
            continue;
        }
        let median = |v: Vec<f64>| median_select(&mut { v });
        let diff = median(both().map(|(a, b)| a - b).collect());
        let left = median(both().map(|(&a, _)| a).collect());
        let right = median(both().map(|(_, &b)| b).collect());
        if diff.abs() <= BALANCE_BAND * left.max(right) {
            continue;
        }
        let (lo, hi) = (bounds[t - 1], bounds[t + 1].min(n));
        // Grains to move from the busier side, at that side's cost per grain.
        let (from, grains) = if diff < 0.0 {
            (right, hi - bounds[t])
        } else {
            (left, bounds[t] - lo)
        };
        let cost = from / grains.max(1) as f64;
        // Moving g grains changes the difference by 2 g × cost.
        let chunks = ((diff.abs() * BALANCE_GAIN / 2.0 / cost) / CHUNK as f64).round() as usize;
        if diff < 0.0 {
            // Whole chunks, never past the next boundary.
            let room = (hi - bounds[t]) / CHUNK;
            bounds[t] += chunks.min(room) * CHUNK;
        } else {
            let room = (bounds[t] - lo) / CHUNK;
            bounds[t] -= chunks.min(room) * CHUNK;
        }
    }
    busy.iter_mut().for_each(|v| *v = 0.0);
}

/// The cache lines that cross between the threads' cores every step at the current
/// split (the explanation `bench dem` gives of two threads' overhead): each is written
/// on one core and read on another, so it moves once there and once back a step.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct CrossLines {
    /// Packed states, spins and rest flags of a later thread's grains that an earlier
    /// thread's pair slots read.
    pub partner_state: usize,
    /// Lines of a later thread's grains' terms that an earlier thread's slots write.
    pub terms: usize,
    /// Rest flags of an earlier thread's grains that a later thread's frozen marking
    /// reads.
    pub marking: usize,
    /// Per-chunk bar sums and power of later threads, which thread 0 folds.
    pub chunk_sums: usize,
}

impl CrossLines {
    pub fn total(&self) -> usize {
        self.partner_state + self.terms + self.marking + self.chunk_sums
    }
}

impl PillarSim {
    /// [`CrossLines`] of the split the last `advance` used (none on one thread), from
    /// the arrays' addresses.
    pub fn cross_core_lines(&self) -> CrossLines {
        let b = &self.scratch.buffers;
        let n = self.grains.len();
        if b.bounds.len() < 3 || b.reverse.term_partner.len() != self.list.j.len() {
            return CrossLines::default();
        }
        let thread_of = |g: usize| b.bounds.partition_point(|&x| x <= g) - 1;
        let line = |base: usize, index: usize, size: usize| (base + index * size) / 64;
        let addr = |p: *const u8| p as usize;
        let (state, spin, rest, terms) = (
            addr(b.packed_state.as_ptr().cast()),
            addr(b.packed_spin.as_ptr().cast()),
            addr(self.scratch.resting.as_ptr().cast()),
            addr(b.terms.as_ptr().cast()),
        );
        let mut sets: [std::collections::HashSet<usize>; 3] = Default::default();
        for i in 0..n {
            for k in self.list.start[i] as usize..self.list.start[i + 1] as usize {
                let j = self.list.j[k] as usize;
                if thread_of(i) == thread_of(j) {
                    continue;
                }
                sets[0].extend([
                    line(state, j, size_of::<Quad>()),
                    line(spin, j, size_of::<Pos>()),
                    line(rest, j, 1),
                ]);
                sets[1].insert(line(
                    terms,
                    b.reverse.term_partner[k] as usize,
                    size_of::<Quad>(),
                ));
                sets[2].insert(line(rest, i, 1));
            }
        }
        let chunks = b.bounds[1].div_ceil(CHUNK)..n.div_ceil(CHUNK);
        let (sums, power) = (
            addr(b.bar_sums.as_ptr().cast()),
            addr(b.power.as_ptr().cast()),
        );
        let chunk_lines: std::collections::HashSet<usize> = chunks
            .flat_map(|c| {
                [
                    line(sums, c, size_of::<[f64; 3]>()),
                    line(power, c, size_of::<[f64; 2]>()),
                ]
            })
            .collect();
        CrossLines {
            partner_state: sets[0].len(),
            terms: sets[1].len(),
            marking: sets[2].len(),
            chunk_sums: chunk_lines.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each thread's work the same in every timed step of the window.
    fn windows(work: &[f64]) -> Vec<f64> {
        work.iter().flat_map(|&w| [w; SAMPLES]).collect()
    }

    #[test]
    fn a_boundary_moves_most_of_the_way_to_even_work_in_whole_chunks() {
        let n = 16_000;
        // Thread 1 works twice as long on as many grains: the difference (1) over twice
        // its cost per grain (2/8000) is 2000 grains; 3/4 of that is 1500, 47 chunks.
        let (mut bounds, mut busy) = (vec![0, 8000, n], windows(&[1.0, 2.0]));
        shift_bounds(&mut bounds, &mut busy, n);
        assert_eq!(bounds, [0, 8000 + 47 * CHUNK, n]);
        assert!(busy.iter().all(|&w| w == 0.0), "the window is cleared");
        let (mut bounds, mut busy) = (vec![0, 8000, n], windows(&[2.0, 1.0]));
        shift_bounds(&mut bounds, &mut busy, n);
        assert_eq!(bounds, [0, 8000 - 47 * CHUNK, n]);
        // Within the band: left alone.
        let (mut bounds, mut busy) = (vec![0, 8000, n], windows(&[1.0, 1.01]));
        shift_bounds(&mut bounds, &mut busy, n);
        assert_eq!(bounds, [0, 8000, n]);
        // A move of half a chunk or more moves a chunk, less stays: all the work on
        // thread 1's 68 grains, 3/8 of them is 0.8 chunk; then of its 36, 0.42 chunk.
        let (mut bounds, mut busy) = (vec![0, 32, 100], windows(&[1e-6, 1.0]));
        shift_bounds(&mut bounds, &mut busy, 100);
        assert_eq!(bounds, [0, 64, 100]);
        shift_bounds(&mut bounds, &mut windows(&[1e-6, 1.0]), 100);
        assert_eq!(bounds, [0, 64, 100], "less than half a chunk: no move");
        // The other way: 3/8 of thread 0's 96 grains is 1.1 chunks, of 64 0.75, of
        // 32 0.38.
        let (mut bounds, mut busy) = (vec![0, 96, 100], windows(&[1.0, 1e-6]));
        shift_bounds(&mut bounds, &mut busy, 100);
        assert_eq!(bounds, [0, 64, 100]);
        shift_bounds(&mut bounds, &mut windows(&[1.0, 1e-6]), 100);
        assert_eq!(bounds, [0, 32, 100]);
        shift_bounds(&mut bounds, &mut windows(&[1.0, 1e-6]), 100);
        assert_eq!(bounds, [0, 32, 100], "less than half a chunk: no move");
    }

    #[test]
    fn one_descheduled_step_does_not_move_a_boundary_the_wrong_way() {
        let n = 16_000;
        // Thread 1 is busier in every timed step but one, in which thread 0 was held
        // up for 50 times a step's work: a sum of the timings would move the boundary
        // far down; the median moves it up as without that step.
        let mut busy = windows(&[1.0, 2.0]);
        busy[3] = 50.0;
        let mut bounds = vec![0, 8000, n];
        shift_bounds(&mut bounds, &mut busy, n);
        assert_eq!(bounds, [0, 8000 + 47 * CHUNK, n]);
    }

    #[test]
    fn too_few_steps_timed_on_both_sides_move_nothing() {
        let n = 16_000;
        // Two timed steps in common: too few to tell noise from imbalance.
        let mut busy = vec![0.0; 2 * SAMPLES];
        busy[0] = 1.0;
        busy[1] = 1.0;
        busy[SAMPLES] = 2.0;
        busy[SAMPLES + 1] = 2.0;
        let mut bounds = vec![0, 8000, n];
        shift_bounds(&mut bounds, &mut busy, n);
        assert_eq!(bounds, [0, 8000, n]);
        // Each side timed in different steps (none in common): no move either.
        let mut busy = vec![0.0; 2 * SAMPLES];
        busy[..SAMPLES / 2].fill(1.0);
        busy[SAMPLES + SAMPLES / 2..].fill(2.0);
        shift_bounds(&mut bounds, &mut busy, n);
        assert_eq!(bounds, [0, 8000, n]);
    }

    #[test]
    fn shares_settle_where_the_work_is_even() {
        // Three threads, grains costing 1, 2 and 4 in thirds of the pillar: each two
        // neighbours' shares settle within the band (and the two chunks' worth the
        // rounding leaves) of equal work.
        let n = 9600;
        let cost = |g: usize| [1.0, 2.0, 4.0][g * 3 / n];
        let work = |r: std::ops::Range<usize>| r.map(cost).sum::<f64>();
        let mut bounds = vec![0, 3200, 6400, n];
        for _ in 0..40 {
            let w: Vec<f64> = bounds.windows(2).map(|w| work(w[0]..w[1])).collect();
            shift_bounds(&mut bounds, &mut windows(&w), n);
        }
        let w: Vec<f64> = bounds.windows(2).map(|w| work(w[0]..w[1])).collect();
        for p in w.windows(2) {
            let (lo, hi) = (p[0].min(p[1]), p[0].max(p[1]));
            assert!(
                hi <= (1.0 + BALANCE_BAND) * lo + 2.0 * 4.0 * CHUNK as f64,
                "{w:?} at {bounds:?}"
            );
        }
        assert!(bounds.iter().skip(1).take(2).all(|b| b % CHUNK == 0));
    }
}
