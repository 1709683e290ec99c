//! Correlation scatter plots (vagberg-sheared-disks Fig. 21): one point per sampled
//! contact, the distribution's mean as a white dot and the principal axes of its
//! covariance as dotted lines through it.

use super::{FONT_FAMILY, Figure, PALETTE};
use plotters::coord::Shift;
use plotters::prelude::*;

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Mean, covariance and principal axes of a 2-d point cloud.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Moments {
    pub n: usize,
    pub mean: (f64, f64),
    /// Standard deviations along x and y.
    pub sd: (f64, f64),
    /// Pearson correlation of x and y (NaN when either has no spread).
    pub r: f64,
    /// Direction of the major principal axis, degrees from +x in (−90°, 90°].
    pub major_deg: f64,
}

impl Moments {
    /// None for fewer than two finite points.
    pub fn of(points: &[(f64, f64)]) -> Option<Moments> {
        let p: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if p.len() < 2 {
            return None;
        }
        let n = p.len() as f64;
        let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
        let my = p.iter().map(|q| q.1).sum::<f64>() / n;
        let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
        for (x, y) in &p {
            sxx += (x - mx) * (x - mx);
            syy += (y - my) * (y - my);
            sxy += (x - mx) * (y - my);
        }
        let (sxx, syy, sxy) = (sxx / (n - 1.0), syy / (n - 1.0), sxy / (n - 1.0));
        // The eigenvector of the larger eigenvalue of [[sxx, sxy], [sxy, syy]].
        let major = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let mut deg = major.to_degrees();
        if deg <= -90.0 {
            deg += 180.0;
        }
        Some(Moments {
            n: p.len(),
            mean: (mx, my),
            sd: (sxx.sqrt(), syy.sqrt()),
            r: sxy / (sxx * syy).sqrt(),
            major_deg: deg,
        })
    }
}

/// y against x for every point, with its moments drawn.
pub struct ScatterFigure {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub points: Vec<(f64, f64)>,
}

/// Axis range holding 99 % of the values: a few fast contacts would otherwise squeeze
/// the cloud into a corner.
fn range(mut v: Vec<f64>) -> (f64, f64) {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return (-1.0, 1.0);
    }
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(0.005), at(0.995));
    let pad = if hi > lo {
        0.08 * (hi - lo)
    } else {
        0.5 * lo.abs().max(1.0)
    };
    (lo - pad, hi + pad)
}

impl Figure for ScatterFigure {
    fn size(&self) -> (u32, u32) {
        (620, 560)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(s)?;
        let xr = range(self.points.iter().map(|p| p.0).collect());
        let yr = range(self.points.iter().map(|p| p.1).collect());
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT_FAMILY, 18))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
            .map_err(s)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_desc)
            .y_desc(&self.y_desc)
            .label_style((FONT_FAMILY, 14))
            .draw()
            .map_err(s)?;
        let inside = |p: &&(f64, f64)| (xr.0..=xr.1).contains(&p.0) && (yr.0..=yr.1).contains(&p.1);
        chart
            .draw_series(
                self.points
                    .iter()
                    .filter(inside)
                    .map(|p| Circle::new(*p, 2, PALETTE[0].mix(0.35).filled())),
            )
            .map_err(s)?;
        let Some(m) = Moments::of(&self.points) else {
            return Ok(());
        };
        // Each principal axis as a dotted line through the mean, across the whole plot.
        let span = (xr.1 - xr.0).hypot(yr.1 - yr.0);
        for deg in [m.major_deg, m.major_deg + 90.0] {
            let (sn, cs) = deg.to_radians().sin_cos();
            let end = |t: f64| (m.mean.0 + t * cs, m.mean.1 + t * sn);
            chart
                .draw_series(DashedLineSeries::new(
                    [end(-span), end(span)],
                    4,
                    4,
                    BLACK.stroke_width(1),
                ))
                .map_err(s)?;
        }
        chart
            .draw_series([
                Circle::new(m.mean, 6, WHITE.filled()),
                Circle::new(m.mean, 6, BLACK.stroke_width(1)),
            ])
            .map_err(s)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn principal_axis_of_a_line_and_of_a_round_cloud() {
        // Points on y = 2x + 1: the major axis at atan 2, perfectly correlated.
        let line: Vec<(f64, f64)> = (0..50).map(|k| (k as f64, 2.0 * k as f64 + 1.0)).collect();
        let m = Moments::of(&line).unwrap();
        assert!(
            (m.major_deg - 2f64.atan().to_degrees()).abs() < 1e-9,
            "{m:?}"
        );
        assert!((m.r - 1.0).abs() < 1e-12);
        assert!((m.mean.1 - (2.0 * m.mean.0 + 1.0)).abs() < 1e-12);
        // Anticorrelated: the major axis points down.
        let down: Vec<(f64, f64)> = line.iter().map(|p| (p.0, -p.1)).collect();
        let m = Moments::of(&down).unwrap();
        assert!(
            (m.major_deg + 2f64.atan().to_degrees()).abs() < 1e-9,
            "{m:?}"
        );
        assert!((m.r + 1.0).abs() < 1e-12);
        // Wider in y than in x, uncorrelated: the major axis is vertical.
        let cross = [(1.0, 0.0), (-1.0, 0.0), (0.0, 3.0), (0.0, -3.0)];
        let m = Moments::of(&cross).unwrap();
        assert!((m.major_deg - 90.0).abs() < 1e-9, "{m:?}");
        assert!(m.r.abs() < 1e-12);
        assert!(Moments::of(&[(1.0, 1.0)]).is_none());
    }
}
