//! The report's figures (Li et al. Figs. 4, 8 and 10d; the maps of Figs. 5 and 6 live in
//! `map`), each a plain-data struct.

pub use super::map::{MapFigure, MapPanel};
use super::{FONT_FAMILY, Figure, PALETTE};
use crate::fit::d2min_over_r2;
use plotters::coord::Shift;
use plotters::prelude::*;

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// One data set of the crossover figure.
#[derive(Debug, Clone)]
pub struct CrossoverSeries {
    pub label: String,
    /// (η^s, D²min/R²) samples (subsampled for drawing).
    pub points: Vec<(f64, f64)>,
    /// Binned curve of the fit's estimator.
    pub binned: Vec<(f64, f64)>,
    /// Fitted Θ and η_c, and whether the data determine each (an undetermined one is
    /// not printed as a number).
    pub theta: f64,
    pub eta_c: f64,
    pub theta_constrained: bool,
    pub eta_c_constrained: bool,
    /// The fitted η^s range; the curve is drawn over it.
    pub range: Option<(f64, f64)>,
    /// Bins left out of the fit (median η^s, median D²min/R²), drawn grey.
    pub excluded: Vec<(f64, f64)>,
}

/// Fig. 8: D²min/R² against η^s on log axes, scatter, binned curve and Eq. 19.
pub struct CrossoverFigure {
    pub series: Vec<CrossoverSeries>,
}

/// Decade-rounded range of the 0.5–99.5 % quantiles of the positive values (a handful of
/// outliers, e.g. D²min = 1e-20 of an exactly affine neighbourhood, would flatten the rest).
fn log_range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let mut v: Vec<f64> = vals.filter(|v| *v > 0.0 && v.is_finite()).collect();
    if v.is_empty() {
        return (1e-3, 1.0);
    }
    v.sort_by(f64::total_cmp);
    let lo = crate::stats::quantile_sorted(&v, 0.005);
    let hi = crate::stats::quantile_sorted(&v, 0.995);
    let (lo, hi) = (lo.log10().floor(), hi.log10().ceil());
    (10f64.powf(lo), 10f64.powf(hi.max(lo + 1.0)))
}

impl Figure for CrossoverFigure {
    fn size(&self) -> (u32, u32) {
        (760, 560)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(s)?;
        let xr = log_range(
            self.series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.0)),
        );
        let yr = log_range(
            self.series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1)),
        );
        let mut chart = ChartBuilder::on(root)
            .caption("D²min/R² against η^s (Eq. 19)", (FONT_FAMILY, 22))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d((xr.0..xr.1).log_scale(), (yr.0..yr.1).log_scale())
            .map_err(s)?;
        chart
            .configure_mesh()
            .x_desc("deviatoric strain η^s")
            .y_desc("D²min / R²")
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style((FONT_FAMILY, 14))
            .draw()
            .map_err(s)?;
        for (k, ser) in self.series.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            chart
                .draw_series(
                    ser.points
                        .iter()
                        .filter(|p| p.0 >= xr.0 && p.0 <= xr.1 && p.1 >= yr.0 && p.1 <= yr.1)
                        .map(|&(x, y)| Circle::new((x, y), 1, c.mix(0.25).filled())),
                )
                .map_err(s)?;
            chart
                .draw_series(
                    ser.binned
                        .iter()
                        .map(|&(x, y)| Circle::new((x, y), 5, c.filled())),
                )
                .map_err(s)?
                .label(format!("{} (binned)", ser.label))
                .legend(move |(x, y)| Circle::new((x, y), 5, c.filled()));
            if !ser.excluded.is_empty() {
                let grey = RGBColor(150, 150, 150);
                chart
                    .draw_series(
                        ser.excluded
                            .iter()
                            .filter(|p| p.0 >= xr.0 && p.0 <= xr.1 && p.1 >= yr.0 && p.1 <= yr.1)
                            .map(move |&(x, y)| Circle::new((x, y), 5, grey.stroke_width(2))),
                    )
                    .map_err(s)?
                    .label(format!("{}: bins left out of the fit", ser.label))
                    .legend(move |(x, y)| Circle::new((x, y), 5, grey.stroke_width(2)));
            }
            let (lo, hi) = ser.range.map_or(xr, |(a, b)| (a.max(xr.0), b.min(xr.1)));
            let n = 120;
            let curve: Vec<(f64, f64)> = (0..=n)
                .map(|i| {
                    let x = (lo.ln() + (hi.ln() - lo.ln()) * i as f64 / n as f64).exp();
                    (x, d2min_over_r2(x, ser.theta, ser.eta_c))
                })
                .filter(|p| p.1 >= yr.0 && p.1 <= yr.1)
                .collect();
            let theta = if ser.theta_constrained {
                format!("{:.3}", ser.theta)
            } else {
                "not constrained".into()
            };
            let eta_c = if ser.eta_c_constrained {
                format!("{:.3e}", ser.eta_c)
            } else {
                "not constrained".into()
            };
            chart
                .draw_series(LineSeries::new(curve, c.stroke_width(3)))
                .map_err(s)?
                .label(format!("{}: Θ = {theta}, η_c = {eta_c}", ser.label))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], c.stroke_width(3))
                });
        }
        // D²min/R² rises with η^s, so the lower right is the empty corner; the legend
        // grows with the data sets and covered the binned curves in the upper left.
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .label_font((FONT_FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(s)?;
        Ok(())
    }
}

