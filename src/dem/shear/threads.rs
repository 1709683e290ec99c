//! The sheared disks' steps on several threads, with the same numbers bit for bit as
//! on one (and so for any thread count).
//!
//! Each thread owns a contiguous range of grains (a band of rows, the grains being in
//! cell order) and the near list's slots of those grains. A grain's force is a sum in
//! slot order: first the terms of slots (i, g) with i < g, then its own slots. The terms
//! from earlier threads' slots (i in an earlier band, or in the bottom band across the
//! Lees–Edwards boundary) are *imports*: each thread evaluates those slots again itself,
//! first, in slot order, and keeps only their j side; its own slots follow, their j
//! side kept only for its own grains. Every grain then gets the terms it gets on one
//! thread, in the same order, and no thread waits for another within an evaluation
//! (the pairs evaluated twice are a few per cent at the bands' edges). Contact events
//! are logged per thread and applied after, in slot order (the collision counts sum
//! durations, whose rounding depends on the order). The integrator works grain by
//! grain and splits as the grains do; the near list's re-selection and the Verlet
//! list's rebuild split into ranges of grains joined in order.
//!
//! The threads are a persistent [`Team`] (one per simulation, kept in its
//! [`ShearThreads`] cache), its workers spinning between the phases (each a job of
//! the team, one share per part): a phase is a fraction of a millisecond at
//! N = 16,384, and handing each to a rayon pool, whose workers had gone to sleep, cost
//! much of the second thread's gain (issue 35). On a busy machine the steps fall back
//! to the one-thread path for a while (see `FALLBACK_WINDOW`).

use crate::dem::backend::shear_integrate_avx2::{
    Now, Packed0, correct_packed, predict_packed_into, unpack_and_predict, unpack_forces,
};
use crate::dem::backend::team::{Team, chunked};
use crate::dem::shear::ShearSim;
use crate::dem::shear::integrate::{Pos, Quad};
use crate::dem::shear::near::{Event, History, Slots};
use crate::dem::shear::pairs::PairParams;
use crate::dem::shear::params::Collisions;
use std::sync::Arc;

/// Grains per thread below which the default thread count (`threads` = 0) adds no
/// thread: an evaluation of fewer grains is over before a woken thread has started.
pub const GRAINS_PER_THREAD: usize = 4096;

/// The threads' tables and team: a cache, rebuilt when missing, never part of a
/// simulation's value.
#[derive(Default)]
pub struct ShearThreads {
    /// The threads the steps run on, kept from step to step (their spinning between
    /// phases is what makes a phase of a fraction of a millisecond worth splitting).
    team: Option<Arc<Team>>,
    parts: Vec<Part>,
    /// The near list's selection (`Slots::selections`) and the split the tables were
    /// made for.
    split_of: Option<(u64, Vec<usize>)>,
    /// The tables' history copies are the near list's (false after any evaluation that
    /// did not run here, which may have changed them).
    hist_synced: bool,
    /// Steps before this step count run on one thread: the team's waits were long (a
    /// busy machine, where each phase can wait out a scheduler time slice).
    solo_until: u64,
    /// Length of the next fall-back (doubling while the machine stays busy).
    solo_len: u64,
    /// The last window looked busy (one busy window alone, its share a little under
    /// `FALLBACK_SHARE`, was seen on an idle VM; two in a row were not).
    busy_before: bool,
    /// Threaded steps since the team's long waits were last looked at.
    window: u64,
    /// Steps that ran on one thread after falling back.
    pub solo_steps: u64,
    /// Wall and CPU seconds (the process's) in the current window's steps.
    in_steps: (f64, f64),
    /// Never fall back on its own (tests).
    pub(crate) no_fallback: bool,
    /// The grains' split among the threads (see [`ShearThreads::rebalance`]).
    bounds: Vec<usize>,
}

/// Steps timed on every part since the last re-balance below which it keeps the
/// bounds (the median of fewer says little).
const BALANCE_MIN_STEPS: usize = 3;
/// Steps kept (the latest) for a re-balance when selections are rare (low rates).
const BALANCE_MAX_STEPS: usize = 128;
/// Fraction of the way to the measured balance a re-balance moves the bounds (each
/// measurement is a few tens of steps on a machine that is never quite quiet).
const BALANCE_GAIN: f64 = 0.5;

