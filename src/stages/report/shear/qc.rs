//! Q_c(φ) the paper's way (vagberg-sheared-disks Sec. III, Figs. 1 and 3): at fixed φ
//! and γ̇, P^el falls roughly as 1/Q in the Newtonian region, drops sharply at Q_c, and
//! rises roughly linearly in Q in the Bagnoldian one. The drop is located between the
//! two consecutive Q of the grid where P^el Q falls the most (by at least a factor of
//! 1.5, P^el itself falling); Q_c lies in that bracket, estimated by its geometric mean.
//! Over φ, Q_c = Q_0 + c (φ_J − φ)^(−x) (Fig. 3; the paper finds x ≈ 1.1, Q_0 ≈ 1.2) is
//! fitted with φ_J from the sweep where it brackets it (`jamming`), else held at the
//! paper's 0.8433: for each x on a grid, Q_0 and c by linear least squares on the
//! relative residuals, the x of least squares kept; 95 % intervals from 400 refits with
//! each Q_c drawn log-uniformly inside its bracket and φ_J uniformly inside its interval.

use super::{Figures, Row, key};
use crate::error::Result;
use crate::rng::Rng;
use crate::stages::report::render::curves::{Annotated, Overlay, XyFigure, XySeries};
use crate::stages::report::render::html::Block;
use std::collections::BTreeMap;

/// P^el Q must fall by at least this factor between consecutive Q to count as the drop
/// (1 on a smooth 1/Q curve; at γ̇ τ_e = 1e-4 the drop at φ = 0.79 spreads over two
/// factor-3 steps of Q, the larger a factor 1.7).
pub const MIN_DROP: f64 = 1.5;

use super::jamming::PhiJ;

/// Q_c located at one (φ, γ̇).
#[derive(Debug, Clone, PartialEq)]
pub struct QcPoint {
    pub phi: f64,
    pub rate: f64,
    /// The bracket: the last Q before the drop and the first after it.
    pub lo: f64,
    pub hi: f64,
    /// By how much P^el Q fell across the bracket (factor).
    pub drop: f64,
}

impl QcPoint {
    pub fn estimate(&self) -> f64 {
        (self.lo * self.hi).sqrt()
    }
}

