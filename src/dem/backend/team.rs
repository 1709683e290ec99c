//! A persistent team of threads that runs one job after another, each split into
//! shares: the sheared disks' step phases (a few a step, each a fraction of a
//! millisecond), for which waking a thread pool's sleeping workers each time cost a
//! sizeable share of the step (issue 35). The calling thread is the team's first; the
//! others are spawned once, with the team, and spin (then sleep, see `barrier`)
//! between jobs.
//!
//! Share t is thread t's, but any thread that has finished its own takes a share
//! nobody has started: on a busy machine, where a worker may wait a scheduler time
//! slice to run, the caller does that worker's share itself rather than wait (a strict
//! barrier there made two threads 0.2× one, measured). Which thread runs a share never
//! changes what it computes.

use crate::dem::backend::barrier::{MAX_SPIN, PoisonOnPanic, SpinBarrier};
use std::any::Any;
use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{JoinHandle, ThreadId};

/// A job: called once for each share with the share's index.
type Job<'a> = &'a (dyn Fn(usize) + Sync + 'a);

/// What the team's threads share.
struct Inner {
    /// Its spinning, sleeping and waking (`sleep_until`, `raise`, `wait_for`).
    barrier: SpinBarrier,
    /// The current job: written by thread 0 before it raises `job_no`, cleared after
    /// every share is done; read only by a thread that has claimed a share of it.
    job: UnsafeCell<Option<Job<'static>>>,
    /// Shares of the current job (at most the team's size).
    shares: AtomicUsize,
    /// Jobs published so far: the current one's number.
    job_no: AtomicU64,
    /// Per share: the number of the last job it was claimed for (or, beyond the
    /// job's shares, that had it unused). Every entry reaches a job's number before
    /// the next job is published, so a claim for an earlier job always fails.
    claimed: Vec<AtomicU64>,
    /// Shares finished, over all jobs.
    done: AtomicU64,
    /// Set (before a last `job_no`) when the team is dropped: the workers return.
    stop: AtomicBool,
    /// The first panic of a share run off the calling thread, resumed on it.
    panic: Mutex<Option<Box<dyn Any + Send>>>,
}

// SAFETY: `job` is written only by thread 0 while no share of a job is claimed and
// unfinished (before publishing, after every share is done); a thread reads it only
// after claiming a share, which the release/acquire of `job_no` and `claimed`
// orders after the write. The job it points to is `Sync`.
unsafe impl Sync for Inner {}
// SAFETY: as above; the job reference is only dereferenced while `run` keeps it alive.
unsafe impl Send for Inner {}

impl Inner {
    /// Claim share `s` of job `no` and run it; whether this thread ran it.
    fn take(&self, no: u64, s: usize) -> bool {
        let c = &self.claimed[s];
        let last = c.load(Ordering::Acquire);
        if last >= no
            || c.compare_exchange(last, no, Ordering::AcqRel, Ordering::Relaxed)
                .is_err()
        {
            return false;
        }
        // SAFETY: a claimed share of job `no` is unfinished, so thread 0 has published
        // `no`'s job (before raising `job_no` to it, which this thread saw) and waits
        // for it: the reference is live.
        let job = unsafe { *self.job.get() }.expect("a job while a share is claimed");
        if let Err(p) = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(s)))
            && let Ok(mut slot) = self.panic.lock()
        {
            slot.get_or_insert(p);
        }
        self.done.fetch_add(1, Ordering::Release);
        true
    }

    /// Thread `t`'s part of job `no`: its own share first (its data is warm in its
    /// cache), then any nobody has started.
    fn work(&self, no: u64, t: usize) {
        let shares = self.shares.load(Ordering::Acquire).min(self.claimed.len());
        if t < shares {
            self.take(no, t);
        }
        for s in (0..shares).filter(|&s| s != t) {
            self.take(no, s);
        }
    }
}

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
    /// jobs).
    busy: AtomicBool,
    /// Thread 0's long waits for others' shares since last taken.
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
            shares: AtomicUsize::new(0),
            job_no: AtomicU64::new(0),
            claimed: (0..size).map(|_| AtomicU64::new(0)).collect(),
            done: AtomicU64::new(0),
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
        // Before the first wake-up: every `raise` happens in `run` or `drop`, after
        // this.
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
    /// thread still gives the same results, but its wake-ups would go to that thread
    /// instead of this one).
    pub fn owned_here(&self) -> bool {
        std::thread::current().id() == self.owner
    }

    /// Thread 0's long waits since the last call (see `barrier::LONG_WAIT`).
    pub fn take_long_waits(&self) -> usize {
        self.long_waits.swap(0, Ordering::Relaxed)
    }

    /// `f` (jobs of this team, from thread 0) with its long waits not counted: work
    /// lent to the team between the jobs whose waits are watched (a worker asleep
    /// after a stretch of serial work makes the first wait long, which says nothing
    /// about the machine).
    pub fn uncounted<R>(&self, f: impl FnOnce() -> R) -> R {
        let before = self.long_waits.load(Ordering::Relaxed);
        let r = f();
        self.long_waits.store(before, Ordering::Relaxed);
        r
    }

    /// `job(s)` for each share s in 0..`shares` (at most the team's size), share t
    /// meant for thread t (share 0 on the calling thread), a share no thread has
    /// started taken by any that is free; returns when every share is done. A panic in
    /// any share is resumed here, after the others are done (the team stays usable).
    pub fn run(&self, shares: usize, job: &(dyn Fn(usize) + Sync)) {
        assert!(shares <= self.size(), "a share per thread at most");
        if self.workers.is_empty() || shares <= 1 {
            (0..shares).for_each(job);
            return;
        }
        assert!(
            !self.busy.swap(true, Ordering::Acquire),
            "a team runs one job at a time"
        );
        let inner = &*self.inner;
        // SAFETY: the lifetime is erased only while shares may run: a thread reads the
        // reference after claiming a share and drops it before counting the share
        // done, and this function returns (or unwinds: thread 0's shares cannot unwind
        // past the wait) only after every share is done.
        let erased = unsafe { std::mem::transmute::<Job<'_>, Job<'static>>(job) };
        // SAFETY: no share is claimed now (see `Inner`).
        unsafe { *inner.job.get() = Some(erased) };
        let no = inner.job_no.load(Ordering::Relaxed) + 1;
        // Shares beyond this job's are marked taken, so no late claim finds them.
        for c in &inner.claimed[shares..] {
            c.store(no, Ordering::Relaxed);
        }
        inner.shares.store(shares, Ordering::Release);
        let target = inner.done.load(Ordering::Acquire) + shares as u64;
        // Should a wait panic (a worker died outside a share), the workers must not
        // wait for this thread either.
        let poison = PoisonOnPanic(&inner.barrier);
        inner.barrier.raise(&inner.job_no, no, 0);
        inner.work(no, 0);
        let mut spin = self.spin.load(Ordering::Relaxed);
        if inner.barrier.wait_for(&inner.done, target, &mut spin) {
            self.long_waits.fetch_add(1, Ordering::Relaxed);
        }
        drop(poison);
        // SAFETY: every share is done: none is claimed and unfinished.
        unsafe { *inner.job.get() = None };
        self.spin.store(spin, Ordering::Relaxed);
        self.busy.store(false, Ordering::Release);
        let panicked = inner.panic.lock().map(|mut p| p.take()).unwrap_or(None);
        if let Some(p) = panicked {
            std::panic::resume_unwind(p);
        }
    }
}

