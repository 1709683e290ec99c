//! The coexistence region crossed at constant pressure (vagberg-sheared-disks Sec. IV,
//! Appendix B; Figs. 25, 34, 35), from a sweep's grid at one Q.
//!
//! - **The contour P = P_0 (Fig. 25).** At each φ, the strain rate where the run
//!   pressure P = p τ_e²/m (Eq. 18) crosses P_0 between two neighbouring rates of the
//!   grid, interpolated linearly in ln P against ln γ̇ (exact for a power law between
//!   them); μ = Σ/P and R_v are interpolated linearly in ln γ̇ at the same place. P_0 is
//!   the run pressure at this Q crossed at the most φ (ties: the one nearest the paper's
//!   2 × 10⁻⁵ in ln P).
//! - **μ along it (Fig. 34) and the Maxwell-like construction (Appendix B).** Contour
//!   points with R_v > [`R_V_BANDED`] are banded. φ_B is the highest φ of the homogeneous
//!   points below the banded stretch, φ_N the lowest above it (the paper's definitions);
//!   μ* is the mean μ over the banded points; φ*_B (φ*_N) is where μ on the homogeneous
//!   Bagnoldian (Newtonian) side, walking away from the banded stretch, first reaches
//!   μ*, interpolated linearly in φ between contour points (γ̇* in ln γ̇ alike).
//! - **The φ* curves (Fig. 35).** The construction repeated on the contours through
//!   every run pressure at this Q: each gives (φ*_B, γ̇*_B) and (φ*_N, γ̇*_N). The paper
//!   measures the band values in the bands' profiles; this reads them off μ along the
//!   contours, as its Fig. 34 also allows. Beside them φ_B(γ̇) and φ_N(γ̇) from R_v.

use super::coexistence::{R_V_BANDED, boundaries, mid};
use super::{Figures, Row, key};
use crate::error::Result;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::html::Block;
use std::collections::BTreeMap;

/// The paper's contour pressure (Figs. 25, 34).
pub const P_PAPER: f64 = 2e-5;

/// One point of a constant-P contour.
#[derive(Debug, Clone, PartialEq)]
pub struct ContourPoint {
    pub phi: f64,
    /// γ̇ τ_e where P = P_0.
    pub rate: f64,
    pub mu: f64,
    pub r_v: Option<f64>,
}

/// One run on a φ's curve: (γ̇ τ_e, P, μ, R_v).
type Run = (f64, f64, f64, Option<f64>);

/// Each φ's runs at `q`, sorted by rate.
fn by_phi(rows: &[Row], q: f64) -> Vec<(f64, Vec<Run>)> {
    let mut by: BTreeMap<i64, (f64, Vec<Run>)> = BTreeMap::new();
    for r in rows.iter().filter(|r| key(r.q) == key(q)) {
        if let (Some(p), Some(mu)) = (r.get("p"), r.get("mu"))
            && p.0 > 0.0
        {
            by.entry(key(r.phi))
                .or_insert_with(|| (r.phi, Vec::new()))
                .1
                .push((r.rate, p.0, mu.0, r.get("r_v").map(|x| x.0)));
        }
    }
    by.into_values()
        .map(|(phi, mut v)| {
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            (phi, v)
        })
        .collect()
}

/// The contour P = `p0` at `q`, ordered by φ.
pub fn contour(rows: &[Row], q: f64, p0: f64) -> Vec<ContourPoint> {
    let target = p0.ln();
    by_phi(rows, q)
        .into_iter()
        .filter_map(|(phi, runs)| {
            runs.windows(2).find_map(|w| {
                let (a, b) = (&w[0], &w[1]);
                let (la, lb) = (a.1.ln(), b.1.ln());
                if (la - target) * (lb - target) > 0.0 || la == lb {
                    return None;
                }
                let t = (target - la) / (lb - la);
                let lr = a.0.ln() + t * (b.0.ln() - a.0.ln());
                Some(ContourPoint {
                    phi,
                    rate: lr.exp(),
                    mu: a.2 + t * (b.2 - a.2),
                    r_v: a.3.zip(b.3).map(|(x, y)| x + t * (y - x)),
                })
            })
        })
        .collect()
}

