//! Curves with error bars and categorical phase diagrams (the sheared-disk figures of
//! vagberg-sheared-disks): plain data in, log axes drawn as log10 coordinates with
//! decade labels so that one chart type serves linear and log axes alike.

use super::{FONT_FAMILY, Figure, Labels, PALETTE};
use plotters::coord::Shift;
use plotters::prelude::*;

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Points beyond which a curve with a line is drawn without markers.
const DENSE: usize = 60;

/// One curve: (x, y, error of y) points, drawn as markers with error bars and a line
/// (the line alone beyond `DENSE` points).
#[derive(Debug, Clone)]
pub struct XySeries {
    pub label: String,
    pub points: Vec<(f64, f64, f64)>,
    /// Markers only (a second quantity beside a curve, say 2τ_dur ν_coll beside Z).
    pub markers_only: bool,
    /// Colour index; series sharing it belong together.
    pub colour: usize,
}

/// y against x, either axis linear or logarithmic.
pub struct XyFigure {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub x_log: bool,
    pub y_log: bool,
    pub series: Vec<XySeries>,
}

/// Colours beyond the palette's four, for grids with many φ.
pub fn colour(k: usize) -> RGBColor {
    const MORE: [RGBColor; 4] = [
        RGBColor(255, 127, 14),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(23, 190, 207),
    ];
    if k < PALETTE.len() {
        PALETTE[k]
    } else {
        MORE[(k - PALETTE.len()) % MORE.len()]
    }
}

fn tf(v: f64, log: bool) -> Option<f64> {
    let t = if log {
        if v > 0.0 { v.log10() } else { f64::NAN }
    } else {
        v
    };
    t.is_finite().then_some(t)
}

fn range(v: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |a, x| {
        (a.0.min(x), a.1.max(x))
    });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = if hi > lo {
        0.08 * (hi - lo)
    } else if log {
        0.5
    } else {
        0.1 * lo.abs().max(1e-3)
    };
    (lo - pad, hi + pad)
}

/// A tick's text on an axis spanning `span`: a linear tick within 1e-9 of the span from
/// zero is the zero that rounding missed (ticks stepped from −0.4 print −2.2e-16 for 0).
fn label(v: f64, log: bool, span: f64) -> String {
    let v = if !log && v.abs() <= 1e-9 * span.abs() {
        0.0
    } else {
        v
    };
    if log {
        let p = 10f64.powf(v);
        if (v - v.round()).abs() < 1e-9 {
            format!("1e{}", v.round() as i64)
        } else {
            format!("{p:.1e}")
        }
    } else {
        // Three significant digits, so that ticks 0.0005 apart stay distinct.
        super::map::tick_label(v)
    }
}

impl Figure for XyFigure {
    fn size(&self) -> (u32, u32) {
        (760, 520)
    }
    fn labels(&self) -> Labels {
        Labels::of(&self.title, &self.x_desc, &self.y_desc)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        draw_xy(self, &Overlay::default(), root)
    }
}

/// What a figure marks beside its curves, in data coordinates: shaded regions (a
/// coexistence region), brackets (an interval with no central value), dashed vertical
/// reference lines (φ_J) and labelled stars (a critical end point).
#[derive(Debug, Clone, Default)]
pub struct Overlay {
    /// (legend label, polygon corners).
    pub regions: Vec<(String, Vec<(f64, f64)>)>,
    /// (x, y_lo, y_hi, colour index).
    pub brackets: Vec<(f64, f64, f64, usize)>,
    /// (legend label, x).
    pub vlines: Vec<(String, f64)>,
    /// (legend label, x, y).
    pub stars: Vec<(String, f64, f64)>,
}

impl Overlay {
    fn is_empty(&self) -> bool {
        self.regions.is_empty()
            && self.brackets.is_empty()
            && self.vlines.is_empty()
            && self.stars.is_empty()
    }
}

/// An [`XyFigure`] with an [`Overlay`].
pub struct Annotated {
    pub xy: XyFigure,
    pub overlay: Overlay,
}

impl Figure for Annotated {
    fn size(&self) -> (u32, u32) {
        self.xy.size()
    }
    fn labels(&self) -> Labels {
        self.xy.labels()
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        draw_xy(&self.xy, &self.overlay, root)
    }
}

const REGION: RGBColor = RGBColor(255, 200, 0);
const REFERENCE: RGBColor = RGBColor(90, 90, 90);

