//! The transition lines of the CDrot phase diagram the way vagberg-sheared-disks
//! Appendix A draws them (Figs. 17, 32, 33), from a sweep with at least two rates.
//!
//! - **Z/γ̇ at two rates (Fig. 32).** Where the flow is weakly inelastic Bagnoldian,
//!   Z ∝ γ̇ τ_e as γ̇ → 0, so Z/(γ̇ τ_e) does not depend on the rate; in Newtonian flow
//!   (Z → const) and in strongly inelastic Bagnoldian flow (Z → 0 slower than γ̇) it grows
//!   as the rate falls. At each φ, D_Z(Q) = Z(γ̇_1)/(γ̇_1 τ_e) − Z(γ̇_2)/(γ̇_2 τ_e), with
//!   γ̇_1 < γ̇_2 the grid's two lowest rates (the paper: 1e-6 and 1e-5), vanishes above a
//!   Q and rises from zero as Q decreases below it. That Q is Q_c where the runs below it
//!   are Newtonian (the paper's φ ≳ 0.8) and Q* where they are Bagnoldian (φ ≲ 0.8).
//! - **B_p^el at two rates (Fig. 33).** B_p^el = P^el/(γ̇ τ_e)² (Eq. 19) is independent of
//!   the rate in Bagnoldian flow and ∝ 1/(γ̇ τ_e) in Newtonian flow. At each Q,
//!   D_B(φ) = B_p^el(γ̇_1) − B_p^el(γ̇_2) vanishes below φ_c(Q) and rises from zero above.
//! - **The onset** (the paper: "the intersection of the dashed lines"): with u = −ln Q
//!   for D_Z (rising as Q falls) and u = φ for D_B, the rise begins at the first two
//!   consecutive points more than [`RISE_SIGMAS`] errors above zero; at least two points
//!   must come before them (else D is already non-zero where the grid starts and the
//!   onset lies beyond it), and none is located without such a pair. Over those points
//!   and the two, a broken line D(u) = c_0 + s·max(0, u − u*) is fitted by weighted
//!   least squares (weights 1/err²): u* scanned on 2000 steps from the second point to
//!   the second-to-last, c_0 and s (> 0) solved for each, the least sum of squares kept.
//!   Only the points up to the first two rising ones enter, so a D that grows steeply
//!   further on (B_p^el near and past jamming) does not drag the line. 95 % interval:
//!   400 refits with every D redrawn from a normal of its error.

use super::classify::Class;
use super::{Classification, Figures, Row, key};
use crate::error::Result;
use crate::rng::Rng;
use crate::stages::report::render::curves::{Annotated, Overlay, XyFigure, XySeries};
use crate::stages::report::render::html::Block;
use std::collections::BTreeMap;

/// A rising point must exceed the flat level by this many of its errors.
pub const RISE_SIGMAS: f64 = 2.0;
/// Steps of the scan of u*.
const SCAN: usize = 2000;

/// One criterion's values along one axis at a fixed other coordinate: (x, D, error),
/// x = Q (D_Z, at fixed φ) or φ (D_B, at fixed Q), sorted by x.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    pub held: f64,
    pub rate1: f64,
    pub rate2: f64,
    pub points: Vec<(f64, f64, f64)>,
}

/// The grid's two lowest rates, γ̇_1 < γ̇_2.
fn two_lowest_rates(rows: &[Row]) -> Option<(f64, f64)> {
    let mut r: Vec<f64> = rows.iter().map(|r| r.rate).collect();
    r.sort_by(f64::total_cmp);
    r.dedup();
    (r.len() >= 2).then(|| (r[0], r[1]))
}

/// D = g(row at γ̇_1) − g(row at γ̇_2) at each (φ, Q) with both, grouped by `held` and
/// ordered by `along`.
fn differences(rows: &[Row], g: &dyn Fn(&Row) -> Option<(f64, f64)>, along_q: bool) -> Vec<Curve> {
    let Some((r1, r2)) = two_lowest_rates(rows) else {
        return Vec::new();
    };
    // (φ, Q) → (φ, Q, g of the run at `rate`).
    type AtRate = BTreeMap<(i64, i64), (f64, f64, (f64, f64))>;
    let at = |rate: f64| -> AtRate {
        rows.iter()
            .filter(|r| r.rate == rate)
            .filter_map(|r| g(r).map(|v| ((key(r.phi), key(r.q)), (r.phi, r.q, v))))
            .collect()
    };
    let (slow, fast) = (at(r1), at(r2));
    let mut by: BTreeMap<i64, Curve> = BTreeMap::new();
    for (k, (phi, q, (a, ea))) in &slow {
        let Some((_, _, (b, eb))) = fast.get(k) else {
            continue;
        };
        let (held, x) = if along_q { (*phi, *q) } else { (*q, *phi) };
        by.entry(key(held))
            .or_insert_with(|| Curve {
                held,
                rate1: r1,
                rate2: r2,
                points: Vec::new(),
            })
            .points
            .push((x, a - b, ea.hypot(*eb)));
    }
    by.into_values()
        .map(|mut c| {
            c.points.sort_by(|a, b| a.0.total_cmp(&b.0));
            c
        })
        .collect()
}

