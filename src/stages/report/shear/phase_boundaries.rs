//! The coexistence region as the paper draws it (vagberg-sheared-disks Sec. IV, Figs.
//! 25, 26, 29), at the Q nearest 1.
//!
//! - **Boundary points.** At each strain rate, φ_B and φ_N by the three measures of
//!   `coexistence::measures` (R_v: the middle of its bracket; the P^el kinks; the μ
//!   switch), and P and Σ there, interpolated along φ at that rate linearly in φ
//!   against ln P (ln Σ) between the neighbouring runs.
//! - **The region** (shaded in Figs. 25, 26): the polygon through the R_v boundaries,
//!   φ_B rising with γ̇ and φ_N back down, at the rates where both are bracketed — the
//!   paper's solid lines, R_v being its most reliable measure.
//! - **The critical end point "*"**: φ_B and φ_N merge as γ̇ grows. The grid brackets
//!   the end point between its highest rate with a banded run and the next rate, at
//!   which no run is banded; "*" is drawn at their geometric mean, at the middle of the
//!   highest banded stretch (its P and Σ from there). Without a higher unbanded rate the
//!   end point lies beyond the grid, and the report says so.
//! - **The contour check**: the constant-P contour enters the banded stretch between two
//!   of its points; φ_B there is compared with R_v's and the P^el kink's at the grid
//!   rate nearest the contour's, within one step of that rate's φ grid.

use super::coexistence::{Boundaries, Measures, R_V_BANDED, boundaries, measures, mid};
use super::contour::{choose_p, contour, pick_q};
use super::stress_space::{MuJ, by_class};
use super::{Classification, Figures, Row, key};
use crate::error::Result;
use crate::stages::report::render::curves::{Annotated, Overlay, XyFigure, XySeries};
use crate::stages::report::render::html::Block;

/// Which of the paper's three measures a boundary point comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measure {
    /// The jump of R_v (Fig. 24).
    Rv,
    /// The kinks of P^el (Fig. 22).
    PelKink,
    /// The switch of μ between its branches (Fig. 23).
    MuSwitch,
}

impl Measure {
    pub fn name(self) -> &'static str {
        match self {
            Measure::Rv => "R_v (Fig. 24)",
            Measure::PelKink => "P^el kink (Fig. 22)",
            Measure::MuSwitch => "μ switch (Fig. 23)",
        }
    }
}

/// The Bagnoldian or the Newtonian side of the region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    B,
    N,
}

/// One boundary point: φ_B or φ_N at a rate by one measure, with P and Σ there.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryPoint {
    pub measure: Measure,
    pub side: Side,
    pub rate: f64,
    pub phi: f64,
    pub p: Option<f64>,
    pub sigma: Option<f64>,
}

/// `quantity` at (q, rate) and φ, linear in φ against its logarithm between the
/// neighbouring runs (exact at a run).
pub fn along_phi(rows: &[Row], q: f64, rate: f64, phi: f64, quantity: &str) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| key(r.q) == key(q) && key(r.rate) == key(rate))
        .filter_map(|r| r.get(quantity).filter(|v| v.0 > 0.0).map(|v| (r.phi, v.0)))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(p) = pts.iter().find(|p| p.0 == phi) {
        return Some(p.1);
    }
    let w = pts.windows(2).find(|w| w[0].0 < phi && phi < w[1].0)?;
    let t = (phi - w[0].0) / (w[1].0 - w[0].0);
    Some((w[0].1.ln() + t * (w[1].1.ln() - w[0].1.ln())).exp())
}

