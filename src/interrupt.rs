//! Graceful interruption. SIGINT (Ctrl-C) and SIGTERM (what Slurm sends at a time limit
//! or preemption, and what a shutdown sends) only raise a flag; long loops poll it at
//! their step boundaries, save a checkpoint and return `Error::Interrupted` (the error
//! module depends on this one, not the other way round), and the
//! CLI prints how to continue. A second signal ends the process at once (exit 128 +
//! signal), as users expect of a second Ctrl-C.
//!
//! Polling rather than unwinding from the handler keeps every write atomic: a run is
//! stopped only between steps, where its state is whole.

use std::sync::atomic::{AtomicI32, Ordering};

/// The first signal received (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);

/// SIGINT's number (POSIX: 2 everywhere).
pub const SIGINT: i32 = 2;
/// SIGTERM's number (POSIX: 15 everywhere).
pub const SIGTERM: i32 = 15;

/// Route SIGINT and SIGTERM to the flag. Called once by the binary; the library never
/// installs handlers of its own (a program embedding it keeps its own).
pub fn install() {
    #[cfg(unix)]
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: `sa` is fully initialised (zeroed, then its mask emptied) before
        // `sigaction` reads it; the handler only touches an atomic and calls the
        // async-signal-safe `write` and `_exit`.
        unsafe {
            let mut sa: libc::sigaction = std::mem::zeroed();
            sa.sa_sigaction = handler as *const () as libc::sighandler_t;
            libc::sigemptyset(&mut sa.sa_mask);
            // Restart interrupted reads and writes: the run stops at its next step
            // boundary, not with an EINTR error in the middle of writing a table.
            sa.sa_flags = libc::SA_RESTART;
            libc::sigaction(sig, &sa, std::ptr::null_mut());
        }
    }
}

#[cfg(unix)]
extern "C" fn handler(sig: libc::c_int) {
    if SIGNAL.swap(sig, Ordering::SeqCst) != 0 {
        // SAFETY: `_exit` is async-signal-safe and takes any status.
        unsafe { libc::_exit(128 + sig) }
    }
    let msg: &[u8] = b"\npillar-pipe: stopping at the next safe point (long runs save a checkpoint first); send the signal again to stop at once\n";
    // SAFETY: `write` is async-signal-safe; the buffer is a static byte string.
    unsafe {
        libc::write(2, msg.as_ptr().cast(), msg.len());
    }
}

/// The signal that asked the process to stop, if any.
pub fn requested() -> Option<i32> {
    match SIGNAL.load(Ordering::Relaxed) {
        0 => None,
        s => Some(s),
    }
}

/// Ask the long loops to stop as a signal `sig` would, without a signal: for a program
/// embedding the library that catches Ctrl-C itself (the Python package polls Python's
/// own SIGINT handling while a stage runs on another thread, then calls this). The
/// stage then stops at its next safe point with `Error::Interrupted`.
pub fn request(sig: i32) {
    SIGNAL.store(sig, Ordering::SeqCst);
}

/// Forget a stop request: an embedding program that survives an interrupted call (a
/// notebook after Ctrl-C) calls this so that its next call is not stopped at once.
pub fn clear() {
    SIGNAL.store(0, Ordering::SeqCst);
}

/// `SIGINT`, `SIGTERM`, or `signal N`.
pub fn name(sig: i32) -> String {
    match sig {
        SIGINT => "SIGINT".into(),
        SIGTERM => "SIGTERM".into(),
        s => format!("signal {s}"),
    }
}

/// The conventional exit status of a process stopped by `sig`.
pub fn exit_code(sig: i32) -> i32 {
    128 + sig
}

/// When a long run saves its state: every `every` steps, every `interval` seconds of
/// wall time (so a SIGKILL loses at most that much work), and at once when a signal asks
/// the process to stop. Where checkpoints fall never changes a number: runs resume
/// bit-exactly from any step.
#[derive(Debug, Clone)]
pub struct CheckpointClock {
    every: u64,
    interval: f64,
    last: std::time::Instant,
}

impl CheckpointClock {
    /// `every` in steps and `interval` in seconds; 0 switches either off.
    pub fn new(every: u64, interval: f64) -> Self {
        CheckpointClock {
            every,
            interval,
            last: std::time::Instant::now(),
        }
    }

    /// Whether a checkpoint is due after `step` for the step count alone.
    pub fn due_by_steps(&self, step: u64) -> bool {
        self.every > 0 && step.is_multiple_of(self.every)
    }

    /// Steps from `step` to the next at which [`CheckpointClock::due_by_steps`] holds
    /// (`None`: never).
    pub fn steps_to_due(&self, step: u64) -> Option<u64> {
        (self.every > 0).then(|| self.every - step % self.every)
    }

    /// Whether a checkpoint is due now for the wall time or a signal.
    pub fn due_now(&self) -> bool {
        requested().is_some()
            || (self.interval > 0.0 && self.last.elapsed().as_secs_f64() >= self.interval)
    }

    /// Call after each checkpoint written.
    pub fn saved(&mut self) {
        self.last = std::time::Instant::now();
    }
}

#[cfg(test)]
mod tests {
    use super::CheckpointClock;

    /// The steps to the next checkpoint by step count land on the multiples of
    /// `every`, a full interval from one of them, never with `every` = 0.
    #[test]
    fn steps_to_due_lands_on_the_multiples() {
        let c = CheckpointClock::new(50, 0.0);
        for (step, want) in [(0, 50), (1, 49), (49, 1), (50, 50), (120, 30)] {
            assert_eq!(c.steps_to_due(step), Some(want));
            assert!(c.due_by_steps(step + want));
        }
        assert_eq!(CheckpointClock::new(0, 10.0).steps_to_due(7), None);
    }
}