/// The contour pressure at `q`: the run pressure crossed at the most φ, ties broken by
/// nearness to [`P_PAPER`] in ln P; `None` when no pressure is crossed at three φ.
pub fn choose_p(rows: &[Row], q: f64) -> Option<f64> {
    let mut ps: Vec<f64> = rows
        .iter()
        .filter(|r| key(r.q) == key(q))
        .filter_map(|r| r.get("p").map(|p| p.0))
        .filter(|p| *p > 0.0)
        .collect();
    ps.sort_by(f64::total_cmp);
    ps.dedup();
    ps.into_iter()
        .map(|p| (contour(rows, q, p).len(), p))
        .filter(|(n, _)| *n >= 3)
        .max_by(|a, b| {
            a.0.cmp(&b.0).then_with(|| {
                let d = |p: f64| (p / P_PAPER).ln().abs();
                d(b.1).total_cmp(&d(a.1))
            })
        })
        .map(|(_, p)| p)
}

/// The construction of Appendix B along one contour.
#[derive(Debug, Clone, PartialEq)]
pub struct Maxwell {
    pub mu_star: f64,
    /// The last homogeneous φ below the banded stretch and the first above (`None`
    /// where the contour ends inside it).
    pub phi_b: Option<f64>,
    pub phi_n: Option<f64>,
    /// (φ*, γ̇* τ_e) on each side, where μ first reaches μ*.
    pub star_b: Option<(f64, f64)>,
    pub star_n: Option<(f64, f64)>,
}

/// Where μ along `pts` (walked in the given order) first reaches `mu`: (φ, γ̇).
fn reaches(pts: &[&ContourPoint], mu: f64) -> Option<(f64, f64)> {
    pts.windows(2).find_map(|w| {
        let (a, b) = (w[0], w[1]);
        let (da, db) = (a.mu - mu, b.mu - mu);
        if da == 0.0 {
            return Some((a.phi, a.rate));
        }
        if da * db > 0.0 {
            return None;
        }
        let t = da / (da - db);
        Some((
            a.phi + t * (b.phi - a.phi),
            (a.rate.ln() + t * (b.rate.ln() - a.rate.ln())).exp(),
        ))
    })
}

/// The construction on a contour with a banded stretch; `None` without one.
pub fn maxwell(pts: &[ContourPoint]) -> Option<Maxwell> {
    let banded = |p: &ContourPoint| p.r_v.is_some_and(|r| r > R_V_BANDED);
    let a = pts.iter().position(banded)?;
    let b = pts.iter().rposition(banded)?;
    let inside: Vec<f64> = pts[a..=b]
        .iter()
        .filter(|p| banded(p))
        .map(|p| p.mu)
        .collect();
    let mu_star = inside.iter().sum::<f64>() / inside.len() as f64;
    let below: Vec<&ContourPoint> = pts[..a].iter().rev().collect();
    let above: Vec<&ContourPoint> = pts[b + 1..].iter().collect();
    Some(Maxwell {
        mu_star,
        phi_b: below.first().map(|p| p.phi),
        phi_n: above.first().map(|p| p.phi),
        star_b: reaches(&below, mu_star),
        star_n: reaches(&above, mu_star),
    })
}