/// One curve of a figure against strain.
#[derive(Debug, Clone)]
pub struct StrainSeries {
    pub label: String,
    /// (ε, y) pairs; points with a non-finite y (κ where P_in = 0) are skipped.
    pub points: Vec<(f64, f64)>,
    /// A yield point to mark (stress curves): the elastic line from the origin to it,
    /// dashed, and the point with its intervals as bars.
    pub yield_point: Option<crate::structure::yielding::YieldPoint>,
}

/// A quantity against strain ε = ΔH/H0: stress (Fig. 4), κ = P_g-s/P_in (Fig. 10d).
pub struct StrainCurveFigure {
    pub title: String,
    /// The y axis label, unit included.
    pub y_desc: String,
    pub series: Vec<StrainSeries>,
}

impl Figure for StrainCurveFigure {
    fn size(&self) -> (u32, u32) {
        (760, 500)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(s)?;
        let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
        let (xmax, ymin, ymax) = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().filter(finite))
            .fold((0.0f64, 0.0f64, 0.0f64), |a, p| {
                (a.0.max(p.0), a.1.min(p.1), a.2.max(p.1))
            });
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT_FAMILY, 22))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..xmax.max(1e-6) * 1.05, ymin..ymax.max(1e-12) * 1.1)
            .map_err(s)?;
        chart
            .configure_mesh()
            .x_desc("strain ε = ΔH/H0")
            .y_desc(&self.y_desc)
            .label_style((FONT_FAMILY, 14))
            .draw()
            .map_err(s)?;
        for (k, ser) in self.series.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(
                    ser.points.iter().filter(finite).copied(),
                    c.stroke_width(2),
                ))
                .map_err(s)?
                .label(ser.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], c.stroke_width(2))
                });
            if let Some(p) = &ser.yield_point {
                // The elastic line, dashed: ten pieces from the origin to (ε_y, σ_y).
                chart
                    .draw_series((0..10).step_by(2).map(|j| {
                        let at = |q: f64| (q * p.eps_y, q * p.sigma_y);
                        PathElement::new(
                            vec![at(j as f64 / 10.0), at((j + 1) as f64 / 10.0)],
                            BLACK.stroke_width(2),
                        )
                    }))
                    .map_err(s)?;
                chart
                    .draw_series([
                        PathElement::new(
                            vec![
                                (p.eps_interval[0], p.sigma_y),
                                (p.eps_interval[1], p.sigma_y),
                            ],
                            BLACK.stroke_width(1),
                        ),
                        PathElement::new(
                            vec![
                                (p.eps_y, p.sigma_interval[0]),
                                (p.eps_y, p.sigma_interval[1]),
                            ],
                            BLACK.stroke_width(1),
                        ),
                    ])
                    .map_err(s)?;
                chart
                    .draw_series([Cross::new((p.eps_y, p.sigma_y), 7, c.stroke_width(3))])
                    .map_err(s)?;
            }
        }
        chart
            .configure_series_labels()
            .label_font((FONT_FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(s)?;
        Ok(())
    }
}
