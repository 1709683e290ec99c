//! The collision-angle figures (vagberg-sheared-disks Sec. III.C, Eq. 27): ϑ is the angle
//! by which v_ij must be rotated to lie along r_ij (cos ϑ = v̂_ij · r̂_ij, −180° < ϑ ≤ 180°),
//! counted at every contact making and breaking. For one run, P(ϑ) with its making and
//! breaking parts (Figs. 7–8, 18); for a sweep, P(ϑ) at three Q per φ (Figs. 8, 18) and
//! P(90°) against Q (Figs. 9, 19).

use super::{Figures, Row, key, versus_q};
use crate::dem::shear::ANGLE_BIN_DEG;
use crate::error::Result;
use crate::io::table::read_table;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use std::collections::BTreeMap;
use std::path::Path;

/// One run's P(ϑ) (per degree, making and breaking together) at the bin centres.
#[derive(Debug, Clone)]
pub struct AnglePdf {
    pub phi: f64,
    pub q: f64,
    pub rate: f64,
    pub points: Vec<(f64, f64)>,
}

/// Read a sweep's `sweep_angles.parquet`, one [`AnglePdf`] per run, in table order; none
/// when the file is absent (a sweep written before the angle of Eq. 27).
pub fn read_sweep_angles(dir: &Path) -> Result<Vec<AnglePdf>> {
    let f = dir.join(crate::stages::sweep::ANGLES);
    if !f.exists() {
        return Ok(Vec::new());
    }
    let t = match read_table(&f, &[]) {
        Ok(t) => t,
        // The table of a sweep whose runs carry no histograms holds its header alone.
        Err(crate::error::Error::Input { msg, .. }) if msg.starts_with("no data rows") => {
            return Ok(Vec::new());
        }
        Err(e) => return Err(e),
    };
    let (phi, q, rate) = (t.f64("phi")?, t.f64("q")?, t.f64("rate")?);
    let (lo, hi, pdf) = (
        t.f64("theta_lo_deg")?,
        t.f64("theta_hi_deg")?,
        t.f64("pdf")?,
    );
    let mut out: Vec<AnglePdf> = Vec::new();
    for i in 0..phi.len() {
        let same = out
            .last()
            .is_some_and(|a| (a.phi, a.q, a.rate) == (phi[i], q[i], rate[i]));
        if !same {
            out.push(AnglePdf {
                phi: phi[i],
                q: q[i],
                rate: rate[i],
                points: Vec::new(),
            });
        }
        let a = out.last_mut().expect("pushed above");
        a.points.push((0.5 * (lo[i] + hi[i]), pdf[i]));
    }
    Ok(out)
}

/// The Q values drawn for one φ, as the paper shows them: one below Q_c, one near it and
/// one above. Where the grid brackets Q_c (`qc::locate`: between the consecutive Q
/// `qc.0` and `qc.1`), the least Q run, the bracket's lower end (its upper end when the
/// lower is the least) and the largest; otherwise the least, the middle and the largest
/// (all of them when there are three or fewer).
fn three_q(mut qs: Vec<f64>, qc: Option<(f64, f64)>) -> Vec<f64> {
    qs.sort_by(f64::total_cmp);
    qs.dedup();
    if qs.len() <= 3 {
        return qs;
    }
    let last = qs.len() - 1;
    let interior = |q: f64| (1..last).find(|&k| key(qs[k]) == key(q));
    let middle = qc
        .and_then(|(lo, hi)| interior(lo).or_else(|| interior(hi)))
        .unwrap_or(qs.len() / 2);
    vec![qs[0], qs[middle], qs[last]]
}

