//! A sweep's figures on the paper's remaining axes (vagberg-sheared-disks): Z beside
//! 2τ_dur ν_coll against Q (Figs. 4–5, 12–13), Σ against γ̇ (Fig. 30), and μ_J, the
//! friction at jamming, fitted for the yield line Σ = μ_J P of Fig. 29 (drawn by
//! `phase_boundaries`). In the units of the runs (d_s = m = τ_e = 1) the dimensionless
//! P = p τ_e²/m and Σ = σ τ_e²/m (Eq. 18) are the summaries' `p` and `sigma`.

use super::classify::Class;
use super::coexistence::R_V_BANDED;
use super::{Classification, Figures, Row, key, series_along, versus_q};
use crate::error::Result;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use std::collections::BTreeMap;

/// The μ_J fit uses at most this many runs, those of smallest inertial number.
pub const MU_J_RUNS: usize = 8;
/// Runs within this of φ_J count for μ_J.
pub const MU_J_WINDOW: f64 = 0.02;

/// μ_J, the macroscopic friction at jamming, fitted with its 95 % interval.
#[derive(Debug, Clone, PartialEq)]
pub struct MuJ {
    pub value: f64,
    pub interval: [f64; 2],
    /// dμ/dI of the fit.
    pub slope: f64,
    /// The runs fitted, and the largest I among them.
    pub runs: usize,
    pub i_max: f64,
    /// The φ_J the window was centred on.
    pub phi_j: f64,
}

/// The inertial number of a run, I = γ̇ τ_e / √P: I = γ̇ d √(ρ/p) of dense granular
/// flow (GDR MiDi 2004) in the runs' units (d_s = m = τ_e = 1, so ρ = m/d_s² = 1 and
/// P = p τ_e²/m, Eq. 18).
pub fn inertial_number(r: &Row) -> Option<f64> {
    let p = r.get("p")?.0;
    (p > 0.0).then(|| r.rate / p.sqrt())
}

/// μ_J fitted as the intercept of μ = μ_J + c I over the [`MU_J_RUNS`] runs of
/// smallest inertial number I (at least three) among those within [`MU_J_WINDOW`] of
/// `phi_j`: μ_J is μ at jamming as γ̇ → 0, and near φ_J both the Newtonian and the
/// Bagnoldian branch reach it as I → 0 (I ∝ γ̇^(1 − q/2) there, q ≈ 0.3 the critical
/// exponent of p, so nearly linear in γ̇; just above φ_J the yield stress ratio of
/// frictionless disks lies close to μ_J). Runs far from φ_J are left out: below it a
/// Newtonian run's I → 0 while μ stays at μ(φ), not μ_J. The interval is the
/// intercept's Student interval. `None` with fewer than three such runs or one I.
pub fn mu_j(rows: &[Row], phi_j: f64) -> Option<MuJ> {
    let mut pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| (r.phi - phi_j).abs() <= MU_J_WINDOW + 1e-12)
        .filter_map(|r| Some((inertial_number(r)?, r.get("mu")?.0)))
        .filter(|(i, mu)| i.is_finite() && mu.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    pts.truncate(MU_J_RUNS);
    if pts.len() < 3 {
        return None;
    }
    let (x, y): (Vec<f64>, Vec<f64>) = pts.iter().copied().unzip();
    let fit = crate::stats::line_fit(&x, &y)?;
    Some(MuJ {
        value: fit.intercept,
        interval: fit.intercept_interval,
        slope: fit.slope,
        runs: fit.n,
        i_max: x[x.len() - 1],
        phi_j,
    })
}

/// The μ_J paragraph; `phi_j` says where φ_J came from.
pub fn mu_j_paragraph(m: &Option<MuJ>, phi_j: &str) -> String {
    match m {
        Some(m) => format!(
            "μ_J = {:.4} [{:.4}, {:.4}] (95 %): the intercept of μ = μ_J + c I, c = {:.3}, fitted over the {} runs of smallest inertial number I = γ̇ τ_e/√P (up to I = {:.3e}) within {MU_J_WINDOW} of φ_J = {phi_j}: near φ_J both rheologies reach μ_J as γ̇ → 0, I → 0; runs further away are left out (a Newtonian run's μ stays at μ(φ) as γ̇ → 0).{} The paper quotes μ_J ≈ 0.1 from its earlier work (vagberg-sheared-disks, text beside Fig. 29).",
            m.value,
            m.interval[0],
            m.interval[1],
            m.slope,
            m.runs,
            m.i_max,
            if m.value > 0.0 {
                ""
            } else {
                " Not positive, so the yield line Σ = μ_J P is not drawn."
            }
        ),
        None => format!(
            "μ_J not fitted: it needs three runs within {MU_J_WINDOW} of φ_J = {phi_j}, with a pressure and a friction μ, at two inertial numbers or more, so the yield line Σ = μ_J P is not drawn."
        ),
    }
}

