//! Yield of a stress–strain curve (li-granular-pillars Sec. III, Fig. 4: "the measured
//! stress shows yielding behavior when the deformation strain exceeds a very small value
//! ε_y"; the yield stress σ_y). The paper names ε_y and σ_y without a construction, so
//! the rule here is the two-line one that its words describe — an initial linear rise
//! that ends at ε_y, then flow — fitted by least squares (a broken-stick regression):
//!
//! σ(ε) = E min(ε, ε_y) + h max(ε − ε_y, 0) on 0 ≤ ε ≤ ε_max,
//!
//! through the origin (the bars start touching the pillar at ε = 0 with no force), E the
//! initial (elastic) slope, h the slope after yield (≈ 0 on a flow plateau, < 0 past an
//! overshoot), σ_y = E ε_y the stress where the two lines meet. The knee is the ε_y of
//! least squared error (scanned over the frames' strains and refined between them).
//!
//! A curve yields only when the fit says the rise ended: h < E / 2 (the slope after the
//! knee at most half the initial one) and at least `MIN_AFTER` frames and 10 % of the
//! fitted strain range after the knee. Otherwise the answer is [`Yield::NotReached`] with
//! the reason, never a number.
//!
//! The interval is a moving-block bootstrap of the fluctuations: the residuals about the
//! fit, resampled in circular blocks of √n frames (they are correlated over a few frames:
//! avalanches) and added back to the fitted curve, refitted. The interval of ε_y and of
//! σ_y is the wider of the 2.5–97.5 percentiles over the replicates that yield and the
//! estimate ± 1.96 bootstrap standard deviations (the percentiles alone covered the true
//! point of AR(1)-noisy test curves 85 % of the time; this covers it 80–92 %, so the
//! interval is somewhat narrower than its nominal 95 %).

use crate::rng::Rng;

/// Frames the curve must have after the knee for a yield to count.
pub const MIN_AFTER: usize = 3;

/// A yield point with its 95 % bootstrap intervals.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct YieldPoint {
    /// Yield strain ε_y (strain unit) and its interval.
    pub eps_y: f64,
    pub eps_interval: [f64; 2],
    /// Yield stress σ_y = E ε_y (stress unit of the input) and its interval.
    pub sigma_y: f64,
    pub sigma_interval: [f64; 2],
    /// Initial slope E and the slope after yield h (stress unit per strain).
    pub modulus: f64,
    pub hardening: f64,
    /// Bootstrap replicates drawn and how many of them yielded.
    pub replicates: usize,
    pub replicates_yielded: usize,
}

/// What a curve says about yield.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Yield {
    Reached(YieldPoint),
    /// The curve does not yield within its strain range (or cannot be fitted): why.
    NotReached(String),
}

impl Yield {
    pub fn point(&self) -> Option<&YieldPoint> {
        match self {
            Yield::Reached(p) => Some(p),
            Yield::NotReached(_) => None,
        }
    }
}

/// The least-squares broken stick at a given knee: (E, h, squared error).
fn fit_at(eps: &[f64], sig: &[f64], knee: f64) -> (f64, f64, f64) {
    let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&e, &s) in eps.iter().zip(sig) {
        let (x1, x2) = (e.min(knee), (e - knee).max(0.0));
        a11 += x1 * x1;
        a12 += x1 * x2;
        a22 += x2 * x2;
        b1 += x1 * s;
        b2 += x2 * s;
    }
    let det = a11 * a22 - a12 * a12;
    let (m, h) = if det.abs() > 1e-300 * (a11 * a22).max(1e-300) && a22 > 0.0 {
        ((b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det)
    } else if a11 > 0.0 {
        (b1 / a11, 0.0)
    } else {
        (0.0, 0.0)
    };
    let sse = eps
        .iter()
        .zip(sig)
        .map(|(&e, &s)| (s - m * e.min(knee) - h * (e - knee).max(0.0)).powi(2))
        .sum();
    (m, h, sse)
}

