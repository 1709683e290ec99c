//! A sweep's figures on the paper's remaining axes (vagberg-sheared-disks): Z beside
//! 2τ_dur ν_coll against Q (Figs. 4–5, 12–13), Σ against γ̇ (Fig. 30), the (P, γ̇)
//! plane (Fig. 26) and the (P, Σ) plane with the yield line Σ = μ_J P (Fig. 29). In the
//! units of the runs (d_s = m = τ_e = 1) the dimensionless P = p τ_e²/m and
//! Σ = σ τ_e²/m (Eq. 18) are the summaries' `p` and `sigma`.

use super::classify::Class;
use super::jamming::PhiJ;
use super::{Classification, Figures, Row, key, series_along, versus_q};
use crate::error::Result;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::html::Block;
use std::collections::BTreeMap;

/// Runs within this of φ_J (`jamming::estimate`: from the grid, else the paper's 0.8433)
/// count for μ_J.
pub const PHI_J_WINDOW: f64 = 0.01;

/// μ_J, the macroscopic friction at jamming, and its standard error: the mean of
/// μ = Σ/P over the runs at the grid's lowest strain rate with |φ − φ_J| ≤ 0.01 (μ
/// approaches μ_J there as γ̇ → 0), the error from their spread, or from the runs' own
/// errors when there is one run. `None` when no run is that close to φ_J.
pub fn mu_j(rows: &[Row], phi_j: f64) -> Option<(f64, f64, usize)> {
    let lowest = rows.iter().map(|r| r.rate).min_by(f64::total_cmp)?;
    let mus: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.rate == lowest && (r.phi - phi_j).abs() <= PHI_J_WINDOW)
        .filter_map(|r| r.get("mu"))
        .collect();
    let n = mus.len();
    if n == 0 {
        return None;
    }
    let mean = mus.iter().map(|m| m.0).sum::<f64>() / n as f64;
    let err = if n > 1 {
        let var = mus.iter().map(|m| (m.0 - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        (var / n as f64).sqrt()
    } else {
        mus[0].1
    };
    Some((mean, err, n))
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
fn by_class(
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

pub(super) fn add_figures(
    f: &mut Figures,
    rows: &[Row],
    c: &Classification,
    phi_j: &PhiJ,
) -> Result<()> {
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
                y_desc: "contacts per particle".into(),
                x_log: true,
                y_log: false,
                series,
            },
            "z_vs_q",
            "The contact number Z (lines) and 2 τ_dur ν_coll (markers) against Q for each (φ, γ̇), with the isostatic Z_iso = 4: Z drops sharply where the rheology turns from Newtonian (small Q) to Bagnoldian (vagberg-sheared-disks Figs. 4–5 for CD, 12–13 for CDrot).".into(),
        )?;
    }
    let sigma = series_along(rows, super::Along::Rate, "sigma", "", false, None);
    if !sigma.is_empty() {
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
            "The dimensionless shear stress Σ against γ̇ τ_e for each (φ, Q): Σ ∝ γ̇ where Newtonian, ∝ γ̇² where Bagnoldian, flat through a shear-banded coexistence region (vagberg-sheared-disks Fig. 30 at φ = 0.802).".into(),
        )?;
    }
    let plane = by_class(rows, c, &|r| Some((r.get("p")?.0, r.rate)));
    if !plane.is_empty() {
        f.add(
            &XyFigure {
                title: "Phase diagram in the (P, dγ/dt) plane (Fig. 26)".into(),
                x_desc: "P = p τ_e² / m".into(),
                y_desc: "dγ/dt · τ_e".into(),
                x_log: true,
                y_log: true,
                series: plane,
            },
            "p_rate_plane",
            "Every run at its pressure P and strain rate, coloured by the class of its (φ, Q) over all the grid's rates (the slope classification above): at fixed P the Newtonian runs lie at small γ̇, the Bagnoldian ones at large γ̇ (vagberg-sheared-disks Fig. 26, Q = 1; the coexistence region between them needs the band analysis, not done here).".into(),
        )?;
    }
    let mut stress = by_class(rows, c, &|r| Some((r.get("p")?.0, r.get("sigma")?.0)));
    if stress.is_empty() {
        return Ok(());
    }
    let line = mu_j(rows, phi_j.value);
    if let Some((mu, _, _)) = line {
        let ps: Vec<f64> = stress
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0))
            .collect();
        let lo = ps.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ps.iter().copied().fold(0.0, f64::max);
        stress.push(XySeries {
            label: format!("Σ = μ_J P, μ_J = {mu:.3}"),
            points: vec![(lo, mu * lo, 0.0), (hi, mu * hi, 0.0)],
            markers_only: false,
            colour: 3,
        });
    }
    f.add(
        &XyFigure {
            title: "Phase diagram in the (P, Σ) plane with Σ = μ_J P (Fig. 29)".into(),
            x_desc: "P = p τ_e² / m".into(),
            y_desc: "Σ = σ τ_e² / m".into(),
            x_log: true,
            y_log: true,
            series: stress,
        },
        "p_sigma_plane",
        "Every run at its pressure P and shear stress Σ, coloured by class, with the yield stress line Σ = μ_J P: runs at the lowest rates and φ near φ_J approach it (vagberg-sheared-disks Fig. 29).".into(),
    )?;
    f.blocks.push(Block::Paragraph(match line {
        Some((mu, err, n)) => format!(
            "μ_J = {mu:.4} ± {err:.4}: the mean of μ = Σ/P over the {n} run(s) at the grid's lowest strain rate with |φ − φ_J| ≤ {PHI_J_WINDOW} ({}), the error from their spread (from the run's own error when there is one). A rule, not a fit to γ̇ → 0: at a finite rate μ lies above μ_J.",
            phi_j.describe()
        ),
        None => format!(
            "μ_J not estimated: no run lies within {PHI_J_WINDOW} of φ_J at the grid's lowest strain rate, so the yield line Σ = μ_J P is not drawn ({}).",
            phi_j.describe()
        ),
    }));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(phi: f64, rate: f64, mu: f64) -> Row {
        Row {
            phi,
            q: 1.0,
            rate,
            v: [("mu".to_string(), (mu, 0.01))].into(),
        }
    }

    #[test]
    fn mu_j_averages_the_slowest_runs_near_jamming() {
        let rows = [
            row(0.84, 1e-5, 0.10),
            row(0.845, 1e-5, 0.12),
            row(0.80, 1e-5, 0.5),
            row(0.84, 1e-4, 0.3),
        ];
        let (mu, err, n) = mu_j(&rows, 0.8433).unwrap();
        assert_eq!(n, 2);
        assert!((mu - 0.11).abs() < 1e-12);
        // Sample standard deviation 0.01414 over √2.
        assert!((err - 0.01).abs() < 1e-12, "{err}");
        assert_eq!(mu_j(&rows[2..3], 0.8433), None);
        let (_, err, n) = mu_j(&rows[..1], 0.8433).unwrap();
        assert_eq!((n, err), (1, 0.01));
    }
}
