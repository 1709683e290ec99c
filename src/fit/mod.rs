//! Deformation-driven diffusion (Li et al., Sec. IV): fit the crossover law Eq. 19 to
//! (η^s, D²min/R²) samples with every estimator, bootstrap intervals over start
//! times, and flag parameters the data cannot constrain.

mod boot;
pub mod estimate;
pub mod model;
pub mod noise;
mod points_boot;
pub mod range;

pub use estimate::{BinPoint, Binning, Method, PointFit, fit_method, fit_points, reduce};
pub use model::d2min_over_r2;
pub use range::{FitRange, RangeRule};

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
    /// The lag each sample was measured over (frames; any label that tells lags apart),
    /// for the range rule: which lags feed which η^s.
    pub lag: Vec<u32>,
}

impl Samples {
    /// A sample of unknown lag (all such samples count as one lag).
    pub fn push(&mut self, eta: f64, y: f64, group: u32) {
        self.push_lag(eta, y, group, 0);
    }
    pub fn push_lag(&mut self, eta: f64, y: f64, group: u32, lag: u32) {
        self.eta_s.push(eta);
        self.d2min_over_r2.push(y);
        self.group.push(group);
        self.lag.push(lag);
    }
    /// The samples with η^s in [lo, hi].
    pub fn within(&self, lo: f64, hi: f64) -> Samples {
        let mut out = Samples::default();
        for k in 0..self.len() {
            if self.eta_s[k] >= lo && self.eta_s[k] <= hi {
                out.push_lag(
                    self.eta_s[k],
                    self.d2min_over_r2[k],
                    self.group[k],
                    self.lag[k],
                );
            }
        }
        out
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
    /// Which η^s are fitted (chosen once on all samples; every replicate uses it).
    #[serde(default = "coverage")]
    pub range: RangeRule,
}

fn coverage() -> RangeRule {
    RangeRule::Coverage
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
    /// RMS residual of ln(D²min/R²) over the fitted points (weighted-mean: of
    /// D²min/R² in units of each bin's standard error).
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

/// What every estimator's fit of one set of samples shares, computed once: the
/// positive samples, their starts numbered densely, the binned curves (one sort) with
/// the end slopes of binned-median's, and the bootstrap's bins.
struct Prepared {
    eta: Vec<f64>,
    y: Vec<f64>,
    dense: Vec<u32>,
    n_groups: usize,
    /// [binned-median's, binned-mean's] (weighted-mean's is binned-mean's).
    curves: [Vec<BinPoint>; 2],
    slopes: Option<(f64, f64)>,
    /// For the binned estimators' bootstrap (None when only `points` is fitted).
    prebinned: Option<boot::Prebinned>,
}

fn prepare(s: &Samples, b: &Binning, binned: bool) -> Prepared {
    let (eta, y, group) = positive(s);
    let mut groups: Vec<u32> = group.clone();
    groups.sort_unstable();
    groups.dedup();
    // Each replicate weighs the starts it drew: the binned estimators bin once, the
    // points estimator keeps each start's residual sums.
    let dense: Vec<u32> = group
        .iter()
        .map(|g| groups.binary_search(g).expect("a start of the samples") as u32)
        .collect();
    drop(group);
    let curves = estimate::reduce_binned(&eta, &y, b);
    let slopes = end_slopes(&curves[0]);
    let prebinned = binned
        .then(|| boot::Prebinned::new(&eta, &y, &dense, groups.len(), Method::BinnedMedian, b));
    Prepared {
        eta,
        y,
        dense,
        n_groups: groups.len(),
        curves,
        slopes,
        prebinned,
    }
}

/// Fit with one estimator, bootstrap over groups.
pub fn fit_estimator(s: &Samples, method: Method, set: &FitSettings) -> Result<EstimatorResult> {
    estimate_prepared(
        &prepare(s, &set.binning, method != Method::Points),
        method,
        set,
    )
}

fn estimate_prepared(p: &Prepared, method: Method, set: &FitSettings) -> Result<EstimatorResult> {
    let (eta, y) = (&p.eta, &p.y);
    // The points estimator's points are the samples: fitted as they are, not copied
    // into a hundred-byte point each.
    let pts = match method {
        Method::Points => Vec::new(),
        Method::BinnedMedian => p.curves[0].clone(),
        Method::BinnedMean | Method::WeightedMean => p.curves[1].clone(),
    };
    let best = if method == Method::Points {
        fit_points(eta, y)
    } else {
        fit_method(&pts, method)
    }
    .map_err(|e| Error::Other(format!("{}: {e}", method.name())))?;
    let fitted_points = if method == Method::Points {
        eta.len()
    } else {
        pts.len()
    };
    let reps = if method == Method::Points {
        set.bootstrap.min(POINTS_REPLICATES_MAX)
    } else {
        set.bootstrap
    };
    let n_groups = p.n_groups;
    enum Pre {
        Binned(boot::Prebinned),
        Points(points_boot::PointsBoot),
    }
    let pre = if method == Method::Points {
        Pre::Points(points_boot::PointsBoot::new(eta, y, &p.dense, n_groups))
    } else {
        Pre::Binned(
            p.prebinned
                .as_ref()
                .expect("binned samples for a binned estimator")
                .for_method(method),
        )
    };
    let fits: Vec<Option<PointFit>> = (0..reps)
        .into_par_iter()
        .map(|b| {
            let mut rng = Rng::new(set.seed ^ (b as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let mut weight = vec![0u32; n_groups];
            for _ in 0..n_groups {
                weight[rng.below(n_groups)] += 1;
            }
            match &pre {
                Pre::Binned(pre) => fit_method(&pre.reduce(&weight), method).ok(),
                Pre::Points(pre) => pre.fit(&weight),
            }
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
    let fitted_eta = |f: &mut dyn FnMut(f64)| {
        if method == Method::Points {
            eta.iter().for_each(|&e| f(e));
        } else {
            pts.iter().for_each(|p| f(p.eta_s));
        }
    };
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    fitted_eta(&mut |e| {
        lo = lo.min(e);
        hi = hi.max(e);
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
    if let Some((low, high)) = p.slopes
        && low < high + SLOPE_FALL_MIN
    {
        eta_c_ok = false;
        notes.push(format!(
            "no crossover in the fitted range: the log slope of D²min/R² against η^s is {low:.2} at its low end and {high:.2} at its high end, where Eq. 19's falls from 2 to 1; η_c is not determined (tracking noise, which adds a floor to D²min, flattens the low end)"
        ));
        // Without a crossover Θ is the diffusive prefactor only where the data are
        // diffusive (slope 1).
        if (high - 1.0).abs() > DIFFUSIVE_SLOPE_TOLERANCE {
            theta_ok = false;
            notes.push(format!(
                "the log slope at the high end, {high:.2}, is not the diffusive regime's 1: Θ is not determined"
            ));
        }
    }
    if n_groups < 2 {
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
        fitted_points,
        bootstrap_replicates: reps,
        bootstrap_failures: reps - ok.len(),
        iterations: best.iterations,
        curve: pts,
    })
}

/// The chosen estimator on the start times of one third of the run (li-granular-pillars
/// Sec. IV assumes the deformation statistics do not drift with strain).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ThirdFit {
    /// "first", "middle" or "last".
    pub part: String,
    /// Start indices (in time order) [first, last] of this third.
    pub starts: [u32; 2],
    #[serde(deserialize_with = "json_nonfinite::nan")]
    pub theta: f64,
    #[serde(deserialize_with = "json_nonfinite::nan_pair")]
    pub theta_interval: [f64; 2],
    #[serde(deserialize_with = "json_nonfinite::nan")]
    pub eta_c: f64,
    #[serde(deserialize_with = "json_nonfinite::nan_pair")]
    pub eta_c_interval: [f64; 2],
    pub theta_constrained: bool,
    pub eta_c_constrained: bool,
    pub fitted_points: usize,
}

/// Θ and η_c of the chosen estimator, with bootstrap intervals, for the first, middle and
/// last third of the start times (by index: starts are numbered in time order), each on
/// the whole fit's η^s range so that only the time window changes. Empty with fewer than
/// six starts (two per third are needed for an interval).
pub fn by_thirds(s: &Samples, set: &FitSettings, range: &FitRange) -> Vec<ThirdFit> {
    let mut starts: Vec<u32> = s.group.clone();
    starts.sort_unstable();
    starts.dedup();
    if starts.len() < 6 {
        return Vec::new();
    }
    let kept = s.within(range.lo, range.hi);
    let n = starts.len();
    ["first", "middle", "last"]
        .iter()
        .enumerate()
        .filter_map(|(k, part)| {
            let (a, b) = (starts[k * n / 3], starts[(k + 1) * n / 3 - 1]);
            let mut sub = Samples::default();
            for i in 0..kept.len() {
                if (a..=b).contains(&kept.group[i]) {
                    sub.push_lag(
                        kept.eta_s[i],
                        kept.d2min_over_r2[i],
                        kept.group[i],
                        kept.lag[i],
                    );
                }
            }
            let r = fit_estimator(&sub, set.method, set).ok()?;
            Some(ThirdFit {
                part: part.to_string(),
                starts: [a, b],
                theta: r.theta,
                theta_interval: r.theta_interval,
                eta_c: r.eta_c,
                eta_c_interval: r.eta_c_interval,
                theta_constrained: r.theta_constrained,
                eta_c_constrained: r.eta_c_constrained,
                fitted_points: r.fitted_points,
            })
        })
        .collect()
}

/// JSON has no NaN or ∞: serde_json writes them as `null`. These read a `null` back as
/// NaN (a failed or undetermined number) or as +∞ (an open upper bound).
pub mod json_nonfinite {
    use serde::{Deserialize, Deserializer};
    pub fn nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
    pub fn nan_pair<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
        let [a, b] = <[Option<f64>; 2]>::deserialize(d)?;
        Ok([a.unwrap_or(f64::NAN), b.unwrap_or(f64::NAN)])
    }
    pub fn inf<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
    }
}

/// Upper ends of η^s the sensitivity table refits with (None: every sample above the
/// chosen range's lower end).
pub const SENSITIVITY_UPPER: [Option<f64>; 4] = [Some(0.2), Some(0.5), Some(1.0), None];

/// One cell of the sensitivity table: an estimator's point fit (no bootstrap) with the
/// fitted range's upper end replaced.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SensitivityRow {
    pub method: Method,
    /// Neighbourhood radius R_c / D of the samples (li-granular-pillars Sec. IV: 1.25).
    #[serde(default)]
    pub rc_over_d: f64,
    /// η^s ∈ [lo, hi] fitted (hi = ∞, `null` in JSON, for "all").
    pub lo: f64,
    #[serde(deserialize_with = "json_nonfinite::inf")]
    pub hi: f64,
    /// NaN (`null` in JSON) where the fit failed (too few points).
    #[serde(deserialize_with = "json_nonfinite::nan")]
    pub theta: f64,
    #[serde(deserialize_with = "json_nonfinite::nan")]
    pub eta_c: f64,
    pub fitted_points: usize,
}

/// Θ and η_c of every estimator for each upper end in [`SENSITIVITY_UPPER`], the lower
/// end kept at `lo` (the chosen range's), for samples taken with R_c = `rc_over_d` D:
/// how much the headline number depends on where the fit stops, shown next to it.
pub fn sensitivity(s: &Samples, rc_over_d: f64, lo: f64, b: &Binning) -> Vec<SensitivityRow> {
    let (eta, y, _) = positive(s);
    // One upper end at a time (the points fit beside the binning): each holds copies
    // of up to all the samples, and four at once took the command past 1 GB. Its
    // samples are filtered once and binned once for the three binned estimators (their
    // curves come from one sort).
    let per_hi: Vec<Vec<SensitivityRow>> = SENSITIVITY_UPPER
        .into_iter()
        .map(|hi| {
            let hi = hi.unwrap_or(f64::INFINITY);
            let (e, v): (Vec<f64>, Vec<f64>) = eta
                .iter()
                .zip(&y)
                .filter(|(e, _)| **e >= lo && **e <= hi)
                .map(|(e, v)| (*e, *v))
                .unzip();
            let row = |m: Method, fit: Option<PointFit>, fitted_points: usize| SensitivityRow {
                method: m,
                rc_over_d,
                lo,
                hi,
                theta: fit.map_or(f64::NAN, |f| f.theta),
                eta_c: fit.map_or(f64::NAN, |f| f.eta_c),
                fitted_points,
            };
            let (points, binned) = rayon::join(
                || fit_points(&e, &v).ok(),
                || estimate::reduce_binned(&e, &v, b),
            );
            Method::ALL
                .iter()
                .map(|&m| match m {
                    Method::Points => row(m, points, e.len()),
                    _ => {
                        let pts = &binned[usize::from(m != Method::BinnedMedian)];
                        row(m, fit_method(pts, m).ok(), pts.len())
                    }
                })
                .collect()
        })
        .collect();
    // Cells in the table's order: by estimator, then upper end.
    (0..Method::ALL.len())
        .flat_map(|m| per_hi.iter().map(move |rows| rows[m].clone()))
        .collect()
}

/// How much the log slope must fall from the low to the high end of the data for a
/// crossover to count as seen (Eq. 19: from 2 to 1).
pub const SLOPE_FALL_MIN: f64 = 0.1;

/// How far from 1 the high end's log slope may be for Θ to count as the diffusive
/// prefactor when no crossover is seen.
pub const DIFFUSIVE_SLOPE_TOLERANCE: f64 = 0.25;

/// Least-squares log–log slopes of the binned medians over the lowest and the highest
/// quarter of the binned range (at least three bins each); None with fewer than six
/// bins.
fn end_slopes(pts: &[BinPoint]) -> Option<(f64, f64)> {
    if pts.len() < 6 {
        return None;
    }
    let k = (pts.len() / 4).max(3);
    let slope = |p: &[BinPoint]| {
        let n = p.len() as f64;
        let (xs, ys): (Vec<f64>, Vec<f64>) = p
            .iter()
            .map(|q| (q.eta_s.ln(), q.d2min_over_r2.ln()))
            .unzip();
        let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
        let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
        let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
        sxy / sxx
    };
    Some((slope(&pts[..k]), slope(&pts[pts.len() - k..])))
}

/// Each estimator's result or its error message, by name.
pub type AllEstimators = BTreeMap<String, std::result::Result<EstimatorResult, String>>;

/// Every estimator, the chosen one first in importance, on the samples within the range
/// `set.range` chooses. Fails only if the chosen one cannot be fitted; the others'
/// failures are recorded as notes by the caller.
pub fn fit_all(
    s: &Samples,
    set: &FitSettings,
) -> Result<(EstimatorResult, AllEstimators, FitRange)> {
    fit_all_above(s, set, None)
}

/// [`fit_all`] with a tracking-noise floor (D²min/R², see [`noise`]): under the default
/// range rule, bins whose median is within [`noise::NOISE_FACTOR`] floors are left out.
pub fn fit_all_above(
    s: &Samples,
    set: &FitSettings,
    noise_floor: Option<f64>,
) -> Result<(EstimatorResult, AllEstimators, FitRange)> {
    if s.len() < 3 {
        return Err(Error::Other(format!(
            "{} (η^s, D²min) samples: too few to fit Eq. 19",
            s.len()
        )));
    }
    let range = range::choose_above(s, set.range, &set.binning, noise_floor);
    let prepared = prepare(&s.within(range.lo, range.hi), &set.binning, true);
    let mut all = BTreeMap::new();
    for m in Method::ALL {
        all.insert(
            m.name().to_string(),
            estimate_prepared(&prepared, m, set).map_err(|e| e.to_string()),
        );
    }
    let chosen = all[set.method.name()].clone().map_err(|e| {
        Error::Other(format!(
            "{e} (fitted range: {}, {} of {} samples)",
            range.description,
            range.samples_in,
            s.len()
        ))
    })?;
    Ok((chosen, all, range))
}

#[cfg(test)]
mod tests;
