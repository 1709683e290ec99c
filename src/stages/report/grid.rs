//! A parameter study's section (li-granular-pillars Sec. II.C): each point's measures
//! against the varied key — for pillar runs ⟨σ⟩ and κ over 0.05 ≤ ε ≤ 0.2 and the yield
//! point ε_y, σ_y with their intervals — and the paper's claims about the key as checks
//! with their values: k_n "does not significantly influence" the flow stress while ε_y
//! falls as k_n rises and σ_y barely moves (Sec. III); σ_y rises with μ_g (Sec. II.C).

use crate::error::Result;
use crate::io::table::read_table;
use crate::stages::grid::{GridRecord, TABLE, read_record};
use crate::stages::report::render::SavedFigure;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::html::{Block, Section};
use crate::stages::report::sections::Figures;
use std::path::Path;

/// The keys the paper makes claims about.
const CLAIMED: [&str; 2] = ["k_n", "mu_g"];

/// The tolerances the claims are judged by.
pub const SIGMA_SPREAD: f64 = 0.10;
pub const SIGMA_Y_SPREAD_KN: f64 = 0.20;

/// `stats::relative_spread` of the finite values; NaN for fewer than two.
fn spread(v: &[f64]) -> f64 {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.len() < 2 {
        return f64::NAN;
    }
    crate::stats::relative_spread(&f)
}

/// The checks for the varied key `key` on points sorted by x: (claim, judged by,
/// measured, verdict).
pub fn checks(key: &str, x: &[f64], col: &dyn Fn(&str) -> Vec<f64>) -> Vec<[String; 4]> {
    let verdict = |ok: bool| if ok { "holds" } else { "does not hold" }.to_string();
    let name = key.rsplit('.').next().unwrap_or(key);
    let mut rows = Vec::new();
    let (eps_y, sigma_y, sigma) = (col("eps_y"), col("sigma_y"), col("sigma_mean"));
    let ends = |v: &[f64]| (v.first().copied(), v.last().copied());
    match name {
        "k_n" => {
            let s = spread(&sigma);
            rows.push([
                "flow stress not significantly influenced by k_n (Sec. II.C)".into(),
                format!("⟨σ⟩ spread ≤ {:.0} %", 100.0 * SIGMA_SPREAD),
                format!("{:.1} %", 100.0 * s),
                if s.is_finite() {
                    verdict(s <= SIGMA_SPREAD)
                } else {
                    "—".into()
                },
            ]);
            if let (Some(lo), Some(hi)) = ends(&eps_y) {
                rows.push([
                    "ε_y falls as k_n rises (Sec. III)".into(),
                    format!(
                        "ε_y at k_n = {} below ε_y at k_n = {}",
                        x[x.len() - 1],
                        x[0]
                    ),
                    format!("{hi:.4} vs {lo:.4}"),
                    if lo.is_finite() && hi.is_finite() {
                        verdict(hi < lo)
                    } else {
                        "—".into()
                    },
                ]);
            }
            let s = spread(&sigma_y);
            rows.push([
                "σ_y barely depends on k_n (Sec. III)".into(),
                format!(
                    "σ_y spread ≤ {:.0} % (our reading of \"barely\")",
                    100.0 * SIGMA_Y_SPREAD_KN
                ),
                format!("{:.1} %", 100.0 * s),
                if s.is_finite() {
                    verdict(s <= SIGMA_Y_SPREAD_KN)
                } else {
                    "—".into()
                },
            ]);
        }
        "mu_g" => {
            let finite: Vec<f64> = sigma_y.iter().copied().filter(|v| v.is_finite()).collect();
            let rising = finite.len() >= 2 && finite.windows(2).all(|w| w[1] > w[0]);
            rows.push([
                "σ_y rises with substrate friction μ_g (Sec. II.C: the parameter that affects σ_y most)".into(),
                "σ_y increases from each μ_g to the next".into(),
                finite.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>().join(", "),
                if finite.len() >= 2 { verdict(rising) } else { "—".into() },
            ]);
        }
        _ => {}
    }
    rows
}