/// Every this many threaded steps the steps are looked at; two busy windows in a row
/// send the next `solo_len` steps to one thread, as the pillar's `advance` does: with
/// a core taken by other work, a share waits for the thread that took it to get its
/// core back, several times a step
/// (0.5–0.7× one thread measured at N = 16,384 and 65,536 with another program busy on
/// one of two cores). Busy means more than `FALLBACK_LONG_WAITS` long waits of the
/// calling thread, or the threads getting less than `FALLBACK_SHARE` of their cores
/// during the steps (the process's CPU time over wall time and threads: a thread that
/// works or spins counts; one waiting for its core does not: measured 0.44–0.6 per
/// window with a core taken, 0.8–1.1 on the idle machine, a few quiet windows down
/// to 0.72, and on an idle AMD guest down to 0.69, with runs of `bench shear` that
/// fell back once for 256 steps on one busy window alone).
const FALLBACK_WINDOW: u64 = 32;
const FALLBACK_LONG_WAITS: usize = 8;
const FALLBACK_SHARE: f64 = 0.65;
/// The first fall-back's length in steps, and the longest (a busy spell tried again
/// every so often costs a window of slow steps each time).
const SOLO_FIRST: u64 = 256;
const SOLO_MAX: u64 = 16_384;

/// A clone gets a team of its own when it first steps on threads: two simulations
/// stepping at once on one team would mix their phases.
impl Clone for ShearThreads {
    fn clone(&self) -> Self {
        ShearThreads::default()
    }
}

impl PartialEq for ShearThreads {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for ShearThreads {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ShearThreads({} parts)", self.parts.len())
    }
}

impl ShearThreads {
    /// Forget that the tables' histories are current (an evaluation elsewhere).
    pub(crate) fn history_changed(&mut self) {
        self.hist_synced = false;
    }

    /// A team of `threads`, the calling thread its first: the last one, if it has
    /// that many threads and was made on this thread (else its barrier would wake
    /// another), else a new one (the old one's workers end as it drops).
    fn team(&mut self, threads: usize) -> Arc<Team> {
        match &self.team {
            Some(t) if t.size() == threads && t.owned_here() => t.clone(),
            _ => {
                // The old team's workers end before the new one's start.
                self.team = None;
                let t = Arc::new(Team::new(threads, "shear"));
                self.team = Some(t.clone());
                t
            }
        }
    }

    /// The team for `threads` threads to lend to work between steps (a re-sort's list
    /// build, a sample's virial; run it through [`Team::uncounted`]), when the steps
    /// run on more than one; none on one or while fallen back.
    pub(crate) fn lend_team(&mut self, threads: usize, step: u64) -> Option<Arc<Team>> {
        (threads > 1 && step >= self.solo_until).then(|| self.team(threads))
    }

    /// Whether the step after `step` runs on one thread (a fall-back is on); counts it.
    pub(crate) fn solo(&mut self, step: u64) -> bool {
        let solo = step < self.solo_until;
        self.solo_steps += u64::from(solo);
        solo
    }

    /// After a threaded step (the step count now `step`) that took `wall` seconds and
    /// `cpu` seconds of the process's CPU time: fall back to one thread when the last
    /// window of steps shows a busy machine (see `FALLBACK_WINDOW`).
    fn watch(&mut self, step: u64, team: &Team, (wall, cpu): (f64, f64)) {
        self.window += 1;
        if self.window == 1 {
            // The window starts here (after a fall-back, or with a new team).
            self.in_steps = (0.0, 0.0);
            team.take_long_waits();
            return;
        }
        self.in_steps.0 += wall;
        self.in_steps.1 += cpu;
        if self.window <= FALLBACK_WINDOW {
            return;
        }
        self.window = 0;
        let share = self.in_steps.1 / (self.in_steps.0 * team.size() as f64);
        self.after_window(step, team.take_long_waits(), share);
    }

    /// `watch`'s decision, given the window's long waits and the threads' share of
    /// their cores (the process's CPU time over the steps' wall time and threads).
    fn after_window(&mut self, step: u64, long_waits: usize, share: f64) {
        let busy = long_waits > FALLBACK_LONG_WAITS || share < FALLBACK_SHARE;
        // A second busy window in a row, or the first after a fall-back (the machine
        // still busy).
        let confirmed = busy && (self.busy_before || self.solo_len > SOLO_FIRST);
        self.busy_before = busy;
        if confirmed && !self.no_fallback {
            // The busy windows' times would steer the next re-balance.
            self.parts.iter_mut().for_each(|p| p.times.clear());
            let len = self.solo_len.clamp(SOLO_FIRST, SOLO_MAX);
            self.solo_until = step + len;
            self.solo_len = (2 * len).min(SOLO_MAX);
        } else {
            self.solo_len = SOLO_FIRST;
        }
    }

    /// Drop the team (its workers end); the tables stay.
    pub(crate) fn end_threads(&mut self) {
        self.team = None;
    }

    /// Threads of the team the last threaded step ran on (0 without one).
    pub fn team_threads(&self) -> usize {
        self.team.as_ref().map_or(0, |t| t.size())
    }

    /// The split of n grains among `threads` threads: the current one, or an even one
    /// for another n or thread count.
    fn bounds_for(&mut self, n: usize, threads: usize) -> Vec<usize> {
        if self.bounds.len() != threads + 1 || self.bounds.last() != Some(&n) {
            self.bounds = bounds(n, threads);
            self.parts.iter_mut().for_each(|p| p.times.clear());
        }
        self.bounds.clone()
    }

