//! Newtonian or Bagnoldian (vagberg-sheared-disks Sec. III, Figs. 3, 17, 25): how the
//! pressure scales with the strain rate, p ∝ γ̇ (Newtonian, η_p constant) or p ∝ γ̇²
//! (Bagnoldian, B_p constant), from the slope of ln p against ln γ̇ across a grid's
//! rates, with its uncertainty from the runs' errors, and where along φ (or Q) the
//! class changes, bracketed by the grid points on either side.

use serde::Serialize;

/// One run's pressure: (γ̇, p, error of p).
pub type Point = (f64, f64, f64);

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Class {
    Newtonian,
    Bagnoldian,
    Undecided,
}

impl Class {
    pub fn name(self) -> &'static str {
        match self {
            Class::Newtonian => "Newtonian",
            Class::Bagnoldian => "Bagnoldian",
            Class::Undecided => "undecided",
        }
    }
}

/// A slope and its class.
#[derive(Debug, Clone, Serialize)]
pub struct Slope {
    /// d ln p / d ln γ̇.
    pub slope: f64,
    /// Its standard error, from the errors of p.
    pub err: f64,
    /// Rates it spans.
    pub rate_lo: f64,
    pub rate_hi: f64,
    pub class: Class,
    /// Why, in words.
    pub note: String,
}

/// How many standard errors the slope's interval extends each way (≈ 95 %).
pub const SIGMAS: f64 = 2.0;

/// The class of a slope s ± e: Newtonian when s ± 2e lies within [1/2, 3/2] (nearer 1
/// than 2 at 95 %), Bagnoldian within [3/2, 5/2]; otherwise the data cannot tell (the
/// interval straddles 3/2: rates too close or errors too large), or the slope is in
/// neither regime (below 1/2: a yield stress; above 5/2).
pub fn class_of(slope: f64, err: f64) -> (Class, String) {
    let (lo, hi) = (slope - SIGMAS * err, slope + SIGMAS * err);
    if !(slope.is_finite() && err.is_finite()) {
        return (Class::Undecided, "no finite slope".into());
    }
    if lo >= 0.5 && hi <= 1.5 {
        (
            Class::Newtonian,
            format!("{lo:.2}–{hi:.2} within [0.5, 1.5]"),
        )
    } else if lo >= 1.5 && hi <= 2.5 {
        (
            Class::Bagnoldian,
            format!("{lo:.2}–{hi:.2} within [1.5, 2.5]"),
        )
    } else if lo < 1.5 && hi > 1.5 {
        (
            Class::Undecided,
            format!("{lo:.2}–{hi:.2} straddles 1.5: the data cannot tell"),
        )
    } else if hi < 0.5 {
        (
            Class::Undecided,
            format!("{lo:.2}–{hi:.2} below 0.5: neither (yield-stress-like)"),
        )
    } else {
        (
            Class::Undecided,
            format!("{lo:.2}–{hi:.2} outside both regimes"),
        )
    }
}

/// Weighted least-squares slope of ln p against ln γ̇ (weights 1/σ², σ = err/p, the
/// error of ln p), with its standard error. Points with p ≤ 0 are left out; a zero
/// error is taken as 1e-12 relative, so exact synthetic data give a decided class.
pub fn fit_slope(points: &[Point]) -> Option<Slope> {
    let pts: Vec<(f64, f64, f64)> = points
        .iter()
        .filter(|(r, p, e)| *r > 0.0 && *p > 0.0 && r.is_finite() && p.is_finite() && e.is_finite())
        .map(|&(r, p, e)| (r.ln(), p.ln(), (e.abs() / p).max(1e-12)))
        .collect();
    let lo = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let hi = pts.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    // The rates as given (not through exp ∘ ln), so that spans compare exactly.
    let rates = points
        .iter()
        .map(|p| p.0)
        .filter(|r| *r > 0.0 && r.is_finite());
    let (rate_lo, rate_hi) = rates.fold((f64::INFINITY, f64::NEG_INFINITY), |a, r| {
        (a.0.min(r), a.1.max(r))
    });
    if pts.len() < 2 || hi - lo <= 0.0 {
        return None;
    }
    let w: Vec<f64> = pts.iter().map(|p| 1.0 / (p.2 * p.2)).collect();
    let sw: f64 = w.iter().sum();
    let xm = pts.iter().zip(&w).map(|(p, w)| w * p.0).sum::<f64>() / sw;
    let ym = pts.iter().zip(&w).map(|(p, w)| w * p.1).sum::<f64>() / sw;
    let sxx: f64 = pts
        .iter()
        .zip(&w)
        .map(|(p, w)| w * (p.0 - xm).powi(2))
        .sum();
    let sxy: f64 = pts
        .iter()
        .zip(&w)
        .map(|(p, w)| w * (p.0 - xm) * (p.1 - ym))
        .sum();
    let slope = sxy / sxx;
    let err = (1.0 / sxx).sqrt();
    let (class, note) = class_of(slope, err);
    Some(Slope {
        slope,
        err,
        rate_lo,
        rate_hi,
        class,
        note,
    })
}