/// The Q the figures are drawn at: the one nearest the paper's Q = 1 (in ln Q) whose
/// runs span at least two rates.
pub(super) fn pick_q(rows: &[Row]) -> Option<f64> {
    let mut rates: BTreeMap<i64, (f64, Vec<i64>)> = BTreeMap::new();
    for r in rows {
        let e = rates.entry(key(r.q)).or_insert_with(|| (r.q, Vec::new()));
        if !e.1.contains(&key(r.rate)) {
            e.1.push(key(r.rate));
        }
    }
    rates
        .into_values()
        .filter(|(q, v)| v.len() >= 2 && *q > 0.0)
        .map(|(q, _)| q)
        .min_by(|a, b| a.ln().abs().total_cmp(&b.ln().abs()))
}

fn opt(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| format!("{v:.4}"))
}

/// Figs. 34 and 35 at the Q nearest 1, with the rules (Fig. 25 with the contour is
/// `phase_boundaries`').
pub(super) fn add_figures(f: &mut Figures, rows: &[Row]) -> Result<()> {
    let Some(q) = pick_q(rows) else {
        return Ok(());
    };
    let Some(p0) = choose_p(rows, q) else {
        f.blocks.push(Block::Paragraph(format!(
            "Constant-P contour (Figs. 25, 34): none at Q = {q} — no run pressure is crossed between neighbouring rates at three or more φ."
        )));
        return Ok(());
    };
    let c = contour(rows, q, p0);
    let mx = maxwell(&c);
    // Fig. 34: μ along the contour.
    let banded = |p: &ContourPoint| p.r_v.is_some_and(|r| r > R_V_BANDED);
    for (against, x_of, x_log, file, panel) in [
        (
            "φ",
            (|p: &ContourPoint| p.phi) as fn(&ContourPoint) -> f64,
            false,
            "mu_contour_phi",
            "a",
        ),
        (
            "dγ/dt τ_e",
            |p: &ContourPoint| p.rate,
            true,
            "mu_contour_rate",
            "b",
        ),
    ] {
        let mut series = vec![
            XySeries {
                label: "homogeneous (R_v ≤ 3)".into(),
                points: c
                    .iter()
                    .filter(|p| !banded(p))
                    .map(|p| (x_of(p), p.mu, 0.0))
                    .collect(),
                markers_only: true,
                colour: 0,
            },
            XySeries {
                label: "banded (R_v > 3)".into(),
                points: c
                    .iter()
                    .filter(|p| banded(p))
                    .map(|p| (x_of(p), p.mu, 0.0))
                    .collect(),
                markers_only: true,
                colour: 1,
            },
        ];
        if let Some(m) = &mx {
            let xs: Vec<f64> = c.iter().map(x_of).collect();
            let (lo, hi) = xs
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                });
            series.push(XySeries {
                label: format!("μ* = {:.4}", m.mu_star),
                points: vec![(lo, m.mu_star, 0.0), (hi, m.mu_star, 0.0)],
                markers_only: false,
                colour: 2,
            });
            let stars: Vec<(f64, f64, f64)> = [m.star_b, m.star_n]
                .into_iter()
                .flatten()
                .map(|(phi, rate)| (if panel == "a" { phi } else { rate }, m.mu_star, 0.0))
                .collect();
            if !stars.is_empty() {
                series.push(XySeries {
                    label: "φ*_B, φ*_N".into(),
                    points: stars,
                    markers_only: true,
                    colour: 3,
                });
            }
        }
        series.retain(|s| !s.points.is_empty());
        f.add(
            &XyFigure {
                title: format!("μ along the contour P = {p0:.2e} against {against}, Q = {q} (Fig. 34{panel})"),
                x_desc: against.into(),
                y_desc: "μ = Σ / P".into(),
                x_log,
                y_log: false,
                series,
            },
            file,
            format!("μ = σ/p along the contour of constant P = {p0:.3e} (Fig. 25's line), against the global {against}, μ and R_v interpolated in ln γ̇ like the contour (vagberg-sheared-disks Fig. 34{panel}). Banded points (R_v > {R_V_BANDED}) should share one μ* (the bands are in mechanical equilibrium); φ*_B and φ*_N are where the homogeneous branches reach it (Appendix B)."),
        )?;
    }
    f.blocks.push(Block::Paragraph(match &mx {
        Some(m) => format!(
            "Along P = {p0:.3e} at Q = {q} (Appendix B): μ* = {:.4} over the banded points; φ_B = {} and φ_N = {} (the last homogeneous φ either side of the banded stretch); φ*_B = {}, γ̇*_B τ_e = {}; φ*_N = {}, γ̇*_N τ_e = {} (where μ on each homogeneous side first reaches μ*; – where it does not on this contour). The paper finds φ*_B < φ_B and φ*_N > φ_N, a finite-size effect.",
            m.mu_star,
            opt(m.phi_b),
            opt(m.phi_n),
            opt(m.star_b.map(|s| s.0)),
            m.star_b.map_or("–".into(), |s| format!("{:.2e}", s.1)),
            opt(m.star_n.map(|s| s.0)),
            m.star_n.map_or("–".into(), |s| format!("{:.2e}", s.1)),
        ),
        None => format!(
            "Along P = {p0:.3e} at Q = {q}: no contour point has R_v > {R_V_BANDED}, so there is no banded stretch and no μ*, φ*_B or φ*_N (Appendix B's construction needs one)."
        ),
    }));
    // Fig. 35: φ* from the contours through every run pressure, φ_B, φ_N from R_v.
    let mut ps: Vec<f64> = rows
        .iter()
        .filter(|r| key(r.q) == key(q))
        .filter_map(|r| r.get("p").map(|p| p.0))
        .filter(|p| *p > 0.0)
        .collect();
    ps.sort_by(f64::total_cmp);
    ps.dedup();
    let stars: Vec<Maxwell> = ps
        .iter()
        .filter_map(|&p| maxwell(&contour(rows, q, p)))
        .collect();
    let rv: Vec<_> = boundaries(rows)
        .into_iter()
        .filter(|b| key(b.q) == key(q))
        .collect();
    let mut series = Vec::new();
    for (label, pts, colour) in [
        (
            "φ_B, R_v",
            rv.iter()
                .filter_map(|b| mid(b.phi_b).map(|x| (x, b.rate, 0.0)))
                .collect::<Vec<_>>(),
            0,
        ),
        (
            "φ_N, R_v",
            rv.iter()
                .filter_map(|b| mid(b.phi_n).map(|x| (x, b.rate, 0.0)))
                .collect(),
            1,
        ),
        (
            "φ*_B, μ = μ* on contours",
            stars
                .iter()
                .filter_map(|m| m.star_b.map(|(x, y)| (x, y, 0.0)))
                .collect(),
            2,
        ),
        (
            "φ*_N, μ = μ* on contours",
            stars
                .iter()
                .filter_map(|m| m.star_n.map(|(x, y)| (x, y, 0.0)))
                .collect(),
            3,
        ),
    ] {
        if !pts.is_empty() {
            series.push(XySeries {
                label: label.into(),
                points: pts,
                markers_only: true,
                colour,
            });
        }
    }
    if series.is_empty() {
        f.blocks.push(Block::Paragraph(format!(
            "φ*_B, φ*_N curves (Fig. 35): none at Q = {q} — no run is banded (R_v > {R_V_BANDED}), so neither the boundaries nor the band values exist on this grid."
        )));
    } else {
        f.add(
            &XyFigure {
                title: format!("φ_B, φ_N and φ*_B, φ*_N in the (φ, dγ/dt) plane, Q = {q} (Fig. 35)"),
                x_desc: "φ".into(),
                y_desc: "dγ/dt τ_e".into(),
                x_log: false,
                y_log: true,
                series,
            },
            "phi_star",
            format!("φ_B(γ̇), φ_N(γ̇) from R_v (the middle of each bracket) and φ*_B(γ̇), φ*_N(γ̇), the band values, from Appendix B's construction on the contours through each of the {} run pressures at Q = {q} that cross a banded stretch (vagberg-sheared-disks Fig. 35; the paper reads the band values from the bands' profiles, which its Fig. 34 shows agree).", stars.len()),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(phi: f64, rate: f64, p: f64, mu: f64, r_v: f64) -> Row {
        Row::with(phi, 1.0, rate, &[("p", p), ("mu", mu), ("r_v", r_v)])
    }

    /// P = γ̇² e^{100 φ} at every φ: the contour P_0 is γ̇ = √(P_0 e^{−100 φ}), exact
    /// under ln–ln interpolation; μ = 1 + ln γ̇ / 100 interpolated linearly in ln γ̇ is
    /// exact too.
    #[test]
    fn the_contour_is_exact_for_a_power_law() {
        let mut rows = Vec::new();
        for &phi in &[0.78f64, 0.79, 0.80] {
            for &rate in &[1e-5f64, 1e-4, 1e-3] {
                let p = rate * rate * (100.0 * phi).exp();
                rows.push(row(phi, rate, p, 1.0 + rate.ln() / 100.0, 1.0));
            }
        }
        let p0 = 1e-8 * (79.0f64).exp();
        let c = contour(&rows, 1.0, p0);
        assert_eq!(c.len(), 3);
        for pt in &c {
            let want = (p0 * (-100.0 * pt.phi).exp()).sqrt();
            assert!((pt.rate / want - 1.0).abs() < 1e-9, "{pt:?}");
            assert!((pt.mu - (1.0 + want.ln() / 100.0)).abs() < 1e-9, "{pt:?}");
        }
        // At φ = 0.79 the contour falls on the grid's 1e-4.
        assert!((c[1].rate / 1e-4 - 1.0).abs() < 1e-9);
        // A pressure crossed at all three φ is chosen, and 2e-5 is not in range here.
        let p = choose_p(&rows, 1.0).unwrap();
        assert_eq!(contour(&rows, 1.0, p).len(), 3);
    }

    /// Planted along a contour: μ falls along each homogeneous branch, the banded
    /// points sit at μ* = 0.35; by hand φ*_B = 0.775 (μ from 0.36 at 0.77 to 0.34 at
    /// 0.78 crosses 0.35 half way) and φ*_N = 0.815.
    #[test]
    fn the_maxwell_construction_reads_phi_star_off_mu() {
        let pt = |phi: f64, rate: f64, mu: f64, r_v: f64| ContourPoint {
            phi,
            rate,
            mu,
            r_v: Some(r_v),
        };
        let c = vec![
            pt(0.76, 1e-4, 0.38, 1.0),
            pt(0.77, 8e-5, 0.36, 1.0),
            pt(0.78, 6e-5, 0.34, 1.0),
            pt(0.79, 4e-5, 0.33, 1.1),
            pt(0.80, 2e-5, 0.35, 9.0),
            pt(0.805, 1e-5, 0.35, 12.0),
            pt(0.81, 8e-6, 0.37, 1.2),
            pt(0.82, 6e-6, 0.33, 1.0),
        ];
        let m = maxwell(&c).unwrap();
        assert!((m.mu_star - 0.35).abs() < 1e-12);
        assert_eq!((m.phi_b, m.phi_n), (Some(0.79), Some(0.81)));
        let (pb, rb) = m.star_b.unwrap();
        assert!((pb - 0.775).abs() < 1e-9, "{m:?}");
        assert!((rb / (8e-5f64 * 6e-5).sqrt() - 1.0).abs() < 1e-9, "{m:?}");
        let (pn, _) = m.star_n.unwrap();
        assert!((pn - 0.815).abs() < 1e-9, "{m:?}");
        // No banded point: no construction.
        let flat: Vec<ContourPoint> = c
            .iter()
            .map(|p| ContourPoint {
                r_v: Some(1.0),
                ..p.clone()
            })
            .collect();
        assert_eq!(maxwell(&flat), None);
    }
}
