//! `report`: experiment and simulation side by side — the D²min–η^s crossover with both
//! fits (Fig. 8), per-particle maps of speed, J2 and D²min (Fig. 5), stress–strain when
//! bar forces exist (Fig. 4), the fit table and provenance — as `report.html` (figures
//! inlined) plus every figure as PNG and SVG under `figures/`.

use super::fit::{FitReport, num, read_fit};
use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::io::{atomic_write_str, read_tracks};
use crate::report::figures::{
    CrossoverFigure, CrossoverSeries, MapFigure, MapPanel, StressStrainFigure, StressStrainSeries,
};
use crate::report::html::{Block, Report, Section, render};
use crate::report::{SavedFigure, save};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// One side of the report (experiment, simulation, …).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct DatasetInputs {
    pub label: String,
    pub tracks: Option<PathBuf>,
    pub kinematics: Option<PathBuf>,
    pub fit: Option<PathBuf>,
    /// A table with `strain` and `stress` columns (the simulator's stress–strain output).
    pub stress: Option<PathBuf>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReportOptions {
    pub title: String,
    pub datasets: Vec<DatasetInputs>,
    /// How many strain stages (start frames) the maps show per data set.
    pub map_stages: usize,
    /// Anything to print under "Provenance" (run id, parameters, hashes, version).
    pub provenance: serde_json::Value,
}

#[derive(Debug, Clone, Serialize)]
pub struct ReportOutput {
    pub html: PathBuf,
    pub figures: Vec<SavedFigure>,
    pub sections: Vec<String>,
}

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

/// One map panel: its title, start frame, and per grain (x, y, radius, [speed, J2, D²min]).
type PanelData = (String, i64, Vec<(f64, f64, f64, [f64; 3])>);

/// Per-particle maps for one data set: `stages` start frames spread over the run.
fn map_panels(d: &DatasetInputs, stages: usize) -> Result<Vec<PanelData>> {
    let Some(kp) = &d.kinematics else {
        return Ok(Vec::new());
    };
    let t = read_table(
        kp,
        &[
            ("frame", Expect::Int),
            ("particle", Expect::Int),
            ("x", Expect::Float),
            ("y", Expect::Float),
            ("speed", Expect::Float),
            ("j2", Expect::Float),
            ("d2min", Expect::Float),
        ],
    )?;
    let (frame, particle) = (t.i64("frame")?, t.i64("particle")?);
    let (x, y, valid) = (t.f64("x")?, t.f64("y")?, t.bool("valid")?);
    let (speed, j2, d2) = (t.f64("speed")?, t.f64("j2")?, t.f64("d2min")?);
    let mut frames: Vec<i64> = frame.clone();
    frames.sort_unstable();
    frames.dedup();
    let pick: Vec<i64> = if frames.len() <= stages {
        frames.clone()
    } else {
        (0..stages)
            .map(|k| frames[k * (frames.len() - 1) / (stages - 1).max(1)])
            .collect()
    };
    let tracks = match &d.tracks {
        Some(p) => Some(read_tracks(p)?.0),
        None => None,
    };
    let mut out = Vec::new();
    for f in pick {
        let radius: HashMap<i64, f64> = tracks
            .as_ref()
            .map(|t| {
                (0..t.len())
                    .filter(|&r| t.frame[r] == f)
                    .map(|r| (t.particle[r], t.radius[r]))
                    .collect()
            })
            .unwrap_or_default();
        let default_r = tracks
            .as_ref()
            .and_then(|t| t.large_diameter())
            .map_or(0.5, |dd| 0.5 * dd);
        // The paper's units (Fig. 5): v in v_c, J2 in v_c/R, D²min in R², so that an
        // experiment and a faster simulation share one colour scale.
        let (vs, js, ds) = match tracks
            .as_ref()
            .and_then(|t| t.meta.bar_speed.zip(t.large_diameter()))
        {
            Some((vc, dd)) if vc > 0.0 => (1.0 / vc, 0.5 * dd / vc, 4.0 / (dd * dd)),
            _ => (1.0, 1.0, 1.0),
        };
        let grains = (0..frame.len())
            .filter(|&r| frame[r] == f && valid[r])
            .map(|r| {
                (
                    x[r],
                    y[r],
                    *radius.get(&particle[r]).unwrap_or(&default_r),
                    [speed[r] * vs, j2[r] * js, d2[r] * ds],
                )
            })
            .collect();
        let time = tracks
            .as_ref()
            .and_then(|t| {
                t.meta
                    .frame_time
                    .map(|ft| format!(", t = {:.0} {}", f as f64 * ft, t.meta.time_unit))
            })
            .unwrap_or_default();
        out.push((format!("{}: frame {f}{time}", d.label), f, grains));
    }
    Ok(out)
}