    /// At a new selection of the near list found by the predictor's stray test (when
    /// the threads' tables are made again anyway; one found after the corrector keeps
    /// the split): move the split towards equal time on every thread, from each part's
    /// median seconds of work a step since the last re-balance (a median, so that one
    /// step held up by the host does not move the split the wrong way, as the
    /// pillar's threads found). A part may cost more a grain for its contacts, its
    /// imports or its thread's core (a host that gives one core less time); any split
    /// gives the same numbers.
    fn rebalance(&mut self) -> Vec<usize> {
        let measured =
            self.parts.len() + 1 == self.bounds.len()
                && self.parts.iter().zip(self.bounds.windows(2)).all(|(p, w)| {
                    (p.lo, p.hi) == (w[0], w[1]) && p.times.len() >= BALANCE_MIN_STEPS
                });
        if measured {
            let busy: Vec<f64> = self
                .parts
                .iter_mut()
                .map(|p| crate::stats::median_select(&mut p.times))
                .collect();
            self.bounds = balanced(&self.bounds, &busy, BALANCE_GAIN);
            self.parts.iter_mut().for_each(|p| p.times.clear());
        }
        self.bounds.clone()
    }

    /// The tables for the current selection of `slots` and split `bounds`, each made
    /// by its own thread of `team`.
    fn split(&mut self, slots: &Slots, bounds: &[usize], team: &Team) {
        if self
            .split_of
            .as_ref()
            .is_some_and(|(s, b)| *s == slots.selections && b == bounds)
        {
            return;
        }
        let moved = self.split_of.as_ref().is_none_or(|(_, b)| b != bounds);
        self.parts.resize_with(bounds.len() - 1, Part::default);
        let jobs: Vec<_> = self
            .parts
            .iter_mut()
            .enumerate()
            .map(|(t, p)| {
                move || {
                    if moved {
                        // Sums another share left (outside its range) would be read
                        // now; times were for the old range.
                        p.acc.clear();
                        p.times.clear();
                    }
                    p.lo = bounds[t];
                    p.hi = bounds[t + 1];
                    p.k0 = slots.split_into((p.lo, p.hi), &mut p.own, &mut p.imports);
                }
            })
            .collect();
        on_threads(team, jobs);
        self.split_of = Some((slots.selections, bounds.to_vec()));
        // `split_into` copied the histories.
        self.hist_synced = true;
    }
}

/// The process's CPU time so far (seconds, all its threads).
fn cpu_seconds() -> f64 {
    // SAFETY: `getrusage` only writes the struct it is given.
    unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        if libc::getrusage(libc::RUSAGE_SELF, &mut u) == 0 {
            let secs = |t: libc::timeval| t.tv_sec as f64 + 1e-6 * t.tv_usec as f64;
            secs(u.ru_utime) + secs(u.ru_stime)
        } else {
            0.0
        }
    }
}

/// One thread's share: grains `lo..hi`, their slots (`own`, from the near list's slot
/// `k0` on) and the earlier slots that reach them (`imports`), the force sums
/// (indexed by grain; only `lo..hi` is read: what lands elsewhere is another thread's
/// and is never read), and the contact events of an evaluation.
#[derive(Default)]
struct Part {
    lo: usize,
    hi: usize,
    k0: usize,
    own: Slots,
    imports: Slots,
    acc: Vec<Quad>,
    log: Vec<Event>,
    /// Seconds its shares took in the current step, and in each step since the last
    /// re-balance (with these `lo`, `hi`).
    busy: f64,
    times: Vec<f64>,
    /// Never written (evaluations without tracking do not count).
    no_coll: Collisions,
}

/// Split grains 0..n into `threads` ranges of about equal size, each boundary a
/// multiple of eight grains (so no cache line of a per-grain array is written by two
/// threads).
fn bounds(n: usize, threads: usize) -> Vec<usize> {
    (0..=threads)
        .map(|t| {
            if t == threads {
                n
            } else {
                (n * t / threads) & !7
            }
        })
        .collect()
}

