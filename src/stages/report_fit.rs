//! The report's crossover section: D²min/R² against η^s with both fits (Li et al.
//! Fig. 8), the table of Θ and η_c with intervals, and whether the two fits agree.

use super::fit::{FitReport, num, read_fit};
use super::report::DatasetInputs;
use super::report_sections::rel;
use crate::error::Result;
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::report::figures::{CrossoverFigure, CrossoverSeries};
use crate::report::html::{Block, Section};
use crate::report::{SavedFigure, save};
use std::path::Path;

/// Most points drawn per data set in the scatter (every k-th, deterministic).
const MAX_SCATTER: usize = 6000;

fn scatter_points(fit: &FitReport) -> Result<Vec<(f64, f64)>> {
    let t = read_table(
        Path::new(&fit.scatter),
        &[("eta_s", Expect::Float), ("d2min_over_r2", Expect::Float)],
    )?;
    let (e, y) = (t.f64("eta_s")?, t.f64("d2min_over_r2")?);
    let stride = e.len().div_ceil(MAX_SCATTER).max(1);
    Ok(e.iter()
        .zip(&y)
        .step_by(stride)
        .map(|(&a, &b)| (a, b))
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .collect())
}

fn fit_rows(fits: &[(String, FitReport)]) -> Vec<Vec<String>> {
    fits.iter()
        .map(|(label, f)| {
            let flag = |ok: bool| if ok { "" } else { " (not constrained)" };
            vec![
                label.clone(),
                f.method.name().to_string(),
                format!(
                    "{} [{}, {}]{}",
                    num(f.theta),
                    num(f.theta_interval[0]),
                    num(f.theta_interval[1]),
                    flag(f.theta_constrained)
                ),
                format!(
                    "{} [{}, {}]{}",
                    num(f.eta_c),
                    num(f.eta_c_interval[0]),
                    num(f.eta_c_interval[1]),
                    flag(f.eta_c_constrained)
                ),
                f.n_points.to_string(),
                f.n_starts.to_string(),
                format!("{:?}", f.protocol.lags_frames),
            ]
        })
        .collect()
}

/// The crossover section, or None when no data set has a fit. Saves its figure under
/// `figdir` and appends it to `figures`.
pub fn crossover_section(
    datasets: &[DatasetInputs],
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Option<Section>> {
    let mut fits: Vec<(String, FitReport)> = Vec::new();
    for d in datasets {
        if let Some(p) = &d.fit {
            fits.push((d.label.clone(), read_fit(p)?));
        }
    }
    if fits.is_empty() {
        return Ok(None);
    }
    {
        let mut series = Vec::new();
        for (label, f) in &fits {
            let binned = f
                .estimators
                .get(f.method.name())
                .and_then(|v| v.get("curve"))
                .and_then(|c| serde_json::from_value::<Vec<crate::fit::BinPoint>>(c.clone()).ok())
                .unwrap_or_default()
                .iter()
                .map(|b| (b.eta_s, b.d2min_over_r2))
                .collect();
            series.push(CrossoverSeries {
                label: label.clone(),
                points: scatter_points(f)?,
                binned,
                theta: f.theta,
                eta_c: f.eta_c,
            });
        }
        let fig = save(&CrossoverFigure { series }, &figdir.join("crossover"))?;
        let mut blocks = vec![
            Block::Figure {
                id: "fig-crossover".into(),
                caption: "D²min/R² against η^s: every sample (faint), the binned curve of the fit's estimator, and Eq. 19 with the fitted Θ, η_c (Li et al. Fig. 8).".into(),
                svg: fig.svg_text.clone(),
                png: rel(&fig),
            },
            Block::Table {
                header: ["data", "estimator", "Θ [95% CI]", "η_c [95% CI]", "points", "starts", "lags (frames)"].map(String::from).to_vec(),
                rows: fit_rows(&fits),
            },
        ];
        if fits.len() == 2 {
            let (a, b) = (&fits[0].1, &fits[1].1);
            let text = match super::compare::incompatibility(a, b) {
                Some(why) => format!("Not compared: the fits were made differently ({why})."),
                None => {
                    let ov = |x: [f64; 2], y: [f64; 2]| x[0] <= y[1] && y[0] <= x[1];
                    format!(
                        "Same estimator, R_c and lags: Θ {} and η_c {} within their 95% intervals.",
                        if ov(a.theta_interval, b.theta_interval) {
                            "agree"
                        } else {
                            "differ"
                        },
                        if ov(a.eta_c_interval, b.eta_c_interval) {
                            "agree"
                        } else {
                            "differ"
                        }
                    )
                }
            };
            blocks.push(Block::Paragraph(text));
        }
        for (label, f) in &fits {
            for n in &f.notes {
                blocks.push(Block::Paragraph(format!("{label}: {n}")));
            }
        }
        figures.push(fig);
        Ok(Some(Section {
            id: "crossover".into(),
            title: "Deformation-driven diffusion".into(),
            blocks,
        }))
    }
}
