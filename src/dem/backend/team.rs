//! A persistent team of threads that runs one job after another, meeting at a
//! [`SpinBarrier`] before and after each: the sheared disks' step phases (a few a
//! step, each a fraction of a millisecond), for which waking a thread pool's sleeping
//! workers each time cost a sizeable share of the step (issue 35). The calling thread
//! is the team's first; the others are spawned once, with the team, and spin (then
//! sleep, see `barrier`) between jobs.

use crate::dem::backend::barrier::{MAX_SPIN, PoisonOnPanic, SpinBarrier};
use std::any::Any;
use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{JoinHandle, ThreadId};

/// A job: called once on each thread of the team with that thread's index.
type Job<'a> = &'a (dyn Fn(usize) + Sync + 'a);

/// What the team's threads share.
struct Inner {
    barrier: SpinBarrier,
    /// The current job: written by thread 0 before the barrier that starts it and
    /// cleared after the barrier that ends it, read by the others only in between.
    job: UnsafeCell<Option<Job<'static>>>,
    /// Set (before a start barrier) when the team is dropped: the workers return.
    stop: AtomicBool,
    /// The first panic of a worker's share of the job, resumed on the calling thread.
    panic: Mutex<Option<Box<dyn Any + Send>>>,
}

// SAFETY: `job` is written only by thread 0 while no worker reads it (the workers are
// between the end barrier of one job and the start barrier of the next), and the
// barrier's acquire/release orders the write before the workers' reads; the job it
// points to is `Sync`.
unsafe impl Sync for Inner {}
// SAFETY: as above; the job reference is only dereferenced while `run` keeps it alive.
unsafe impl Send for Inner {}

/// A team of `size` threads: the one that made it (thread 0, which must be the one
/// that runs its jobs; [`Team::owned_here`] tells) and `size` − 1 spawned workers,
/// which live until the team is dropped.
pub struct Team {
    inner: Arc<Inner>,
    workers: Vec<JoinHandle<()>>,
    /// The thread the barrier wakes as thread 0.
    owner: ThreadId,
    /// Thread 0's spinning budget, carried from job to job.
    spin: AtomicU32,
    /// A job is running (a second `run` at once, from a clone's owner, would mix two
    /// jobs' barriers).
    busy: AtomicBool,
    /// Thread 0's long waits (a worker was descheduled: a busy machine) since last
    /// taken. The workers' own long waits are not counted: theirs include waiting
    /// for the caller's serial work between jobs, which is no sign of a busy machine.
    long_waits: AtomicUsize,
}

impl std::fmt::Debug for Team {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Team({} threads)", self.size())
    }
}

impl Team {
    /// A team of `size` ≥ 1 threads, the calling thread the first; workers named
    /// `{name}-{t}`.
    pub fn new(size: usize, name: &str) -> Self {
        assert!(size >= 1, "a team has at least its calling thread");
        let inner = Arc::new(Inner {
            barrier: SpinBarrier::new(size),
            job: UnsafeCell::new(None),
            stop: AtomicBool::new(false),
            panic: Mutex::new(None),
        });
        let workers: Vec<_> = (1..size)
            .map(|t| {
                let inner = inner.clone();
                std::thread::Builder::new()
                    .name(format!("{name}-{t}"))
                    .spawn(move || worker(&inner, t))
                    .expect("a thread for the team")
            })
            .collect();
        let mut handles = vec![std::thread::current()];
        handles.extend(workers.iter().map(|w| w.thread().clone()));
        // Before the first wait: every wait happens in `run` or `drop`, after this.
        let _ = inner.barrier.handles.set(handles);
        Team {
            inner,
            workers,
            owner: std::thread::current().id(),
            spin: AtomicU32::new(MAX_SPIN),
            busy: AtomicBool::new(false),
            long_waits: AtomicUsize::new(0),
        }
    }

    /// Threads in the team, the calling one included.
    pub fn size(&self) -> usize {
        self.inner.barrier.threads
    }

    /// Whether the calling thread is the team's thread 0 (a team made on another
    /// thread still gives the same results, but the barrier would wake that thread
    /// instead of this one, which then waits out its timed sleeps).
    pub fn owned_here(&self) -> bool {
        std::thread::current().id() == self.owner
    }

    /// Thread 0's long waits since the last call (see `barrier::LONG_WAIT`).
    pub fn take_long_waits(&self) -> usize {
        self.long_waits.swap(0, Ordering::Relaxed)
    }

    /// `job(t)` on each thread t of the team, `job(0)` on the calling thread; returns
    /// when every thread has finished. A panic in any share is resumed here, after the
    /// others have finished (the team stays usable).
    pub fn run(&self, job: &(dyn Fn(usize) + Sync)) {
        if self.size() == 1 {
            job(0);
            return;
        }
        assert!(
            !self.busy.swap(true, Ordering::Acquire),
            "a team runs one job at a time"
        );
        let inner = &*self.inner;
        // SAFETY: the lifetime is erased only for the time the workers hold the
        // reference: they read it after the start barrier below and drop it before the
        // end barrier, which this function always reaches (thread 0's share cannot
        // unwind past it) before `job` goes out of scope.
        let erased = unsafe { std::mem::transmute::<Job<'_>, Job<'static>>(job) };
        // SAFETY: no worker reads `job` now (see `Inner`).
        unsafe { *inner.job.get() = Some(erased) };
        let mut spin = self.spin.load(Ordering::Relaxed);
        // Should the barrier panic (a worker died outside a job), the workers must
        // not wait for this thread either.
        let poison = PoisonOnPanic(&inner.barrier);
        let long = inner.barrier.wait(0, &mut spin);
        let mine = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(0)));
        let long = usize::from(long) + usize::from(inner.barrier.wait(0, &mut spin));
        drop(poison);
        if long > 0 {
            self.long_waits.fetch_add(long, Ordering::Relaxed);
        }
        // SAFETY: every worker has passed the end barrier: none reads `job`.
        unsafe { *inner.job.get() = None };
        self.spin.store(spin, Ordering::Relaxed);
        self.busy.store(false, Ordering::Release);
        if let Err(p) = mine {
            std::panic::resume_unwind(p);
        }
        let theirs = inner.panic.lock().map(|mut p| p.take()).unwrap_or(None);
        if let Some(p) = theirs {
            std::panic::resume_unwind(p);
        }
    }
}

