//! One estimator's fit of Eq. 19 with argmin's Brent method on the profile cost: for
//! each η_c the best Θ is closed form, so the fit is a one-dimensional minimisation over
//! ln η_c (positive, and the scatter's decades weigh alike in the log fit).

use super::model::{d2min_over_r2, residual_sums};
use crate::error::{Error, Result};
use crate::stats::{mean, median_sorted, quantile_sorted};
use argmin::core::{CostFunction, Executor, State};
use argmin::solver::brent::BrentOpt;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How the scatter is reduced before fitting.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    Serialize,
    Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Median D²min in log-spaced η^s bins (the bulk of the cloud; default).
    BinnedMedian,
    /// Mean D²min in log-spaced η^s bins (pulled up by the heavy tail).
    BinnedMean,
    /// Every point, least squares in log space.
    Points,
    /// Mean D²min in log-spaced η^s bins, least squares in *linear* space with each bin
    /// weighted by 1/se² (se: the standard error of its mean), so well-sampled bins
    /// count most and the diffusive regime's large values are not compressed by a log.
    WeightedMean,
}

impl Method {
    pub const ALL: [Method; 4] = [
        Method::BinnedMedian,
        Method::BinnedMean,
        Method::Points,
        Method::WeightedMean,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Method::BinnedMedian => "binned-median",
            Method::BinnedMean => "binned-mean",
            Method::Points => "points",
            Method::WeightedMean => "weighted-mean",
        }
    }
    /// Bins keep the quantile nodes of their η^s: the model of a bin mean is the mean
    /// of Eq. 19 over the bin, not Eq. 19 at its centre.
    fn is_mean(self) -> bool {
        matches!(self, Method::BinnedMean | Method::WeightedMean)
    }
}

/// Binning of η^s.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Binning {
    pub bins_per_decade: f64,
    /// Bins with fewer points are dropped.
    pub min_count: usize,
}

impl Default for Binning {
    fn default() -> Self {
        Binning {
            bins_per_decade: 5.0,
            min_count: 10,
        }
    }
}

/// Quantile nodes of η^s kept per bin for the binned-mean model (see `BinPoint`).
pub const NODES: usize = 8;

/// A reduced point of the curve: the bin's median η^s, its D²min/R² statistic, and
/// how many points it holds. The model of a bin *mean* is the mean of Eq. 19 over the
/// bin's η^s values, not Eq. 19 at the centre (Eq. 19 is curved: within a 0.2-decade
/// bin the difference is 3.5 % in the ballistic regime), so binned-mean bins also keep
/// `NODES` quantiles of their η^s to average the model over. For the median, Eq. 19 at
/// the median η^s is exact for a monotone law and multiplicative scatter.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct BinPoint {
    pub eta_s: f64,
    pub d2min_over_r2: f64,
    pub n: usize,
    /// Standard error of the bin's mean (means only; the weighted-mean fit's 1/√weight).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub se: Option<f64>,
    #[serde(skip)]
    pub nodes: Option<[f64; NODES]>,
}

impl BinPoint {
    /// The model's prediction for this point's statistic.
    fn predict(&self, theta: f64, eta_c: f64) -> f64 {
        match &self.nodes {
            Some(nodes) => {
                nodes
                    .iter()
                    .map(|&e| d2min_over_r2(e, theta, eta_c))
                    .sum::<f64>()
                    / NODES as f64
            }
            None => d2min_over_r2(self.eta_s, theta, eta_c),
        }
    }
}

/// Reduce (η, y) pairs (both > 0) to binned points for `method`; `Points` keeps all.
pub fn reduce(eta: &[f64], y: &[f64], method: Method, b: &Binning) -> Vec<BinPoint> {
    if method == Method::Points {
        return eta
            .iter()
            .zip(y)
            .map(|(&e, &v)| BinPoint {
                eta_s: e,
                d2min_over_r2: v,
                n: 1,
                se: None,
                nodes: None,
            })
            .collect();
    }
    let [median, mean] = reduce_binned(eta, y, b);
    if method.is_mean() { mean } else { median }
}