/// The section of one study, `dir` its grid stage's folder.
pub fn grid_section(
    label: &str,
    dir: &Path,
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Section> {
    let rec: GridRecord = read_record(dir)?;
    let t = read_table(&dir.join(TABLE), &[])?;
    // The axis: a key the paper makes claims about (a study of k_n varies dt with it),
    // else the first.
    let key = rec
        .keys
        .iter()
        .find(|k| CLAIMED.iter().any(|c| k.rsplit('.').next() == Some(*c)))
        .or(rec.keys.first())
        .cloned()
        .unwrap_or_default();
    // Points sorted by it.
    let x0 = t.f64_or_nan(&key)?;
    let mut order: Vec<usize> = (0..x0.len()).collect();
    order.sort_by(|&a, &b| x0[a].total_cmp(&x0[b]));
    let col = |name: &str| -> Vec<f64> {
        t.f64_or_nan(name)
            .map(|v| order.iter().map(|&i| v[i]).collect())
            .unwrap_or_default()
    };
    let x = col(&key);
    let positive = x.iter().all(|v| *v > 0.0);
    let x_log = positive
        && x.iter().copied().fold(0.0, f64::max)
            >= 10.0 * x.iter().copied().fold(f64::INFINITY, f64::min);
    let stem: String = label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let mut f = Figures {
        figdir,
        prefix: format!("grid_{stem}"),
        figures,
        blocks: Vec::new(),
    };
    f.blocks.push(Block::Paragraph(format!(
        "{} points of a {} stage varying {} (li-granular-pillars Sec. II.C); table grid.csv of the study's stage.",
        rec.points,
        rec.of,
        rec.keys.join(", ")
    )));
    let series = |y: &str, lo: Option<&str>, hi: Option<&str>, err: Option<&str>| -> XySeries {
        let (v, l, h, e) = (col(y), lo.map(col), hi.map(col), err.map(col));
        XySeries {
            label: label.to_string(),
            points: (0..x.len())
                .filter(|&i| v.get(i).is_some_and(|y| y.is_finite()))
                .map(|i| {
                    let bar = match (&l, &h, &e) {
                        (Some(l), Some(h), _) => 0.5 * (h[i] - l[i]),
                        (_, _, Some(e)) => e[i],
                        _ => 0.0,
                    };
                    (x[i], v[i], if bar.is_finite() { bar } else { 0.0 })
                })
                .collect(),
            markers_only: false,
            colour: 0,
        }
    };
    let pillar = rec.columns.iter().any(|c| c == "sigma_mean");
    let plots: Vec<(&str, &str, XySeries, &str)> = if pillar {
        vec![
            (
                "sigma",
                "⟨σ⟩, 0.05 ≤ ε ≤ 0.2  (m g μ / D)",
                series("sigma_mean", None, None, Some("sigma_err")),
                "The mean flow stress (errors from four blocks of the window)",
            ),
            (
                "kappa",
                "⟨κ⟩ = P_g-s / P_in",
                series("kappa_mean", None, None, None),
                "The fraction of the input power dissipated by substrate friction over the window",
            ),
            (
                "eps_y",
                "ε_y",
                series("eps_y", Some("eps_y_lo"), Some("eps_y_hi"), None),
                "The yield strain (bars: half the 95 % bootstrap interval)",
            ),
            (
                "sigma_y",
                "σ_y  (m g μ / D)",
                series("sigma_y", Some("sigma_y_lo"), Some("sigma_y_hi"), None),
                "The yield stress (bars: half the 95 % bootstrap interval)",
            ),
        ]
    } else {
        rec.columns
            .iter()
            .filter(|c| c.as_str() != "point")
            .map(|c| {
                (
                    c.as_str(),
                    c.as_str(),
                    series(c, None, None, None),
                    "The point's metric",
                )
            })
            .collect()
    };
    for (file, y_desc, s, what) in plots {
        if s.points.is_empty() {
            continue;
        }
        f.add(
            &XyFigure {
                title: format!("{y_desc} against {key} ({label})"),
                x_desc: key.clone(),
                y_desc: y_desc.into(),
                x_log,
                y_log: false,
                series: vec![s],
            },
            file,
            format!("{what} at each point of the study against {key}."),
        )?;
    }
    let rows = checks(&key, &x, &col);
    if !rows.is_empty() {
        f.blocks.push(Block::Table {
            header: ["the paper's claim", "judged by", "measured", "verdict"]
                .map(String::from)
                .to_vec(),
            rows: rows.into_iter().map(|r| r.to_vec()).collect(),
        });
    }
    for (i, why) in &rec.missing {
        f.blocks.push(Block::Paragraph(format!("Point {i}: {why}")));
    }
    Ok(Section {
        id: format!("grid-{stem}"),
        title: format!("Parameter study: {} ({label})", rec.keys.join(", ")),
        blocks: f.blocks,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table<'a>(cols: &'a [(&'a str, Vec<f64>)]) -> impl Fn(&str) -> Vec<f64> + 'a {
        move |n: &str| {
            cols.iter()
                .find(|(c, _)| *c == n)
                .map(|(_, v)| v.clone())
                .unwrap_or_default()
        }
    }

    /// Planted studies whose verdicts are known by hand.
    #[test]
    fn the_claims_are_judged_as_stated() {
        let x = [1000.0, 10000.0, 100000.0];
        let cols = [
            ("sigma_mean", vec![1.0, 1.05, 0.98]),
            ("eps_y", vec![0.02, 0.01, 0.005]),
            ("sigma_y", vec![0.5, 0.52, 0.55]),
        ];
        let rows = checks("set.k_n", &x, &table(&cols));
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[0][3], "holds", "spread 7 %: {:?}", rows[0]);
        assert_eq!(rows[1][3], "holds", "ε_y falls");
        assert_eq!(rows[2][3], "holds", "σ_y spread 9.6 %");
        let cols = [
            ("sigma_mean", vec![1.0, 1.3, 0.98]),
            ("eps_y", vec![0.01, 0.01, 0.02]),
            ("sigma_y", vec![0.5, 0.52, 0.55]),
        ];
        let rows = checks("set.k_n", &x, &table(&cols));
        assert_eq!(rows[0][3], "does not hold");
        assert_eq!(rows[1][3], "does not hold");
        let mu = [0.0, 0.1, 0.2];
        let rising = [("sigma_y", vec![0.3, 0.4, 0.5])];
        assert_eq!(checks("set.mu_g", &mu, &table(&rising))[0][3], "holds");
        let not = [("sigma_y", vec![0.3, 0.5, 0.4])];
        assert_eq!(checks("set.mu_g", &mu, &table(&not))[0][3], "does not hold");
        assert!(checks("set.dt", &mu, &table(&not)).is_empty());
    }
}
