//! φ_J with an interval from a sweep's elastic pressure as γ̇ → 0 (vagberg-sheared-disks
//! Sec. II uses φ_J ≈ 0.8433 for this mixture, from earlier work).
//!
//! Below jamming the elastic pressure vanishes with the strain rate, P^el ∝ γ̇ (Newtonian)
//! or γ̇² (Bagnoldian); above it P^el tends to the yield pressure, so its slope against
//! γ̇ tends to zero. At each (φ, Q) with two or more rates the slope
//! s = Δ ln P^el/Δ ln γ̇ between the grid's two lowest rates, with its error from the
//! runs' errors of P^el, classifies the point: **flowing** when s − 2e > 1/2, **jammed**
//! when s + 2e < 1/2, else undecided. At each Q, φ_J is bracketed by the largest flowing
//! φ below the smallest jammed φ and that jammed φ; φ_J does not depend on Q, so the
//! brackets of every Q are intersected. The estimate is the middle of the intersection,
//! its interval the intersection itself. Where no Q brackets φ_J (the grid does not reach
//! past jamming, or one rate), or the brackets of different Q do not overlap, the
//! paper's value is kept and the report says why.
//!
//! At finite rates the slope at φ_J itself is the critical exponent (about 0.3), and just
//! below φ_J it is still small, so the bracket leans below the γ̇ → 0 φ_J by an amount
//! that shrinks with the rates: the measure is of the grid, not of the limit.

use super::{Row, key};
use std::collections::BTreeMap;

/// The paper's φ_J for the 50:50 mixture of diameter ratio 1.4.
pub const PHI_J_PAPER: f64 = 0.8433;
/// The slope between "vanishes with γ̇" (≥ 1) and "yield pressure" (0).
pub const SLOPE_SPLIT: f64 = 0.5;
/// Standard errors the slope must clear the split by.
pub const SIGMAS: f64 = 2.0;

/// φ_J as used by the report.
#[derive(Debug, Clone, PartialEq)]
pub struct PhiJ {
    pub value: f64,
    /// The interval: the intersected bracket, or the value itself when held.
    pub lo: f64,
    pub hi: f64,
    /// `None` when measured from the grid; otherwise why the paper's value is held.
    pub held_because: Option<String>,
    /// Each Q's bracket (Q, largest flowing φ, smallest jammed φ).
    pub per_q: Vec<(f64, f64, f64)>,
}

impl PhiJ {
    /// The paper's value, held.
    pub fn paper(why: impl Into<String>) -> Self {
        PhiJ {
            value: PHI_J_PAPER,
            lo: PHI_J_PAPER,
            hi: PHI_J_PAPER,
            held_because: Some(why.into()),
            per_q: Vec::new(),
        }
    }

    /// In words, for captions.
    pub fn describe(&self) -> String {
        match &self.held_because {
            None => format!(
                "φ_J = {:.4} [{:.4}, {:.4}] from P^el → 0 as γ̇ → 0 over the grid",
                self.value, self.lo, self.hi
            ),
            Some(why) => format!("φ_J = {} held at the paper's value ({why})", self.value),
        }
    }
}

/// Flowing (`Some(true)`), jammed (`Some(false)`) or undecided, from the slope of
/// ln P^el between two rates.
fn flowing(rate1: f64, p1: (f64, f64), rate2: f64, p2: (f64, f64)) -> Option<bool> {
    if !(p1.0 > 0.0 && p2.0 > 0.0) {
        return None;
    }
    let d = (rate2 / rate1).ln();
    let s = (p2.0 / p1.0).ln() / d;
    let e = (p1.1 / p1.0).hypot(p2.1 / p2.0) / d.abs();
    if s - SIGMAS * e > SLOPE_SPLIT {
        Some(true)
    } else if s + SIGMAS * e < SLOPE_SPLIT {
        Some(false)
    } else {
        None
    }
}

/// φ_J from the sweep, or the paper's value with the reason.
pub fn estimate(rows: &[Row]) -> PhiJ {
    let mut rates: Vec<f64> = rows.iter().map(|r| r.rate).collect();
    rates.sort_by(f64::total_cmp);
    rates.dedup();
    if rates.len() < 2 {
        return PhiJ::paper("the grid has one rate, so P^el cannot be followed as γ̇ → 0");
    }
    let (r1, r2) = (rates[0], rates[1]);
    // Q → (Q, [(φ, flowing?)]).
    type ByQ = BTreeMap<i64, (f64, Vec<(f64, Option<bool>)>)>;
    let mut by_q: ByQ = BTreeMap::new();
    let at = |rate: f64, phi: f64, q: f64| {
        rows.iter()
            .find(|r| r.rate == rate && key(r.phi) == key(phi) && key(r.q) == key(q))
            .and_then(|r| r.get("p_el"))
    };
    for r in rows.iter().filter(|r| r.rate == r1) {
        if let (Some(a), Some(b)) = (r.get("p_el"), at(r2, r.phi, r.q)) {
            by_q.entry(key(r.q))
                .or_insert_with(|| (r.q, Vec::new()))
                .1
                .push((r.phi, flowing(r1, a, r2, b)));
        }
    }
    let mut per_q = Vec::new();
    for (q, mut pts) in by_q.into_values() {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let Some(jammed) = pts.iter().find(|p| p.1 == Some(false)).map(|p| p.0) else {
            continue;
        };
        if let Some(fl) = pts
            .iter()
            .filter(|p| p.1 == Some(true) && p.0 < jammed)
            .map(|p| p.0)
            .next_back()
        {
            per_q.push((q, fl, jammed));
        }
    }
    if per_q.is_empty() {
        return PhiJ::paper(format!(
            "no Q of the grid has a flowing φ below a jammed one between γ̇ τ_e = {r1:.0e} and {r2:.0e} (slope of ln P^el against ln γ̇ clear of {SLOPE_SPLIT} by {SIGMAS} errors)"
        ));
    }
    let lo = per_q.iter().map(|b| b.1).fold(f64::NEG_INFINITY, f64::max);
    let hi = per_q.iter().map(|b| b.2).fold(f64::INFINITY, f64::min);
    if lo >= hi {
        let mut p = PhiJ::paper(format!(
            "the brackets of different Q do not overlap: {}",
            per_q
                .iter()
                .map(|b| format!("Q = {}: {} – {}", b.0, b.1, b.2))
                .collect::<Vec<_>>()
                .join(", ")
        ));
        p.per_q = per_q;
        return p;
    }
    PhiJ {
        value: 0.5 * (lo + hi),
        lo,
        hi,
        held_because: None,
        per_q,
    }
}