/// The binned curves of (η, y) pairs (both > 0) from one sort: [binned-median's,
/// binned-mean's] (weighted-mean's is binned-mean's). Each is `reduce`'s, bit for bit:
/// at 4 M samples a sort costs half a second, and the fit needs every curve.
pub fn reduce_binned(eta: &[f64], y: &[f64], b: &Binning) -> [Vec<BinPoint>; 2] {
    let mut keyed: Vec<(i64, f64, f64)> = eta
        .iter()
        .zip(y)
        .map(|(&e, &v)| ((e.log10() * b.bins_per_decade).floor() as i64, e, v))
        .collect();
    keyed.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let (mut medians, mut means) = (Vec::new(), Vec::new());
    let (mut etas, mut ys) = (Vec::new(), Vec::new());
    let mut s = 0;
    while s < keyed.len() {
        let mut e = s;
        while e < keyed.len() && keyed[e].0 == keyed[s].0 {
            e += 1;
        }
        if e - s >= b.min_count {
            // keyed is sorted by η within the bin
            etas.clear();
            etas.extend(keyed[s..e].iter().map(|k| k.1));
            ys.clear();
            ys.extend(keyed[s..e].iter().map(|k| k.2));
            ys.sort_by(f64::total_cmp);
            let eta_s = median_sorted(&etas);
            medians.push(BinPoint {
                eta_s,
                d2min_over_r2: median_sorted(&ys),
                n: e - s,
                se: None,
                nodes: None,
            });
            let m = mean(&ys);
            means.push(BinPoint {
                eta_s,
                d2min_over_r2: m,
                n: e - s,
                se: Some(standard_error(&ys, m)),
                nodes: Some(std::array::from_fn(|k| {
                    quantile_sorted(&etas, (k as f64 + 0.5) / NODES as f64)
                })),
            });
        }
        s = e;
    }
    [medians, means]
}

/// Sample standard deviation over √n, floored at 1e-9 of the mean so that a bin of
/// identical values gets a large but finite weight.
fn standard_error(ys: &[f64], mean: f64) -> f64 {
    let n = ys.len() as f64;
    let var = ys.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (var / n).sqrt().max(1e-9 * mean.abs())
}

/// What is minimised: mean squared log residual, or (weighted means) mean squared
/// residual in units of each bin's standard error.
pub(super) const LN_4: f64 = std::f64::consts::LN_2 * 2.0;

struct LogCost<'a> {
    /// The reduced points (empty for [`LogCost::points`], which needs only their logs).
    pts: &'a [BinPoint],
    /// Points fitted.
    n: usize,
    /// ln of each point's statistic, computed once.
    ln_y: Vec<f64>,
    /// 1/se² per point for the linear weighted fit; empty for the log fit.
    weights: Vec<f64>,
    /// ln η^s per point where the model is Eq. 19 at the point (no bin-mean nodes): the
    /// log model is then ln 4 + ln η_c + ln shape(η/η_c), tabulated in ln(η/η_c).
    ln_eta: Option<Vec<f64>>,
}