/// Every boundary point at `q`, rates ascending.
pub fn points(rows: &[Row], q: f64) -> Vec<BoundaryPoint> {
    let mut out = Vec::new();
    let mut ms: Vec<Measures> = measures(rows)
        .into_iter()
        .filter(|m| key(m.q) == key(q))
        .collect();
    ms.sort_by(|a, b| a.rate.total_cmp(&b.rate));
    for m in &ms {
        let rv = m.r_v.as_ref();
        let found = [
            (Measure::Rv, Side::B, rv.and_then(|b| mid(b.phi_b))),
            (Measure::Rv, Side::N, rv.and_then(|b| mid(b.phi_n))),
            (Measure::PelKink, Side::B, m.p_el.and_then(|x| x.0)),
            (Measure::PelKink, Side::N, m.p_el.and_then(|x| x.1)),
            (Measure::MuSwitch, Side::B, m.mu.and_then(|x| x.0)),
            (Measure::MuSwitch, Side::N, m.mu.and_then(|x| x.1)),
        ];
        for (measure, side, phi) in found {
            if let Some(phi) = phi {
                out.push(BoundaryPoint {
                    measure,
                    side,
                    rate: m.rate,
                    phi,
                    p: along_phi(rows, q, m.rate, phi, "p"),
                    sigma: along_phi(rows, q, m.rate, phi, "sigma"),
                });
            }
        }
    }
    out
}

/// The region's corners from the R_v points, as (x(point), γ̇): the B side with rising
/// rate, then the N side back down, at the rates where both sides exist; empty with
/// fewer than two such rates.
pub fn region(pts: &[BoundaryPoint], x: &dyn Fn(&BoundaryPoint) -> Option<f64>) -> Vec<(f64, f64)> {
    let side = |s: Side| -> Vec<&BoundaryPoint> {
        pts.iter()
            .filter(|p| p.measure == Measure::Rv && p.side == s)
            .collect()
    };
    let (b, n) = (side(Side::B), side(Side::N));
    let both: Vec<(f64, f64, f64)> = b
        .iter()
        .filter_map(|pb| {
            let pn = n.iter().find(|pn| key(pn.rate) == key(pb.rate))?;
            Some((pb.rate, x(pb)?, x(pn)?))
        })
        .collect();
    if both.len() < 2 {
        return Vec::new();
    }
    both.iter()
        .map(|t| (t.1, t.0))
        .chain(both.iter().rev().map(|t| (t.2, t.0)))
        .collect()
}

/// The critical end point as the grid brackets it.
#[derive(Debug, Clone, PartialEq)]
pub struct EndPoint {
    /// The highest rate with a banded run, and the next rate of the grid (none banded
    /// there); `None` when the grid has no higher rate.
    pub below: f64,
    pub above: Option<f64>,
    /// The middle of the highest banded stretch, and P, Σ there.
    pub phi: f64,
    pub p: Option<f64>,
    pub sigma: Option<f64>,
}

impl EndPoint {
    /// Where "*" is drawn along γ̇: between the two rates.
    pub fn rate(&self) -> Option<f64> {
        self.above.map(|a| (a * self.below).sqrt())
    }
}

/// The end point at `q` from the R_v brackets; `None` without a banded run.
pub fn end_point(rows: &[Row], q: f64) -> Option<EndPoint> {
    let bs: Vec<Boundaries> = boundaries(rows)
        .into_iter()
        .filter(|b| key(b.q) == key(q))
        .collect();
    let top = bs.iter().max_by(|a, b| a.rate.total_cmp(&b.rate))?;
    let above = rows
        .iter()
        .filter(|r| key(r.q) == key(q) && r.rate > top.rate && r.get("r_v").is_some())
        .map(|r| r.rate)
        .min_by(f64::total_cmp);
    let (lo, hi) = top
        .banded
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let phi = 0.5 * (lo + hi);
    Some(EndPoint {
        below: top.rate,
        above,
        phi,
        p: along_phi(rows, q, top.rate, phi, "p"),
        sigma: along_phi(rows, q, top.rate, phi, "sigma"),
    })
}

const CHECK: &str = "Check — the constant-P contour, the R_v jump and the P^el kink agree on φ_B within one step of the φ grid";