/// The class of each (φ, Q) over all its rates.
fn classes(c: &Classification) -> BTreeMap<(i64, i64), Class> {
    c.slopes
        .iter()
        .filter(|s| s.scope == "all")
        .map(|s| ((key(s.phi), key(s.q)), s.slope.class))
        .collect()
}

/// The runs as points (x, y) split by the class of their (φ, Q): one marker series
/// per class.
pub(super) fn by_class(
    rows: &[Row],
    c: &Classification,
    xy: &dyn Fn(&Row) -> Option<(f64, f64)>,
) -> Vec<XySeries> {
    let cls = classes(c);
    [
        (Class::Newtonian, "Newtonian"),
        (Class::Bagnoldian, "Bagnoldian"),
        (Class::Undecided, "undecided or unclassified"),
    ]
    .into_iter()
    .enumerate()
    .filter_map(|(colour, (class, name))| {
        let points: Vec<(f64, f64, f64)> = rows
            .iter()
            .filter(|r| {
                cls.get(&(key(r.phi), key(r.q)))
                    .copied()
                    .unwrap_or(Class::Undecided)
                    == class
            })
            .filter_map(|r| xy(r).map(|(x, y)| (x, y, 0.0)))
            .filter(|(x, y, _)| *x > 0.0 && *y > 0.0)
            .collect();
        (!points.is_empty()).then(|| XySeries {
            label: name.into(),
            points,
            markers_only: true,
            colour,
        })
    })
    .collect()
}