/// The rule and the result, for the report.
pub fn paragraph(j: &PhiJ) -> String {
    let brackets = if j.per_q.is_empty() {
        String::new()
    } else {
        format!(
            " Brackets by Q: {}.",
            j.per_q
                .iter()
                .map(|b| format!("Q = {}: {} – {}", b.0, b.1, b.2))
                .collect::<Vec<_>>()
                .join("; ")
        )
    };
    format!(
        "{}. Rule: at each (φ, Q) the slope s of ln P^el against ln γ̇ between the grid's two lowest rates — P^el vanishing with γ̇ (s ≥ 1) below jamming, tending to a yield pressure (s → 0) above — flowing when s − {SIGMAS}e > {SLOPE_SPLIT}, jammed when s + {SIGMAS}e < {SLOPE_SPLIT}; at each Q φ_J lies between the largest flowing φ below the smallest jammed φ and that φ, and the brackets of all Q are intersected (φ_J does not depend on Q). At finite rates the slope just below φ_J is already small, so the bracket leans low. Used by the Q_c fit below.{brackets}",
        j.describe()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(phi: f64, q: f64, rate: f64, p_el: f64) -> Row {
        Row {
            phi,
            q,
            rate,
            v: [("p_el".to_string(), (p_el, 1e-3 * p_el))].into(),
        }
    }

    /// P^el = 1e3 γ̇ below φ = 0.835 (Newtonian, slope 1), P^el = 1e-2 (φ − 0.835) + γ̇
    /// above it (a yield pressure, slope near 0 at these rates): φ_J lies between 0.83
    /// and 0.84 at both Q, and at Q = 10 the grid is finer (0.836 jammed).
    #[test]
    fn phi_j_is_bracketed_between_the_last_flowing_and_the_first_jammed_phi() {
        let p = |phi: f64, rate: f64| {
            if phi < 0.835 {
                1e3 * rate
            } else {
                1e-2 * (phi - 0.835) + rate
            }
        };
        let mut rows = Vec::new();
        for &rate in &[1e-6, 1e-5, 1e-4] {
            for &phi in &[0.80, 0.82, 0.83, 0.84, 0.85] {
                rows.push(row(phi, 1.0, rate, p(phi, rate)));
            }
            for &phi in &[0.82, 0.83, 0.836, 0.85] {
                rows.push(row(phi, 10.0, rate, p(phi, rate)));
            }
        }
        let j = estimate(&rows);
        assert_eq!(j.held_because, None, "{j:?}");
        assert_eq!(j.per_q, vec![(1.0, 0.83, 0.84), (10.0, 0.83, 0.836)]);
        assert_eq!((j.lo, j.hi), (0.83, 0.836));
        assert!((j.value - 0.833).abs() < 1e-12);
        // Only below jamming: held, with the reason.
        let below: Vec<Row> = rows.iter().filter(|r| r.phi < 0.835).cloned().collect();
        let j = estimate(&below);
        assert_eq!(j.value, PHI_J_PAPER);
        assert!(j.held_because.unwrap().contains("no Q"));
        // One rate: held.
        let one: Vec<Row> = rows.iter().filter(|r| r.rate == 1e-6).cloned().collect();
        assert!(estimate(&one).held_because.unwrap().contains("one rate"));
    }

    #[test]
    fn brackets_that_do_not_overlap_keep_the_paper_value() {
        let mut rows = Vec::new();
        for &rate in &[1e-6, 1e-5] {
            // Q = 1 jams between 0.80 and 0.81, Q = 10 between 0.83 and 0.84.
            for (q, edge) in [(1.0, 0.805), (10.0, 0.835)] {
                for &phi in &[0.80, 0.81, 0.83, 0.84] {
                    let p = if phi < edge { rate } else { 1e-4 };
                    rows.push(row(phi, q, rate, p));
                }
            }
        }
        let j = estimate(&rows);
        assert_eq!(j.value, PHI_J_PAPER);
        assert!(j.held_because.unwrap().contains("do not overlap"));
        assert_eq!(j.per_q.len(), 2);
    }
}