/// The contour P = P_0's own φ_B against R_v's and the P^el kink's at the grid rate
/// nearest the contour's there, in words; where the data do not allow it, why.
pub fn contour_check(rows: &[Row], q: f64) -> String {
    let Some(p0) = choose_p(rows, q) else {
        return format!(
            "{CHECK}: not made at Q = {q}, no run pressure is crossed between neighbouring rates at three or more φ (no contour)."
        );
    };
    let c = contour(rows, q, p0);
    let Some(a) = c.iter().position(|p| p.r_v.is_some_and(|r| r > R_V_BANDED)) else {
        return format!(
            "{CHECK}: not made at Q = {q}, the contour P = {p0:.3e} meets no banded run (R_v > {R_V_BANDED}) on this grid."
        );
    };
    if a == 0 {
        return format!(
            "{CHECK}: not made at Q = {q}, the contour P = {p0:.3e} is banded from the grid's first φ on, so its φ_B lies below the grid."
        );
    }
    let (lo, hi, rate) = (c[a - 1].phi, c[a].phi, c[a].rate);
    let on_contour = 0.5 * (lo + hi);
    let has_phi_b = |m: &Measures| {
        m.r_v.as_ref().and_then(|b| b.phi_b).is_some() || m.p_el.and_then(|x| x.0).is_some()
    };
    let nearest = measures(rows)
        .into_iter()
        .filter(|m| key(m.q) == key(q) && has_phi_b(m))
        .min_by(|x, y| {
            (x.rate / rate)
                .ln()
                .abs()
                .total_cmp(&(y.rate / rate).ln().abs())
        });
    let Some(m) = nearest else {
        return format!(
            "{CHECK}: not made at Q = {q}, neither R_v nor the P^el kink finds a φ_B at any rate."
        );
    };
    let mut said = vec![format!(
        "the contour P = {p0:.3e} enters the banded stretch between φ = {lo} and {hi} (φ_B ≈ {on_contour:.4}, at γ̇ τ_e ≈ {rate:.2e})"
    )];
    let mut agree = true;
    for (name, phi) in [
        ("R_v", m.r_v.as_ref().and_then(|b| mid(b.phi_b))),
        ("the P^el kink", m.p_el.and_then(|x| x.0)),
    ] {
        match phi {
            Some(v) => {
                let steps = (m.index(v) - m.index(on_contour)).abs();
                let ok = steps <= 1.0 + 1e-9;
                agree &= ok;
                said.push(format!(
                    "{name} at γ̇ τ_e = {:.1e} puts it at {v:.4} ({steps:.1} grid steps away: {})",
                    m.rate,
                    if ok { "agrees" } else { "does not agree" }
                ));
            }
            None => said.push(format!("{name} finds no φ_B at γ̇ τ_e = {:.1e}", m.rate)),
        }
    }
    format!(
        "{CHECK}: {}. {}",
        said.join("; "),
        if agree {
            "Holds where the data allow."
        } else {
            "Does not hold here."
        }
    )
}

fn series_of(
    pts: &[BoundaryPoint],
    xy: &dyn Fn(&BoundaryPoint) -> Option<(f64, f64)>,
) -> Vec<XySeries> {
    let mut out = Vec::new();
    for (k, measure) in [Measure::Rv, Measure::PelKink, Measure::MuSwitch]
        .into_iter()
        .enumerate()
    {
        for (side, name) in [(Side::B, "φ_B"), (Side::N, "φ_N")] {
            let points: Vec<(f64, f64, f64)> = pts
                .iter()
                .filter(|p| p.measure == measure && p.side == side)
                .filter_map(|p| xy(p).map(|(x, y)| (x, y, 0.0)))
                .collect();
            if !points.is_empty() {
                out.push(XySeries {
                    label: format!("{name}, {}", measure.name()),
                    points,
                    // R_v's points joined by lines, as the paper's.
                    markers_only: measure != Measure::Rv,
                    colour: 2 * k + usize::from(side == Side::N),
                });
            }
        }
    }
    out
}

fn star(
    end: &Option<EndPoint>,
    xy: &dyn Fn(&EndPoint) -> Option<(f64, f64)>,
) -> Vec<(String, f64, f64)> {
    end.as_ref()
        .and_then(|e| {
            let (x, y) = xy(e)?;
            Some((
                format!(
                    "critical end point * (between γ̇ τ_e = {:.0e} and {:.0e})",
                    e.below, e.above?
                ),
                x,
                y,
            ))
        })
        .into_iter()
        .collect()
}