/// D_Z(Q) = Z/(γ̇_1 τ_e) − Z/(γ̇_2 τ_e) at each φ (Fig. 32); `rate` is γ̇ τ_e.
pub fn z_curves(rows: &[Row]) -> Vec<Curve> {
    differences(
        rows,
        &|r| r.get("z").map(|(z, e)| (z / r.rate, e / r.rate)),
        true,
    )
}

/// D_B(φ) = B_p^el(γ̇_1) − B_p^el(γ̇_2) at each Q (Fig. 33; B_p^el of Eq. 19 is `b_p_el`).
pub fn b_curves(rows: &[Row]) -> Vec<Curve> {
    differences(rows, &|r| r.get("b_p_el"), false)
}

/// A located onset on the u axis of [`onset`].
#[derive(Debug, Clone, PartialEq)]
pub struct Onset {
    pub u: f64,
    /// 95 % interval of u from the redraws.
    pub u_ci: (f64, f64),
    /// The flat level c_0 and the slope s.
    pub c0: f64,
    pub s: f64,
    /// The grid values of u either side of u*: the last flat one and the first rising one.
    pub bracket: (f64, f64),
}

/// (u*, c_0, s, sum of squares) of the broken line through (u, D, err), u ascending.
fn broken_line(pts: &[(f64, f64, f64)]) -> Option<(f64, f64, f64, f64)> {
    let n = pts.len();
    if n < 4 {
        return None;
    }
    let scale = pts.iter().map(|p| p.2.abs()).fold(0.0, f64::max);
    let w = |e: f64| {
        let e = if e.is_finite() && e > 0.0 { e } else { scale };
        if e > 0.0 { 1.0 / (e * e) } else { 1.0 }
    };
    // u* from the second point to the second-to-last: two flat, two rising.
    let (lo, hi) = (pts[1].0, pts[n - 2].0);
    let mut best: Option<(f64, f64, f64, f64)> = None;
    for k in 0..SCAN {
        let us = lo + (hi - lo) * k as f64 / SCAN as f64;
        let (mut sw, mut sh, mut sd, mut shh, mut shd) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(u, d, e) in pts {
            let (wi, h) = (w(e), (u - us).max(0.0));
            sw += wi;
            sh += wi * h;
            sd += wi * d;
            shh += wi * h * h;
            shd += wi * h * d;
        }
        let det = sw * shh - sh * sh;
        if !(det.abs() > 1e-300) {
            continue;
        }
        let s = (sw * shd - sh * sd) / det;
        let c0 = (sd - s * sh) / sw;
        if s <= 0.0 {
            continue;
        }
        let ss: f64 = pts
            .iter()
            .map(|&(u, d, e)| w(e) * (d - c0 - s * (u - us).max(0.0)).powi(2))
            .sum();
        if best.is_none_or(|b| ss < b.3) {
            best = Some((us, c0, s, ss));
        }
    }
    best
}

/// Where D, zero at low u, starts to rise: the broken line of the module's rule, or
/// `None` without two consecutive points significantly above zero after at least two
/// others, or without a rising fit.
pub fn onset(pts: &[(f64, f64, f64)]) -> Option<Onset> {
    let mut pts: Vec<(f64, f64, f64)> = pts
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let up = |p: &(f64, f64, f64)| p.1 > RISE_SIGMAS * p.2.max(0.0);
    let first = pts.windows(2).position(|w| up(&w[0]) && up(&w[1]))?;
    if first < 2 {
        return None;
    }
    pts.truncate(first + 2);
    let (u, c0, s, _) = broken_line(&pts)?;
    let mut rng = Rng::new(0xa9_9e4d);
    let mut us = Vec::new();
    for _ in 0..400 {
        let draw: Vec<(f64, f64, f64)> = pts
            .iter()
            .map(|&(x, d, e)| (x, d + e.max(0.0) * rng.normal(), e))
            .collect();
        if let Some((v, ..)) = broken_line(&draw) {
            us.push(v);
        }
    }
    us.sort_by(f64::total_cmp);
    let at = |f: f64| us[((us.len() - 1) as f64 * f).round() as usize];
    let u_ci = if us.len() >= 100 {
        (at(0.025), at(0.975))
    } else {
        (f64::NAN, f64::NAN)
    };
    let last_flat = pts.iter().rev().find(|p| p.0 <= u).map_or(u, |p| p.0);
    let first_rising = pts.iter().find(|p| p.0 > u).map_or(u, |p| p.0);
    Some(Onset {
        u,
        u_ci,
        c0,
        s,
        bracket: (last_flat, first_rising),
    })
}

