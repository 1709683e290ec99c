//! Deformation-driven diffusion (Li et al., Sec. IV): fit the crossover law Eq. 19 to
//! (η^s, D²min/R²) samples with every estimator, bootstrap intervals over start
//! times, and flag parameters the data cannot constrain.

pub mod estimate;
pub mod model;

pub use estimate::{BinPoint, Binning, Method, PointFit, fit_points, reduce};
pub use model::d2min_over_r2;

use crate::error::{Error, Result};
use crate::rng::Rng;
use crate::stats::quantile_sorted;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// (η^s, D²min/R²) samples, each tagged with the start time it came from (the unit of
/// the bootstrap: particles of one start are correlated, starts far apart are not).
#[derive(Debug, Clone, Default)]
pub struct Samples {
    pub eta_s: Vec<f64>,
    pub d2min_over_r2: Vec<f64>,
    pub group: Vec<u32>,
}

impl Samples {
    pub fn push(&mut self, eta: f64, y: f64, group: u32) {
        self.eta_s.push(eta);
        self.d2min_over_r2.push(y);
        self.group.push(group);
    }
    pub fn len(&self) -> usize {
        self.eta_s.len()
    }
    pub fn is_empty(&self) -> bool {
        self.eta_s.is_empty()
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FitSettings {
    pub method: Method,
    pub binning: Binning,
    /// Bootstrap replicates over start times (the `points` estimator uses at most
    /// `POINTS_REPLICATES_MAX`: each of its fits touches every sample).
    pub bootstrap: usize,
    pub seed: u64,
}

pub const POINTS_REPLICATES_MAX: usize = 50;

/// One estimator's result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EstimatorResult {
    pub method: Method,
    pub theta: f64,
    pub eta_c: f64,
    /// 95 % bootstrap percentile intervals [2.5 %, 97.5 %].
    pub theta_interval: [f64; 2],
    pub eta_c_interval: [f64; 2],
    pub theta_constrained: bool,
    pub eta_c_constrained: bool,
    /// Why a parameter is not constrained (empty when both are).
    pub notes: Vec<String>,
    /// RMS residual of ln(D²min/R²) over the fitted points.
    pub residual_rms: f64,
    pub fitted_points: usize,
    pub bootstrap_replicates: usize,
    pub bootstrap_failures: usize,
    pub iterations: u64,
    /// The reduced curve that was fitted (binned estimators), for reports.
    pub curve: Vec<BinPoint>,
}

/// Samples that can be fitted in log space (both coordinates > 0 and finite).
fn positive(s: &Samples) -> (Vec<f64>, Vec<f64>, Vec<u32>) {
    let mut e = Vec::with_capacity(s.len());
    let mut y = Vec::with_capacity(s.len());
    let mut g = Vec::with_capacity(s.len());
    for k in 0..s.len() {
        let (a, b) = (s.eta_s[k], s.d2min_over_r2[k]);
        if a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite() {
            e.push(a);
            y.push(b);
            g.push(s.group[k]);
        }
    }
    (e, y, g)
}

/// Fit with one estimator, bootstrap over groups.
pub fn fit_estimator(s: &Samples, method: Method, set: &FitSettings) -> Result<EstimatorResult> {
    let (eta, y, group) = positive(s);
    let pts = reduce(&eta, &y, method, &set.binning);
    let best = fit_points(&pts).map_err(|e| Error::Other(format!("{}: {e}", method.name())))?;
    let mut groups: Vec<u32> = group.clone();
    groups.sort_unstable();
    groups.dedup();
    let mut members: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (k, g) in group.iter().enumerate() {
        members.entry(*g).or_default().push(k);
    }
    let reps = if method == Method::Points {
        set.bootstrap.min(POINTS_REPLICATES_MAX)
    } else {
        set.bootstrap
    };
    let fits: Vec<Option<PointFit>> = (0..reps)
        .into_par_iter()
        .map(|b| {
            let mut rng = Rng::new(set.seed ^ (b as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let (mut be, mut by) = (Vec::new(), Vec::new());
            for _ in 0..groups.len() {
                let g = groups[rng.below(groups.len())];
                for &k in &members[&g] {
                    be.push(eta[k]);
                    by.push(y[k]);
                }
            }
            fit_points(&reduce(&be, &by, method, &set.binning)).ok()
        })
        .collect();
    let ok: Vec<PointFit> = fits.iter().flatten().copied().collect();
    let interval = |f: fn(&PointFit) -> f64| {
        let mut v: Vec<f64> = ok.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        if v.is_empty() {
            [f64::NAN, f64::NAN]
        } else {
            [quantile_sorted(&v, 0.025), quantile_sorted(&v, 0.975)]
        }
    };
    let theta_interval = interval(|p| p.theta);
    let eta_c_interval = interval(|p| p.eta_c);
    let (lo, hi) = pts.iter().fold((f64::MAX, f64::MIN), |a, p| {
        (a.0.min(p.eta_s), a.1.max(p.eta_s))
    });
    let mut notes = Vec::new();
    let mut theta_ok = true;
    let mut eta_c_ok = true;
    if hi < 2.0 * best.eta_c {
        theta_ok = false;
        eta_c_ok = false;
        notes.push(format!(
            "no data in the diffusive regime: largest η^s {hi:.3e} < 2 η_c; only Θ/η_c is determined"
        ));
    }
    if lo > 0.5 * best.eta_c {
        eta_c_ok = false;
        notes.push(format!(
            "no data in the ballistic regime: smallest η^s {lo:.3e} > η_c/2; η_c is not determined"
        ));
    }
    if groups.len() < 2 {
        theta_ok = false;
        eta_c_ok = false;
        notes.push("a single start time: no bootstrap interval".into());
    }
    if ok.len() < reps / 2 || !(eta_c_interval[1] / eta_c_interval[0] < 10.0) {
        eta_c_ok = false;
        notes.push(format!(
            "η_c bootstrap interval [{:.3e}, {:.3e}] spans a decade or more",
            eta_c_interval[0], eta_c_interval[1]
        ));
    }
    let residual_rms = best.cost.sqrt();
    Ok(EstimatorResult {
        method,
        theta: best.theta,
        eta_c: best.eta_c,
        theta_interval,
        eta_c_interval,
        theta_constrained: theta_ok,
        eta_c_constrained: eta_c_ok,
        notes,
        residual_rms,
        fitted_points: pts.len(),
        bootstrap_replicates: reps,
        bootstrap_failures: reps - ok.len(),
        iterations: best.iterations,
        curve: if method == Method::Points {
            Vec::new()
        } else {
            pts
        },
    })
}

/// Each estimator's result or its error message, by name.
pub type AllEstimators = BTreeMap<String, std::result::Result<EstimatorResult, String>>;

/// Every estimator, the chosen one first in importance. Fails only if the chosen one
/// cannot be fitted; the others' failures are recorded as notes by the caller.
pub fn fit_all(s: &Samples, set: &FitSettings) -> Result<(EstimatorResult, AllEstimators)> {
    if s.len() < 3 {
        return Err(Error::Other(format!(
            "{} (η^s, D²min) samples: too few to fit Eq. 19",
            s.len()
        )));
    }
    let mut all = BTreeMap::new();
    for m in Method::ALL {
        all.insert(
            m.name().to_string(),
            fit_estimator(s, m, set).map_err(|e| e.to_string()),
        );
    }
    let chosen = all[set.method.name()].clone().map_err(Error::Other)?;
    Ok((chosen, all))
}

#[cfg(test)]
mod tests;