fn draw_xy<DB: DrawingBackend>(
    fig: &XyFigure,
    overlay: &Overlay,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(s)?;
    let pts = |ser: &XySeries| -> Vec<(f64, f64, f64, f64)> {
        ser.points
            .iter()
            .filter_map(|&(x, y, e)| {
                let (x, y) = (tf(x, fig.x_log)?, tf(y, fig.y_log)?);
                let e = if e.is_finite() { e.abs() } else { 0.0 };
                let raw = if fig.y_log { 10f64.powf(y) } else { y };
                // On a log axis a bar reaching zero is cut at a decade below.
                let lo = tf(raw - e, fig.y_log).unwrap_or(y - 1.0).max(y - 1.0);
                let hi = tf(raw + e, fig.y_log).unwrap_or(y);
                Some((x, y, lo, hi))
            })
            .collect()
    };
    let all: Vec<(f64, f64, f64, f64)> = fig.series.iter().flat_map(pts).collect();
    let (xl, yl) = (fig.x_log, fig.y_log);
    // The overlay's points in axis coordinates; what it marks stays inside the frame.
    let at = |x: f64, y: f64| Some((tf(x, xl)?, tf(y, yl)?));
    let marked: Vec<(f64, f64)> = overlay
        .regions
        .iter()
        .flat_map(|r| r.1.iter().copied())
        .chain(
            overlay
                .brackets
                .iter()
                .flat_map(|b| [(b.0, b.1), (b.0, b.2)]),
        )
        .chain(overlay.stars.iter().map(|s| (s.1, s.2)))
        .filter_map(|(x, y)| at(x, y))
        .collect();
    let vx: Vec<f64> = overlay.vlines.iter().filter_map(|v| tf(v.1, xl)).collect();
    let xr = range(
        all.iter()
            .map(|p| p.0)
            .chain(marked.iter().map(|m| m.0))
            .chain(vx.iter().copied()),
        xl,
    );
    let yr = range(
        all.iter()
            .flat_map(|p| [p.2, p.3])
            .chain(marked.iter().map(|m| m.1)),
        yl,
    );
    let mut chart = frame(root, &fig.title, xr, yr)?;
    let (xs, ys) = (xr.1 - xr.0, yr.1 - yr.0);
    chart
        .configure_mesh()
        .x_desc(&fig.x_desc)
        .y_desc(&fig.y_desc)
        .x_label_formatter(&|v| label(*v, xl, xs))
        .y_label_formatter(&|v| label(*v, yl, ys))
        .label_style((FONT_FAMILY, 14))
        .draw()
        .map_err(s)?;
    if !overlay.is_empty() {
        draw_overlay_below(&mut chart, overlay, &at, yr)?;
    }
    for ser in &fig.series {
        let c = colour(ser.colour);
        let p = pts(ser);
        if !ser.markers_only {
            chart
                .draw_series(LineSeries::new(
                    p.iter().map(|q| (q.0, q.1)),
                    c.stroke_width(2),
                ))
                .map_err(s)?;
        }
        // Bars only where there is an error to show.
        chart
            .draw_series(
                p.iter()
                    .filter(|q| q.3 > q.2)
                    .map(|q| ErrorBar::new_vertical(q.0, q.2, q.1, q.3, c.stroke_width(1), 6)),
            )
            .map_err(s)?;
        let filled = !ser.markers_only;
        // A dense curve (a run's frames, an outline) is its line; markers would hide it.
        let dense = filled && p.len() > DENSE;
        chart
            .draw_series(p.iter().filter(|_| !dense).map(|q| {
                let style = if filled {
                    c.filled()
                } else {
                    c.stroke_width(2)
                };
                Circle::new((q.0, q.1), 4, style)
            }))
            .map_err(s)?
            .label(ser.label.clone())
            .legend(move |(x, y)| {
                let style = if filled {
                    c.filled()
                } else {
                    c.stroke_width(2)
                };
                Circle::new((x, y), 4, style)
            });
    }
    for (name, x, y) in &overlay.stars {
        if let Some(p) = at(*x, *y) {
            chart
                .draw_series(std::iter::once(Cross::new(p, 9, BLACK.stroke_width(3))))
                .map_err(s)?
                .label(name.clone())
                .legend(|(x, y)| Cross::new((x, y), 6, BLACK.stroke_width(3)));
        }
    }
    legend(&mut chart)
}

