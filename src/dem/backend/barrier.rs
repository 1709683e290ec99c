//! A barrier for a fixed set of threads that meet tens of thousands of times a second
//! (the pillar's step phases, the sheared disks' `team`): waiters spin, and sleep only
//! when waits grow long, as on a machine busy with other work, where spinning would
//! steal the time the others need.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::thread::Thread;

/// A barrier for a fixed number of threads: waiters spin for a while (tens of
/// microseconds, longer than a step's imbalance), then sleep until the last thread to
/// arrive wakes them, so a machine busy with other work is not made busier by
/// spinning.
pub struct SpinBarrier {
    pub threads: usize,
    count: AtomicUsize,
    generation: AtomicUsize,
    /// Waiters that have gone to sleep (in the same cache line as `count`, which the
    /// last to arrive has just written): it wakes them only if there are any, since
    /// waking a thread that is spinning still costs a cache line from its core.
    sleeping: AtomicUsize,
    /// Every participant, set before the first wait by the thread that spawns them.
    pub handles: OnceLock<Vec<Thread>>,
    /// Set when a participant panics, so the others stop waiting for it.
    poisoned: AtomicBool,
    /// Waits that lasted long (the others were descheduled), since last read.
    pub long_waits: AtomicUsize,
}

/// Poisons the barrier if its thread unwinds.
pub struct PoisonOnPanic<'a>(pub &'a SpinBarrier);

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
    pub fn new(threads: usize) -> Self {
        SpinBarrier {
            threads,
            count: AtomicUsize::new(0),
            generation: AtomicUsize::new(0),
            sleeping: AtomicUsize::new(0),
            handles: OnceLock::new(),
            poisoned: AtomicBool::new(false),
            long_waits: AtomicUsize::new(0),
        }
    }

    /// Whether a participant has panicked (the others' waits panic too).
    pub fn poisoned(&self) -> bool {
        self.poisoned.load(Ordering::Acquire)
    }

    /// Wait for every thread; `spin` is this thread's spinning budget (iterations),
    /// adapted: halved when the wait was long (the others were descheduled: a busy
    /// machine, where spinning steals time), doubled otherwise. Returns whether the
    /// wait was long (also counted in `long_waits`).
    pub fn wait(&self, me: usize, spin: &mut u32) -> bool {
        if self.threads == 1 {
            return false;
        }
        let g = self.generation.load(Ordering::Acquire);
        if self.count.fetch_add(1, Ordering::AcqRel) + 1 == self.threads {
            self.count.store(0, Ordering::Relaxed);
            // SeqCst with the sleepers' count (a waiter raises it, then looks at the
            // generation): either it sees the new generation or this sees it asleep.
            self.generation.store(g + 1, Ordering::SeqCst);
            self.wake_sleepers(me);
            return false;
        }
        let slept = self.spin_then(
            || self.generation.load(Ordering::Acquire) != g,
            *spin,
            || self.sleep_while(|| self.generation.load(Ordering::SeqCst) == g),
        );
        self.adapt(slept, spin)
    }

    /// Wait until `flag` (another thread's signal, a count it raises with
    /// [`SpinBarrier::raise`]) reaches `target`: spinning as [`SpinBarrier::wait`]
    /// does, then asleep until `raise` wakes it (a team's worker waiting for its next
    /// job, which may be long in coming). Returns whether the wait was long.
    pub fn sleep_until(&self, flag: &AtomicU64, target: u64, spin: &mut u32) -> bool {
        let slept = self.spin_then(
            || flag.load(Ordering::Acquire) >= target,
            *spin,
            || self.sleep_while(|| flag.load(Ordering::SeqCst) < target),
        );
        self.adapt(slept, spin)
    }

    /// Set `flag` to `value` and wake every participant but `me` that sleeps in
    /// [`SpinBarrier::sleep_until`] (or [`SpinBarrier::wait`]).
    pub fn raise(&self, flag: &AtomicU64, value: u64, me: usize) {
        // SeqCst with the sleepers' count, as in `wait`.
        flag.store(value, Ordering::SeqCst);
        self.wake_sleepers(me);
    }

    /// Unpark every participant but `me` if any sleeps; called right after a SeqCst
    /// store of what the sleepers wait for, so that a sleeper either sees it or is seen.
    fn wake_sleepers(&self, me: usize) {
        if self.sleeping.load(Ordering::SeqCst) > 0
            && let Some(hs) = self.handles.get()
        {
            hs.iter()
                .enumerate()
                .filter(|&(t, _)| t != me)
                .for_each(|(_, h)| h.unpark());
        }
    }

    /// One sleep of a waiter, counted in `sleeping` (which the waker reads), unless
    /// `still` (its condition, read SeqCst after raising the count) no longer holds.
    fn sleep_while(&self, still: impl Fn() -> bool) {
        self.sleeping.fetch_add(1, Ordering::SeqCst);
        if still() {
            // Timed, so a wake-up that raced ahead is never waited for long.
            std::thread::park_timeout(std::time::Duration::from_micros(500));
        }
        self.sleeping.fetch_sub(1, Ordering::SeqCst);
    }

    /// A waiter's spinning budget after a wait that first slept at `slept`, if it did;
    /// returns whether the wait was long.
    fn adapt(&self, slept: Option<std::time::Instant>, spin: &mut u32) -> bool {
        // Sleeping was right only if the others were long in coming (descheduled on a
        // busy machine, for a time slice of milliseconds); a shorter sleep means spinning
        // a little longer would have won. (A 200 µs threshold misfired on an idle VM,
        // whose wake-ups alone can take that long, and sent 88 of 351 output intervals of
        // the paper run to one thread.)
        let long = slept.is_some_and(|t| t.elapsed() > LONG_WAIT);
        *spin = if long {
            self.long_waits.fetch_add(1, Ordering::Relaxed);
            (*spin / 2).max(MIN_SPIN)
        } else {
            (*spin * 2).min(MAX_SPIN)
        };
        long
    }
}

