//! Small order statistics used across stages.

/// Median of an already sorted slice (NaN if empty).
pub fn median_sorted(v: &[f64]) -> f64 {
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Quantile q ∈ [0, 1] of a sorted slice, linear interpolation.
pub fn quantile_sorted(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let h = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    v[lo] + (h - lo as f64) * (v[hi] - v[lo])
}

pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Median of unsorted values in O(n) (reorders `v`); NaN for an empty slice. Agrees
/// with `median_sorted` on the sorted values.
pub fn median_select(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        return hi;
    }
    let lo = v[..n / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_select_matches_sorted_median() {
        for v in [
            vec![3.0, 1.0, 2.0],
            vec![4.0, 1.0, 3.0, 2.0],
            vec![5.0],
            vec![2.0, 2.0, 1.0, 9.0, 9.0, 0.5],
        ] {
            let mut s = v.clone();
            s.sort_by(f64::total_cmp);
            let mut w = v.clone();
            assert_eq!(median_select(&mut w), median_sorted(&s));
        }
    }
}

/// A mean duration from right-censored observations (see [`survival_mean`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurvivalMean {
    pub mean: f64,
    /// Observations that ended, and that were still open (censored).
    pub events: u64,
    pub censored: u64,
    /// Survival left after the last bin: the share of durations longer than anything
    /// observed, whose mean is extrapolated (see [`survival_mean`]).
    pub tail: f64,
}

/// Mean of a duration distribution from binned, right-censored observations: the
/// Kaplan–Meier (product-limit) estimator over the bins in its life-table form (a bin's
/// censored observations count as at risk for half the bin), each bin's probability
/// mass placed at the mean of the durations that ended in it (`ended_sum[k]` /
/// `ended[k]`). Without censoring it is the plain sample mean, exactly. The mass left
/// beyond the last observation (`tail`) is given the mean of an exponential tail whose
/// rate is the hazard measured over the last decade of observed durations (events over
/// time at risk there); with no event there it sits at the end of the observations,
/// and the mean is a lower bound. Bins in increasing order of duration, bin k spanning
/// `edges[k]..edges[k + 1]`.
pub fn survival_mean(
    ended: &[u64],
    ended_sum: &[f64],
    censored: &[u64],
    edges: &[f64],
) -> SurvivalMean {
    let bins = ended.len();
    assert!(ended_sum.len() == bins && censored.len() == bins && edges.len() == bins + 1);
    let events: u64 = ended.iter().sum();
    let cens: u64 = censored.iter().sum();
    if events + cens == 0 {
        return SurvivalMean {
            mean: f64::NAN,
            events,
            censored: cens,
            tail: 0.0,
        };
    }
    let last = (0..bins)
        .rev()
        .find(|&k| ended[k] + censored[k] > 0)
        .unwrap_or(0);
    let t_end = edges[last + 1];
    let mut at_risk = (events + cens) as f64;
    let (mut surv, mut mean) = (1.0, 0.0);
    // Events and time at risk over the last decade of observations (the tail's hazard).
    let (mut tail_events, mut exposure) = (0.0, 0.0);
    for k in 0..=last {
        let (e, c) = (ended[k] as f64, censored[k] as f64);
        let effective = at_risk - 0.5 * c;
        if edges[k] >= 0.1 * t_end {
            tail_events += e;
            exposure += (effective - 0.5 * e).max(0.0) * (edges[k + 1] - edges[k]);
        }
        if e > 0.0 && effective > 0.0 {
            let q = (e / effective).min(1.0);
            mean += surv * q * (ended_sum[k] / e);
            surv *= 1.0 - q;
        }
        at_risk -= e + c;
    }
    if surv > 0.0 {
        let residual = if tail_events > 0.0 && exposure > 0.0 {
            exposure / tail_events
        } else {
            0.0
        };
        mean += surv * (t_end + residual);
    }
    SurvivalMean {
        mean,
        events,
        censored: cens,
        tail: surv,
    }
}

#[cfg(test)]
mod survival_tests {
    use super::*;
    use crate::rng::Rng;

    /// Bins as the sheared-disk cohort uses them: 20 per decade from 1e-3.
    fn bin(d: f64) -> usize {
        ((d.max(1e-3) / 1e-3).log10() * 20.0) as usize
    }
    fn edges(n: usize) -> Vec<f64> {
        (0..=n)
            .map(|k| 1e-3 * 10f64.powf(k as f64 / 20.0))
            .collect()
    }