/// Z beside 2τ_dur ν_coll against Q (Figs. 4–5, 12–13) and Σ against γ̇ (Fig. 30).
pub(super) fn add_figures(f: &mut Figures, rows: &[Row]) -> Result<()> {
    let qs = {
        let mut v: Vec<i64> = rows.iter().map(|r| key(r.q)).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    if qs > 1 {
        let mut series = versus_q(rows, "z");
        let n = series.len().max(1);
        for mut s in versus_q(rows, "two_tau_dur_nu_coll") {
            s.label = format!("2τν, {}", s.label);
            s.markers_only = true;
            s.colour %= n;
            series.push(s);
        }
        if let (Some(lo), Some(hi)) = (
            rows.iter().map(|r| r.q).min_by(f64::total_cmp),
            rows.iter().map(|r| r.q).max_by(f64::total_cmp),
        ) {
            series.push(XySeries {
                label: "Z_iso = 4".into(),
                points: vec![(lo, 4.0, 0.0), (hi, 4.0, 0.0)],
                markers_only: false,
                colour: n,
            });
        }
        f.add(
            &XyFigure {
                title: "Z and 2 τ_dur ν_coll against Q (Figs. 4–5, 12–13)".into(),
                x_desc: "Q".into(),
                y_desc: "Z, 2 τ_dur ν_coll (contacts per particle)".into(),
                x_log: true,
                y_log: false,
                series,
            },
            "z_vs_q",
            "The contact number Z (lines) and 2 τ_dur ν_coll (markers) against Q for each (φ, γ̇), with the isostatic Z_iso = 4: Z drops sharply where the rheology turns from Newtonian (small Q) to Bagnoldian (vagberg-sheared-disks Figs. 4–5 for CD, 12–13 for CDrot).".into(),
        )?;
    }
    let mut sigma = series_along(rows, super::Along::Rate, "sigma", "", false, None);
    if !sigma.is_empty() {
        // The banded runs, ringed: along γ̇ at one φ they lie between γ̇_B and γ̇_N.
        let banded: Vec<(f64, f64, f64)> = rows
            .iter()
            .filter(|r| r.get("r_v").is_some_and(|v| v.0 > R_V_BANDED))
            .filter_map(|r| r.get("sigma").map(|s| (r.rate, s.0, 0.0)))
            .collect();
        let n = sigma.len();
        if !banded.is_empty() {
            sigma.push(XySeries {
                label: format!("shear banded (R_v > {R_V_BANDED})"),
                points: banded,
                markers_only: true,
                colour: n,
            });
        }
        f.add(
            &XyFigure {
                title: "Σ against dγ/dt (Fig. 30)".into(),
                x_desc: "dγ/dt · τ_e".into(),
                y_desc: "Σ = σ τ_e² / m".into(),
                x_log: true,
                y_log: true,
                series: sigma,
            },
            "sigma_vs_rate",
            format!("The dimensionless shear stress Σ against γ̇ τ_e for each (φ, Q): Σ ∝ γ̇ where Newtonian, ∝ γ̇² where Bagnoldian, flat through a shear-banded coexistence region, whose runs (R_v > {R_V_BANDED}) are ringed: along γ̇ at one φ they lie between the paper's γ̇_B and γ̇_N (vagberg-sheared-disks Fig. 30 at φ = 0.802)."),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run with pressure P and friction μ at rate γ̇: I = γ̇/√P.
    fn row(rate: f64, p: f64, mu: f64) -> Row {
        Row {
            phi: 0.8,
            q: 1.0,
            rate,
            v: [("mu".to_string(), (mu, 0.01)), ("p".to_string(), (p, 0.0))].into(),
        }
    }

    /// μ = 0.1 + 2 I exactly on the eight runs of smallest I at φ = 0.835 (I = 0.01 …
    /// 0.08, P = 1e-4 so γ̇ = I/100), and far off the line at larger I (left out):
    /// μ_J = 0.1 with no width, c = 2. Runs further than 0.02 from φ_J, however small
    /// their I, are left out.
    #[test]
    fn mu_j_is_the_intercept_of_mu_against_the_inertial_number_near_jamming() {
        let near = |rate: f64, p: f64, mu: f64| Row {
            phi: 0.835,
            ..row(rate, p, mu)
        };
        let mut rows: Vec<Row> = (1..=8)
            .map(|k| {
                let i = 0.01 * k as f64;
                near(i / 100.0, 1e-4, 0.1 + 2.0 * i)
            })
            .collect();
        rows.push(near(0.5 / 100.0, 1e-4, 5.0));
        rows.push(near(0.9 / 100.0, 1e-4, -3.0));
        let m = mu_j(&rows, 0.8433).unwrap();
        assert!(
            (m.value - 0.1).abs() < 1e-12 && (m.slope - 2.0).abs() < 1e-9,
            "{m:?}"
        );
        assert!((m.interval[1] - m.interval[0]).abs() < 1e-9, "{m:?}");
        assert_eq!(m.runs, MU_J_RUNS);
        assert!((m.i_max - 0.08).abs() < 1e-12);
        assert!((inertial_number(&rows[0]).unwrap() - 0.01).abs() < 1e-15);
        // Newtonian runs at φ = 0.80 with the smallest I of all and μ = 0.5: left out.
        let mut with_far = rows.clone();
        with_far.extend((1..=4).map(|k| row(1e-6 * k as f64, 1e-4, 0.5)));
        assert_eq!(mu_j(&with_far, 0.8433), Some(m.clone()));
        // Scatter widens the interval around the same intercept: ±0.01 alternating.
        let noisy: Vec<Row> = (1..=8)
            .map(|k| {
                let i = 0.01 * k as f64;
                near(
                    i / 100.0,
                    1e-4,
                    0.1 + 2.0 * i + if k % 2 == 0 { 0.01 } else { -0.01 },
                )
            })
            .collect();
        let m = mu_j(&noisy, 0.8433).unwrap();
        assert!(m.interval[0] < m.value && m.value < m.interval[1], "{m:?}");
        assert!(m.interval[0] < 0.1 && 0.1 < m.interval[1], "{m:?}");
        // Two runs, or none near φ_J: no fit.
        assert_eq!(mu_j(&rows[..2], 0.8433), None);
        assert_eq!(mu_j(&rows, 0.80), None);
    }
}