/// A titled chart over the ranges (axis coordinates), as every chart here has it.
fn frame<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    xr: (f64, f64),
    yr: (f64, f64),
) -> Result<Chart<'a, DB>, String> {
    ChartBuilder::on(root)
        .caption(title, (FONT_FAMILY, 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(s)
}

/// The series' legend box, as every chart here draws it.
fn legend<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>) -> Result<(), String> {
    chart
        .configure_series_labels()
        .label_font((FONT_FAMILY, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(s)
}

type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// The overlay's regions, brackets and reference lines, under the curves.
fn draw_overlay_below<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    overlay: &Overlay,
    at: &dyn Fn(f64, f64) -> Option<(f64, f64)>,
    yr: (f64, f64),
) -> Result<(), String> {
    for (name, corners) in &overlay.regions {
        let poly: Vec<(f64, f64)> = corners.iter().filter_map(|&(x, y)| at(x, y)).collect();
        if poly.len() < 3 {
            continue;
        }
        chart
            .draw_series(std::iter::once(Polygon::new(
                poly,
                REGION.mix(0.35).filled(),
            )))
            .map_err(s)?
            .label(name.clone())
            .legend(|(x, y)| {
                Rectangle::new([(x - 6, y - 5), (x + 6, y + 5)], REGION.mix(0.35).filled())
            });
    }
    for &(x, lo, hi, c) in &overlay.brackets {
        if let (Some(a), Some(b)) = (at(x, lo), at(x, hi)) {
            chart
                .draw_series(std::iter::once(ErrorBar::new_vertical(
                    a.0,
                    a.1,
                    0.5 * (a.1 + b.1),
                    b.1,
                    colour(c).stroke_width(2),
                    10,
                )))
                .map_err(s)?;
        }
    }
    for (k, (name, x)) in overlay.vlines.iter().enumerate() {
        // y = 1 is on either kind of axis; only x matters.
        let Some((x, _)) = at(*x, 1.0) else {
            continue;
        };
        let style = REFERENCE.mix(1.0 - 0.25 * (k % 3) as f64).stroke_width(2);
        chart
            .draw_series(DashedLineSeries::new([(x, yr.0), (x, yr.1)], 8, 6, style))
            .map_err(s)?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], style));
    }
    Ok(())
}

/// Points of a phase diagram, each in one of `classes` (by index), and intervals
/// along x where the class changes (drawn as shaded bands).
pub struct PhaseFigure {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub y_log: bool,
    /// Class names, in colour order.
    pub classes: Vec<String>,
    /// (x, y, class index).
    pub points: Vec<(f64, f64, usize)>,
    /// (x_lo, x_hi, y_lo, y_hi): a transition bracketed by grid points.
    pub bands: Vec<(f64, f64, f64, f64)>,
}

/// Newtonian, Bagnoldian, undecided.
const CLASS_COLOURS: [RGBColor; 3] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(150, 150, 150),
];

impl Figure for PhaseFigure {
    fn size(&self) -> (u32, u32) {
        (760, 520)
    }
    fn labels(&self) -> Labels {
        Labels::of(&self.title, &self.x_desc, &self.y_desc)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(s)?;
        let pts: Vec<(f64, f64, usize)> = self
            .points
            .iter()
            .filter_map(|&(x, y, c)| Some((tf(x, false)?, tf(y, self.y_log)?, c)))
            .collect();
        let xr = range(
            pts.iter()
                .map(|p| p.0)
                .chain(self.bands.iter().flat_map(|b| [b.0, b.1])),
            false,
        );
        let yr = range(pts.iter().map(|p| p.1), self.y_log);
        let mut chart = frame(root, &self.title, xr, yr)?;
        let (yl, ys) = (self.y_log, yr.1 - yr.0);
        chart
            .configure_mesh()
            .x_desc(&self.x_desc)
            .y_desc(&self.y_desc)
            .x_label_formatter(&|v| format!("{v:.3}"))
            .y_label_formatter(&|v| label(*v, yl, ys))
            .label_style((FONT_FAMILY, 14))
            .draw()
            .map_err(s)?;
        for &(x0, x1, y0, y1) in &self.bands {
            let (Some(a), Some(b)) = (tf(y0, yl), tf(y1, yl)) else {
                continue;
            };
            let pad = 0.05 * (yr.1 - yr.0);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x0, a - pad), (x1, b + pad)],
                    RGBColor(255, 200, 0).mix(0.35).filled(),
                )))
                .map_err(s)?;
        }
        for (k, name) in self.classes.iter().enumerate() {
            let c = CLASS_COLOURS[k % CLASS_COLOURS.len()];
            chart
                .draw_series(
                    pts.iter()
                        .filter(|p| p.2 == k)
                        .map(|p| Circle::new((p.0, p.1), 7, c.filled())),
                )
                .map_err(s)?
                .label(name.clone())
                .legend(move |(x, y)| Circle::new((x, y), 6, c.filled()));
        }
        legend(&mut chart)
    }
}

#[cfg(test)]
mod tests {
    use super::label;

    /// Issue 36: the outline figure's axis printed "-2.2e-16" where its tick was 0.
    #[test]
    fn a_tick_that_rounding_moved_off_zero_prints_0() {
        let tick = 0.1 + 0.2 - 0.3; // 5.55e-17: ticks stepped in floating point
        assert_ne!(tick, 0.0);
        assert_eq!(label(tick, false, 1.2), "0");
        assert_eq!(label(-2.2e-16, false, 2.0), "0");
        // A small value on a small axis is still itself; log axes are untouched.
        assert_eq!(label(2.5e-5, false, 1e-4), "2.5e-5");
        assert_eq!(label(-3.0, true, 6.0), "1e-3");
    }
}