/// Local slopes between neighbouring rates (sorted), each classified: the (φ, γ̇)
/// phase diagram's points, at the rates' geometric mean.
pub fn local_slopes(points: &[Point]) -> Vec<Slope> {
    let mut v: Vec<Point> = points.to_vec();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v.windows(2).filter_map(fit_slope).collect()
}

/// Where the class changes along an axis (φ at fixed Q, or Q at fixed φ): the last
/// value of one decided class and the first of the other, undecided points between
/// them lying inside the interval.
#[derive(Debug, Clone, Serialize)]
pub struct Transition {
    pub from: Class,
    pub to: Class,
    pub lo: f64,
    pub hi: f64,
}

/// `classes` sorted by the axis value; every change between the decided classes.
pub fn transitions(classes: &[(f64, Class)]) -> Vec<Transition> {
    let mut out = Vec::new();
    let mut last: Option<(f64, Class)> = None;
    for &(x, c) in classes {
        if c == Class::Undecided {
            continue;
        }
        if let Some((lx, lc)) = last
            && lc != c
        {
            out.push(Transition {
                from: lc,
                to: c,
                lo: lx,
                hi: x,
            });
        }
        last = Some((x, c));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(exp: f64, rates: &[f64], rel_err: f64) -> Vec<Point> {
        rates
            .iter()
            .map(|&r| {
                let p = 3.0 * r.powf(exp);
                (r, p, rel_err * p)
            })
            .collect()
    }

    #[test]
    fn p_proportional_to_rate_is_newtonian() {
        let s = fit_slope(&table(1.0, &[1e-5, 1e-4, 1e-3], 0.05)).unwrap();
        assert!((s.slope - 1.0).abs() < 1e-9, "{s:?}");
        assert_eq!(s.class, Class::Newtonian, "{s:?}");
    }

    #[test]
    fn p_proportional_to_rate_squared_is_bagnoldian() {
        let s = fit_slope(&table(2.0, &[1e-5, 1e-4, 1e-3], 0.05)).unwrap();
        assert!((s.slope - 2.0).abs() < 1e-9, "{s:?}");
        assert_eq!(s.class, Class::Bagnoldian, "{s:?}");
        // Exact data (no errors) decide too.
        let s = fit_slope(&table(2.0, &[1e-4, 1e-3], 0.0)).unwrap();
        assert_eq!(s.class, Class::Bagnoldian, "{s:?}");
    }

    #[test]
    fn rates_a_factor_1_1_apart_cannot_tell() {
        // 5 % errors over ln 1.1 = 0.095: the slope's error is ≈ 0.74.
        for exp in [1.0, 2.0] {
            let s = fit_slope(&table(exp, &[1e-4, 1.1e-4], 0.05)).unwrap();
            assert_eq!(s.class, Class::Undecided, "{s:?}");
            assert!(s.err > 0.5, "{s:?}");
        }
        // The same errors over a decade decide.
        let s = fit_slope(&table(2.0, &[1e-4, 1e-3], 0.05)).unwrap();
        assert_eq!(s.class, Class::Bagnoldian, "{s:?}");
    }

    #[test]
    fn one_rate_gives_no_slope_and_a_yield_stress_is_neither() {
        assert!(fit_slope(&table(1.0, &[1e-4], 0.05)).is_none());
        let s = fit_slope(&table(0.1, &[1e-5, 1e-4, 1e-3], 0.01)).unwrap();
        assert_eq!(s.class, Class::Undecided, "{s:?}");
        assert!(s.note.contains("yield"), "{s:?}");
    }

    #[test]
    fn local_slopes_follow_a_crossover() {
        // Bagnoldian at low rates, Newtonian at high: p = γ̇² / (1 + γ̇/γ̇*), γ̇* = 1e-3.
        let pts: Vec<Point> = [1e-6, 1e-5, 1e-1, 1.0]
            .iter()
            .map(|&r| {
                let p = r * r / (1.0 + r / 1e-3);
                (r, p, 0.01 * p)
            })
            .collect();
        let l = local_slopes(&pts);
        assert_eq!(l.len(), 3);
        assert_eq!(l[0].class, Class::Bagnoldian, "{l:?}");
        assert_eq!(l[2].class, Class::Newtonian, "{l:?}");
    }

    #[test]
    fn transition_is_bracketed_by_the_decided_neighbours() {
        let t = transitions(&[
            (0.76, Class::Bagnoldian),
            (0.78, Class::Bagnoldian),
            (0.80, Class::Undecided),
            (0.82, Class::Newtonian),
            (0.84, Class::Newtonian),
        ]);
        assert_eq!(t.len(), 1);
        assert_eq!((t[0].lo, t[0].hi), (0.78, 0.82));
        assert_eq!((t[0].from, t[0].to), (Class::Bagnoldian, Class::Newtonian));
        assert!(transitions(&[(0.8, Class::Newtonian), (0.82, Class::Undecided)]).is_empty());
    }
}