/// Figs. 25, 26 and 29 at the Q nearest 1; the runs by slope class in the (P, γ̇) and
/// (P, Σ) planes, without the paper's numbers, when no boundary is found.
pub(super) fn add_figures(
    f: &mut Figures,
    rows: &[Row],
    c: &Classification,
    phi_j: f64,
    mu_j: &Option<MuJ>,
) -> Result<()> {
    // The Q nearest 1 with two rates (the contour needs them), else with one.
    let Some(q) = pick_q(rows).or_else(|| {
        rows.iter()
            .map(|r| r.q)
            .filter(|q| *q > 0.0)
            .min_by(|a, b| a.ln().abs().total_cmp(&b.ln().abs()))
    }) else {
        return Ok(());
    };
    let pts = points(rows, q);
    let end = end_point(rows, q);
    let p0 = choose_p(rows, q);
    if pts.is_empty() {
        f.blocks.push(Block::Paragraph(format!(
            "The coexistence region (Figs. 25, 26, 29): at Q = {q} no run is banded (R_v > {R_V_BANDED}) and no P^el kink or μ switch is found along φ, so the region's boundaries do not exist on this grid and the paper's figures are not drawn. The runs are shown by slope class in the (P, γ̇) and (P, Σ) planes instead."
        )));
        return runs_by_class(f, rows, c, mu_j);
    }
    let end_text = match &end {
        Some(e) => match e.above {
            Some(a) => format!(
                "the critical end point \"*\" lies between γ̇ τ_e = {:.1e}, the highest rate with a banded run (at φ ≈ {:.4}), and {a:.1e}, where no run is banded",
                e.below, e.phi
            ),
            None => format!(
                "the highest rate with a banded run is the grid's highest, {:.1e}: the critical end point lies beyond the grid",
                e.below
            ),
        },
        None => "no run is banded, so the grid does not bracket the critical end point".into(),
    };
    // Fig. 25.
    let mut series = series_of(&pts, &|p| Some((p.phi, p.rate)));
    if let Some(p0) = p0 {
        let line: Vec<(f64, f64, f64)> = contour(rows, q, p0)
            .iter()
            .map(|p| (p.phi, p.rate, 0.0))
            .collect();
        if !line.is_empty() {
            series.push(XySeries {
                label: format!("P = {p0:.3e}"),
                points: line,
                markers_only: false,
                colour: 6,
            });
        }
    }
    f.add(
        &Annotated {
            xy: XyFigure {
                title: format!("Coexistence region in the (φ, dγ/dt) plane, Q = {q} (Fig. 25)"),
                x_desc: "φ".into(),
                y_desc: "dγ/dt τ_e".into(),
                x_log: false,
                y_log: true,
                series,
            },
            overlay: Overlay {
                regions: vec![(
                    "coexistence (R_v)".into(),
                    region(&pts, &|p| Some(p.phi)),
                )],
                vlines: vec![(format!("φ_J = {phi_j:.4}"), phi_j)],
                stars: star(&end, &|e| Some((e.phi, e.rate()?))),
                ..Overlay::default()
            },
        },
        "coexistence_plane",
        format!(
            "φ_B(γ̇) and φ_N(γ̇) by the paper's three measures (R_v: the middle of its bracket, joined by lines; the P^el kinks; the μ switch — rules in the table above), the region between the R_v boundaries shaded, the contour of constant P{} and φ_J dashed; {end_text} (vagberg-sheared-disks Fig. 25).",
            p0.map_or(String::new(), |p| format!(" = {p:.3e} (the run pressure crossed at the most φ; the paper's is 2 × 10⁻⁵)"))
        ),
    )?;
    // Fig. 26.
    let with_p: Vec<BoundaryPoint> = pts.iter().filter(|p| p.p.is_some()).cloned().collect();
    if !with_p.is_empty() {
        f.add(
            &Annotated {
                xy: XyFigure {
                    title: format!("Coexistence region in the (P, dγ/dt) plane, Q = {q} (Fig. 26)"),
                    x_desc: "P = p τ_e² / m".into(),
                    y_desc: "dγ/dt τ_e".into(),
                    x_log: true,
                    y_log: true,
                    series: series_of(&with_p, &|p| Some((p.p?, p.rate))),
                },
                overlay: Overlay {
                    regions: vec![("coexistence (R_v)".into(), region(&with_p, &|p| p.p))],
                    vlines: p0
                        .map(|p| (format!("P = {p:.3e} contour"), p))
                        .into_iter()
                        .collect(),
                    stars: star(&end, &|e| Some((e.p?, e.rate()?))),
                    ..Overlay::default()
                },
            },
            "p_rate_plane",
            format!("P_B(γ̇) and P_N(γ̇): the pressure at each boundary point of Fig. 25 (interpolated along φ at its rate, linearly in φ against ln P), by the three measures, the region between the R_v boundaries shaded, the constant-P contour dashed; {end_text}. At fixed P, raising γ̇ crosses from Newtonian to Bagnoldian (vagberg-sheared-disks Fig. 26)."),
        )?;
    }
    // Fig. 29.
    let with_ps: Vec<BoundaryPoint> = with_p
        .iter()
        .filter(|p| p.sigma.is_some())
        .cloned()
        .collect();
    if !with_ps.is_empty() {
        let mut series = series_of(&with_ps, &|p| Some((p.p?, p.sigma?)));
        let ps: Vec<f64> = with_ps.iter().filter_map(|p| p.p).collect();
        series.extend(yield_line(mu_j, &ps, 6));
        f.add(
            &Annotated {
                xy: XyFigure {
                    title: format!("Transition line in the (P, Σ) plane, Q = {q} (Fig. 29)"),
                    x_desc: "P = p τ_e² / m".into(),
                    y_desc: "Σ = σ τ_e² / m".into(),
                    x_log: true,
                    y_log: true,
                    series,
                },
                overlay: Overlay {
                    stars: star(&end, &|e| Some((e.p?, e.sigma?))),
                    ..Overlay::default()
                },
            },
            "p_sigma_plane",
            "(P, Σ) at the Bagnoldian and Newtonian boundaries of Fig. 25 by the three measures: where the bands are in mechanical equilibrium they fall on one line, the first-order transition, ending at the critical end point; with the yield-stress line Σ = μ_J P (μ_J fitted below; the paper quotes μ_J ≈ 0.1) (vagberg-sheared-disks Fig. 29).".into(),
        )?;
    }
    f.blocks.push(Block::Paragraph(contour_check(rows, q)));
    Ok(())
}

