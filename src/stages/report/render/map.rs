//! Per-particle maps (Li et al. Figs. 5 and 6): grains as disks of their true radii on one
//! shared colour scale, with a colour bar whose ticks print plain numbers.

use super::{FONT_FAMILY, Figure, viridis};
use plotters::coord::Shift;
use plotters::prelude::*;

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// One panel of a particle map: grains as disks of their radii, coloured by `value`.
#[derive(Debug, Clone)]
pub struct MapPanel {
    pub title: String,
    /// (x, y, radius, value), length unit.
    pub grains: Vec<(f64, f64, f64, f64)>,
}

/// Panels on one shared colour scale (log10 when `log`), with a colour bar.
pub struct MapFigure {
    pub quantity: String,
    pub panels: Vec<MapPanel>,
    pub log: bool,
    /// Panels per row (one row per data set when this is the stages per data set).
    pub columns: usize,
}

/// Below this fraction of the 98th percentile a value counts as "at rest" on a log scale:
/// grains that did not move in a simulation carry J2 or D²min of round-off size
/// (1e-20 and below) that would otherwise stretch the scale over twenty decades.
pub const LOG_FLOOR: f64 = 1e-12;

/// A colour-bar tick value as text that parses back as a number: three significant
/// digits in plain notation between 0.01 and 10⁴, otherwise like `2.0e-3`.
pub fn tick_label(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.1e}")
    }
}

impl MapFigure {
    /// The smallest value drawn in colour on a log scale (see `LOG_FLOOR`); 0 when linear.
    pub fn floor(&self) -> f64 {
        if !self.log {
            return 0.0;
        }
        let mut v: Vec<f64> = self
            .panels
            .iter()
            .flat_map(|p| p.grains.iter().map(|g| g.3))
            .filter(|v| *v > 0.0 && v.is_finite())
            .collect();
        if v.is_empty() {
            return 0.0;
        }
        v.sort_by(f64::total_cmp);
        LOG_FLOOR * crate::stats::quantile_sorted(&v, 0.98)
    }

    /// Colour scale limits on the drawn scale (log10 when `log`): the 2nd and 98th
    /// percentiles over all panels, grains at rest left out.
    pub fn limits(&self) -> (f64, f64) {
        let floor = self.floor();
        let mut v: Vec<f64> = self
            .panels
            .iter()
            .flat_map(|p| p.grains.iter().map(|g| self.scale(g.3, floor)))
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

    /// The colour bar's ticks: (position 0–1 along the bar, value in the data's unit,
    /// label).
    pub fn ticks(&self) -> Vec<(f64, f64, String)> {
        let (lo, hi) = self.limits();
        (0..=4)
            .map(|k| {
                let t = k as f64 / 4.0;
                let v = lo + t * (hi - lo);
                let v = if self.log { 10f64.powf(v) } else { v };
                (t, v, tick_label(v))
            })
            .collect()
    }

    /// (rows, columns) of the panel grid.
    fn grid(&self) -> (usize, usize) {
        let cols = self.columns.clamp(1, self.panels.len().max(1));
        (self.panels.len().div_ceil(cols).max(1), cols)
    }

    /// The value on the drawn scale; NaN (grey) for values a log scale cannot show.
    fn scale(&self, v: f64, floor: f64) -> f64 {
        if !self.log {
            v
        } else if v > floor && v > 0.0 {
            v.log10()
        } else {
            f64::NAN
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
        let floor = self.floor();
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
                    let t = (self.scale(v, floor) - lo) / (hi - lo);
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
        for (t, _, label) in self.ticks() {
            bar.draw(&Text::new(label, (50, y_at(t) - 6), style.clone()))
                .map_err(s)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_numbers() {
        for v in [0.0, 2.0e-3, 0.0123, 0.5, 1.0, 12.345, 999.9, 2.5e4, -3.0e-5] {
            let l = tick_label(v);
            let back: f64 = l.parse().unwrap_or_else(|_| panic!("{l}"));
            assert!((back - v).abs() <= 0.06 * v.abs(), "{v} -> {l}");
        }
        assert_eq!(tick_label(2.0e-3), "2.0e-3");
        assert_eq!(tick_label(0.5), "0.500");
    }

    #[test]
    fn log_scale_ignores_grains_at_rest() {
        let grains = (0..100)
            .map(|k| {
                (
                    k as f64,
                    0.0,
                    0.5,
                    if k < 30 {
                        1e-22
                    } else {
                        1e-3 * (1 + k % 7) as f64
                    },
                )
            })
            .chain([(0.0, 1.0, 0.5, 0.0)])
            .collect();
        let f = MapFigure {
            quantity: "q".into(),
            panels: vec![MapPanel {
                title: "p".into(),
                grains,
            }],
            log: true,
            columns: 1,
        };
        let (lo, hi) = f.limits();
        assert!(
            lo >= -3.0 - 1e-9 && hi <= (7e-3f64).log10() + 1e-9,
            "{lo} {hi}"
        );
        let ticks = f.ticks();
        assert!((ticks[0].1 - 1e-3).abs() < 1e-9 && ticks[0].2.parse::<f64>().is_ok());
    }
}
