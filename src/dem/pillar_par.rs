//! Running pillar steps on several threads (or one): the phases of `pillar_phases`,
//! separated by a spinning barrier, with the few serial parts (pair-list rebuild,
//! totals, force snapshots) on the first thread. A step of N = 1000 grains is tens of
//! microseconds, far below what waking a thread pool costs, so the threads live for a
//! whole `advance` call and wait on each other by spinning.
//!
//! Safety: each phase writes only its own range of grains or pair slots (disjoint
//! between threads) and reads only what no thread writes in that phase; the barrier
//! between phases orders the writes before the reads (release/acquire). Arrays are
//! reached through raw pointers refreshed by the first thread after any reallocation
//! (a list rebuild), while the others wait at the barrier.

use super::pillar::PillarSim;
use super::pillar_kernels::{GrainConsts, kick_drift};
use super::pillar_phases::{
    BarGrains, Bars, CHUNK, GrainState, Reverse, SlotRecord, bar_contacts, gather, mark_frozen,
    pair_slots, substrate_chunks,
};
use super::verlet::Boundary;
use std::cell::UnsafeCell;
use std::ops::Range;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::thread::Thread;

/// Per-step work the serial sections share with the phases (not state).
#[derive(Debug, Clone, Default)]
pub struct StepBuffers {
    /// Contact force (x, y, N) on the slot's owner and its torque (N m), per pair slot.
    pub slot_force: Vec<[f64; 3]>,
    /// Whether `slot_force` holds this list's forces (a slot between frozen grains is
    /// then left as it is).
    pub slots_valid: bool,
    pub reverse: Reverse,
    /// F_n, |F_t| (N) and touching per slot, filled on force-snapshot steps.
    pub rec_fn: Vec<f64>,
    pub rec_ft: Vec<f64>,
    pub rec_touch: Vec<bool>,
    /// Per chunk: Σ F_n top, Σ F_n bottom, Σ bar shear (N); substrate power (W).
    pub bar_sums: Vec<[f64; 3]>,
    pub power: Vec<[f64; 2]>,
    /// Per thread: largest squared move since the list build (m²), slots skipped,
    /// frozen grains.
    pub moved2: Vec<f64>,
    pub skipped: Vec<u64>,
    pub frozen_count: Vec<usize>,
    /// Thread t works on grains bounds[t]..bounds[t + 1] (chunk multiples).
    pub bounds: Vec<usize>,
    /// Seconds each thread spent working (not waiting) since the last rebalance.
    pub busy: Vec<f64>,
}

#[derive(Clone, Copy)]
struct P<T>(*mut T, usize);
unsafe impl<T> Send for P<T> {}
unsafe impl<T> Sync for P<T> {}

impl<T> P<T> {
    fn of(v: &mut [T]) -> Self {
        P(v.as_mut_ptr(), v.len())
    }
    /// # Safety
    /// No thread writes any of it for the lifetime of the slice.
    unsafe fn all<'a>(self) -> &'a [T] {
        unsafe { std::slice::from_raw_parts(self.0, self.1) }
    }
    /// # Safety
    /// No other thread touches `r` for the lifetime of the slice.
    unsafe fn part<'a>(self, r: Range<usize>) -> &'a mut [T] {
        assert!(
            r.start <= r.end && r.end <= self.1,
            "range within the array"
        );
        unsafe { std::slice::from_raw_parts_mut(self.0.add(r.start), r.end - r.start) }
    }
}

/// Raw views of every array a phase touches.
#[derive(Clone, Copy)]
struct Arrays {
    x: P<f64>,
    y: P<f64>,
    vx: P<f64>,
    vy: P<f64>,
    ax: P<f64>,
    ay: P<f64>,
    theta: P<f64>,
    omega: P<f64>,
    radius: P<f64>,
    x_ref: P<f64>,
    y_ref: P<f64>,
    start: P<u32>,
    js: P<u32>,
    shear: P<f64>,
    fx: P<f64>,
    fy: P<f64>,
    tq: P<f64>,
    sub_fx: P<f64>,
    sub_fy: P<f64>,
    top_shear: P<f64>,
    bottom_shear: P<f64>,
    resting: P<bool>,
    frozen: P<bool>,
    slot_force: P<[f64; 3]>,
    rec_fn: P<f64>,
    rec_ft: P<f64>,
    rec_touch: P<bool>,
    bar_sums: P<[f64; 3]>,
    power: P<[f64; 2]>,
    moved2: P<f64>,
    skipped: P<u64>,
    frozen_count: P<usize>,
    busy: P<f64>,
    inv_mass: P<f64>,
    inv_inertia: P<f64>,
    f_max: P<f64>,
    f_max2: P<f64>,
    t_max: P<f64>,
    xi_omega: P<f64>,
    rev: *const Reverse,
    bounds: *const Vec<usize>,
    /// This step: frozen grains skipped; force snapshot wanted; second kick.
    freeze: bool,
    record: bool,
    kick: bool,
}
unsafe impl Send for Arrays {}
unsafe impl Sync for Arrays {}