impl SpinBarrier {
    /// Wait until `flag` (another thread's progress, a step count it raises) reaches
    /// `target`: spinning as [`SpinBarrier::wait`] does, then yielding the core, since
    /// nobody wakes this waiter. Long waits count towards the fallback as there;
    /// returns whether this one was.
    pub fn wait_for(&self, flag: &AtomicU64, target: u64, spin: &mut u32) -> bool {
        let slept = self.spin_then(
            || flag.load(Ordering::Acquire) >= target,
            *spin,
            std::thread::yield_now,
        );
        let long = slept.is_some_and(|t| t.elapsed() > LONG_WAIT);
        if long {
            self.long_waits.fetch_add(1, Ordering::Relaxed);
            *spin = (*spin / 2).max(MIN_SPIN);
        }
        long
    }

    /// Until `done`: spin `spin` times, then `sleep` between checks; panics if another
    /// thread did. Returns when it first slept, if it did.
    fn spin_then(
        &self,
        done: impl Fn() -> bool,
        spin: u32,
        mut sleep: impl FnMut(),
    ) -> Option<std::time::Instant> {
        let mut spins = 0u32;
        let mut slept = None;
        while !done() {
            if self.poisoned.load(Ordering::Acquire) {
                panic!("another thread at this barrier panicked");
            }
            if spins < spin {
                spins += 1;
                std::hint::spin_loop();
            } else {
                slept.get_or_insert_with(std::time::Instant::now);
                sleep();
            }
        }
        slept
    }
}

/// A wait longer than this after falling asleep counts as the others being descheduled.
pub const LONG_WAIT: std::time::Duration = std::time::Duration::from_millis(1);

/// Spin budget bounds (iterations of `spin_loop`); a thread starts at the maximum.
pub const MIN_SPIN: u32 = 64;
pub const MAX_SPIN: u32 = 50_000;