/// The yield-stress line Σ = μ_J P across the pressures `ps` (none without a positive
/// μ_J or a positive pressure).
fn yield_line(mu_j: &Option<MuJ>, ps: &[f64], colour: usize) -> Option<XySeries> {
    let m = mu_j.as_ref().filter(|m| m.value > 0.0)?;
    let ps = ps.iter().copied().filter(|p| *p > 0.0 && p.is_finite());
    let (lo, hi) = ps.fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p), b.max(p)));
    (hi > 0.0).then(|| XySeries {
        label: format!("Σ = μ_J P, μ_J = {:.3}", m.value),
        points: vec![(lo, m.value * lo, 0.0), (hi, m.value * hi, 0.0)],
        markers_only: false,
        colour,
    })
}

/// Every run in the (P, γ̇) and (P, Σ) planes by the slope class of its (φ, Q): what
/// the report shows where the coexistence boundaries do not exist.
fn runs_by_class(
    f: &mut Figures,
    rows: &[Row],
    c: &Classification,
    mu_j: &Option<MuJ>,
) -> Result<()> {
    let plane = by_class(rows, c, &|r| Some((r.get("p")?.0, r.rate)));
    if !plane.is_empty() {
        f.add(
            &XyFigure {
                title: "Runs in the (P, dγ/dt) plane by slope class".into(),
                x_desc: "P = p τ_e² / m".into(),
                y_desc: "dγ/dt · τ_e".into(),
                x_log: true,
                y_log: true,
                series: plane,
            },
            "p_rate_runs",
            "Every run at its pressure P and strain rate, coloured by the class of its (φ, Q) over all the grid's rates (the slope classification above): at fixed P the Newtonian runs lie at small γ̇, the Bagnoldian ones at large γ̇. The paper's Fig. 26 draws the coexistence region in this plane, which needs banded runs.".into(),
        )?;
    }
    let mut stress = by_class(rows, c, &|r| Some((r.get("p")?.0, r.get("sigma")?.0)));
    if stress.is_empty() {
        return Ok(());
    }
    let ps: Vec<f64> = stress
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .collect();
    stress.extend(yield_line(mu_j, &ps, 3));
    f.add(
        &XyFigure {
            title: "Runs in the (P, Σ) plane by slope class, with Σ = μ_J P".into(),
            x_desc: "P = p τ_e² / m".into(),
            y_desc: "Σ = σ τ_e² / m".into(),
            x_log: true,
            y_log: true,
            series: stress,
        },
        "p_sigma_runs",
        "Every run at its pressure P and shear stress Σ, coloured by class, with the yield stress line Σ = μ_J P (μ_J fitted below): runs at the lowest rates and φ near φ_J approach it. The paper's Fig. 29 draws the transition line of the coexistence boundaries in this plane, which needs banded runs.".into(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(phi: f64, rate: f64, p: f64, sigma: f64, r_v: f64) -> Row {
        let values = [("p", p), ("sigma", sigma), ("mu", sigma / p), ("r_v", r_v)];
        Row::with(phi, 1.0, rate, &values)
    }

    /// A planted grid: φ 0.76–0.84 by 0.01 at rates 1e-5, 1e-4, 1e-3. Banded (R_v = 10)
    /// at 1e-5 over 0.79–0.81 and at 1e-4 over 0.80 only; nothing banded at 1e-3. So by
    /// hand: R_v's φ_B = 0.785, φ_N = 0.815 at 1e-5, and 0.795, 0.805 at 1e-4; the region
    /// is the four corners; the end point lies between 1e-4 and 1e-3 at φ = 0.80; P at
    /// φ_B = 0.785, 1e-5 is the geometric mean of P at 0.78 and 0.79. P = γ̇² e^k at the
    /// k-th φ: the run pressures 1e-6, 1e-8 e^4 and 1e-10 e^8 are each crossed at all
    /// nine φ, and 1e-6 is the nearest the paper's 2e-5, so the contour is P = 1e-6,
    /// through γ̇ = 1e-3 e^(−k/2): at φ = 0.79 γ̇ = 2.2e-4 (R_v 1, between 1e-4 and 1e-3),
    /// at 0.80 γ̇ = 1.35e-4 (R_v 8.8 interpolated in ln γ̇): it enters the banded stretch
    /// between 0.79 and 0.80, at the grid rate 1e-4 where R_v brackets φ_B the same.
    fn planted() -> Vec<Row> {
        let mut rows = Vec::new();
        for k in 0..9 {
            let phi = 0.76 + 0.01 * k as f64;
            let phi = (phi * 100.0).round() / 100.0;
            for &rate in &[1e-5, 1e-4, 1e-3] {
                let banded =
                    (rate == 1e-5 && (0.79..=0.81).contains(&phi)) || (rate == 1e-4 && phi == 0.80);
                let p = rate * rate * (k as f64).exp();
                rows.push(row(phi, rate, p, 0.3 * p, if banded { 10.0 } else { 1.0 }));
            }
        }
        rows
    }

    /// The same runs with R_v = 1 everywhere: nothing banded.
    fn unbanded(rows: &[Row]) -> Vec<Row> {
        rows.iter()
            .cloned()
            .map(|mut r| {
                r.v.insert("r_v".into(), (1.0, 0.0));
                r
            })
            .collect()
    }

    #[test]
    fn boundaries_region_and_end_point_by_hand() {
        let rows = planted();
        let pts = points(&rows, 1.0);
        let rv: Vec<(Side, f64, f64)> = pts
            .iter()
            .filter(|p| p.measure == Measure::Rv)
            .map(|p| (p.side, p.rate, p.phi))
            .collect();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert_eq!(rv.len(), 4, "{rv:?}");
        for (side, rate, phi) in [
            (Side::B, 1e-5, 0.785),
            (Side::N, 1e-5, 0.815),
            (Side::B, 1e-4, 0.795),
            (Side::N, 1e-4, 0.805),
        ] {
            assert!(
                rv.iter()
                    .any(|p| p.0 == side && p.1 == rate && close(p.2, phi)),
                "{side:?} {rate} {phi}: {rv:?}"
            );
        }
        let b = pts
            .iter()
            .find(|p| p.measure == Measure::Rv && p.side == Side::B && p.rate == 1e-5)
            .unwrap();
        let want = (1e-10 * 2f64.exp() * 1e-10 * 3f64.exp()).sqrt();
        assert!((b.p.unwrap() / want - 1.0).abs() < 1e-12, "{b:?}");
        assert!((b.sigma.unwrap() / (0.3 * want) - 1.0).abs() < 1e-12);
        let poly = region(&pts, &|p| Some(p.phi));
        let want_poly = [(0.785, 1e-5), (0.795, 1e-4), (0.805, 1e-4), (0.815, 1e-5)];
        assert_eq!(poly.len(), 4);
        for (a, w) in poly.iter().zip(want_poly) {
            assert!(close(a.0, w.0) && a.1 == w.1, "{poly:?}");
        }
        let e = end_point(&rows, 1.0).unwrap();
        assert_eq!((e.below, e.above), (1e-4, Some(1e-3)));
        assert!(close(e.phi, 0.80));
        assert!((e.rate().unwrap() / (1e-7f64).sqrt() - 1.0).abs() < 1e-12);
        // Banded at the grid's top rate: the end point is beyond the grid.
        let top: Vec<Row> = rows.iter().filter(|r| r.rate < 1e-3).cloned().collect();
        assert_eq!(end_point(&top, 1.0).unwrap().above, None);
        // Nothing banded: no end point; along_phi is exact at a run.
        let flat = unbanded(&rows);
        assert_eq!(end_point(&flat, 1.0), None);
        assert_eq!(
            along_phi(&rows, 1.0, 1e-4, 0.80, "p"),
            Some(1e-8 * 4f64.exp())
        );
    }

    #[test]
    fn the_contour_check_names_agreement_within_a_grid_step() {
        let rows = planted();
        assert_eq!(choose_p(&rows, 1.0), Some(1e-6));
        let text = contour_check(&rows, 1.0);
        assert!(text.starts_with("Check — the constant-P contour"), "{text}");
        assert!(text.contains("between φ = 0.79 and 0.8"), "{text}");
        assert!(
            text.contains("R_v at γ̇ τ_e = 1.0e-4 puts it at 0.7950 (0.0 grid steps away: agrees)"),
            "{text}"
        );
        assert!(text.ends_with("Holds where the data allow."), "{text}");
        // No banded run: the check says it is not made, and why.
        let flat = unbanded(&rows);
        let text = contour_check(&flat, 1.0);
        assert!(
            text.contains("not made at Q = 1, the contour P = ")
                && text.contains("meets no banded run"),
            "{text}"
        );
        // A P^el kink two and a half grid steps below the contour's φ_B: ln P^el at
        // γ̇ τ_e = 1e-4 rises by 1 a step but by 20 from φ = 0.77 to 0.78, so the kink's
        // φ_B is 0.77 against the contour's 0.795. The check names it and fails.
        let kinked: Vec<Row> = rows
            .iter()
            .cloned()
            .map(|mut r| {
                if r.rate == 1e-4 {
                    let k = ((r.phi - 0.76) * 100.0).round();
                    let ln = k + if k >= 2.0 { 19.0 } else { 0.0 };
                    r.v.insert("p_el".into(), (ln.exp() * 1e-12, 0.0));
                }
                r
            })
            .collect();
        let text = contour_check(&kinked, 1.0);
        assert!(
            text.contains("the P^el kink at γ̇ τ_e = 1.0e-4 puts it at 0.7700 (2.5 grid steps away: does not agree)"),
            "{text}"
        );
        assert!(text.ends_with("Does not hold here."), "{text}");
    }
}