/// A worker's life: wait for a job, run its share, meet the others at its end.
fn worker(inner: &Inner, t: usize) {
    let _poison = PoisonOnPanic(&inner.barrier);
    let mut spin = MAX_SPIN;
    loop {
        inner.barrier.wait(t, &mut spin);
        if inner.stop.load(Ordering::Relaxed) {
            return;
        }
        // SAFETY: thread 0 wrote the job before the start barrier and clears it only
        // after the end barrier, which this thread has not passed yet.
        let job = unsafe { *inner.job.get() }.expect("a job after the start barrier");
        let share = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(t)));
        if let Err(p) = share
            && let Ok(mut slot) = inner.panic.lock()
        {
            slot.get_or_insert(p);
        }
        inner.barrier.wait(t, &mut spin);
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        if self.workers.is_empty() {
            return;
        }
        if self.inner.barrier.poisoned() {
            // A worker died outside a job (it cannot inside one): the others return
            // from their next wait with a panic; nothing to join in order.
            return;
        }
        self.inner.stop.store(true, Ordering::Relaxed);
        let mut spin = self.spin.load(Ordering::Relaxed);
        // The start barrier of no job: the workers see `stop` (the barrier orders it)
        // and return.
        self.inner.barrier.wait(0, &mut spin);
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

/// Threads of an optional team (one without).
pub fn team_size(team: Option<&Team>) -> usize {
    team.map_or(1, Team::size)
}

/// `f` over each item on the threads of `team` (item t on thread t; as many items as
/// threads, or fewer), or in turn on the calling thread without a team or with one
/// item; the results in order.
pub fn chunked<I: Send, T: Send>(
    team: Option<&Team>,
    items: Vec<I>,
    f: impl Fn(I) -> T + Sync,
) -> Vec<T> {
    match team {
        Some(team) if items.len() > 1 => {
            assert!(items.len() <= team.size(), "an item per thread at most");
            // Each thread takes its own item and writes its own result.
            let slots: Vec<Mutex<(Option<I>, Option<T>)>> = items
                .into_iter()
                .map(|i| Mutex::new((Some(i), None)))
                .collect();
            team.run(&|t| {
                if let Some(slot) = slots.get(t) {
                    let mut slot = slot.lock().expect("an item's slot");
                    let item = slot.0.take().expect("each item taken once");
                    // The lock is uncontended (one thread per slot): held while `f`
                    // runs, it costs nothing.
                    slot.1 = Some(f(item));
                }
            });
            slots
                .into_iter()
                .map(|s| {
                    s.into_inner()
                        .expect("an item's slot")
                        .1
                        .expect("every item ran")
                })
                .collect()
        }
        _ => items.into_iter().map(f).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    #[test]
    fn every_thread_runs_its_share_of_every_job() {
        for size in [1, 2, 3] {
            let team = Team::new(size, "test");
            let sum = AtomicUsize::new(0);
            for _ in 0..1000 {
                team.run(&|t| {
                    sum.fetch_add(t + 1, Ordering::Relaxed);
                });
            }
            assert_eq!(sum.into_inner(), 1000 * size * (size + 1) / 2);
        }
    }

    #[test]
    fn chunked_keeps_the_order() {
        let team = Team::new(3, "test");
        let out = chunked(Some(&team), vec![1, 2, 3], |i| i * 10);
        assert_eq!(out, vec![10, 20, 30]);
        let out = chunked(Some(&team), vec![1, 2], |i| i * 10);
        assert_eq!(out, vec![10, 20]);
        assert_eq!(chunked(None, vec![4, 5], |i| i + 1), vec![5, 6]);
    }

    /// A panic in a worker's share reaches the caller, does not hang, and leaves the
    /// team working.
    #[test]
    fn a_panic_in_a_share_is_resumed_and_the_team_goes_on() {
        let team = Team::new(2, "test");
        for panicking in [1, 0] {
            let got = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                team.run(&|t| {
                    if t == panicking {
                        panic!("share {t}");
                    }
                })
            }));
            let p = got.expect_err("the panic reaches the caller");
            assert_eq!(
                p.downcast_ref::<String>().map(|s| s.as_str()),
                Some(&*format!("share {panicking}"))
            );
            let ran = AtomicUsize::new(0);
            team.run(&|_| {
                ran.fetch_add(1, Ordering::Relaxed);
            });
            assert_eq!(ran.into_inner(), 2);
        }
    }

    #[test]
    fn dropping_a_team_ends_its_threads() {
        let team = Team::new(3, "test");
        let inner = Arc::downgrade(&team.inner);
        team.run(&|_| {});
        drop(team);
        // Every worker held a reference to the shared part until it returned.
        assert_eq!(inner.strong_count(), 0);
    }
}