    /// Contacts begun uniformly over a window and followed to its end: those still open
    /// are censored, and the longer a contact, the likelier. The ended ones alone
    /// underestimate the mean; the survival estimate recovers it, also where a few
    /// per cent outlive every observation (the short window).
    #[test]
    fn censored_durations_recover_the_true_mean() {
        let mut rng = Rng::new(11);
        for (shape, true_mean, window) in [
            ("exponential", 50.0, 1000.0),
            ("two-timescale", 0.5 * 5.0 + 0.5 * 200.0, 1000.0),
            (
                "two-timescale, short window",
                0.5 * 5.0 + 0.5 * 200.0,
                500.0,
            ),
        ] {
            let n = 40_000;
            let mut ended = vec![0u64; 300];
            let mut sum = vec![0.0; 300];
            let mut censored = vec![0u64; 300];
            let (mut naive_sum, mut naive_n) = (0.0, 0.0);
            for _ in 0..n {
                let start = window * rng.uniform();
                let scale = match shape {
                    "exponential" => 50.0,
                    _ => {
                        if rng.uniform() < 0.5 {
                            5.0
                        } else {
                            200.0
                        }
                    }
                };
                let d = -scale * (1.0 - rng.uniform()).ln();
                if start + d <= window {
                    ended[bin(d)] += 1;
                    sum[bin(d)] += d;
                    naive_sum += d;
                    naive_n += 1.0;
                } else {
                    let seen = window - start;
                    censored[bin(seen)] += 1;
                }
            }
            let naive = naive_sum / naive_n;
            let s = survival_mean(&ended, &sum, &censored, &edges(300));
            assert!(s.censored > 0 && s.events + s.censored == n as u64);
            assert!(
                naive < 0.97 * true_mean,
                "{shape}: the ended-only mean {naive} should be biased low"
            );
            assert!(
                (s.mean - true_mean).abs() < 0.03 * true_mean,
                "{shape}: survival mean {} vs true {true_mean} (naive {naive})",
                s.mean
            );
        }
        // Nothing censored: the sample mean, exactly.
        let e = [0.0, 1.0, 2.0, 3.0];
        let s = survival_mean(&[1, 2, 0], &[0.5, 3.0, 0.0], &[0, 0, 0], &e);
        assert!((s.mean - 3.5 / 3.0).abs() < 1e-15 && s.tail == 0.0, "{s:?}");
        assert!(survival_mean(&[0], &[0.0], &[0], &e[..2]).mean.is_nan());
    }
}

/// (max − min) / mean: how far apart values that should agree are, relative to their
/// size (the size scan's and the parameter studies' independence checks).
pub fn relative_spread(v: &[f64]) -> f64 {
    let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &x| {
        (a.0.min(x), a.1.max(x))
    });
    (hi - lo) / (v.iter().sum::<f64>() / v.len() as f64)
}

/// Student's t at 97.5 % for `dof` degrees of freedom (two-sided 95 % intervals), to
/// three decimals from the standard table up to 30 (NaN for none); beyond, the table's
/// 40, 60 and 120 rows, then the normal's 1.960.
pub fn t_95(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match dof {
        0 => f64::NAN,
        1..=30 => T[dof - 1],
        31..=40 => 2.021,
        41..=60 => 2.000,
        61..=120 => 1.980,
        _ => 1.960,
    }
}

/// The exponent b of y = a x^b by least squares on ln y against ln x, with its 95 %
/// interval (NaN with two points: a line through two points has no scatter to judge).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PowerLaw {
    pub exponent: f64,
    pub interval: [f64; 2],
}

/// [`PowerLaw`] of the points with x, y > 0 and finite; None with fewer than two such
/// points or one x.
pub fn power_law(x: &[f64], y: &[f64]) -> Option<PowerLaw> {
    let p: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(a, b)| **a > 0.0 && **b > 0.0 && a.is_finite() && b.is_finite())
        .map(|(a, b)| (a.ln(), b.ln()))
        .collect();
    let r = Regression::of(&p)?;
    let half = r.t_half(r.s2 / r.sxx);
    Some(PowerLaw {
        exponent: r.b,
        interval: [r.b - half, r.b + half],
    })
}

/// y = a + b x by least squares, with the 95 % interval of the intercept a (Student's t
/// on n − 2 degrees of freedom; NaN with two points).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LineFit {
    pub intercept: f64,
    pub slope: f64,
    pub intercept_interval: [f64; 2],
    pub n: usize,
}

/// [`LineFit`] of the finite points; None with fewer than two or one x.
pub fn line_fit(x: &[f64], y: &[f64]) -> Option<LineFit> {
    let p: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    let r = Regression::of(&p)?;
    let half = r.t_half(r.s2 * (1.0 / r.n as f64 + r.xm * r.xm / r.sxx));
    Some(LineFit {
        intercept: r.a,
        slope: r.b,
        intercept_interval: [r.a - half, r.a + half],
        n: r.n,
    })
}

/// Ordinary least squares y = a + b x of finite points: what the two fits above share.
struct Regression {
    a: f64,
    b: f64,
    n: usize,
    xm: f64,
    sxx: f64,
    /// The residual variance; NaN with two points (no scatter to judge).
    s2: f64,
}

