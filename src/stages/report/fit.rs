//! The report's crossover section: D²min/R² against η^s with both fits (Li et al.
//! Fig. 8), the table of Θ and η_c with intervals, and whether the two fits agree.

use crate::error::Result;
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::stages::fit::{FitReport, num, read_fit, with_interval};
use crate::stages::report::DatasetInputs;
use crate::stages::report::render::figures::{CrossoverFigure, CrossoverSeries};
use crate::stages::report::render::html::{Block, Section};
use crate::stages::report::render::{SavedFigure, save};
use crate::stages::report::sections::rel;
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
            vec![
                label.clone(),
                f.method.name().to_string(),
                with_interval(f.theta, f.theta_interval, f.theta_constrained),
                with_interval(f.eta_c, f.eta_c_interval, f.eta_c_constrained),
                f.range.as_ref().map_or("all".into(), |r| {
                    format!("[{}, {}] ({})", num(r.lo), num(r.hi), r.rule.name())
                }),
                f.n_points.to_string(),
                f.n_starts.to_string(),
                format!("{:?}", f.protocol.lags_frames),
            ]
        })
        .collect()
}

/// Θ / η_c of every estimator (rows) for each upper end of the fitted η^s (columns),
/// beside the paper's values: how much the headline depends on choices the paper does
/// not state.
fn sensitivity_table(label: &str, f: &FitReport) -> Block {
    let mut his: Vec<f64> = f.sensitivity.iter().map(|r| r.hi).collect();
    his.sort_by(f64::total_cmp);
    his.dedup();
    let mut rcs: Vec<f64> = f.sensitivity.iter().map(|r| r.rc_over_d).collect();
    rcs.sort_by(f64::total_cmp);
    rcs.dedup();
    let mut header = vec![format!("{label}: estimator, R_c (Θ / η_c)")];
    header.extend(his.iter().map(|h| {
        if h.is_finite() {
            format!("η^s ≤ {h}")
        } else {
            "all η^s".into()
        }
    }));
    let cells = crate::fit::Method::ALL
        .iter()
        .flat_map(|m| rcs.iter().map(move |rc| (*m, *rc)));
    let mut rows: Vec<Vec<String>> = cells
        .map(|(m, rc)| {
            let mut row = vec![format!("{}, {rc} D", m.name())];
            for h in &his {
                let cell = f
                    .sensitivity
                    .iter()
                    .find(|r| r.method == m && r.hi == *h && r.rc_over_d == rc)
                    .filter(|r| r.theta.is_finite())
                    .map_or("—".into(), |r| {
                        format!("{} / {}", num(r.theta), num(r.eta_c))
                    });
                row.push(cell);
            }
            row
        })
        .collect();
    let mut paper = vec!["Li et al. (paper)".to_string()];
    paper.extend(his.iter().map(|_| "0.3 / 0.05".to_string()));
    rows.push(paper);
    Block::Table { header, rows }
}

/// The crossover figure (Li et al. Fig. 8: D²min/R² against η^s, both dimensionless,
/// on log axes, with Eq. 19 over the fitted range) of labelled fits, saved as
/// `stem.png` and `stem.svg`: what the report shows, for callers that want the figure
/// alone (the Python package's `crossover_figure`).
pub fn crossover_figure(fits: &[(String, FitReport)], stem: &Path) -> Result<SavedFigure> {
    let mut series = Vec::new();
    for (label, f) in fits {
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
            theta_constrained: f.theta_constrained,
            eta_c_constrained: f.eta_c_constrained,
            range: f.range.as_ref().map(|r| (r.lo, r.hi)),
            excluded: f.range.as_ref().map_or(Vec::new(), |r| {
                r.excluded
                    .iter()
                    .map(|b| (b.eta_s, b.d2min_over_r2))
                    .collect()
            }),
        });
    }
    save(&CrossoverFigure { series }, stem)
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
        let fig = crossover_figure(&fits, &figdir.join("crossover"))?;
        let mut blocks = vec![
            Block::Figure {
                id: "fig-crossover".into(),
                caption: "D²min/R² against η^s: every sample (faint), the binned curve of the fit's estimator, bins left out of the fit (grey rings; see below why), and Eq. 19 with the fitted Θ, η_c over the fitted range (Li et al. Fig. 8; the paper finds Θ ≈ 0.3, η_c ≈ 0.05).".into(),
                svg: fig.svg_text.clone(),
                png: rel(&fig),
            },
            Block::Table {
                header: ["data", "estimator", "Θ [95% CI]", "η_c [95% CI]", "fitted η^s (rule)", "points", "starts", "lags (frames)"].map(String::from).to_vec(),
                rows: fit_rows(&fits),
            },
        ];
        if fits.len() == 2 {
            let (a, b) = (&fits[0].1, &fits[1].1);
            let text = match crate::stages::compare::incompatibility(a, b) {
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
            if !f.sensitivity.is_empty() {
                blocks.push(sensitivity_table(label, f));
            }
            if !f.stationarity.is_empty() {
                blocks.push(Block::Table {
                    header: [
                        format!("{label}: start times"),
                        "Θ [95% CI]".into(),
                        "η_c [95% CI]".into(),
                        "bins".into(),
                    ]
                    .to_vec(),
                    rows: f
                        .stationarity
                        .iter()
                        .map(|t| {
                            vec![
                                format!(
                                    "{} third (starts {}–{})",
                                    t.part, t.starts[0], t.starts[1]
                                ),
                                with_interval(t.theta, t.theta_interval, t.theta_constrained),
                                with_interval(t.eta_c, t.eta_c_interval, t.eta_c_constrained),
                                t.fitted_points.to_string(),
                            ]
                        })
                        .collect(),
                });
            }
        }
        for (label, f) in &fits {
            if let Some(r) = &f.range {
                let mut why: std::collections::BTreeMap<&str, usize> = Default::default();
                for b in &r.excluded {
                    *why.entry(b.reason.as_str()).or_default() += 1;
                }
                let why: Vec<String> = why.iter().map(|(r, n)| format!("{n} × {r}")).collect();
                blocks.push(Block::Paragraph(format!(
                    "{label}: fitted {}. Bins left out: {}.",
                    r.summary(),
                    if why.is_empty() {
                        "none".to_string()
                    } else {
                        why.join("; ")
                    }
                )));
            }
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
