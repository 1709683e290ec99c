//! Where a command's wall time went, phase by phase (`--timings`): what a user times is
//! the whole command, so the report says how much of it the kernel was.

use serde::Serialize;
use std::time::Instant;

/// One phase's accumulated wall time, seconds.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Phase {
    pub name: &'static str,
    pub seconds: f64,
}

/// Accumulates wall time per named phase, in the order phases first appear.
#[derive(Debug)]
pub struct PhaseTimer {
    born: Instant,
    last: Instant,
    phases: Vec<Phase>,
}

impl Default for PhaseTimer {
    fn default() -> Self {
        let now = Instant::now();
        Self {
            born: now,
            last: now,
            phases: Vec::new(),
        }
    }
}

impl PhaseTimer {
    /// Charge the time since the previous `lap` (or the timer's birth) to `name`.
    pub fn lap(&mut self, name: &'static str) {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        match self.phases.iter_mut().find(|p| p.name == name) {
            Some(p) => p.seconds += dt,
            None => self.phases.push(Phase { name, seconds: dt }),
        }
    }

    /// The phases, closed with the time since the last lap as `other` when it is not
    /// negligible, so the phases sum to the timer's whole life.
    pub fn finish(mut self) -> Vec<Phase> {
        if self.last.elapsed().as_secs_f64() > 1e-4 {
            self.lap("other");
        }
        let _ = self.born;
        self.phases
    }
}

/// `phase  seconds  share` lines for a report.
pub fn format_phases(phases: &[Phase]) -> String {
    let total: f64 = phases.iter().map(|p| p.seconds).sum();
    let mut s = String::new();
    for p in phases {
        s.push_str(&format!(
            "timing        {:<14} {:>8.3} s  {:>5.1} %\n",
            p.name,
            p.seconds,
            100.0 * p.seconds / total.max(1e-12)
        ));
    }
    s.push_str(&format!("timing        {:<14} {:>8.3} s", "total", total));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phases_accumulate_in_first_seen_order_and_sum_to_the_whole() {
        let mut t = PhaseTimer::default();
        std::thread::sleep(std::time::Duration::from_millis(5));
        t.lap("read");
        std::thread::sleep(std::time::Duration::from_millis(3));
        t.lap("compute");
        std::thread::sleep(std::time::Duration::from_millis(3));
        t.lap("read");
        let born = t.born;
        let p = t.finish();
        let names: Vec<_> = p.iter().map(|p| p.name).collect();
        assert_eq!(&names[..2], &["read", "compute"]);
        assert!(p[0].seconds >= 0.008 && p[1].seconds >= 0.003);
        let sum: f64 = p.iter().map(|p| p.seconds).sum();
        assert!((sum - born.elapsed().as_secs_f64()).abs() < 2e-3);
    }
}