/// `bounds` (from 0 to n, ascending) moved `gain` of the way to where each part's
/// work would take equal time, the work of a part's grains being `busy` (its seconds)
/// spread evenly over them; each boundary a multiple of eight, each part at least
/// eight grains (as in [`bounds`]). Unchanged when a part's time is not positive.
fn balanced(bounds: &[usize], busy: &[f64], gain: f64) -> Vec<usize> {
    let parts = bounds.len() - 1;
    let n = bounds[parts];
    let total: f64 = busy.iter().sum();
    if busy.len() != parts || !busy.iter().all(|&b| b > 0.0 && b.is_finite()) || n < 8 * parts {
        return bounds.to_vec();
    }
    let mut out = bounds.to_vec();
    let (mut t, mut before) = (0, 0.0);
    for (k, b) in out.iter_mut().enumerate().take(parts).skip(1) {
        let want = total * k as f64 / parts as f64;
        while before + busy[t] < want && t + 1 < parts {
            before += busy[t];
            t += 1;
        }
        let len = (bounds[t + 1] - bounds[t]) as f64;
        let at = bounds[t] as f64 + (want - before) / busy[t] * len;
        let moved = *b as f64 + gain * (at - *b as f64);
        *b = 8 * (moved / 8.0).round().max(0.0) as usize;
    }
    // Each part at least eight grains, from the first boundary up and the last down.
    for k in 1..parts {
        out[k] = out[k].max(out[k - 1] + 8);
    }
    for k in (1..parts).rev() {
        out[k] = out[k].min((out[k + 1] - 8) & !7);
    }
    out
}

/// Cut `v` at `bounds` (ascending, from 0 to `v.len()`).
fn cut<'a, T>(mut v: &'a mut [T], bounds: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(bounds.len() - 1);
    for w in bounds.windows(2) {
        let (a, rest) = v.split_at_mut(w[1] - w[0]);
        out.push(a);
        v = rest;
    }
    out
}

/// Run each job, job t on thread t of `team` (the first on the calling thread);
/// their results in order.
fn on_threads<J, T>(team: &Team, jobs: Vec<J>) -> Vec<T>
where
    J: FnOnce() -> T + Send,
    T: Send,
{
    chunked(Some(team), jobs, |job| job())
}

/// Forces of one part at the packed state (`pos`, `vel`): the imports, then its own
/// slots (with `TRACK`, their contact events logged), `done` called with the part's
/// grains' sums as they are complete.
///
/// # Safety
/// The processor has AVX2; `pos` and `vel` hold the n grains the near list the part's
/// tables were split from was selected for.
unsafe fn part_forces<const TRACK: bool>(
    (pos, vel): (&[Pos], &[Quad]),
    part: &mut Part,
    pp: &PairParams,
    done: crate::dem::shear::near::Done,
) {
    use crate::dem::backend::shear_avx2::evaluate;
    let Part {
        lo,
        hi,
        own,
        imports,
        acc,
        log,
        no_coll,
        ..
    } = part;
    let (lo, hi) = (*lo, *hi);
    // SAFETY: this function's contract; the tables hold indices < n, padded to a
    // multiple of eight (`Slots::split_into`).
    unsafe {
        // The histories move out while the kernel reads the tables (as `with_history`).
        let mut hist = std::mem::take(&mut imports.hist);
        let mut h = History::logging(&mut hist, log);
        let mut skip = |_: std::ops::Range<usize>, _: &mut [Quad], _: &Slots| {};
        evaluate::<false>(
            pos,
            vel,
            imports,
            acc,
            true,
            &mut h,
            pp,
            no_coll,
            lo..lo,
            &mut skip,
        );
        imports.hist = hist;
        let mut hist = std::mem::take(&mut own.hist);
        let mut h = History::logging(&mut hist, log);
        evaluate::<TRACK>(pos, vel, own, acc, true, &mut h, pp, no_coll, lo..hi, done);
        own.hist = hist;
    }
}

impl ShearSim {
    /// Threads a step uses: the `threads` setting, or (0) one per core
    /// (`RAYON_NUM_THREADS` when set) up to one per [`GRAINS_PER_THREAD`] grains. Only
    /// the packed steps (harmonic law, AVX2) run on several; the result never depends
    /// on it.
    pub fn threads_for_run(&self) -> usize {
        let n = self.g.len();
        crate::dem::backend::threads_for(self.threads, n / GRAINS_PER_THREAD, n / 64)
    }

