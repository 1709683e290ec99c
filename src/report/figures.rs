//! The report's figures (Li et al. Figs. 4, 5 and 8), each a plain-data struct.

use super::{FONT_FAMILY, Figure, PALETTE, viridis};
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
    /// Fitted Θ and η_c.
    pub theta: f64,
    pub eta_c: f64,
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
            let n = 120;
            let curve: Vec<(f64, f64)> = (0..=n)
                .map(|i| {
                    let x = (xr.0.ln() + (xr.1.ln() - xr.0.ln()) * i as f64 / n as f64).exp();
                    (x, d2min_over_r2(x, ser.theta, ser.eta_c))
                })
                .filter(|p| p.1 >= yr.0 && p.1 <= yr.1)
                .collect();
            chart
                .draw_series(LineSeries::new(curve, c.stroke_width(3)))
                .map_err(s)?
                .label(format!(
                    "{}: Θ = {:.3}, η_c = {:.3e}",
                    ser.label, ser.theta, ser.eta_c
                ))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], c.stroke_width(3))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font((FONT_FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(s)?;
        Ok(())
    }
}

/// One panel of a particle map: grains as disks of their radii, coloured by `value`.
#[derive(Debug, Clone)]
pub struct MapPanel {
    pub title: String,
    /// (x, y, radius, value), length unit.
    pub grains: Vec<(f64, f64, f64, f64)>,
}

/// Fig. 5: panels side by side on one shared colour scale (log10 when `log`), with a
/// colour bar.
pub struct MapFigure {
    pub quantity: String,
    pub panels: Vec<MapPanel>,
    pub log: bool,
    /// Panels per row (one row per data set when this is the stages per data set).
    pub columns: usize,
}

impl MapFigure {
    /// Colour scale limits: the 2nd and 98th percentiles over all panels.
    pub fn limits(&self) -> (f64, f64) {
        let mut v: Vec<f64> = self
            .panels
            .iter()
            .flat_map(|p| p.grains.iter().map(|g| self.scale(g.3)))
            .filter(|v| v.is_finite())
            .collect();
        if v.is_empty() {
            return (0.0, 1.0);
        }
        v.sort_by(f64::total_cmp);
        let lo = crate::stats::quantile_sorted(&v, 0.02);
        let hi = crate::stats::quantile_sorted(&v, 0.98);
        if hi > lo {
            (lo, hi)
        } else {
            (lo - 0.5, lo + 0.5)
        }
    }
    /// (rows, columns) of the panel grid.
    fn grid(&self) -> (usize, usize) {
        let cols = self.columns.clamp(1, self.panels.len().max(1));
        (self.panels.len().div_ceil(cols).max(1), cols)
    }
    fn scale(&self, v: f64) -> f64 {
        if self.log {
            if v > 0.0 { v.log10() } else { f64::NAN }
        } else {
            v
        }
    }
}

impl Figure for MapFigure {
    fn size(&self) -> (u32, u32) {
        let (rows, cols) = self.grid();
        (300 * cols as u32 + 110, 520 * rows as u32 + 40)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(s)?;
        let (w, _) = self.size();
        let root = root.titled(&self.quantity, (FONT_FAMILY, 20)).map_err(s)?;
        let (maps, bar) = root.split_horizontally(w - 110);
        let (lo, hi) = self.limits();
        let areas = maps.split_evenly(self.grid());
        for (panel, area) in self.panels.iter().zip(&areas) {
            let (x0, x1, y0, y1) =
                panel
                    .grains
                    .iter()
                    .fold((f64::MAX, f64::MIN, f64::MAX, f64::MIN), |a, g| {
                        (
                            a.0.min(g.0 - g.2),
                            a.1.max(g.0 + g.2),
                            a.2.min(g.1 - g.2),
                            a.3.max(g.1 + g.2),
                        )
                    });
            if x0 > x1 {
                continue;
            }
            // Equal aspect: pad the shorter side.
            let (pw, ph) = area.dim_in_pixel();
            let (pw, ph) = (pw as f64 - 20.0, ph as f64 - 50.0);
            let scale = (pw / (x1 - x0)).min(ph / (y1 - y0));
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            let (hx, hy) = (0.5 * pw / scale, 0.5 * ph / scale);
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, (FONT_FAMILY, 14))
                .margin(10)
                .build_cartesian_2d(cx - hx..cx + hx, cy - hy..cy + hy)
                .map_err(s)?;
            chart
                .draw_series(panel.grains.iter().map(|&(x, y, r, v)| {
                    let t = (self.scale(v) - lo) / (hi - lo);
                    let c = if t.is_finite() {
                        viridis(t)
                    } else {
                        RGBColor(200, 200, 200)
                    };
                    Circle::new((x, y), ((r * scale).round() as i32).max(1), c.filled())
                }))
                .map_err(s)?;
        }
        // Colour bar.
        let (_, bh) = bar.dim_in_pixel();
        let (top, bottom) = (40i32, bh as i32 - 40);
        let n = 100;
        let y_at = |t: f64| bottom - ((bottom - top) as f64 * t).round() as i32;
        for k in 0..n {
            let (t0, t1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
            bar.draw(&Rectangle::new(
                [(20, y_at(t1)), (45, y_at(t0))],
                viridis(0.5 * (t0 + t1)).filled(),
            ))
            .map_err(s)?;
        }
        let style = (FONT_FAMILY, 13).into_font().color(&BLACK);
        for k in 0..=4 {
            let t = k as f64 / 4.0;
            let v = lo + t * (hi - lo);
            let y = bottom - ((bottom - top) as f64 * t) as i32;
            let label = if self.log {
                format!("1e{v:.1}")
            } else {
                format!("{v:.2e}")
            };
            bar.draw(&Text::new(label, (50, y - 6), style.clone()))
                .map_err(s)?;
        }
        Ok(())
    }
}

/// One curve of the stress–strain figure.
#[derive(Debug, Clone)]
pub struct StressStrainSeries {
    pub label: String,
    /// (ε, σ) pairs.
    pub points: Vec<(f64, f64)>,
}

/// Fig. 4: stress against strain.
pub struct StressStrainFigure {
    pub series: Vec<StressStrainSeries>,
    pub stress_unit: String,
}

impl Figure for StressStrainFigure {
    fn size(&self) -> (u32, u32) {
        (760, 500)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(s)?;
        let (xmax, ymin, ymax) = self
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .fold((0.0f64, 0.0f64, 0.0f64), |a, p| {
                (a.0.max(p.0), a.1.min(p.1), a.2.max(p.1))
            });
        let mut chart = ChartBuilder::on(root)
            .caption("Stress–strain (Fig. 4)", (FONT_FAMILY, 22))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..xmax.max(1e-6) * 1.05, ymin..ymax.max(1e-12) * 1.1)
            .map_err(s)?;
        chart
            .configure_mesh()
            .x_desc("strain ε = ΔH/H0")
            .y_desc(format!("σ ({})", self.stress_unit))
            .label_style((FONT_FAMILY, 14))
            .draw()
            .map_err(s)?;
        for (k, ser) in self.series.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(
                    ser.points.iter().copied(),
                    c.stroke_width(2),
                ))
                .map_err(s)?
                .label(ser.label.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x - 10, y), (x + 10, y)], c.stroke_width(2))
                });
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
