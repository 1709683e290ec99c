//! Blocks of the report's sections: map figures (Li et al. Figs. 5 and 6) and curves
//! against strain (Figs. 4 and 10d).

use crate::error::Result;
use crate::stages::report::DatasetInputs;
use crate::stages::report::data::{Panel, strain_curve};
use crate::stages::report::render::figures::{
    MapFigure, MapPanel, StrainCurveFigure, StrainSeries,
};
use crate::stages::report::render::html::Block;
use crate::stages::report::render::{SavedFigure, save};
use std::path::Path;

/// A figure's PNG relative to the report.
pub fn rel(f: &SavedFigure) -> String {
    format!(
        "figures/{}",
        f.png
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    )
}

/// One figure per quantity (name, file stem, log scale), every panel on one colour scale.
pub fn map_blocks(
    panels: &[Panel],
    quantities: [(&str, &str, bool); 3],
    columns: usize,
    caption: &str,
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Vec<Block>> {
    let mut blocks = Vec::new();
    for (k, (name, file, log)) in quantities.into_iter().enumerate() {
        let fig = MapFigure {
            quantity: name.to_string(),
            log,
            columns,
            panels: panels
                .iter()
                .map(|p| MapPanel {
                    title: p.title.clone(),
                    grains: p
                        .grains
                        .iter()
                        .map(|&(x, y, r, v)| (x, y, r, v[k]))
                        .collect(),
                })
                .collect(),
        };
        let saved = save(&fig, &figdir.join(file))?;
        blocks.push(Block::Figure {
            id: format!("fig-{file}"),
            caption: format!("{name} per grain, drawn at its true radius, {caption}"),
            svg: saved.svg_text.clone(),
            png: rel(&saved),
        });
        figures.push(saved);
    }
    Ok(blocks)
}

/// Stress (Fig. 4) and κ (Fig. 10d) against strain, from the data sets' stress tables.
pub fn strain_blocks(
    datasets: &[DatasetInputs],
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Vec<Block>> {
    // Each data set's simulated curve and its measured one (a force sensor's, Fig. 4a).
    let mut tables: Vec<(String, &Path)> = Vec::new();
    for d in datasets {
        match (d.stress.as_deref(), d.measured_stress.as_deref()) {
            (Some(s), Some(m)) => {
                tables.push((d.label.clone(), s));
                tables.push((format!("{} (force sensor)", d.label), m));
            }
            (Some(p), None) | (None, Some(p)) => tables.push((d.label.clone(), p)),
            (None, None) => {}
        }
    }
    // κ is the simulator's alone.
    let kappa_tables: Vec<(String, &Path)> = datasets
        .iter()
        .filter_map(|d| d.stress.as_deref().map(|p| (d.label.clone(), p)))
        .collect();
    if tables.is_empty() {
        return Ok(vec![Block::Paragraph("No bar-force data in these inputs (trackpy experiments carry none unless a force table is given).".into())]);
    }
    let curves_of = |tables: &[(String, &Path)], col: &str| -> Result<Option<Vec<StrainSeries>>> {
        let mut out = Vec::new();
        for (label, p) in tables {
            match strain_curve(p, col)? {
                Some(points) => out.push(StrainSeries {
                    label: label.to_string(),
                    points,
                    yield_point: None,
                }),
                None => return Ok(None),
            }
        }
        Ok(Some(out))
    };
    let curves = |col: &str| curves_of(&tables, col);
    // The paper's unit m g μ / D where every table has it, so sizes compare (Fig. 4).
    let (series, unit, eq) = match curves("stress_reduced")? {
        Some(s) => (s, "m g μ / D", "σ = F_bar / W in units of m g μ / D"),
        None => (
            curves("stress")?.unwrap_or_default(),
            "N/m",
            "σ = F_bar / W",
        ),
    };
    // The yield point of each stress curve (docs/size-scan.md, "Yield").
    let mut series = series;
    let mut yields = Vec::new();
    for ser in &mut series {
        let (e, s): (Vec<f64>, Vec<f64>) = ser.points.iter().copied().unzip();
        match crate::structure::yielding::yield_point(
            &e,
            &s,
            crate::stages::sizes::WINDOW.1,
            crate::stages::sizes::YIELD_REPLICATES,
            crate::stages::sizes::YIELD_SEED,
        ) {
            crate::structure::yielding::Yield::Reached(p) => {
                yields.push(format!(
                    "{}: ε_y = {:.4} [{:.4}, {:.4}], σ_y = {:.3} [{:.3}, {:.3}] {unit}",
                    ser.label,
                    p.eps_y,
                    p.eps_interval[0],
                    p.eps_interval[1],
                    p.sigma_y,
                    p.sigma_interval[0],
                    p.sigma_interval[1]
                ));
                ser.yield_point = Some(p);
            }
            crate::structure::yielding::Yield::NotReached(why) => {
                yields.push(format!("{}: yield not reached ({why})", ser.label))
            }
        }
    }
    let mut blocks = Vec::new();
    let mut figure = |fig: StrainCurveFigure, file: &str, caption: String| -> Result<()> {
        let saved = save(&fig, &figdir.join(file))?;
        blocks.push(Block::Figure {
            id: format!("fig-{}", file.replace('_', "-")),
            caption,
            svg: saved.svg_text.clone(),
            png: rel(&saved),
        });
        figures.push(saved);
        Ok(())
    };
    figure(
        StrainCurveFigure {
            title: "Stress–strain with the yield point (Fig. 4)".into(),
            y_desc: format!("σ ({unit})"),
            series,
        },
        "stress_strain",
        format!(
            "{eq} against ε = ΔH/H0 (Li et al. Fig. 4). Dashed: the elastic line of the yield rule (a least-squares broken stick over 0 ≤ ε ≤ 0.2, docs/size-scan.md) up to the yield point ×, its bars the 95 % bootstrap intervals of ε_y and σ_y. {}. The paper's stages 1–6 are not marked: it gives no strains for them.{}",
            yields.join("; "),
            if datasets.iter().any(|d| d.measured_stress.is_some()) {
                " A force sensor's curve (Fig. 4a, `ingest-force`) divides by the one pillar width W it is given, the simulator's by W measured per frame."
            } else {
                ""
            }
        ),
    )?;
    if let Some(series) = curves_of(&kappa_tables, "kappa_exact")?
        && !series.is_empty()
    {
        figure(
            StrainCurveFigure { title: "Substrate dissipation κ (Fig. 10d)".into(), y_desc: "κ = P_g-s / P_in".into(), series },
            "kappa",
            "κ = P_g-s / P_in against ε: the fraction of the bar's input power (Eq. 20) dissipated by grain–substrate friction, from the simulator's exact Σ|f_i·v_i| (Li et al. Fig. 10d).".into(),
        )?;
    }
    Ok(blocks)
}

/// Figures of one section, saved as `<prefix>_<file>.{png,svg}` and collected as blocks.
pub struct Figures<'a> {
    pub figdir: &'a Path,
    pub prefix: String,
    pub figures: &'a mut Vec<SavedFigure>,
    pub blocks: Vec<Block>,
}

impl Figures<'_> {
    pub fn add(
        &mut self,
        fig: &impl crate::stages::report::render::Figure,
        file: &str,
        caption: String,
    ) -> Result<()> {
        let stem = format!("{}_{file}", self.prefix);
        let saved = save(fig, &self.figdir.join(&stem))?;
        self.blocks.push(Block::Figure {
            id: format!("fig-{}", stem.replace('_', "-")),
            caption,
            svg: saved.svg_text.clone(),
            png: rel(&saved),
        });
        self.figures.push(saved);
        Ok(())
    }
}