impl Regression {
    fn of(p: &[(f64, f64)]) -> Option<Regression> {
        let n = p.len();
        if n < 2 {
            return None;
        }
        let xm = p.iter().map(|q| q.0).sum::<f64>() / n as f64;
        let ym = p.iter().map(|q| q.1).sum::<f64>() / n as f64;
        let sxx: f64 = p.iter().map(|q| (q.0 - xm).powi(2)).sum();
        if !(sxx > 0.0) {
            return None;
        }
        let b = p.iter().map(|q| (q.0 - xm) * (q.1 - ym)).sum::<f64>() / sxx;
        let a = ym - b * xm;
        let s2 = if n > 2 {
            p.iter().map(|q| (q.1 - a - b * q.0).powi(2)).sum::<f64>() / (n - 2) as f64
        } else {
            f64::NAN
        };
        Some(Regression {
            a,
            b,
            n,
            xm,
            sxx,
            s2,
        })
    }

    /// Half the 95 % Student interval of an estimate whose variance is `var`.
    fn t_half(&self, var: f64) -> f64 {
        t_95(self.n.saturating_sub(2)) * var.sqrt()
    }
}

#[cfg(test)]
mod power_law_tests {
    use super::*;

    #[test]
    fn exact_power_laws_give_their_exponent_and_no_width() {
        let x = [1.0, 2.0, 4.0, 8.0];
        let y: Vec<f64> = x.iter().map(|v: &f64| 3.0 * v.powi(2)).collect();
        let p = power_law(&x, &y).unwrap();
        assert!((p.exponent - 2.0).abs() < 1e-12);
        assert!((p.interval[1] - p.interval[0]).abs() < 1e-9);
        // Two points: the exponent, no interval.
        let two = power_law(&x[..2], &y[..2]).unwrap();
        assert!((two.exponent - 2.0).abs() < 1e-12 && two.interval[0].is_nan());
        assert!(power_law(&[1.0, 1.0], &[2.0, 3.0]).is_none());
        assert!(power_law(&[1.0, -2.0], &[2.0, 3.0]).is_none());
    }

    /// Scatter about y = x: the interval covers 1 and has the width of the t-interval
    /// worked out by hand: ln y = ln x ± 0.1 alternately at x = 1, e, e², e³.
    #[test]
    fn the_interval_is_students() {
        let x: Vec<f64> = (0..4).map(|k| (k as f64).exp()).collect();
        let y: Vec<f64> = (0..4)
            .map(|k| (k as f64 + if k % 2 == 0 { 0.1 } else { -0.1 }).exp())
            .collect();
        let p = power_law(&x, &y).unwrap();
        // x̄ = 1.5, Sxx = 5; Sxy = Σ (k − 1.5)(k + e_k − ȳ) = 5 + Σ (k − 1.5) e_k = 5 − 0.2.
        let b = 4.8 / 5.0;
        assert!((p.exponent - b).abs() < 1e-12);
        let resid: f64 = (0..4)
            .map(|k| {
                let e = if k % 2 == 0 { 0.1 } else { -0.1 };
                (k as f64 + e - 1.5 - b * (k as f64 - 1.5)).powi(2)
            })
            .sum();
        let half = 4.303 * (resid / 2.0 / 5.0).sqrt();
        assert!((p.interval[1] - b - half).abs() < 1e-12, "{p:?}");
    }
}

#[cfg(test)]
mod line_fit_tests {
    use super::*;

    /// By hand: (0, 1), (1, 2), (2, 2), (3, 4): x̄ = 1.5, ȳ = 2.25, Sxx = 5, Sxy = 4.5,
    /// b = 0.9, a = 0.9; residuals 0.1, 0.2, −0.7, 0.4, s² = 0.7/2 = 0.35; the
    /// intercept's standard error √(0.35 (1/4 + 2.25/5)) = √0.245, times t(2) = 4.303.
    #[test]
    fn a_line_and_its_intercept_interval_by_hand() {
        let f = line_fit(&[0.0, 1.0, 2.0, 3.0], &[1.0, 2.0, 2.0, 4.0]).unwrap();
        assert!(
            (f.slope - 0.9).abs() < 1e-12 && (f.intercept - 0.9).abs() < 1e-12,
            "{f:?}"
        );
        let half = 4.303 * 0.245f64.sqrt();
        assert!(
            (f.intercept_interval[1] - 0.9 - half).abs() < 1e-12,
            "{f:?}"
        );
        assert!((f.intercept_interval[0] - 0.9 + half).abs() < 1e-12);
        assert_eq!(f.n, 4);
        assert!(line_fit(&[1.0, 1.0], &[0.0, 1.0]).is_none());
        assert!(line_fit(&[1.0], &[0.0]).is_none());
        assert!(
            line_fit(&[0.0, 1.0], &[1.0, 3.0])
                .unwrap()
                .intercept_interval[0]
                .is_nan()
        );
    }
}