fn stress_series(d: &DatasetInputs) -> Result<Option<StressStrainSeries>> {
    let Some(p) = &d.stress else { return Ok(None) };
    let t = read_table(p, &[("strain", Expect::Float), ("stress", Expect::Float)])?;
    t.require(&["strain", "stress"])?;
    let (e, s) = (t.f64("strain")?, t.f64("stress")?);
    Ok(Some(StressStrainSeries {
        label: d.label.clone(),
        points: e.into_iter().zip(s).collect(),
    }))
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

pub fn run(out_dir: &Path, opt: &ReportOptions) -> Result<ReportOutput> {
    if opt.datasets.is_empty() {
        return Err(Error::param(
            "datasets",
            "a report needs at least one data set",
        ));
    }
    let figdir = out_dir.join("figures");
    std::fs::create_dir_all(&figdir).map_err(|e| Error::io(&figdir, e))?;
    let mut figures = Vec::new();
    let mut sections = Vec::new();
    let rel = |f: &SavedFigure| {
        format!(
            "figures/{}",
            f.png
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        )
    };

    // Fits and the crossover figure.
    let mut fits: Vec<(String, FitReport)> = Vec::new();
    for d in &opt.datasets {
        if let Some(p) = &d.fit {
            fits.push((d.label.clone(), read_fit(p)?));
        }
    }
    if !fits.is_empty() {
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
        sections.push(Section {
            id: "crossover".into(),
            title: "Deformation-driven diffusion".into(),
            blocks,
        });
        figures.push(fig);
    }

    // Maps: one figure per quantity, every data set's stages side by side on one scale.
    let mut panels = Vec::new();
    for d in &opt.datasets {
        panels.extend(map_panels(d, opt.map_stages)?);
    }
    let reduced = opt
        .datasets
        .iter()
        .filter(|d| d.kinematics.is_some())
        .all(|d| {
            d.tracks
                .as_ref()
                .and_then(|p| crate::io::tracks_io::read_meta(p).ok().flatten())
                .is_some_and(|m| m.bar_speed.is_some())
        });
    if !panels.is_empty() {
        let mut blocks = Vec::new();
        let names = if reduced {
            [
                "speed |v| / v_c (Eq. 13)",
                "J2 = η^s/Δt in v_c/R (Eq. 18)",
                "D²min / R² (Eq. 14)",
            ]
        } else {
            [
                "speed |v| (Eq. 13)",
                "J2 = η^s/Δt (Eq. 18)",
                "D²min (Eq. 14)",
            ]
        };
        for (k, (name, file, log)) in [
            (names[0], "map_speed", false),
            (names[1], "map_j2", true),
            (names[2], "map_d2min", true),
        ]
        .into_iter()
        .enumerate()
        {
            let fig = MapFigure {
                quantity: name.to_string(),
                log,
                columns: opt.map_stages.max(1),
                panels: panels
                    .iter()
                    .map(|(title, _, g)| MapPanel {
                        title: title.clone(),
                        grains: g.iter().map(|&(x, y, r, v)| (x, y, r, v[k])).collect(),
                    })
                    .collect(),
            };
            let saved = save(&fig, &figdir.join(file))?;
            blocks.push(Block::Figure {
                id: format!("fig-{file}"),
                caption: format!("{name} per grain, drawn at its true radius, on one colour scale for all panels (Li et al. Fig. 5)."),
                svg: saved.svg_text.clone(),
                png: rel(&saved),
            });
            figures.push(saved);
        }
        sections.push(Section {
            id: "maps".into(),
            title: "Per-particle maps".into(),
            blocks,
        });
    }

    // Stress–strain.
    let mut ss = Vec::new();
    for d in &opt.datasets {
        if let Some(s) = stress_series(d)? {
            ss.push(s);
        }
    }
    let mut blocks = Vec::new();
    if ss.is_empty() {
        blocks.push(Block::Paragraph("No bar-force data in these inputs (trackpy experiments carry none unless a force table is given).".into()));
    } else {
        let saved = save(
            &StressStrainFigure {
                series: ss,
                stress_unit: "N/m".into(),
            },
            &figdir.join("stress_strain"),
        )?;
        blocks.push(Block::Figure {
            id: "fig-stress-strain".into(),
            caption: "σ = F_bar / W against ε = ΔH/H0 (Li et al. Fig. 4).".into(),
            svg: saved.svg_text.clone(),
            png: rel(&saved),
        });
        figures.push(saved);
    }
    sections.push(Section {
        id: "stress".into(),
        title: "Stress–strain".into(),
        blocks,
    });

    // Provenance.
    let mut rows = Vec::new();
    for d in &opt.datasets {
        for (what, p) in [
            ("tracks", &d.tracks),
            ("kinematics", &d.kinematics),
            ("fit", &d.fit),
            ("stress", &d.stress),
        ] {
            if let Some(p) = p {
                rows.push(vec![
                    d.label.clone(),
                    what.into(),
                    p.display().to_string(),
                    crate::io::sha256_file(p)?,
                ]);
            }
        }
    }
    sections.push(Section {
        id: "provenance".into(),
        title: "Provenance".into(),
        blocks: vec![
            Block::Table {
                header: ["data", "input", "file", "sha256"]
                    .map(String::from)
                    .to_vec(),
                rows,
            },
            Block::Pre(serde_json::to_string_pretty(&opt.provenance).expect("json")),
        ],
    });
    let report = Report {
        title: opt.title.clone(),
        subtitle: format!(
            "{} {} — {}",
            super::TOOL,
            super::VERSION,
            opt.datasets
                .iter()
                .map(|d| d.label.as_str())
                .collect::<Vec<_>>()
                .join(" vs ")
        ),
        sections,
    };
    let html = out_dir.join("report.html");
    atomic_write_str(&html, &render(&report))?;
    let names: BTreeMap<usize, String> = report
        .sections
        .iter()
        .enumerate()
        .map(|(k, s)| (k, s.id.clone()))
        .collect();
    Ok(ReportOutput {
        html,
        figures,
        sections: names.into_values().collect(),
    })
}