/// Q_c at every (φ, γ̇) with at least three Q whose P^el is known and a drop.
pub fn locate(rows: &[Row]) -> Vec<QcPoint> {
    // (φ, γ̇) → (φ, γ̇, [(Q, P^el)]).
    type Curve = (f64, f64, Vec<(f64, f64)>);
    let mut by: BTreeMap<(i64, i64), Curve> = BTreeMap::new();
    for r in rows {
        if let Some((p, _)) = r.get("p_el")
            && p > 0.0
        {
            by.entry((key(r.phi), key(r.rate)))
                .or_insert_with(|| (r.phi, r.rate, Vec::new()))
                .2
                .push((r.q, p));
        }
    }
    let mut out = Vec::new();
    for (_, (phi, rate, mut pts)) in by {
        if pts.len() < 3 {
            continue;
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let best = pts
            .windows(2)
            .filter(|w| w[1].1 < w[0].1)
            .map(|w| (w[0].0, w[1].0, (w[0].1 * w[0].0) / (w[1].1 * w[1].0)))
            .max_by(|a, b| a.2.total_cmp(&b.2));
        if let Some((lo, hi, drop)) = best
            && drop >= MIN_DROP
        {
            out.push(QcPoint {
                phi,
                rate,
                lo,
                hi,
                drop,
            });
        }
    }
    out
}

/// The fit of Q_c = Q_0 + c (φ_J − φ)^(−x), with 95 % intervals.
#[derive(Debug, Clone, PartialEq)]
pub struct QcFit {
    pub q0: f64,
    pub c: f64,
    pub x: f64,
    pub q0_ci: (f64, f64),
    pub c_ci: (f64, f64),
    pub x_ci: (f64, f64),
    pub points: usize,
}

/// (Q_0, c, x, sum of squared relative residuals) for the points (φ, Q_c) at φ_J.
fn fit_once(pts: &[(f64, f64)], phi_j: f64) -> Option<(f64, f64, f64, f64)> {
    let mut best: Option<(f64, f64, f64, f64)> = None;
    for k in 0..=540 {
        let x = 0.3 + 0.005 * k as f64;
        // Weighted least squares of Q_c = Q_0 + c u with weights 1/Q_c².
        let (mut sw, mut su, mut sq, mut suu, mut suq) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(phi, q) in pts {
            let u = (phi_j - phi).powf(-x);
            let w = 1.0 / (q * q);
            sw += w;
            su += w * u;
            sq += w * q;
            suu += w * u * u;
            suq += w * u * q;
        }
        let det = sw * suu - su * su;
        if !(det.abs() > 1e-300) {
            continue;
        }
        let c = (sw * suq - su * sq) / det;
        let q0 = (sq - c * su) / sw;
        let ss: f64 = pts
            .iter()
            .map(|&(phi, q)| ((q - q0 - c * (phi_j - phi).powf(-x)) / q).powi(2))
            .sum();
        if best.is_none_or(|b| ss < b.3) {
            best = Some((q0, c, x, ss));
        }
    }
    best
}

/// Fit the points at one rate (the caller picks it); `None` with fewer than four
/// distinct φ below φ_J's interval (three parameters).
pub fn fit(points: &[QcPoint], phi_j: &PhiJ) -> Option<QcFit> {
    let pts: Vec<&QcPoint> = points.iter().filter(|p| p.phi < phi_j.lo).collect();
    let mut phis: Vec<i64> = pts.iter().map(|p| key(p.phi)).collect();
    phis.sort();
    phis.dedup();
    if phis.len() < 4 || phis.len() != pts.len() {
        return None;
    }
    let central: Vec<(f64, f64)> = pts.iter().map(|p| (p.phi, p.estimate())).collect();
    let (q0, c, x, _) = fit_once(&central, phi_j.value)?;
    let mut rng = Rng::new(0x9c_f17);
    let (mut q0s, mut cs, mut xs) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..400 {
        let draw: Vec<(f64, f64)> = pts
            .iter()
            .map(|p| (p.phi, p.lo * (p.hi / p.lo).powf(rng.uniform())))
            .collect();
        // A held φ_J draws nothing, so the refits are those of a fixed φ_J.
        let pj = if phi_j.hi > phi_j.lo {
            phi_j.lo + (phi_j.hi - phi_j.lo) * rng.uniform()
        } else {
            phi_j.value
        };
        if let Some((a, b, e, _)) = fit_once(&draw, pj) {
            q0s.push(a);
            cs.push(b);
            xs.push(e);
        }
    }
    let ci = |v: &mut Vec<f64>| -> (f64, f64) {
        v.sort_by(f64::total_cmp);
        let at = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
        (at(0.025), at(0.975))
    };
    if q0s.len() < 100 {
        return None;
    }
    Some(QcFit {
        q0,
        c,
        x,
        q0_ci: ci(&mut q0s),
        c_ci: ci(&mut cs),
        x_ci: ci(&mut xs),
        points: pts.len(),
    })
}

/// The Q_c figure (Fig. 3) and its table, when some (φ, γ̇) has a drop.
pub(super) fn add_figures(f: &mut Figures, rows: &[Row], phi_j: &PhiJ) -> Result<()> {
    let pts = locate(rows);
    if pts.is_empty() {
        return Ok(());
    }
    let mut rates: Vec<f64> = pts.iter().map(|p| p.rate).collect();
    rates.sort_by(f64::total_cmp);
    rates.dedup();
    let lowest = rates[0];
    let at_lowest: Vec<QcPoint> = pts.iter().filter(|p| p.rate == lowest).cloned().collect();
    let law = fit(&at_lowest, phi_j);
    let mut series: Vec<XySeries> = rates
        .iter()
        .enumerate()
        .map(|(k, &rate)| XySeries {
            label: format!("Q_c, rate {rate:.0e} (bars: the bracket)"),
            points: pts
                .iter()
                .filter(|p| p.rate == rate)
                .map(|p| (p.phi, p.estimate(), 0.0))
                .collect(),
            markers_only: true,
            colour: k,
        })
        .collect();
    // Each bracket as drawn: from one Q of the grid to the next (not symmetric about
    // the marker, which is their geometric mean).
    let brackets = pts
        .iter()
        .map(|p| {
            let k = rates.iter().position(|&r| r == p.rate).unwrap_or(0);
            (p.phi, p.lo, p.hi, k)
        })
        .collect();
    if let Some(l) = &law {
        let (lo, hi) = at_lowest.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.phi), b.max(p.phi))
        });
        series.push(XySeries {
            label: format!("Q_0 + c (φ_J − φ)^−x, x = {:.2}", l.x),
            points: (0..=40)
                .map(|i| {
                    let phi = lo + (hi - lo) * i as f64 / 40.0;
                    (phi, l.q0 + l.c * (phi_j.value - phi).powf(-l.x), 0.0)
                })
                .collect(),
            markers_only: false,
            colour: rates.len(),
        });
    }
    f.add(
        &Annotated {
            xy: XyFigure {
                title: "Q_c(φ) from the drop of P^el (Fig. 3)".into(),
                x_desc: "φ".into(),
                y_desc: "Q_c".into(),
                x_log: false,
                y_log: true,
                series,
            },
            overlay: Overlay {
                brackets,
                vlines: vec![(format!("φ_J = {:.4}", phi_j.value), phi_j.value)],
                ..Overlay::default()
            },
        },
        "q_c",
        format!(
            "Q_c at each (φ, γ̇): between the two consecutive Q of the grid where P^el·Q falls the most (by at least {MIN_DROP}×, P^el itself falling), marked at their geometric mean, the bracket drawn as a bar from one Q to the other (vagberg-sheared-disks Figs. 1, 3); dashed: φ_J. The line: Q_c = Q_0 + c (φ_J − φ)^−x fitted at the lowest rate with {}.",
            phi_j.describe()
        ),
    )?;
    f.blocks.push(Block::Table {
        header: ["φ", "γ̇ τ_e", "Q_c bracket", "P^el·Q falls by"]
            .map(String::from)
            .to_vec(),
        rows: pts
            .iter()
            .map(|p| {
                vec![
                    p.phi.to_string(),
                    format!("{:.1e}", p.rate),
                    format!("{} – {}", p.lo, p.hi),
                    format!("{:.1}×", p.drop),
                ]
            })
            .collect(),
    });
    f.blocks.push(Block::Paragraph(match &law {
        Some(l) => format!(
            "Fit at γ̇ τ_e = {lowest:.1e} over {} φ: Q_0 = {:.2} [{:.2}, {:.2}], c = {:.3} [{:.3}, {:.3}], x = {:.2} [{:.2}, {:.2}] (95 % intervals from the brackets and φ_J's interval); the paper finds x ≈ 1.1, Q_0 ≈ 1.2 for CD.",
            l.points, l.q0, l.q0_ci.0, l.q0_ci.1, l.c, l.c_ci.0, l.c_ci.1, l.x, l.x_ci.0, l.x_ci.1
        ),
        None => format!(
            "Q_c = Q_0 + c (φ_J − φ)^−x not fitted: it needs Q_c at four or more φ below φ_J at one rate; this grid gives {} at γ̇ τ_e = {lowest:.1e}.",
            at_lowest.len()
        ),
    }));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(phi: f64, q: f64, p_el: f64) -> Row {
        Row {
            phi,
            q,
            rate: 1e-5,
            v: [("p_el".to_string(), (p_el, 0.01 * p_el))].into(),
        }
    }

    /// P^el ∝ 1/Q below Q_c, a factor 30 lower just above it, rising ∝ Q beyond.
    fn sweep(qc: &[(f64, f64)]) -> Vec<Row> {
        let qs = [0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0];
        let mut rows = Vec::new();
        for &(phi, q_c) in qc {
            for q in qs {
                let p = if q < q_c {
                    1e-3 / q
                } else {
                    1e-3 / q_c / 30.0 * q / q_c
                };
                rows.push(row(phi, q, p));
            }
        }
        rows
    }

    #[test]
    fn the_drop_is_bracketed() {
        let pts = locate(&sweep(&[(0.76, 17.0), (0.82, 66.0)]));
        assert_eq!(pts.len(), 2);
        assert_eq!((pts[0].lo, pts[0].hi), (10.0, 30.0));
        assert_eq!((pts[1].lo, pts[1].hi), (30.0, 100.0));
        assert!(pts[0].drop > 5.0, "{pts:?}");
        // A smooth 1/Q curve has no drop.
        let smooth: Vec<Row> = [0.3, 1.0, 3.0, 10.0]
            .map(|q| row(0.8, q, 1e-3 / q))
            .to_vec();
        assert!(locate(&smooth).is_empty());
    }

    #[test]
    fn the_power_law_is_recovered_from_exact_points() {
        // Q_c = 1.2 + 0.9 (φ_J − φ)^(−1.1), given exactly (brackets of zero width).
        let pj = PhiJ::paper("test");
        let law = |phi: f64| 1.2 + 0.9 * (pj.value - phi).powf(-1.1);
        let pts: Vec<QcPoint> = [0.70, 0.74, 0.78, 0.80, 0.82]
            .map(|phi| QcPoint {
                phi,
                rate: 1e-5,
                lo: law(phi),
                hi: law(phi),
                drop: 30.0,
            })
            .to_vec();
        let f = fit(&pts, &pj).unwrap();
        assert!((f.x - 1.1).abs() < 0.006, "{f:?}");
        assert!(
            (f.q0 - 1.2).abs() < 0.05 && (f.c - 0.9).abs() < 0.02,
            "{f:?}"
        );
        assert!(f.x_ci.0 <= f.x && f.x <= f.x_ci.1);
        // Three φ cannot fix three parameters.
        assert!(fit(&pts[..3], &pj).is_none());
        // A φ_J measured with an interval: the fit takes its middle, and its interval
        // widens the exponent's.
        let measured = PhiJ {
            value: 0.85,
            lo: 0.845,
            hi: 0.855,
            held_because: None,
            per_q: Vec::new(),
        };
        let law = |phi: f64| 1.2 + 0.9 * (0.85 - phi).powf(-1.1);
        let pts: Vec<QcPoint> = pts
            .iter()
            .map(|p| QcPoint {
                lo: law(p.phi),
                hi: law(p.phi),
                ..p.clone()
            })
            .collect();
        let g = fit(&pts, &measured).unwrap();
        assert!((g.x - 1.1).abs() < 0.006, "{g:?}");
        assert!(g.x_ci.1 - g.x_ci.0 > 0.02, "{g:?}");
    }
}
