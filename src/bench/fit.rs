//! `pillar-pipe bench fit`: the crossover fit (li-granular-pillars Eq. 19) with 1000
//! bootstrap replicates on samples shaped like the Sec. IV protocol's at the scale of an
//! N = 16,000 pillar (35 starts × 7 lags, ~4 M samples). Issue 22's target is absolute
//! (under 30 s on these 2 cores); there is no second implementation to compare with, so
//! each estimator's time is reported beside the whole fit's.

use crate::fit::{FitSettings, Method, RangeRule, Samples, d2min_over_r2, fit_all, fit_estimator};
use crate::rng::Rng;
use serde::Serialize;
use std::time::Instant;

#[derive(Debug, Clone, Serialize)]
pub struct FitBench {
    pub samples: usize,
    pub starts: u32,
    pub bootstrap: usize,
    /// Seconds of each estimator's fit and bootstrap, alone, on the fitted range.
    pub estimator_s: Vec<(String, f64)>,
    /// Seconds of `fit_all` (range rule and every estimator), as `fit` runs it.
    pub fit_all_s: f64,
    pub theta: f64,
    pub eta_c: f64,
}

/// Samples like the protocol's: `starts` start times × 7 lags doubling from a median η^s
/// of 0.004 (log-normal spread 0.8 per lag), Eq. 19 with Θ = 0.3, η_c = 0.05 times
/// log-normal scatter 0.5.
pub fn protocol_samples(total: usize, starts: u32, seed: u64) -> Samples {
    let mut rng = Rng::new(seed);
    let mut s = Samples::default();
    let per = (total / (starts as usize * 7)).max(1);
    for g in 0..starts {
        for lag in 0..7u32 {
            let typical = 0.004 * 2f64.powi(lag as i32);
            for _ in 0..per {
                let eta = typical * (0.8 * rng.normal()).exp();
                let y = d2min_over_r2(eta, 0.3, 0.05) * (0.5 * rng.normal()).exp();
                s.push_lag(eta, y, g, 1 << lag);
            }
        }
    }
    s
}

pub fn bench_fit(total: usize, starts: u32, bootstrap: usize) -> FitBench {
    let s = protocol_samples(total, starts, 7);
    let set = FitSettings {
        method: Method::BinnedMedian,
        binning: Default::default(),
        bootstrap,
        seed: 1,
        range: RangeRule::Coverage,
    };
    let t = Instant::now();
    let (chosen, _, range) = fit_all(&s, &set).expect("synthetic samples fit");
    let fit_all_s = t.elapsed().as_secs_f64();
    let kept = s.within(range.lo, range.hi);
    let estimator_s = Method::ALL
        .iter()
        .map(|&m| {
            let t = Instant::now();
            let _ = fit_estimator(&kept, m, &set);
            (m.name().to_string(), t.elapsed().as_secs_f64())
        })
        .collect();
    FitBench {
        samples: s.len(),
        starts,
        bootstrap,
        estimator_s,
        fit_all_s,
        theta: chosen.theta,
        eta_c: chosen.eta_c,
    }
}