impl<'a> LogCost<'a> {
    fn new(pts: &'a [BinPoint], weighted: bool) -> Self {
        let plain = !weighted && pts.iter().all(|p| p.nodes.is_none());
        LogCost {
            pts,
            n: pts.len(),
            ln_y: pts.iter().map(|p| p.d2min_over_r2.ln()).collect(),
            weights: if weighted {
                pts.iter()
                    .map(|p| p.se.map_or(0.0, |se| 1.0 / (se * se)))
                    .collect()
            } else {
                Vec::new()
            },
            ln_eta: plain.then(|| pts.iter().map(|p| p.eta_s.ln()).collect()),
        }
    }
    /// The `points` estimator's cost straight from the samples: the same numbers as
    /// [`LogCost::new`] on `reduce(eta, y, Points, _)`, without its points (a hundred
    /// bytes each: 400 MB at 4 M samples).
    fn points(eta: &[f64], y: &[f64]) -> LogCost<'static> {
        LogCost {
            pts: &[],
            n: eta.len(),
            ln_y: y.iter().map(|v| v.ln()).collect(),
            weights: Vec::new(),
            ln_eta: Some(eta.iter().map(|e| e.ln()).collect()),
        }
    }
    /// ln of the model at Θ = 1 for point `i`.
    #[inline]
    fn ln_model(&self, i: usize, ln_eta_c: f64, eta_c: f64) -> f64 {
        match &self.ln_eta {
            Some(le) => self.ln_plain(le[i], ln_eta_c),
            None => self.pts[i].predict(1.0, eta_c).ln(),
        }
    }
    /// ln of Eq. 19 at Θ = 1 at ln η^s = `le`.
    #[inline(always)]
    fn ln_plain(&self, le: f64, ln_eta_c: f64) -> f64 {
        LN_4 + ln_eta_c + super::model::ln_shape_of_ln(le - ln_eta_c)
    }
    /// ln(4Θ η_c g) = ln Θ + ln(4 η_c g): Θ only shifts (scales, in linear space).
    fn eval(&self, ln_theta: f64, ln_eta_c: f64) -> f64 {
        let ec = ln_eta_c.exp();
        let mut s = 0.0;
        if let Some(le) = &self.ln_eta {
            for (ly, &e) in self.ln_y.iter().zip(le) {
                let r = ly - ln_theta - self.ln_plain(e, ln_eta_c);
                s += r * r;
            }
        } else if self.weights.is_empty() {
            for (i, ly) in self.ln_y.iter().enumerate() {
                let r = ly - ln_theta - self.ln_model(i, ln_eta_c, ec);
                s += r * r;
            }
        } else {
            let th = ln_theta.exp();
            for (p, w) in self.pts.iter().zip(&self.weights) {
                let r = p.d2min_over_r2 - th * p.predict(1.0, ec);
                s += w * r * r;
            }
        }
        s / self.n as f64
    }
    /// The cost at ln η_c with Θ at its best, in one pass (f64::MAX where not finite).
    /// Log fit: the variance of the log residuals (shifted by the first, against
    /// cancellation); weighted fit: Σwy² − (Σwym)²/Σwm², over n.
    fn profile(&self, ln_eta_c: f64) -> f64 {
        let ec = ln_eta_c.exp();
        let n = self.n as f64;
        let c = if let Some(le) = self.ln_eta.as_ref().filter(|_| self.weights.is_empty()) {
            let shift = self.ln_y[0] - self.ln_plain(le[0], ln_eta_c);
            let (s1, s2) = residual_sums(&self.ln_y, le, ln_eta_c, |ly, shape| {
                ly - (LN_4 + ln_eta_c + shape) - shift
            });
            (s2 - s1 * s1 / n) / n
        } else if self.weights.is_empty() {
            let shift = self.ln_y[0] - self.ln_model(0, ln_eta_c, ec);
            let (mut s1, mut s2) = (0.0, 0.0);
            for (i, ly) in self.ln_y.iter().enumerate() {
                let r = ly - self.ln_model(i, ln_eta_c, ec) - shift;
                s1 += r;
                s2 += r * r;
            }
            (s2 - s1 * s1 / n) / n
        } else {
            let (mut yy, mut ym, mut mm) = (0.0, 0.0, 0.0);
            for (p, w) in self.pts.iter().zip(&self.weights) {
                let (y, m) = (p.d2min_over_r2, p.predict(1.0, ec));
                yy += w * y * y;
                ym += w * y * m;
                mm += w * m * m;
            }
            (yy - ym * ym / mm) / n
        };
        if c.is_finite() { c.max(0.0) } else { f64::MAX }
    }
    /// For fixed η_c the best ln Θ in closed form: the mean log residual, or for the
    /// weighted fit Θ = Σ w y m / Σ w m² (m: the model at Θ = 1).
    fn best_ln_theta(&self, ln_eta_c: f64) -> f64 {
        let ec = ln_eta_c.exp();
        if self.weights.is_empty() {
            return self
                .ln_y
                .iter()
                .enumerate()
                .map(|(i, ly)| ly - self.ln_model(i, ln_eta_c, ec))
                .sum::<f64>()
                / self.n as f64;
        }
        let (mut num, mut den) = (0.0, 0.0);
        for (p, w) in self.pts.iter().zip(&self.weights) {
            let m = p.predict(1.0, ec);
            num += w * p.d2min_over_r2 * m;
            den += w * m * m;
        }
        (num / den).ln()
    }
}

/// The cost as a function of ln η_c alone, Θ at its best (closed form): the fit is a
/// one-dimensional minimisation.
struct Profile<'a>(&'a LogCost<'a>);