/// Add P(ϑ) at three Q for each φ (at the sweep's smallest rate, the paper's
/// γ̇ τ_e = 1e-5 being its slowest) and P(±90°) against Q.
pub(super) fn add_sweep_figures(f: &mut Figures, rows: &[Row], pdfs: &[AnglePdf]) -> Result<()> {
    if let Some(rate) = pdfs.iter().map(|a| a.rate).min_by(f64::total_cmp) {
        let mut by_phi: BTreeMap<i64, Vec<&AnglePdf>> = BTreeMap::new();
        for a in pdfs.iter().filter(|a| a.rate == rate) {
            by_phi.entry(key(a.phi)).or_default().push(a);
        }
        let located = super::qc::locate(rows);
        for runs in by_phi.values() {
            let phi = runs[0].phi;
            let qc = located
                .iter()
                .find(|p| key(p.phi) == key(phi) && key(p.rate) == key(rate))
                .map(|p| (p.lo, p.hi));
            let qs = three_q(runs.iter().map(|a| a.q).collect(), qc);
            let series = runs
                .iter()
                .filter(|a| qs.contains(&a.q))
                .enumerate()
                .map(|(k, a)| XySeries {
                    label: match qc {
                        Some((lo, _)) if key(a.q) == key(lo) => {
                            format!("Q = {} (just below Q_c)", a.q)
                        }
                        Some((_, hi)) if key(a.q) == key(hi) => {
                            format!("Q = {} (just above Q_c)", a.q)
                        }
                        Some((lo, _)) if a.q < lo => format!("Q = {} (below Q_c)", a.q),
                        Some((_, hi)) if a.q > hi => format!("Q = {} (above Q_c)", a.q),
                        _ => format!("Q = {}", a.q),
                    },
                    points: a.points.iter().map(|(x, y)| (*x, *y, 0.0)).collect(),
                    markers_only: false,
                    colour: k,
                })
                .collect();
            f.add(
                &XyFigure {
                    title: match qc {
                        Some((lo, hi)) => format!("P(ϑ) at φ = {phi}, Q_c between {lo} and {hi} (Figs. 8, 18)"),
                        None => format!("P(ϑ) at φ = {phi}, three Q (Figs. 8, 18)"),
                    },
                    x_desc: "ϑ (degrees), Eq. 27".into(),
                    y_desc: "P(ϑ) (1/degree)".into(),
                    x_log: false,
                    y_log: false,
                    series,
                },
                &format!("theta_phi_{phi}").replace('.', "p"),
                format!(
                    "The collision angle ϑ (Eq. 27: the rotation that takes the relative velocity v_ij onto r_ij) at every contact making and breaking, as one histogram per degree, at φ = {phi} and γ̇ τ_e = {rate:e} for the least Q run, the one nearest Q_c (where the grid brackets it from the drop of P^el, Fig. 3; else a middle one) and the largest: above Q_c collisions come from every direction, with minima at ±90°; below Q_c they are glancing, peaked at ±90° (vagberg-sheared-disks Figs. 8 for CD, 18 for CDrot). Making events lie at |ϑ| > 90°, breaking events at |ϑ| < 90°."
                ),
            )?;
        }
    }
    let mut series = versus_q(rows, "p_theta_90");
    if series.is_empty() {
        return Ok(());
    }
    for s in &mut series {
        s.label = format!("P(90°), {}", s.label);
    }
    let n = series.len();
    for mut s in versus_q(rows, "p_theta_minus_90") {
        s.label = format!("P(−90°), {}", s.label);
        s.markers_only = true;
        s.colour %= n.max(1);
        series.push(s);
    }
    f.add(
        &XyFigure {
            title: "P(ϑ = 90°) against Q (Figs. 9, 19)".into(),
            x_desc: "Q".into(),
            y_desc: "P(ϑ = 90°) (1/degree)".into(),
            x_log: true,
            y_log: false,
            series,
        },
        "p_theta_90",
        "P(ϑ = 90°), the density of the collision angle (Eq. 27) at tangential collisions, against Q for each (φ, γ̇): the mean of the two 3.6° bins that meet at +90° (curves; open markers: the two at −90°), counting errors as bars. Near zero above Q_c (Bagnoldian: collisions from every direction), rising sharply below it (Newtonian: glancing contacts) (vagberg-sheared-disks Figs. 9 for CD, 19 for CDrot).".into(),
    )
}

/// One run's P(ϑ) with its making and breaking parts, from its `collision_angles.parquet`.
pub(super) fn add_run_figure(f: &mut Figures, file: &Path) -> Result<()> {
    let t = read_table(file, &[])?;
    let (lo, hi) = (t.f64("theta_lo_deg")?, t.f64("theta_hi_deg")?);
    let mid: Vec<f64> = lo.iter().zip(&hi).map(|(a, b)| 0.5 * (a + b)).collect();
    let (mk, br) = (t.f64("making")?, t.f64("breaking")?);
    let total: f64 = mk.iter().chain(&br).sum();
    // Each part as its share of P(ϑ), so the two add up to the paper's histogram.
    let share = |c: &[f64]| -> Vec<f64> {
        c.iter()
            .map(|x| {
                if total > 0.0 {
                    x / (total * ANGLE_BIN_DEG)
                } else {
                    0.0
                }
            })
            .collect()
    };
    let series = [
        ("P(ϑ), making and breaking", t.f64("pdf")?, 0),
        ("contacts making", share(&mk), 1),
        ("contacts breaking", share(&br), 2),
    ]
    .into_iter()
    .map(|(label, y, colour)| XySeries {
        label: label.into(),
        points: mid.iter().zip(&y).map(|(x, y)| (*x, *y, 0.0)).collect(),
        markers_only: colour != 0,
        colour,
    })
    .collect();
    f.add(
        &XyFigure {
            title: "P(ϑ), ϑ of Eq. 27, at contact making and breaking (Figs. 8, 18)".into(),
            x_desc: "ϑ (degrees)".into(),
            y_desc: "P(ϑ) (1/degree)".into(),
            x_log: false,
            y_log: false,
            series,
        },
        "angles",
        "The collision angle ϑ of Eq. 27 (the rotation that takes the relative velocity v_ij = v_i − v_j onto r_ij = r_i − r_j, −180° < ϑ ≤ 180°) over the steady window: the paper's P(ϑ), making and breaking together (line), and each part's share (markers). Contacts form with the grains driven together (|ϑ| > 90°) and break with them driven apart (|ϑ| < 90°) (vagberg-sheared-disks Figs. 7–8, 18).".into(),
    )
}

#[cfg(test)]
mod tests {
    use super::three_q;

    #[test]
    fn three_q_keeps_the_ends_and_a_middle() {
        assert_eq!(three_q(vec![5.0, 1.0], None), [1.0, 5.0]);
        assert_eq!(
            three_q(vec![20.0, 1.0, 5.0, 2.0, 1.0], None),
            [1.0, 5.0, 20.0]
        );
        // Q_c bracketed: the bracket's lower end, or its upper one when the lower is
        // the least Q run.
        let qs = vec![0.3, 1.0, 2.0, 5.0, 10.0, 100.0];
        assert_eq!(three_q(qs.clone(), Some((1.0, 2.0))), [0.3, 1.0, 100.0]);
        assert_eq!(three_q(qs.clone(), Some((0.3, 1.0))), [0.3, 1.0, 100.0]);
        assert_eq!(three_q(qs.clone(), Some((10.0, 100.0))), [0.3, 10.0, 100.0]);
        assert_eq!(three_q(qs, None), [0.3, 5.0, 100.0]);
    }
}