/// A worker's life: wait for the next job, do its part (see `Inner::work`).
fn worker(inner: &Inner, t: usize) {
    let _poison = PoisonOnPanic(&inner.barrier);
    let mut spin = MAX_SPIN;
    let mut seen = 0;
    loop {
        inner
            .barrier
            .sleep_until(&inner.job_no, seen + 1, &mut spin);
        if inner.stop.load(Ordering::Acquire) {
            return;
        }
        // The latest job: any before it is done (its shares all claimed).
        seen = inner.job_no.load(Ordering::Acquire);
        inner.work(seen, t);
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        if self.workers.is_empty() || self.inner.barrier.poisoned() {
            // Nothing to end, or a worker died outside a share (it cannot inside one)
            // and the others panic out of their next wait.
            return;
        }
        let inner = &*self.inner;
        inner.stop.store(true, Ordering::Release);
        let no = inner.job_no.load(Ordering::Relaxed) + 1;
        // A job with no shares: the workers wake, see `stop` and return.
        for c in &inner.claimed {
            c.store(no, Ordering::Relaxed);
        }
        inner.barrier.raise(&inner.job_no, no, 0);
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

/// Threads of an optional team (one without).
pub fn team_size(team: Option<&Team>) -> usize {
    team.map_or(1, Team::size)
}

/// `f` over each item as a share of a job of `team` (item t meant for thread t; as
/// many items as threads, or fewer), or in turn on the calling thread without a team
/// or with one item; the results in order.
pub fn chunked<I: Send, T: Send>(
    team: Option<&Team>,
    items: Vec<I>,
    f: impl Fn(I) -> T + Sync,
) -> Vec<T> {
    match team {
        Some(team) if items.len() > 1 => {
            let shares = items.len();
            // Each share takes its item and writes its result.
            let slots: Vec<Mutex<(Option<I>, Option<T>)>> = items
                .into_iter()
                .map(|i| Mutex::new((Some(i), None)))
                .collect();
            team.run(shares, &|s| {
                let mut slot = slots[s].lock().expect("an item's slot");
                let item = slot.0.take().expect("each item taken once");
                // Uncontended (one share per slot): held while `f` runs, it costs
                // nothing.
                slot.1 = Some(f(item));
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

    /// Every share of every job runs once, whatever the number of shares (a late
    /// claim for an earlier job never runs a share of a later one).
    #[test]
    fn every_share_of_every_job_runs_once() {
        for size in [1, 2, 3] {
            let team = Team::new(size, "test");
            let runs: Vec<AtomicUsize> = (0..size).map(|_| AtomicUsize::new(0)).collect();
            let mut want = vec![0; size];
            for k in 0..3000 {
                let shares = 1 + k % size;
                team.run(shares, &|s| {
                    runs[s].fetch_add(1, Ordering::Relaxed);
                });
                want[..shares].iter_mut().for_each(|w| *w += 1);
            }
            let got: Vec<_> = runs.into_iter().map(AtomicUsize::into_inner).collect();
            assert_eq!(got, want, "{size} threads");
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

    /// A panic in a share (the caller's or another's) reaches the caller, does not hang, and leaves the
    /// team working.
    #[test]
    fn a_panic_in_a_share_is_resumed_and_the_team_goes_on() {
        let team = Team::new(2, "test");
        for panicking in [1, 0] {
            let got = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                team.run(2, &|t| {
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
            team.run(2, &|_| {
                ran.fetch_add(1, Ordering::Relaxed);
            });
            assert_eq!(ran.into_inner(), 2);
        }
    }

    #[test]
    fn dropping_a_team_ends_its_threads() {
        let team = Team::new(3, "test");
        let inner = Arc::downgrade(&team.inner);
        team.run(3, &|_| {});
        drop(team);
        // Every worker held a reference to the shared part until it returned.
        assert_eq!(inner.strong_count(), 0);
    }
}