impl CostFunction for Profile<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, ln_eta_c: &f64) -> std::result::Result<f64, argmin::core::Error> {
        Ok(self.0.profile(*ln_eta_c))
    }
}

/// A point estimate: Θ, η_c, the mean squared log residual, and the solver's iterations.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct PointFit {
    pub theta: f64,
    pub eta_c: f64,
    /// Mean squared residual of ln(D²min/R²).
    pub cost: f64,
    pub iterations: u64,
}

/// Fit Eq. 19 to points reduced for `method`: in log space, or for `WeightedMean` in
/// linear space weighted by 1/se². For each η_c the best Θ is closed form, so the cost
/// is minimised over ln η_c alone: the best node of a coarse grid, then Brent's method
/// between its neighbours; the answer does not depend on a user's guess.
pub fn fit_method(pts: &[BinPoint], method: Method) -> Result<PointFit> {
    too_few(pts.len())?;
    let weighted = method == Method::WeightedMean;
    if weighted && pts.iter().any(|p| p.se.is_none()) {
        return Err(Error::Other(
            "weighted-mean needs each bin's standard error".into(),
        ));
    }
    fit_cost(&LogCost::new(pts, weighted))
}

/// The `points` estimator on (η, y) pairs (both > 0): `fit_method(&reduce(eta, y,
/// Points, _), Points)`, the same numbers, without building the points.
pub fn fit_points(eta: &[f64], y: &[f64]) -> Result<PointFit> {
    too_few(eta.len())?;
    fit_cost(&LogCost::points(eta, y))
}

fn too_few(n: usize) -> Result<()> {
    if n < 3 {
        return Err(Error::Other(format!(
            "only {n} points to fit 2 parameters; need at least 3 (more data, or fewer bins per decade / a lower minimum bin count)"
        )));
    }
    Ok(())
}

fn fit_cost(cost: &LogCost) -> Result<PointFit> {
    // Each node's cost is its own pass over the points; the first smallest wins, as
    // in one pass.
    let grid: Vec<f64> = (0..=GRID_STEPS)
        .into_par_iter()
        .map(|k| cost.profile(grid_node(k)))
        .collect();
    let best = grid
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(k, _)| k);
    let (ln_ec, iterations) = refine(Profile(cost), best, |l| cost.profile(l))?;
    let ln_th = cost.best_ln_theta(ln_ec);
    let p = [ln_th, ln_ec];
    Ok(PointFit {
        theta: p[0].exp(),
        eta_c: p[1].exp(),
        cost: cost.eval(p[0], p[1]),
        iterations,
    })
}

/// The η_c grid the profile is scanned on before Brent's method: ln η_c from
/// ln 1e-5 to ln 1e2 in `GRID_STEPS` steps (4 per decade).
pub(super) const GRID_STEPS: usize = 28;

/// ln η_c at grid node `k` (0..=GRID_STEPS).
pub(super) fn grid_node(k: usize) -> f64 {
    let (lo, hi) = ((1e-5f64).ln(), (1e2f64).ln());
    lo + k as f64 * (hi - lo) / GRID_STEPS as f64
}

/// Brent's method on `cost` between the neighbours of the best grid node `best`; the
/// node itself where it is lower (the minimum at the grid's edge). Returns ln η_c and
/// the solver's iterations. `profile` is the same cost as a plain function.
pub(super) fn refine<C>(cost: C, best: usize, profile: impl Fn(f64) -> f64) -> Result<(f64, u64)>
where
    C: CostFunction<Param = f64, Output = f64>,
{
    let (a, b) = (
        grid_node(best.saturating_sub(1)),
        grid_node((best + 1).min(GRID_STEPS)),
    );
    let solver = BrentOpt::new(a, b).set_tolerance(1e-10, 1e-12);
    let res = Executor::new(cost, solver)
        .configure(|s| s.max_iters(200))
        .timer(false)
        .run()
        .map_err(|e| Error::Other(format!("fit: {e}")))?;
    let st = res.state();
    let ln_ec = *st
        .get_best_param()
        .ok_or_else(|| Error::Other("fit: no parameters".into()))?;
    let node = grid_node(best);
    let ln_ec = if profile(node) < profile(ln_ec) {
        node
    } else {
        ln_ec
    };
    Ok((ln_ec, st.get_iter()))
}