/// The best knee (ε_y, E, h) of points sorted by strain, or why there is none.
fn best_knee(eps: &[f64], sig: &[f64]) -> std::result::Result<(f64, f64, f64), String> {
    let n = eps.len();
    // Knees from the second frame on (the origin is not a rise) to the last.
    let mut best = (f64::INFINITY, 0.0);
    for k in 1..n {
        for q in 0..4 {
            let knee = if k + 1 < n {
                eps[k] + 0.25 * q as f64 * (eps[k + 1] - eps[k])
            } else if q == 0 {
                eps[k]
            } else {
                continue;
            };
            let sse = fit_at(eps, sig, knee).2;
            if sse < best.0 {
                best = (sse, knee);
            }
        }
    }
    // Golden-section refinement between the neighbouring candidates.
    let step = (eps[n - 1] - eps[0]) / (4.0 * (n - 1) as f64);
    let (mut lo, mut hi) = ((best.1 - step).max(eps[1]), (best.1 + step).min(eps[n - 1]));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..40 {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if fit_at(eps, sig, a).2 <= fit_at(eps, sig, b).2 {
            hi = b;
        } else {
            lo = a;
        }
    }
    let mid = 0.5 * (lo + hi);
    let knee = if fit_at(eps, sig, mid).2 < best.0 {
        mid
    } else {
        best.1
    };
    let (m, h, _) = fit_at(eps, sig, knee);
    if !(m > 0.0) {
        return Err(format!("no initial rise (slope {m:.3e})"));
    }
    if !(h < 0.5 * m) {
        return Err(format!(
            "still rising at the end: the slope after the best knee (ε = {knee:.4}) is {:.0} % of the initial one",
            100.0 * h / m
        ));
    }
    let after = eps.iter().filter(|&&e| e > knee).count();
    let span = eps[n - 1] - eps[0];
    if after < MIN_AFTER || eps[n - 1] - knee < 0.1 * span {
        return Err(format!(
            "the knee (ε = {knee:.4}) is at the end of the curve ({after} frames after it, ε up to {:.4}): yield not reached",
            eps[n - 1]
        ));
    }
    Ok((knee, m, h))
}