    /// `step_packed` on `threads` threads: the same numbers.
    pub(super) fn step_threads(
        &mut self,
        threads: usize,
        ahead: Option<super::Ahead>,
        fuse: bool,
    ) -> Option<super::Ahead> {
        let (dt, rotate, n) = (self.p.dt, self.rotate, self.g.len());
        assert!(std::is_x86_feature_detected!("avx2"), "no AVX2");
        // For the fall-back's watch (two system calls a step of tens of microseconds
        // or more).
        let (clock, cpu) = (std::time::Instant::now(), cpu_seconds());
        let mut bounds = self.par.bounds_for(n, threads);
        let team = self.par.team(threads);
        // The Verlet list's rebuilds and the near list's selections, inside the syncs
        // below, run on the same threads.
        self.list.spare.team = Some(team.clone());
        self.advance_clock();
        let b = self.boundary();
        let pp = PairParams::new(&self.p, self.l, b.offset(), self.time);

        // Eqs. 21–22, with the near list's stray test (made by the step before, or
        // here).
        let strayed = if let Some(a) = ahead {
            a.strayed
        } else {
            let (g, pr) = (&self.g, &self.pred);
            let test = self.slots.stray_test(self.list.builds, n, b);
            let (pos, vel) = self.packed.reserve(n);
            let jobs: Vec<_> = cut(pos, &bounds)
                .into_iter()
                .zip(cut(vel, &bounds))
                .enumerate()
                .map(|(t, (pos, vel))| {
                    let r = bounds[t]..bounds[t + 1];
                    move || {
                        let rr = || r.clone();
                        predict_packed_into(
                            dt,
                            rotate,
                            (
                                &g.x[rr()],
                                &g.y[rr()],
                                &g.vx[rr()],
                                &g.vy[rr()],
                                &g.omega[rr()],
                            ),
                            &g.radius[rr()],
                            (&pr.inv_m[rr()], &pr.inv_i[rr()]),
                            (&pr.f0x[rr()], &pr.f0y[rr()], &pr.t0[rr()]),
                            (pos, vel),
                            test.map(|t| t.range(rr())),
                        )
                    }
                })
                .collect();
            let answers = on_threads(&team, jobs);
            answers.iter().try_fold(false, |a, s| s.map(|s| a | s))
        };
        if !self.slots.current(&self.list, n, b, strayed) {
            // The tables are made again below: the time to move the split.
            bounds = self.par.rebalance();
            let pr = &mut self.pred;
            pr.x.clear();
            pr.y.clear();
            pr.x.extend(self.packed.pos.iter().map(|p| p.0[0]));
            pr.y.extend(self.packed.pos.iter().map(|p| p.0[1]));
        }
        let r = &self.g.radius;
        let pr = &self.pred;
        self.slots
            .sync_tested(&mut self.list, r, (&pr.x, &pr.y), b, strayed);
        self.par.split(&self.slots, &bounds, &team);

        // Forces at the predicted state, and Eqs. 23–24 range by range as each part's
        // sums are complete; the state at t + Δt to `packed_now`.
        let strayed = {
            let ShearSim {
                g,
                pred: pr,
                slots,
                packed,
                packed_now,
                par,
                list,
                ..
            } = self;
            let pr = &*pr;
            // The Verlet list's build after the sync above (it may have rebuilt it).
            let test = slots.stray_test(list.builds, n, b);
            let (now_pos, now_vel) = packed_now.reserve(n);
            let (packed, pp) = (&*packed, &pp);
            let r = &g.radius[..];
            let (x, y, th) = (
                cut(&mut g.x, &bounds),
                cut(&mut g.y, &bounds),
                cut(&mut g.theta, &bounds),
            );
            let (vx, vy, w) = (
                cut(&mut g.vx, &bounds),
                cut(&mut g.vy, &bounds),
                cut(&mut g.omega, &bounds),
            );
            let (now_pos, now_vel) = (cut(now_pos, &bounds), cut(now_vel, &bounds));
            let mut jobs = Vec::with_capacity(threads);
            let per = par
                .parts
                .iter_mut()
                .zip(x)
                .zip(y)
                .zip(th)
                .zip(vx)
                .zip(vy)
                .zip(w)
                .zip(now_pos)
                .zip(now_vel);
            for ((((((((part, x), y), th), vx), vy), w), np), nv) in per {
                jobs.push(move || {
                    let clock = std::time::Instant::now();
                    let lo = part.lo;
                    let (mut tested, mut far) = (true, false);
                    let mut correct = |range: std::ops::Range<usize>,
                                       f1: &mut [Quad],
                                       _: &Slots| {
                        let test = test.map(|t| t.range(range.clone()));
                        tested &= test.is_some();
                        let l = range.start - lo..range.end - lo;
                        let now = Now {
                            x: &mut x[l.clone()],
                            y: &mut y[l.clone()],
                            theta: &mut th[l.clone()],
                            vx: &mut vx[l.clone()],
                            vy: &mut vy[l.clone()],
                            w: &mut w[l.clone()],
                            r: &r[range.clone()],
                            f0: (
                                &pr.f0x[range.clone()],
                                &pr.f0y[range.clone()],
                                &pr.t0[range.clone()],
                            ),
                        };
                        let inv = (&pr.inv_m[range.clone()], &pr.inv_i[range.clone()]);
                        let out = (&mut np[l.clone()], &mut nv[l]);
                        far |= correct_packed(dt, rotate, inv, now, f1, out, test) == Some(true);
                    };
                    // SAFETY: AVX2 present (asserted above); `packed` holds the n
                    // predicted grains the near list was just made valid for.
                    unsafe {
                        part_forces::<false>((&packed.pos, &packed.vel), part, pp, &mut correct)
                    };
                    part.busy += clock.elapsed().as_secs_f64();
                    (tested, far)
                });
            }
            let answers = on_threads(&team, jobs);
            let tested = answers.iter().all(|a| a.0);
            tested.then(|| answers.iter().any(|a| a.1))
        };
        let g = &self.g;
        self.slots
            .sync_tested(&mut self.list, &g.radius, (&g.x, &g.y), b, strayed);
        self.par.split(&self.slots, &bounds, &team);

        // Forces at t + Δt (f_0 of the next step) into the arrays, part by part, the
        // contact events logged; with `fuse`, the next step's Eqs. 21–22 from them.
        let b_next = self.next_boundary();
        let predicted = {
            let ShearSim {
                pred: pr,
                slots,
                list,
                packed,
                packed_now,
                par,
                fx,
                fy,
                tq,
                ..
            } = self;
            let synced = std::mem::replace(&mut par.hist_synced, true);
            let (slots, packed_now, pp, pr) = (&*slots, &*packed_now, &pp, &*pr);
            let test = slots.stray_test(list.builds, n, b_next);
            let (fx, fy, tq) = (cut(fx, &bounds), cut(fy, &bounds), cut(tq, &bounds));
            let (pos, vel) = packed.reserve(n);
            let (pos, vel) = (cut(pos, &bounds), cut(vel, &bounds));
            let jobs: Vec<_> = par
                .parts
                .iter_mut()
                .zip(fx)
                .zip(fy)
                .zip(tq)
                .zip(pos)
                .zip(vel)
                .map(|(((((part, fx), fy), tq), pos), vel)| {
                    move || {
                        let clock = std::time::Instant::now();
                        if !synced {
                            part.own.copy_history(slots, part.k0);
                        }
                        let lo = part.lo;
                        let (mut tested, mut far) = (true, false);
                        let mut unpack =
                            |range: std::ops::Range<usize>, f: &mut [Quad], _: &Slots| {
                                let l = range.start - lo..range.end - lo;
                                let forces =
                                    (&mut fx[l.clone()], &mut fy[l.clone()], &mut tq[l.clone()]);
                                if !fuse {
                                    unpack_forces(f, forces);
                                    return;
                                }
                                let test = test.map(|t| t.range(range.clone()));
                                tested &= test.is_some();
                                let now = Packed0 {
                                    pos: &packed_now.pos[range.clone()],
                                    vel: &packed_now.vel[range.clone()],
                                    inv_m: &pr.inv_m[range.clone()],
                                    inv_i: &pr.inv_i[range.clone()],
                                };
                                let out = (&mut pos[l.clone()], &mut vel[l]);
                                far |= unpack_and_predict(dt, rotate, f, forces, now, out, test)
                                    == Some(true);
                            };
                        let state = (&packed_now.pos[..], &packed_now.vel[..]);
                        // SAFETY: AVX2 present; `packed_now` holds the n grains at
                        // t + Δt, which the near list was just made valid for.
                        unsafe { part_forces::<true>(state, part, pp, &mut unpack) };
                        // The step's last phase.
                        let busy = std::mem::take(&mut part.busy);
                        if part.times.len() == BALANCE_MAX_STEPS {
                            part.times.drain(..BALANCE_MAX_STEPS / 2);
                        }
                        part.times.push(busy + clock.elapsed().as_secs_f64());
                        (tested, far)
                    }
                })
                .collect();
            let answers = on_threads(&team, jobs);
            let tested = answers.iter().all(|a| a.0);
            fuse.then(|| super::Ahead {
                n,
                strayed: tested.then(|| answers.iter().any(|a| a.1)),
            })
        };
        self.list.spare.team = None;
        // The events, in slot order: part by part, each part's in its order.
        let ShearSim {
            slots,
            list,
            par,
            coll,
            ..
        } = self;
        let now = pp.now;
        slots.with_history(&mut list.shear, |_, h| {
            for part in &mut par.parts {
                for e in part.log.drain(..) {
                    let k = part.k0 + e.k;
                    h.update(k, e.touch, e.d, || e.dv, now, coll);
                    part.own.hist[e.k] = h.near[k];
                }
            }
        });
        let step = self.step;
        let spent = (clock.elapsed().as_secs_f64(), cpu_seconds() - cpu);
        self.par.watch(step, &team, spent);
        predicted
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::shear::{Dissipation, ShearParams};

    /// 600 disks at φ = 0.84, CDrot, γ̇ = 1e-2: contacts made and broken within a few
    /// hundred steps.
    fn dense_600(seed: u64) -> ShearSim {
        ShearSim::new(ShearParams {
            n: 600,
            phi: 0.84,
            q: 1.0,
            rate: 1e-2,
            model: Dissipation::Cdrot,
            alpha: 2.0,
            dt: 0.05,
            seed,
        })
    }

    /// Every grain's state and force, as bits.
    fn bits(s: &ShearSim) -> Vec<u64> {
        let g = &s.g;
        [
            &g.x, &g.y, &g.vx, &g.vy, &g.theta, &g.omega, &s.fx, &s.fy, &s.tq,
        ]
        .iter()
        .flat_map(|v| v.iter().map(|x| x.to_bits()))
        .collect()
    }

    /// Two busy windows in a row send the next steps to one thread, then each busy
    /// window after a fall-back, for twice as long each time up to `SOLO_MAX`; a quiet
    /// window starts over.
    #[test]
    fn busy_windows_fall_back_for_longer_and_longer() {
        let mut par = ShearThreads::default();
        par.after_window(100, FALLBACK_LONG_WAITS, FALLBACK_SHARE);
        assert_eq!(par.solo_until, 0, "at the threshold: no fall-back");
        par.after_window(68, FALLBACK_LONG_WAITS + 1, 1.0);
        assert_eq!(par.solo_until, 0, "one busy window: no fall-back");
        par.after_window(100, FALLBACK_LONG_WAITS + 1, 1.0);
        assert_eq!(par.solo_until, 100 + SOLO_FIRST);
        assert!(par.solo(99 + SOLO_FIRST) && !par.solo(100 + SOLO_FIRST));
        assert_eq!(par.solo_steps, 1);
        let mut step = 1000;
        for k in 1..10 {
            par.after_window(step, 100, 1.0);
            assert_eq!(par.solo_until - step, (SOLO_FIRST << k).min(SOLO_MAX));
            step = par.solo_until + FALLBACK_WINDOW;
        }
        // A quiet window starts over; two busy ones by the cores' share alone fall
        // back.
        par.after_window(step, 0, 1.0);
        assert!(par.solo_until < step);
        par.after_window(step, 0, FALLBACK_SHARE - 0.1);
        assert!(par.solo_until < step, "one busy window after a quiet one");
        par.after_window(step + 32, 0, FALLBACK_SHARE - 0.1);
        assert_eq!(par.solo_until - step - 32, SOLO_FIRST);
    }

    /// Steps sent to one thread by a fall-back, and a team rebuilt for another thread
    /// count, give the one-thread run bit for bit.
    #[test]
    fn a_fall_back_and_a_new_team_give_the_same_bits() {
        if !std::is_x86_feature_detected!("avx2") {
            eprintln!("SKIP: no AVX2: the steps do not run on threads here");
            return;
        }
        let start = dense_600(3);
        let run = |threads: &dyn Fn(u64) -> usize, solo_at: Option<u64>| {
            let mut s = start.clone();
            // Only the fall-back asked for below (this machine may be busy).
            s.par.no_fallback = true;
            for k in 0..150 {
                s.threads = threads(k);
                if solo_at == Some(k) {
                    s.par.solo_until = s.step + 30;
                }
                s.step();
            }
            s
        };
        let one = run(&|_| 1, None);
        let other = run(&|k| if k < 100 { 2 } else { 3 }, Some(40));
        assert_eq!(other.par.solo_steps, 30);
        assert_eq!(other.par.team_threads(), 3, "a new team for three threads");
        assert!(bits(&one) == bits(&other));
        assert_eq!(one.list.shear, other.list.shear);
        assert_eq!(one.coll, other.coll);
        assert!(one.coll.begun > 0);
    }

    /// The split moves to equal time by hand: part costs 3 and 1 over equal halves put
    /// the boundary at 2/3 of the first half (gain 1), half-way there at gain 1/2;
    /// three parts; a part never below eight grains; no time, no move.
    #[test]
    fn a_re_balance_moves_the_split_towards_equal_time() {
        use super::balanced;
        assert_eq!(balanced(&[0, 1000, 2000], &[3.0, 1.0], 1.0), [0, 664, 2000]);
        assert_eq!(balanced(&[0, 1000, 2000], &[3.0, 1.0], 0.5), [0, 832, 2000]);
        assert_eq!(
            balanced(&[0, 1000, 2000], &[1.0, 1.0], 0.5),
            [0, 1000, 2000]
        );
        // Thirds of 4: 1 + 1/3 in the second part, 2 + 2/3 in the third.
        assert_eq!(
            balanced(&[0, 800, 1600, 2400], &[1.0, 1.0, 2.0], 1.0),
            [0, 1064, 1864, 2400]
        );
        assert_eq!(
            balanced(&[0, 8, 16, 24], &[1000.0, 1.0, 1.0], 1.0),
            [0, 8, 16, 24]
        );
        assert_eq!(
            balanced(&[0, 1000, 2000], &[0.0, 1.0], 1.0),
            [0, 1000, 2000]
        );
        // Grains costing 2 and 1 (a slow core's part, say): the boundary settles at
        // a third of the grains.
        let mut b = vec![0, 3000, 6000];
        for _ in 0..12 {
            let busy = [2.0 * b[1] as f64, (b[2] - b[1]) as f64];
            b = balanced(&b, &busy, 0.5);
        }
        assert!((b[1] as i64 - 2000).abs() <= 8, "{b:?}");
    }

    /// Splits moved during a run (uneven, then the other way, then three threads)
    /// give the one-thread run bit for bit.
    #[test]
    fn a_moved_split_gives_the_same_bits() {
        if !std::is_x86_feature_detected!("avx2") {
            eprintln!("SKIP: no AVX2: the steps do not run on threads here");
            return;
        }
        let start = dense_600(5);
        let mut one = start.clone();
        let mut other = start.clone();
        one.threads = 1;
        other.threads = 2;
        other.par.no_fallback = true;
        for k in 0..160 {
            let set = match k {
                40 => Some(96),
                80 => Some(504),
                120 => {
                    other.threads = 3;
                    None
                }
                _ => None,
            };
            if let Some(at) = set {
                other.par.bounds = vec![0, at, 600];
            }
            one.step();
            other.step();
            if let Some(at) = set {
                // The tables were split at the bounds set (the parts' times were for
                // the old ones: no re-balance in that step).
                let split: Vec<_> = other.par.parts.iter().map(|p| (p.lo, p.hi)).collect();
                assert_eq!(split, [(0, at), (at, 600)]);
            }
        }
        assert_eq!(other.par.team_threads(), 3);
        assert_eq!(other.par.parts.len(), 3);
        assert!(bits(&one) == bits(&other));
        assert_eq!(one.list.shear, other.list.shear);
        assert_eq!(one.coll, other.coll);
    }

    /// `steps(k)`, which predicts each next step as the last forces come out (the
    /// threads' parts; one thread takes such a prediction up after a fall-back but
    /// makes none), gives `step()` k times bit for bit: CDrot and
    /// CD (spins not integrated), 1, 2 and 3 threads, calls of several lengths, with
    /// re-selections, list rebuilds and re-sorts (every 37 steps) inside the calls.
    #[test]
    fn steps_predicted_ahead_give_the_single_steps_bits() {
        if !std::is_x86_feature_detected!("avx2") {
            eprintln!("SKIP: no AVX2: the steps are not packed, nothing is predicted ahead");
            return;
        }
        for cd in [false, true] {
            let mut start = dense_600(7);
            start.resort_every = 37;
            if cd {
                start.p.model = Dissipation::Cd;
                start.rotate = false;
            }
            for threads in [1, 2, 3] {
                let mut single = start.clone();
                single.threads = 1;
                let mut s = start.clone();
                s.threads = threads;
                s.par.no_fallback = true;
                let mut done = 0;
                for k in [1, 5, 64, 2, 150, 3, 75] {
                    if k == 150 {
                        // A fall-back inside the call: predictions made on the threads
                        // used by the one-thread step and the other way round.
                        s.par.solo_until = s.step + 20;
                    }
                    s.steps(k);
                    done += k;
                    while single.step < done {
                        single.step();
                    }
                    assert!(
                        bits(&s) == bits(&single),
                        "{threads} threads, cd {cd}, step {done}"
                    );
                    assert_eq!(s.list.shear, single.list.shear);
                    assert_eq!(s.coll, single.coll);
                    // The stray tests made ahead gave the same re-selections.
                    assert_eq!(s.slots.selections, single.slots.selections);
                    assert_eq!(s.list.builds, single.list.builds);
                    assert_eq!(s.slots.skin().to_bits(), single.slots.skin().to_bits());
                }
                if threads > 1 {
                    assert_eq!(s.par.solo_steps, 20);
                }
                assert!(s.slots.selections > 10 && s.list.builds > 2);
                // The carried prediction was made (on threads only) and used: a step
                // ahead is the packed state of the next step's prediction.
                let ahead = s.step_ahead(None, true);
                assert_eq!(ahead.is_some(), threads > 1);
                let Some(ahead) = ahead else { continue };
                let packed = s.packed.clone();
                let mut again = s.clone();
                again.packed = Default::default();
                again.step_ahead(None, false);
                s.step_ahead(Some(ahead), false);
                assert!(bits(&s) == bits(&again));
                let pos_bits = |p: &crate::dem::shear::integrate::Packed| -> Vec<u64> {
                    let xy = p.pos.iter().flat_map(|q| q.0);
                    xy.chain(p.vel.iter().flat_map(|q| q.0))
                        .map(f64::to_bits)
                        .collect()
                };
                assert_eq!(packed.pos.len(), 600);
                assert!(pos_bits(&packed) == pos_bits(&again.packed));
            }
        }
    }

    #[test]
    fn bounds_cover_the_grains_in_multiples_of_eight() {
        let b = super::bounds(1000, 3);
        assert_eq!(b, vec![0, 328, 664, 1000]);
        assert!(b.windows(2).all(|w| w[0] < w[1]));
    }
}