/// A barrier for a fixed number of threads: waiters spin for a while (tens of
/// microseconds, longer than a step's imbalance), then sleep until the last thread to
/// arrive wakes them, so a machine busy with other work is not made busier by
/// spinning.
struct SpinBarrier {
    threads: usize,
    count: AtomicUsize,
    generation: AtomicUsize,
    /// Every participant, set before the first wait by the thread that spawns them.
    handles: OnceLock<Vec<Thread>>,
    /// Set when a participant panics, so the others stop waiting for it.
    poisoned: AtomicBool,
    /// Waits that lasted long (the others were descheduled), since last read.
    long_waits: AtomicUsize,
}

/// Poisons the barrier if its thread unwinds.
struct PoisonOnPanic<'a>(&'a SpinBarrier);

impl Drop for PoisonOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.poisoned.store(true, Ordering::Release);
            if let Some(hs) = self.0.handles.get() {
                hs.iter().for_each(|h| h.unpark());
            }
        }
    }
}

impl SpinBarrier {
    fn new(threads: usize) -> Self {
        SpinBarrier {
            threads,
            count: AtomicUsize::new(0),
            generation: AtomicUsize::new(0),
            handles: OnceLock::new(),
            poisoned: AtomicBool::new(false),
            long_waits: AtomicUsize::new(0),
        }
    }

    /// Wait for every thread; `spin` is this thread's spinning budget (iterations),
    /// adapted: halved when the wait was long (the others were descheduled: a busy
    /// machine, where spinning steals time), doubled otherwise.
    fn wait(&self, me: usize, spin: &mut u32) {
        if self.threads == 1 {
            return;
        }
        let g = self.generation.load(Ordering::Acquire);
        if self.count.fetch_add(1, Ordering::AcqRel) + 1 == self.threads {
            self.count.store(0, Ordering::Relaxed);
            self.generation.store(g + 1, Ordering::Release);
            if let Some(hs) = self.handles.get() {
                // Cheap (no system call) for a thread that is still spinning.
                hs.iter()
                    .enumerate()
                    .filter(|&(t, _)| t != me)
                    .for_each(|(_, h)| h.unpark());
            }
            return;
        }
        let mut spins = 0u32;
        let mut slept: Option<std::time::Instant> = None;
        while self.generation.load(Ordering::Acquire) == g {
            if self.poisoned.load(Ordering::Acquire) {
                panic!("another pillar thread panicked");
            }
            if spins < *spin {
                spins += 1;
                std::hint::spin_loop();
            } else {
                slept.get_or_insert_with(std::time::Instant::now);
                // Timed, so a wake-up that raced ahead is never waited for long.
                std::thread::park_timeout(std::time::Duration::from_micros(500));
            }
        }
        // Sleeping was right only if the others were long in coming (descheduled on a
        // busy machine); a short sleep means spinning a little longer would have won.
        let long = slept.is_some_and(|t| t.elapsed() > std::time::Duration::from_micros(200));
        *spin = if long {
            self.long_waits.fetch_add(1, Ordering::Relaxed);
            (*spin / 2).max(MIN_SPIN)
        } else {
            (*spin * 2).min(MAX_SPIN)
        };
    }
}

const MIN_SPIN: u32 = 64;
/// Over each window of steps, more long waits than this send the rest of an `advance`
/// call to one thread.
const FALLBACK_WINDOW: u64 = 64;
const FALLBACK_LONG_WAITS: usize = 16;
/// Steps between rebalances of the threads' shares.
const REBALANCE_EVERY: u64 = 32;
const MAX_SPIN: u32 = 50_000;

/// The serial sections' view of the arrays, republished after each.
struct Shared(UnsafeCell<Arrays>);
unsafe impl Sync for Shared {}
impl Shared {
    fn get(&self) -> *mut Arrays {
        self.0.get()
    }
}

