//! One sheared-disk run's contact velocities and shear bands (vagberg-sheared-disks):
//! scatter plots of the components of the velocity difference of contacts (Eqs. 30–34,
//! Fig. 21) with a table of their moments, the flow profile v_x(y), γ̇(y) and φ(y)
//! across the box (Fig. 28), and maps of the local φ(x, y) and γ̇(x, y) (Fig. 27).

use super::Figures;
use crate::error::Result;
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::html::Block;
use crate::stages::report::render::map::{MapFigure, MapPanel};
use crate::stages::report::render::scatter::{Moments, ScatterFigure};
use std::path::Path;

/// The pairs of Fig. 21: (x column, y column, x axis, y axis, file, panel).
const PAIRS: [(&str, &str, &str, &str, &str, &str); 3] = [
    ("v_t", "v_r", "V_ij,T", "V^R_ij", "vt_vr", "(a, b)"),
    ("v_c_t", "v_r", "V^C_ij,T", "V^R_ij", "vct_vr", "(c, d)"),
    ("v_c_t", "v_n", "V^C_ij,T", "V_ij,N", "vct_vn", "(e, f)"),
];

fn fmt(x: f64) -> String {
    if !x.is_finite() {
        "–".into()
    } else if x != 0.0 && !(1e-3..1e4).contains(&x.abs()) {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// The moments of each Fig. 21 pair of `contact_velocities.parquet`: (pair name,
/// moments), for the table and for tests.
pub fn contact_moments(file: &Path) -> Result<Vec<(String, Moments)>> {
    let t = read_table(
        file,
        &["v_t", "v_r", "v_c_t", "v_n"].map(|c| (c, Expect::Float)),
    )?;
    t.require(&["v_t", "v_r", "v_c_t", "v_n"])?;
    let mut out = Vec::new();
    for (x, y, xd, yd, _, _) in PAIRS {
        let pts: Vec<(f64, f64)> = t.f64(x)?.into_iter().zip(t.f64(y)?).collect();
        if let Some(m) = Moments::of(&pts) {
            out.push((format!("{yd} vs {xd}"), m));
        }
    }
    Ok(out)
}

/// Add whatever of `contact_velocities.parquet`, `profile.parquet` and `fields.parquet`
/// the run's directory holds; `rate` is the imposed γ̇ τ_e.
pub(super) fn add(f: &mut Figures, dir: &Path, rate: Option<f64>) -> Result<()> {
    let cf = dir.join("contact_velocities.parquet");
    if cf.exists() {
        let t = read_table(&cf, &[])?;
        t.require(&["v_t", "v_r", "v_c_t", "v_n"])?;
        for (x, y, xd, yd, file, panel) in PAIRS {
            let points: Vec<(f64, f64)> = t.f64(x)?.into_iter().zip(t.f64(y)?).collect();
            f.add(
                &ScatterFigure {
                    title: format!("{yd} against {xd} (Fig. 21{panel})"),
                    x_desc: format!("{xd} / (d_s dγ/dt)"),
                    y_desc: format!("{yd} / (d_s dγ/dt)"),
                    points,
                },
                &format!("contacts_{file}"),
                format!("Components of the velocity difference of two disks in contact (Eqs. 30–34, in units of d_s γ̇), one point per contact drawn at a random time of the steady window: {yd} against {xd}; white dot: the mean, dotted lines: the principal axes of the covariance; axes cover 99 % of the points (vagberg-sheared-disks Fig. 21{panel})."),
            )?;
        }
        let moments = contact_moments(&cf)?;
        f.blocks.push(Block::Table {
            header: [
                "pair",
                "contacts",
                "mean x",
                "mean y",
                "sd x",
                "sd y",
                "correlation r",
                "major axis (°)",
            ]
            .map(String::from)
            .to_vec(),
            rows: moments
                .iter()
                .map(|(name, m)| {
                    vec![
                        name.clone(),
                        m.n.to_string(),
                        fmt(m.mean.0),
                        fmt(m.mean.1),
                        fmt(m.sd.0),
                        fmt(m.sd.1),
                        format!("{:.3}", m.r),
                        format!("{:.1}", m.major_deg),
                    ]
                })
                .collect(),
        });
    }
    let pf = dir.join("profile.parquet");
    if pf.exists() {
        let t = read_table(&pf, &[])?;
        t.require(&["y", "vx", "vx_affine", "gamma_dot", "phi"])?;
        let y = t.f64("y")?;
        let curve = |col: &str, label: &str, colour: usize| -> Result<XySeries> {
            Ok(XySeries {
                label: label.into(),
                points: y
                    .iter()
                    .zip(t.f64_or_nan(col)?)
                    .map(|(y, v)| (*y, v, 0.0))
                    .collect(),
                markers_only: false,
                colour,
            })
        };
        let rate_line = rate.map(|r| XySeries {
            label: format!("imposed {r:e}"),
            points: vec![(y[0], r, 0.0), (y.last().copied().unwrap_or(y[0]), r, 0.0)],
            markers_only: false,
            colour: 1,
        });
        let panels = [
            (
                "vx",
                vec![
                    curve("vx", "v_x(y)", 0)?,
                    curve("vx_affine", "γ̇ y (uniform shear)", 1)?,
                ],
                "v_x τ_e / d_s",
                "the mean flow velocity v_x(y) beside the uniform profile γ̇ y: a shear band is a stretch where the slope differs",
            ),
            (
                "gamma_dot",
                std::iter::once(curve("gamma_dot", "γ̇(y)", 0)?)
                    .chain(rate_line)
                    .collect(),
                "dγ/dt(y) · τ_e",
                "the local strain rate γ̇(y) τ_e = dv_x/dy beside the imposed one",
            ),
            (
                "phi",
                vec![curve("phi", "φ(y)", 0)?],
                "φ(y)",
                "the local packing fraction φ(y): denser where the flow is slower (the Newtonian band)",
            ),
        ];
        for (file, series, y_desc, what) in panels {
            f.add(
                &XyFigure {
                    title: format!("Profile across the box: {y_desc} (Fig. 28)"),
                    x_desc: "y / d_s".into(),
                    y_desc: y_desc.into(),
                    x_log: false,
                    y_log: false,
                    series,
                },
                &format!("profile_{file}"),
                format!("Across the flow, in 20 bins of y, averaged over the steady window: {what} (vagberg-sheared-disks Fig. 28). Bands that wander over the window are averaged out."),
            )?;
        }
        super::coexistence::add_run(f, &t.f64_or_nan("phi")?, &t.f64_or_nan("gamma_dot")?);
    }
    let ff = dir.join("fields.parquet");
    if ff.exists() {
        let t = read_table(&ff, &[])?;
        t.require(&["x", "y", "phi", "gamma_dot"])?;
        let (x, y) = (t.f64("x")?, t.f64("y")?);
        let mut xs = x.clone();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        // Each grid point drawn as a disk filling its cell.
        let radius = xs
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        let radius = if radius.is_finite() {
            0.5 * radius
        } else {
            2.0
        };
        for (col, name, file) in [
            ("phi", "local φ(x, y)", "field_phi"),
            ("gamma_dot", "local γ̇(x, y) τ_e", "field_gamma_dot"),
        ] {
            let v = t.f64_or_nan(col)?;
            let grains = (0..x.len())
                .filter(|&i| v[i].is_finite())
                .map(|i| (x[i], y[i], radius, v[i]))
                .collect();
            f.add(
                &MapFigure {
                    quantity: name.into(),
                    panels: vec![MapPanel {
                        title: format!("{name}, steady-window mean"),
                        grains,
                    }],
                    log: false,
                    columns: 1,
                },
                file,
                format!("The {name} over circles of radius {} d_s on a grid, averaged over {} snapshots of the steady window; shear bands show as stripes along x (vagberg-sheared-disks Fig. 27, there a single snapshot).", crate::stages::shear::FIELD_RADIUS, crate::stages::shear::FIELD_SNAPSHOTS),
            )?;
        }
    }
    Ok(())
}