/// What a located Z/γ̇ onset is, by the class of the runs on its rising side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Line {
    /// Newtonian below: the Bagnoldian–Newtonian transition Q_c.
    Qc,
    /// Bagnoldian below: the crossover Q* between weakly and strongly inelastic
    /// Bagnoldian flow.
    QStar,
    /// The runs below are undecided or split.
    Unknown,
}

impl Line {
    pub fn name(self) -> &'static str {
        match self {
            Line::Qc => "Q_c",
            Line::QStar => "Q*",
            Line::Unknown => "Q_c or Q* (the runs below are undecided)",
        }
    }
}

/// An Appendix A line at one φ (along Q) or one Q (along φ).
#[derive(Debug, Clone, PartialEq)]
pub struct Located {
    pub held: f64,
    /// Q (Fig. 32) or φ_c (Fig. 33), with its 95 % interval and grid bracket.
    pub value: f64,
    pub ci: (f64, f64),
    pub bracket: (f64, f64),
    pub line: Line,
}

/// Q_c or Q* at each φ of the sweep (Fig. 32), named by the majority class (over all
/// rates, `classify`) of the runs at smaller Q.
pub fn locate_q(rows: &[Row], c: &Classification) -> Vec<Located> {
    let class: BTreeMap<(i64, i64), Class> = c
        .slopes
        .iter()
        .filter(|s| s.scope == "all")
        .map(|s| ((key(s.phi), key(s.q)), s.slope.class))
        .collect();
    z_curves(rows)
        .into_iter()
        .filter_map(|cv| {
            let pts: Vec<(f64, f64, f64)> = cv
                .points
                .iter()
                .filter(|p| p.0 > 0.0)
                .map(|&(q, d, e)| (-q.ln(), d, e))
                .collect();
            let o = onset(&pts)?;
            let q_star = (-o.u).exp();
            let q_of = |u: f64| cv.points.iter().find(|p| -p.0.ln() == u).map(|p| p.0);
            let below: Vec<Class> = cv
                .points
                .iter()
                .filter(|p| p.0 < q_star)
                .filter_map(|p| class.get(&(key(cv.held), key(p.0))).copied())
                .collect();
            let count = |k: Class| below.iter().filter(|&&x| x == k).count();
            let (n, b) = (count(Class::Newtonian), count(Class::Bagnoldian));
            let line = if 2 * n > below.len() {
                Line::Qc
            } else if 2 * b > below.len() {
                Line::QStar
            } else {
                Line::Unknown
            };
            Some(Located {
                held: cv.held,
                value: q_star,
                ci: ((-o.u_ci.1).exp(), (-o.u_ci.0).exp()),
                // The grid's own Q either side, found by their u (exp(−ln Q) need not
                // give Q back exactly).
                bracket: (
                    q_of(o.bracket.1).unwrap_or(q_star),
                    q_of(o.bracket.0).unwrap_or(q_star),
                ),
                line,
            })
        })
        .collect()
}

/// φ_c at each Q of the sweep (Fig. 33).
pub fn locate_phi(rows: &[Row]) -> Vec<Located> {
    b_curves(rows)
        .into_iter()
        .filter_map(|cv| {
            let o = onset(&cv.points)?;
            Some(Located {
                held: cv.held,
                value: o.u,
                ci: o.u_ci,
                bracket: o.bracket,
                line: Line::Qc,
            })
        })
        .collect()
}

fn fmt_ci(ci: (f64, f64)) -> String {
    if ci.0.is_finite() && ci.1.is_finite() {
        format!("[{:.4}, {:.4}]", ci.0, ci.1)
    } else {
        "not constrained".into()
    }
}