impl PillarSim {
    /// Threads an `advance` uses: the `threads` setting, or (0) one per core up to one
    /// per 256 grains (fewer grains per thread cost more in waiting than they save).
    pub fn threads_for_run(&self) -> usize {
        let n = self.grains.len();
        match self.scratch.threads {
            0 => std::thread::available_parallelism()
                .map_or(1, |c| c.get())
                .min(n / 256)
                .max(1),
            t => t.min(n).max(1),
        }
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
        let sim: *mut PillarSim = self;
        let sim = SendPtr(sim);
        // Steps done, and a request (from thread 0) to finish on one thread: on a machine
        // busy with other work each barrier can cost a scheduler time slice.
        let done = AtomicU64::new(0);
        let fall_back = AtomicBool::new(false);
        let body = |t: usize| {
            let _poison = PoisonOnPanic(&barrier);
            let mut spin = MAX_SPIN;
            for _ in 0..steps {
                // SAFETY: see the module notes; serial sections run on thread 0 while
                // the others wait at a barrier holding no references.
                unsafe {
                    let a = *shared.get();
                    let clock = std::time::Instant::now();
                    let m = phase_kick(&a, t, (*sim.get()).params.dt);
                    *a.moved2.part(t..t + 1).first_mut().expect("slot") = m;
                    let mut work = clock.elapsed().as_secs_f64();
                    barrier.wait(t, &mut spin);
                    if t == 0 {
                        let s = &mut *sim.get();
                        s.serial_before();
                        if s.step.is_multiple_of(REBALANCE_EVERY) {
                            s.rebalance();
                        }
                        *shared.get() = s.arrays(true);
                    }
                    barrier.wait(t, &mut spin);
                    let a = *shared.get();
                    let s = &*sim.get();
                    let clock = std::time::Instant::now();
                    phase_frozen(&a, t, s);
                    work += clock.elapsed().as_secs_f64();
                    barrier.wait(t, &mut spin);
                    let clock = std::time::Instant::now();
                    phase_pairs(&a, t, s);
                    work += clock.elapsed().as_secs_f64();
                    barrier.wait(t, &mut spin);
                    let clock = std::time::Instant::now();
                    phase_grains(&a, t, s);
                    work += clock.elapsed().as_secs_f64();
                    a.busy.part(t..t + 1)[0] += work;
                    barrier.wait(t, &mut spin);
                    if t == 0 {
                        (*sim.get()).serial_after(true);
                        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                        if threads > 1
                            && d.is_multiple_of(FALLBACK_WINDOW)
                            && barrier.long_waits.swap(0, Ordering::Relaxed) > FALLBACK_LONG_WAITS
                        {
                            fall_back.store(true, Ordering::Relaxed);
                        }
                    }
                    barrier.wait(t, &mut spin);
                    if fall_back.load(Ordering::Relaxed) {
                        break;
                    }
                }
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
        let left = steps - done.load(Ordering::Relaxed);
        if left > 0 {
            self.advance_with(left, 1);
        }
    }

    /// Forces and accelerations at the current state without moving anything (contact
    /// history advances by δt × the current slip, so use on a copy or at rest).
    pub fn refresh_forces(&mut self) {
        self.prepare(1);
        self.scratch.frozen.iter_mut().for_each(|f| *f = false);
        let a = self.arrays(false);
        // SAFETY: one thread; the arrays outlive the calls.
        unsafe {
            let s = &*(self as *const PillarSim);
            phase_pairs(&a, 0, s);
            phase_grains(&a, 0, s);
        }
        self.serial_after(false);
    }

    /// Sizes every buffer for `threads` threads.
    fn prepare(&mut self, threads: usize) {
        let n = self.grains.len();
        let sub = self.substrate();
        self.scratch
            .consts
            .refresh(&self.grains, &sub, self.params.dt);
        let sc = &mut self.scratch;
        sc.resting.resize(n, false);
        sc.frozen.resize(n, false);
        let b = &mut sc.buffers;
        let chunks = n.div_ceil(CHUNK);
        b.bar_sums.resize(chunks, [0.0; 3]);
        b.power.resize(chunks, [0.0; 2]);
        b.moved2 = vec![0.0; threads];
        b.skipped = vec![0; threads];
        b.frozen_count = vec![0; threads];
        b.busy = vec![0.0; threads];
        self.sync_list_buffers();
        let b = &self.scratch.buffers;
        if b.bounds.len() != threads + 1 || b.bounds.last() != Some(&n) {
            self.balance(threads);
        }
    }

    /// Split the grains into `threads` runs of whole chunks, equal in number (any split
    /// gives the same numbers; `rebalance` then follows the measured work).
    fn balance(&mut self, threads: usize) {
        let n = self.grains.len();
        let chunks = n.div_ceil(CHUNK);
        self.scratch.buffers.bounds = (0..=threads)
            .map(|t| (chunks * t / threads * CHUNK).min(n))
            .collect();
    }

    /// Move each boundary between two threads one chunk towards the one that worked
    /// less since the last call (frozen grains cost little and gather at the bottom,
    /// so equal shares of grains are unequal shares of work).
    fn rebalance(&mut self) {
        let n = self.grains.len();
        let b = &mut self.scratch.buffers;
        let t_max = b.bounds.len() - 1;
        for t in 1..t_max {
            let (left, right) = (b.busy[t - 1], b.busy[t]);
            if left < 0.9 * right && b.bounds[t] + CHUNK <= b.bounds[t + 1].min(n) {
                b.bounds[t] += CHUNK;
            } else if left > 1.1 * right && b.bounds[t] >= b.bounds[t - 1] + CHUNK {
                b.bounds[t] -= CHUNK;
            }
        }
        b.busy.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Per-slot buffers and the reverse index for the current list.
    fn sync_list_buffers(&mut self) {
        let (n, slots) = (self.grains.len(), self.list.len());
        let b = &mut self.scratch.buffers;
        if b.reverse.start.len() != n + 1
            || b.slot_force.len() != slots
            || b.reverse.slot.len() != slots
        {
            b.slots_valid = false;
        }
        if !b.slots_valid {
            b.reverse = Reverse::build(n, &self.list.start, &self.list.j);
            b.slot_force = vec![[0.0; 3]; slots];
        }
        let rec = self.record.is_some();
        let want = if rec { slots } else { 0 };
        b.rec_fn.resize(want, 0.0);
        b.rec_ft.resize(want, 0.0);
        b.rec_touch.resize(want, false);
    }

    /// Thread 0 between the kick and the forces: the list's rebuild test and rebuild,
    /// the step count.
    fn serial_before(&mut self) {
        let b = &self.scratch.buffers;
        let moved2 = b.moved2.iter().copied().fold(0.0, f64::max);
        let half = 0.5 * self.list.skin;
        if moved2 > half * half || self.list.x_ref.len() != self.grains.len() {
            let g = &self.grains;
            self.list.build(&g.x, &g.y, &g.radius, Boundary::Open);
            self.scratch.buffers.slots_valid = false;
            self.sync_list_buffers();
        }
        self.step += 1;
    }

    /// Thread 0 after the forces: totals in chunk order, the output interval's sums,
    /// the force snapshot.
    fn serial_after(&mut self, kick: bool) {
        let b = &mut self.scratch.buffers;
        b.slots_valid = true;
        let mut tot = [0.0; 3];
        for s in &b.bar_sums {
            for (t, v) in tot.iter_mut().zip(s) {
                *t += v;
            }
        }
        let (mut p_t, mut p_r) = (0.0, 0.0);
        for p in &b.power {
            p_t += p[0];
            p_r += p[1];
        }
        [self.top_force, self.bottom_force, self.bar_shear_force] = tot;
        let sc = &mut self.scratch;
        sc.skipped_pairs += sc.buffers.skipped.iter().sum::<u64>();
        sc.frozen_grain_steps += sc.buffers.frozen_count.iter().sum::<usize>() as u64;
        sc.buffers.skipped.iter_mut().for_each(|v| *v = 0);
        sc.buffers.frozen_count.iter_mut().for_each(|v| *v = 0);
        if let Some(rec) = self.record.as_mut() {
            let n = self.grains.len();
            *rec = super::forces::ContactRecord::zeroed(n);
            let b = &self.scratch.buffers;
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
        if kick {
            let iv = &mut self.interval;
            iv.steps += 1;
            iv.top_force += self.top_force;
            iv.bottom_force += self.bottom_force;
            iv.substrate_power += p_t;
            iv.substrate_power_rot += p_r;
        }
    }

    fn arrays(&mut self, kick: bool) -> Arrays {
        let freeze = self.scratch.skip_frozen
            && self.record.is_none()
            && self.scratch.buffers.slots_valid
            && kick;
        let record = self.record.is_some();
        let g = &mut self.grains;
        let l = &mut self.list;
        let sc = &mut self.scratch;
        let c = &mut sc.consts;
        let b = &mut sc.buffers;
        Arrays {
            x: P::of(&mut g.x),
            y: P::of(&mut g.y),
            vx: P::of(&mut g.vx),
            vy: P::of(&mut g.vy),
            ax: P::of(&mut g.ax),
            ay: P::of(&mut g.ay),
            theta: P::of(&mut g.theta),
            omega: P::of(&mut g.omega),
            radius: P::of(&mut g.radius),
            x_ref: P::of(&mut l.x_ref),
            y_ref: P::of(&mut l.y_ref),
            start: P::of(&mut l.start),
            js: P::of(&mut l.j),
            shear: P::of(&mut l.shear),
            fx: P::of(&mut self.fx),
            fy: P::of(&mut self.fy),
            tq: P::of(&mut self.tq),
            sub_fx: P::of(&mut self.sub_fx),
            sub_fy: P::of(&mut self.sub_fy),
            top_shear: P::of(&mut self.top_shear),
            bottom_shear: P::of(&mut self.bottom_shear),
            resting: P::of(&mut sc.resting),
            frozen: P::of(&mut sc.frozen),
            slot_force: P::of(&mut b.slot_force),
            rec_fn: P::of(&mut b.rec_fn),
            rec_ft: P::of(&mut b.rec_ft),
            rec_touch: P::of(&mut b.rec_touch),
            bar_sums: P::of(&mut b.bar_sums),
            power: P::of(&mut b.power),
            moved2: P::of(&mut b.moved2),
            skipped: P::of(&mut b.skipped),
            frozen_count: P::of(&mut b.frozen_count),
            busy: P::of(&mut b.busy),
            inv_mass: P::of(&mut c.inv_mass),
            inv_inertia: P::of(&mut c.inv_inertia),
            f_max: P::of(&mut c.f_max),
            f_max2: P::of(&mut c.f_max2),
            t_max: P::of(&mut c.t_max),
            xi_omega: P::of(&mut c.xi_omega),
            rev: &b.reverse,
            bounds: &b.bounds,
            freeze,
            record,
            kick,
        }
    }
}

struct SendPtr(*mut PillarSim);
unsafe impl Send for SendPtr {}
unsafe impl Sync for SendPtr {}
impl SendPtr {
    fn get(&self) -> *mut PillarSim {
        self.0
    }
}

/// Thread t's grains.
unsafe fn range(a: &Arrays, t: usize) -> Range<usize> {
    let b = unsafe { &*a.bounds };
    b[t]..b[t + 1]
}

/// Phase 1: kick and drift of thread t's grains; their largest move since the build.
unsafe fn phase_kick(a: &Arrays, t: usize, dt: f64) -> f64 {
    unsafe {
        let r = range(a, t);
        let refs_ok = a.x_ref.1 == a.x.1;
        let (xr, yr): (&[f64], &[f64]) = if refs_ok {
            (&a.x_ref.all()[r.clone()], &a.y_ref.all()[r.clone()])
        } else {
            (&[], &[])
        };
        kick_drift(
            dt,
            a.x.part(r.clone()),
            a.y.part(r.clone()),
            a.theta.part(r.clone()),
            a.vx.part(r.clone()),
            a.vy.part(r.clone()),
            &a.ax.all()[r.clone()],
            &a.ay.all()[r.clone()],
            &a.omega.all()[r.clone()],
            a.resting.part(r.clone()),
            xr,
            yr,
        )
    }
}

/// Phase 2: frozen flags of thread t's grains.
unsafe fn phase_frozen(a: &Arrays, t: usize, s: &PillarSim) {
    unsafe {
        let r = range(a, t);
        let out = a.frozen.part(r.clone());
        if !a.freeze {
            out.fill(false);
            return;
        }
        let margin = 2.0 * s.params.bar_speed * s.params.dt;
        let c = mark_frozen(
            r,
            out,
            a.resting.all(),
            a.y.all(),
            a.radius.all(),
            (a.start.all(), a.js.all()),
            &*a.rev,
            (s.top_y(), s.bottom_y, margin),
        );
        a.frozen_count.part(t..t + 1)[0] = c;
    }
}

/// Phase 3: the pair slots of thread t's grains.
unsafe fn phase_pairs(a: &Arrays, t: usize, s: &PillarSim) {
    unsafe {
        let r = range(a, t);
        let start = a.start.all();
        let slots = start[r.start] as usize..start[r.end] as usize;
        let g = GrainState {
            x: a.x.all(),
            y: a.y.all(),
            vx: a.vx.all(),
            vy: a.vy.all(),
            omega: a.omega.all(),
            radius: a.radius.all(),
        };
        let rec = a.record.then(|| SlotRecord {
            f_n: a.rec_fn.part(slots.clone()),
            f_t: a.rec_ft.part(slots.clone()),
            touching: a.rec_touch.part(slots.clone()),
        });
        let skipped = pair_slots(
            r,
            g,
            (start, a.js.all()),
            a.shear.part(slots.clone()),
            a.slot_force.part(slots),
            a.freeze.then(|| a.frozen.all()),
            (&s.normal(), &s.tangential(), s.params.dt),
            rec,
        );
        a.skipped.part(t..t + 1)[0] = skipped;
    }
}

/// Phase 4: thread t's grains: contact sums, bars, substrate and second kick.
unsafe fn phase_grains(a: &Arrays, t: usize, s: &PillarSim) {
    unsafe {
        let r = range(a, t);
        let frozen = a.frozen.all();
        let fz = a.freeze.then_some(frozen);
        let (fx, fy, tq) = (
            a.fx.part(r.clone()),
            a.fy.part(r.clone()),
            a.tq.part(r.clone()),
        );
        gather(
            r.clone(),
            a.start.all(),
            &*a.rev,
            a.slot_force.all(),
            fz,
            fx,
            fy,
            tq,
        );
        let p = &s.params;
        let bars = Bars {
            normal: super::contact::Hooke {
                k_n: 2.0 * p.k_n,
                damping: p.damping_n,
            },
            tangential: super::contact::CundallStrack {
                k_t: 2.0 * p.kt_over_kn * p.k_n,
                mu: p.mu_bar,
            },
            top: s.top_y(),
            bottom: s.bottom_y,
            v_bar: p.bar_speed,
            dt: p.dt,
        };
        let chunks = r.start / CHUNK..r.end.div_ceil(CHUNK);
        let sums = a.bar_sums.part(chunks.clone());
        // Own-range views only: other threads write their ranges of these arrays now.
        let (vx, vy, omega) = (
            a.vx.part(r.clone()),
            a.vy.part(r.clone()),
            a.omega.part(r.clone()),
        );
        let (ys, rs) = (a.y.all(), a.radius.all());
        let (top_shear, bottom_shear) =
            (a.top_shear.part(r.clone()), a.bottom_shear.part(r.clone()));
        for (k, ch) in chunks.clone().enumerate() {
            let cr = ch * CHUNK..((ch + 1) * CHUNK).min(r.end);
            let local = cr.start - r.start..cr.end - r.start;
            sums[k] = bar_contacts(
                &bars,
                BarGrains {
                    y: &ys[cr.clone()],
                    vx: &vx[local.clone()],
                    vy: &vy[local.clone()],
                    omega: &omega[local.clone()],
                    radius: &rs[cr.clone()],
                    frozen: fz.map(|f| &f[cr.clone()]),
                    top_shear: &mut top_shear[local.clone()],
                    bottom_shear: &mut bottom_shear[local.clone()],
                },
                &mut fx[local.clone()],
                &mut fy[local.clone()],
                &mut tq[local],
            );
        }
        let c = GrainConsts {
            inv_mass: &a.inv_mass.all()[r.clone()],
            inv_inertia: &a.inv_inertia.all()[r.clone()],
            f_max: &a.f_max.all()[r.clone()],
            f_max2: &a.f_max2.all()[r.clone()],
            t_max: &a.t_max.all()[r.clone()],
            xi_omega: &a.xi_omega.all()[r.clone()],
        };
        substrate_chunks(
            a.kick,
            p.dt,
            &s.substrate(),
            &c,
            fz.map(|f| &f[r.clone()]),
            (fx, fy, tq),
            (vx, vy, a.ax.part(r.clone()), a.ay.part(r.clone()), omega),
            (a.sub_fx.part(r.clone()), a.sub_fy.part(r.clone())),
            a.power.part(chunks),
        );
    }
}