/// ε_y and σ_y of the curve (`eps`, `sigma`) over 0 ≤ ε ≤ `eps_max` (non-finite points
/// left out; strains need not be sorted), with `replicates` bootstrap replicates from
/// `seed` for the intervals.
pub fn yield_point(
    eps: &[f64],
    sigma: &[f64],
    eps_max: f64,
    replicates: usize,
    seed: u64,
) -> Yield {
    let mut pts: Vec<(f64, f64)> = eps
        .iter()
        .zip(sigma)
        .filter(|(e, s)| e.is_finite() && s.is_finite() && **e >= 0.0 && **e <= eps_max)
        .map(|(&e, &s)| (e, s))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if pts.len() < 2 * MIN_AFTER + 2 {
        return Yield::NotReached(format!(
            "{} frames with 0 ≤ ε ≤ {eps_max}: too few for a yield point",
            pts.len()
        ));
    }
    let (e, s): (Vec<f64>, Vec<f64>) = pts.into_iter().unzip();
    let (knee, m, h) = match best_knee(&e, &s) {
        Ok(v) => v,
        Err(why) => return Yield::NotReached(why),
    };
    let fitted: Vec<f64> = e
        .iter()
        .map(|&x| m * x.min(knee) + h * (x - knee).max(0.0))
        .collect();
    let resid: Vec<f64> = s.iter().zip(&fitted).map(|(a, b)| a - b).collect();
    let n = e.len();
    let block = ((n as f64).sqrt().round() as usize).max(3);
    let mut rng = Rng::new(seed);
    let (mut eps_b, mut sig_b) = (Vec::new(), Vec::new());
    let mut boot = vec![0.0; n];
    for _ in 0..replicates {
        let mut k = 0;
        while k < n {
            let start = rng.below(n);
            for j in 0..block.min(n - k) {
                boot[k + j] = fitted[k + j] + resid[(start + j) % n];
            }
            k += block;
        }
        if let Ok((kb, mb, _)) = best_knee(&e, &boot) {
            eps_b.push(kb);
            sig_b.push(mb * kb);
        }
    }
    let interval = |mut v: Vec<f64>, at: f64| {
        if v.is_empty() {
            return [at, at];
        }
        v.sort_by(f64::total_cmp);
        let m = crate::stats::mean(&v);
        let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
        [
            crate::stats::quantile_sorted(&v, 0.025).min(at - 1.96 * sd),
            crate::stats::quantile_sorted(&v, 0.975).max(at + 1.96 * sd),
        ]
    };
    let yielded = eps_b.len();
    Yield::Reached(YieldPoint {
        eps_y: knee,
        eps_interval: {
            // A strain below the origin is no yield strain.
            let [lo, hi] = interval(eps_b, knee);
            [lo.max(0.0), hi]
        },
        sigma_y: m * knee,
        sigma_interval: interval(sig_b, m * knee),
        modulus: m,
        hardening: h,
        replicates,
        replicates_yielded: yielded,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An elastic rise of slope 1000 to ε_y = 0.02 (σ_y = 20), then a plateau, on frames
    /// every 0.001 up to 0.2.
    fn elastic_plateau(slope_after: f64) -> (Vec<f64>, Vec<f64>) {
        let e: Vec<f64> = (0..=200).map(|k| k as f64 * 0.001).collect();
        let s = e
            .iter()
            .map(|&x| 1000.0 * x.min(0.02) + slope_after * (x - 0.02).max(0.0))
            .collect();
        (e, s)
    }

    #[test]
    fn a_piecewise_linear_curve_yields_where_its_lines_meet() {
        for after in [0.0, -20.0, 30.0] {
            let (e, s) = elastic_plateau(after);
            let y = yield_point(&e, &s, 0.2, 50, 1);
            let p = y.point().unwrap_or_else(|| panic!("{y:?}"));
            assert!((p.eps_y - 0.02).abs() < 1e-6, "{p:?}");
            assert!((p.sigma_y - 20.0).abs() < 1e-3, "{p:?}");
            assert!((p.modulus - 1000.0).abs() < 1e-3 && (p.hardening - after).abs() < 1e-3);
            // No noise: the interval is the point.
            assert!(p.eps_interval[1] - p.eps_interval[0] < 1e-6, "{p:?}");
        }
        // The knee between frames is found too (ε_y = 0.0205).
        let e: Vec<f64> = (0..=200).map(|k| k as f64 * 0.001).collect();
        let s: Vec<f64> = e.iter().map(|&x| 1000.0 * x.min(0.0205)).collect();
        let p = yield_point(&e, &s, 0.2, 0, 1).point().unwrap().clone();
        assert!((p.eps_y - 0.0205).abs() < 1e-5, "{p:?}");
        assert!((p.sigma_y - 20.5).abs() < 1e-2, "{p:?}");
    }

    /// Noise of 2–8 % of σ_y, correlated over a few frames as a granular curve's is
    /// (AR(1), coefficient 0.6): the point moves, stays near the true one, lies inside its
    /// interval, and the interval covers the true point in at least 30 of these 40 curves
    /// (95 % nominal; 80 % here, 92 % over 60 other curves: it is somewhat narrow); more
    /// noise, a wider interval.
    #[test]
    fn noise_moves_the_yield_point_within_its_interval() {
        let (e, clean) = elastic_plateau(0.0);
        let fit = |amp: f64, seed: u64| {
            let mut rng = Rng::new(seed);
            let mut ar = 0.0;
            let s: Vec<f64> = clean
                .iter()
                .map(|&v| {
                    ar = 0.6 * ar + amp * rng.normal();
                    v + ar
                })
                .collect();
            let p = yield_point(&e, &s, 0.2, 200, 7).point().unwrap().clone();
            assert!(p.eps_interval[0] <= p.eps_y && p.eps_y <= p.eps_interval[1]);
            assert!(p.sigma_interval[0] <= p.sigma_y && p.sigma_y <= p.sigma_interval[1]);
            assert!(
                (p.eps_y - 0.02).abs() < 0.008 && (p.sigma_y - 20.0).abs() < 3.0,
                "{amp} {seed} {p:?}"
            );
            assert!(p.eps_y != 0.02, "the noise moved it");
            p
        };
        for (small, large) in [(0.4, 1.6)] {
            let (mut cover_e, mut cover_s) = (0, 0);
            for seed in 1..=20 {
                let (a, b) = (fit(small, seed), fit(large, seed));
                for p in [&a, &b] {
                    cover_e += (p.eps_interval[0] <= 0.02 && 0.02 <= p.eps_interval[1]) as usize;
                    cover_s +=
                        (p.sigma_interval[0] <= 20.0 && 20.0 <= p.sigma_interval[1]) as usize;
                }
                let w = |p: &YieldPoint| p.sigma_interval[1] - p.sigma_interval[0];
                assert!(w(&a) > 0.0 && w(&b) > 1.5 * w(&a), "{a:?} {b:?}");
            }
            assert!(cover_e >= 30 && cover_s >= 30, "{cover_e} {cover_s} of 40");
        }
    }

    #[test]
    fn a_curve_still_rising_at_its_end_has_not_yielded() {
        let e: Vec<f64> = (0..=100).map(|k| k as f64 * 0.002).collect();
        // A straight rise, a hardening one, and one that bends only in its last frames.
        let straight: Vec<f64> = e.iter().map(|&x| 500.0 * x).collect();
        let convex: Vec<f64> = e.iter().map(|&x| 500.0 * x + 4000.0 * x * x).collect();
        let late: Vec<f64> = e.iter().map(|&x| 500.0 * x.min(0.198)).collect();
        for s in [straight, convex, late] {
            match yield_point(&e, &s, 0.2, 20, 1) {
                Yield::NotReached(why) => assert!(!why.is_empty()),
                y => panic!("{y:?}"),
            }
        }
        // Too few frames, and a flat (no rise) curve.
        assert!(yield_point(&e[..5], &e[..5], 0.2, 0, 1).point().is_none());
        let flat = vec![0.0; e.len()];
        assert!(yield_point(&e, &flat, 0.2, 0, 1).point().is_none());
    }

    /// Only 0 ≤ ε ≤ ε_max counts: a second rise beyond it is not seen.
    #[test]
    fn the_strain_range_is_respected() {
        let (mut e, mut s) = elastic_plateau(0.0);
        e.extend((1..50).map(|k| 0.2 + k as f64 * 0.001));
        s.extend((1..50).map(|k| 20.0 + 5000.0 * k as f64 * 0.001));
        let p = yield_point(&e, &s, 0.2, 0, 1).point().unwrap().clone();
        assert!((p.eps_y - 0.02).abs() < 1e-6);
        assert!((p.hardening).abs() < 1e-6, "{p:?}");
    }
}