/// Figs. 32, 33 and the Appendix A lines on the (φ, Q) plane (Fig. 17), with the rule.
pub(super) fn add_figures(
    f: &mut Figures,
    rows: &[Row],
    c: &Classification,
    phi_j: f64,
) -> Result<()> {
    let (zc, bc) = (z_curves(rows), b_curves(rows));
    if zc.is_empty() && bc.is_empty() {
        return Ok(());
    }
    let (qs, phis) = (locate_q(rows, c), locate_phi(rows));
    let (r1, r2) = two_lowest_rates(rows).expect("curves need two rates");
    let series = |curves: &[Curve], what: &str| -> Vec<XySeries> {
        curves
            .iter()
            .enumerate()
            .map(|(k, cv)| XySeries {
                label: format!("{what} = {}", cv.held),
                points: cv.points.clone(),
                markers_only: false,
                colour: k,
            })
            .collect()
    };
    let rule = format!(
        "The onset, the paper's intersection of two dashed lines: the rise begins at the first two consecutive points more than {RISE_SIGMAS} errors above zero (with at least two points before them; u = −ln Q for Fig. 32, u = φ for Fig. 33), and a broken line D = c_0 + s·max(0, u − u*) fitted by least squares weighted by the errors to the points up to those two puts the onset at u*; 95 % intervals from 400 refits with each D redrawn within its error."
    );
    if !zc.is_empty() {
        f.add(
            &XyFigure {
                title: "Z/(dγ/dt τ_e) at two rates against Q (Fig. 32)".into(),
                x_desc: "Q".into(),
                y_desc: format!("Z/(γ̇_1 τ_e) − Z/(γ̇_2 τ_e), γ̇_1 τ_e = {r1:.0e}, γ̇_2 τ_e = {r2:.0e}"),
                x_log: true,
                y_log: false,
                series: series(&zc, "φ"),
            },
            "appendix_a_z",
            format!("(Z/γ̇_1 τ_e) − (Z/γ̇_2 τ_e) against Q at each φ, with γ̇_1, γ̇_2 the grid's two lowest rates (the paper: 1e-6 and 1e-5), errors combined from the runs' (vagberg-sheared-disks Appendix A, Fig. 32). Zero where Z ∝ γ̇ (weakly inelastic Bagnoldian flow), rising as Q falls below Q_c (Newtonian below) or Q* (strongly inelastic Bagnoldian below). {rule}"),
        )?;
    }
    if !bc.is_empty() {
        f.add(
            &XyFigure {
                title: "B_p^el at two rates against φ (Fig. 33)".into(),
                x_desc: "φ".into(),
                y_desc: format!("B_p1^el − B_p2^el, γ̇_1 τ_e = {r1:.0e}, γ̇_2 τ_e = {r2:.0e}"),
                x_log: false,
                y_log: false,
                series: series(&bc, "Q"),
            },
            "appendix_a_b",
            format!("B_p1^el − B_p2^el = P^el/(γ̇_1 τ_e)² − P^el/(γ̇_2 τ_e)² (Eq. 19) against φ at each Q (vagberg-sheared-disks Appendix A, Fig. 33): zero in Bagnoldian flow (φ < φ_c), rising above φ_c where B_p^el ∝ 1/γ̇. {rule}"),
        )?;
    }
    let mut lines = Vec::new();
    for (k, line) in [Line::Qc, Line::QStar, Line::Unknown]
        .into_iter()
        .enumerate()
    {
        let points: Vec<(f64, f64, f64)> = qs
            .iter()
            .filter(|l| l.line == line)
            .map(|l| (l.held, l.value, 0.0))
            .collect();
        if !points.is_empty() {
            lines.push(XySeries {
                label: format!("{} from Z/γ̇ (Fig. 32)", line.name()),
                points,
                markers_only: true,
                colour: k,
            });
        }
    }
    if !phis.is_empty() {
        lines.push(XySeries {
            label: "φ_c(Q) from B_p^el (Fig. 33)".into(),
            points: phis.iter().map(|l| (l.value, l.held, 0.0)).collect(),
            markers_only: true,
            colour: 3,
        });
    }
    if !lines.is_empty() {
        f.add(
            &Annotated {
                xy: XyFigure {
                    title: "Q_c, Q* and φ_c by Appendix A on the (φ, Q) plane (Fig. 17)".into(),
                    x_desc: "φ".into(),
                    y_desc: "Q".into(),
                    x_log: false,
                    y_log: true,
                    series: lines,
                },
                overlay: Overlay {
                    vlines: vec![(format!("φ_J = {phi_j:.4}"), phi_j)],
                    ..Overlay::default()
                },
            },
            "appendix_a_lines",
            "The lines of the CDrot phase diagram located by the Appendix A criteria (vagberg-sheared-disks Fig. 17): Q_c(φ) where D_Z rises below a Q whose smaller-Q runs are Newtonian, Q*(φ) where they are Bagnoldian (the crossover from weakly to strongly inelastic Bagnoldian flow), φ_c(Q) where D_B rises. The runs' class is the slope of ln p against ln γ̇ over every rate (the classification below). Intervals in the table; dashed: φ_J.".into(),
        )?;
    }
    let mut table = Vec::new();
    for l in &qs {
        table.push(vec![
            format!("φ = {}", l.held),
            l.line.name().into(),
            format!("{:.4}", l.value),
            fmt_ci(l.ci),
            format!("{} – {}", l.bracket.0, l.bracket.1),
        ]);
    }
    for l in &phis {
        table.push(vec![
            format!("Q = {}", l.held),
            "φ_c".into(),
            format!("{:.4}", l.value),
            fmt_ci(l.ci),
            format!("{} – {}", l.bracket.0, l.bracket.1),
        ]);
    }
    let none: Vec<String> = zc
        .iter()
        .filter(|cv| !qs.iter().any(|l| l.held == cv.held))
        .map(|cv| format!("φ = {}", cv.held))
        .chain(
            bc.iter()
                .filter(|cv| !phis.iter().any(|l| l.held == cv.held))
                .map(|cv| format!("Q = {}", cv.held)),
        )
        .collect();
    if !table.is_empty() {
        f.blocks.push(Block::Table {
            header: ["at", "line", "value", "95 % interval", "grid bracket"]
                .map(String::from)
                .to_vec(),
            rows: table,
        });
    }
    if !none.is_empty() {
        f.blocks.push(Block::Paragraph(format!(
            "Appendix A: no onset at {} (no two consecutive points more than {RISE_SIGMAS} errors above zero after two that are not: the difference vanishes over the grid, or is non-zero already where the grid starts).",
            none.join(", ")
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(phi: f64, q: f64, rate: f64, z: f64, b: f64) -> Row {
        Row {
            phi,
            q,
            rate,
            v: [
                ("z".to_string(), (z, 1e-6 * z)),
                ("b_p_el".to_string(), (b, 1e-3 * b)),
            ]
            .into(),
        }
    }

    #[test]
    fn a_broken_line_is_found_at_its_kink_between_grid_points() {
        // D = 0 for u ≤ 1.3, 4 (u − 1.3) above; grid u = 0..5.
        let pts: Vec<(f64, f64, f64)> = (0..6)
            .map(|k| {
                let u = k as f64;
                (u, 4.0 * (u - 1.3f64).max(0.0), 0.01)
            })
            .collect();
        let o = onset(&pts).unwrap();
        assert!((o.u - 1.3).abs() < 0.003, "{o:?}");
        assert!((o.s - 4.0).abs() < 0.01 && o.c0.abs() < 0.01, "{o:?}");
        assert_eq!(o.bracket, (1.0, 2.0));
        assert!(o.u_ci.0 <= o.u && o.u <= o.u_ci.1 && o.u_ci.1 - o.u_ci.0 < 0.05);
        // Zero within the errors everywhere: no onset.
        let flat: Vec<(f64, f64, f64)> = (0..6).map(|k| (k as f64, 0.01, 0.02)).collect();
        assert_eq!(onset(&flat), None);
        // Too few points.
        assert_eq!(onset(&pts[..3]), None);
        // Non-zero already at the second point: the onset lies beyond the grid.
        let early: Vec<(f64, f64, f64)> = (0..6)
            .map(|k| (k as f64, 4.0 * (k as f64 - 0.5).max(0.0), 0.01))
            .collect();
        assert_eq!(onset(&early), None);
        // A D that grows steeply far past the onset does not move it: only the points up
        // to the first two rising ones enter.
        let mut steep = pts.clone();
        steep[5].1 = 1e6;
        let o2 = onset(&steep).unwrap();
        assert!((o2.u - 1.3).abs() < 0.003, "{o2:?}");
    }

    /// A planted CDrot sweep at rates 1e-6 and 1e-5. At φ = 0.82, Z = 1e4 γ̇ (∝ γ̇,
    /// weakly inelastic Bagnoldian) plus, below Q_c = 5, a rate-independent part
    /// 0.5 ln(5/Q) (Newtonian: Z → const), so D_Z = 0.5 ln(5/Q) (1e6 − 1e5), a straight
    /// line in ln Q meeting zero at Q = 5. At φ = 0.76 the extra part below Q* = 2 is
    /// 0.01 √γ̇ ln(2/Q) (Z → 0 slower than γ̇): D_Z = 0.01 ln(2/Q) (1e3 − 10^2.5).
    #[test]
    fn z_over_rate_locates_q_c_and_q_star_by_the_class_below() {
        let qs: [f64; 6] = [0.3, 1.0, 3.0, 10.0, 30.0, 100.0];
        let mut rows = Vec::new();
        for &rate in &[1e-6f64, 1e-5] {
            for &q in &qs {
                let z82 = 1e4 * rate + 0.5 * (5.0 / q).ln().max(0.0);
                rows.push(row(0.82, q, rate, z82, 1.0));
                let z76 = 1e4 * rate + 0.01 * rate.sqrt() * (2.0 / q).ln().max(0.0);
                rows.push(row(0.76, q, rate, z76, 1.0));
            }
        }
        let curves = z_curves(&rows);
        assert_eq!(curves.len(), 2);
        let c82 = &curves[1];
        assert_eq!(c82.held, 0.82);
        let d = 0.5 * (5.0f64 / 0.3).ln() * 9e5;
        assert!((c82.points[0].1 - d).abs() < 1e-6 * d, "{:?}", c82.points);
        assert!(c82.points[5].1.abs() < 1e-6, "{:?}", c82.points);
        // The class below the onset, as `classify` would give it: Newtonian at 0.82,
        // Bagnoldian at 0.76.
        let slope = |phi: f64, q: f64, class: Class| super::super::Classified {
            phi,
            q,
            scope: "all",
            slope: super::super::classify::Slope {
                rate_lo: 1e-6,
                rate_hi: 1e-5,
                slope: 0.0,
                err: 0.0,
                class,
                note: String::new(),
            },
        };
        let mut slopes = Vec::new();
        for &q in &qs {
            slopes.push(slope(0.82, q, Class::Newtonian));
            slopes.push(slope(0.76, q, Class::Bagnoldian));
        }
        let c = Classification {
            slopes,
            transitions: Vec::new(),
        };
        let located = locate_q(&rows, &c);
        assert_eq!(located.len(), 2, "{located:?}");
        let (l76, l82) = (&located[0], &located[1]);
        // The kinks lie between grid points; the bracket names the grid's Q either side.
        assert!((l82.value / 5.0 - 1.0).abs() < 0.01, "{l82:?}");
        assert_eq!(l82.bracket, (3.0, 10.0));
        assert!(l82.ci.0 <= l82.value && l82.value <= l82.ci.1, "{l82:?}");
        assert_eq!(l82.line, Line::Qc);
        assert!((l76.value / 2.0 - 1.0).abs() < 0.01, "{l76:?}");
        assert_eq!(l76.bracket, (1.0, 3.0));
        assert_eq!(l76.line, Line::QStar);
    }

    /// B_p^el constant in γ̇ below φ_c = 0.80 (Bagnoldian) and P^el = η γ̇ above it
    /// with η rising linearly from zero at 0.80, so B_1 − B_2 = η (1e6 − 1e5)
    /// rises linearly from φ_c: the broken line recovers 0.80 exactly.
    #[test]
    fn b_p_at_two_rates_locates_phi_c() {
        let mut rows = Vec::new();
        for &rate in &[1e-6, 1e-5] {
            for k in 0..8 {
                let phi = 0.76 + 0.01 * k as f64;
                let eta = 1e-3 * (phi - 0.80f64).max(0.0);
                let b = 2.0 + eta * rate / (rate * rate);
                rows.push(row(phi, 1.0, rate, 1.0, b));
            }
        }
        let l = locate_phi(&rows);
        assert_eq!(l.len(), 1);
        assert!((l[0].value - 0.80).abs() < 1e-4, "{l:?}");
        let (lo, hi) = l[0].bracket;
        // The kink sits on a grid point; u* lands within a scan step of it, either side.
        assert!(
            lo <= 0.80 + 1e-9 && hi >= 0.80 - 1e-9 && hi - lo < 0.0101,
            "{l:?}"
        );
        // One rate: no criterion.
        let one: Vec<Row> = rows.into_iter().filter(|r| r.rate == 1e-6).collect();
        assert!(b_curves(&one).is_empty());
    }
}
