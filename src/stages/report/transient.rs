//! The size scan's "transient shear lines" part (li-granular-pillars Sec. V, Fig. 11
//! text): each run's lines linked across consecutive frame pairs
//! (`structure::line_tracks`, computed by the `sizes` stage), how long they live, how
//! many are born, how many there are per pillar area, and the paper's two claims as
//! checks: the lines are transient, and bigger pillars have more of them.

use crate::error::Result;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::html::Block;
use crate::stages::report::sections::Figures;
use crate::stages::size_analysis::RunLines;
use crate::stages::sizes::SizeScan;

/// Largest share of a pair's line grains that are in a line again in the next pair
/// for the lines to count as transient: a line that carried the deformation on would
/// keep nearly all of its grains; at one half, most of its grains have stopped shearing
/// fast one Δt later (the paper: they "may not accumulate significant amount of shear
/// strain continuously").
pub const TRANSIENT_PERSISTENCE: f64 = 0.5;

/// The transient check's verdict from each run's grain persistence (NaN: no lines in
/// two consecutive pairs, so nothing to judge).
fn transient_verdict(persistence: &[f64]) -> &'static str {
    if persistence.iter().any(|p| !p.is_finite()) {
        "not made: a run has no lines in two consecutive pairs"
    } else if persistence.iter().all(|p| *p < TRANSIENT_PERSISTENCE) {
        "holds"
    } else {
        "does not hold"
    }
}

pub fn section(
    f: &mut Figures,
    scan: &SizeScan,
    names: &[String],
    runs: &[RunLines],
) -> Result<()> {
    if runs.is_empty() {
        return Ok(());
    }
    let mut rows = Vec::new();
    let mut series = Vec::new();
    // (N, lines per pair) for the size check, in scan order (by W0).
    let mut per_pair = Vec::new();
    let mut persistence = Vec::new();
    for run in runs {
        let (r, t, de) = (&scan.rows[run.row], &run.tracks, run.strain_per_pair);
        let area = r.w0_over_d * r.h0_over_d;
        per_pair.push((r.n, t.lines_per_pair));
        persistence.push(t.grain_persistence);
        // NaN (nothing to measure: no uncensored track, no following pair) as a dash.
        let num = |v: f64, digits: usize| {
            if v.is_finite() {
                format!("{v:.digits$}")
            } else {
                "—".into()
            }
        };
        rows.push(vec![
            names[run.row].clone(),
            format!("{} (Δε = {})", t.pairs, num(de, 4)),
            num(t.lines_per_pair, 2),
            num(1000.0 * t.lines_per_pair / area, 2),
            format!("{} ({} censored)", t.tracks, t.censored),
            format!(
                "{} ({})",
                num(t.mean_lifetime, 2),
                num(t.mean_lifetime * de, 4)
            ),
            format!("{} %", num(100.0 * t.single_pair_fraction, 0)),
            num(t.births_per_pair / de, 1),
            format!(
                "{} % (chance {} %)",
                num(100.0 * t.grain_persistence, 0),
                num(100.0 * t.grain_chance, 0)
            ),
        ]);
        let complete: usize = t.lifetime_counts.iter().sum();
        if complete > 0 {
            series.push(XySeries {
                label: names[run.row].clone(),
                points: t
                    .lifetime_counts
                    .iter()
                    .enumerate()
                    .map(|(l, &c)| ((l + 1) as f64 * de, c as f64 / complete as f64, 0.0))
                    .collect(),
                markers_only: false,
                colour: run.row,
            });
        }
    }
    f.blocks.push(Block::Paragraph(
        "Transient shear lines: each frame pair's lines linked to the next pair's when they share at least 30 % of the smaller line's grains (one link each way, the largest share first); a track's lifetime is the pairs it spans, censored when it is alive at the first or last pair. Method: docs/shear-lines.md.".into(),
    ));
    f.blocks.push(Block::Table {
        header: [
            "run",
            "frame pairs (strain per pair)",
            "lines per pair",
            "lines per 1000 D² of W0 H0",
            "tracks",
            "mean lifetime, pairs (strain), uncensored",
            "lived one pair",
            "births per unit strain",
            "line grains in a line again next pair",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    let verdict = transient_verdict(&persistence);
    f.blocks.push(Block::Paragraph(format!(
        "Check — the lines are transient (Sec. V): at every size fewer than {:.0} % of a pair's line grains are in a line again one pair later: {}; {verdict}.",
        100.0 * TRANSIENT_PERSISTENCE,
        persistence
            .iter()
            .map(|p| {
                if p.is_finite() {
                    format!("{:.0} %", 100.0 * p)
                } else {
                    "—".into()
                }
            })
            .collect::<Vec<_>>()
            .join(", "),
    )));
    if per_pair.len() >= 2 {
        let more = per_pair.windows(2).all(|w| w[1].1 > w[0].1);
        f.blocks.push(Block::Paragraph(format!(
            "Check — bigger pillars have more lines (Sec. V: \"there must be more of them in larger systems\"): lines per frame pair {}, {}.",
            per_pair
                .iter()
                .map(|(n, l)| format!("{l:.2} at N = {n}"))
                .collect::<Vec<_>>()
                .join(", "),
            if more {
                "rising with N: holds"
            } else {
                "not rising with N at every step: does not hold"
            }
        )));
    }
    if !series.is_empty() {
        f.add(
            &XyFigure {
                title: "Shear-line lifetimes by size (Sec. V)".into(),
                x_desc: "lifetime (strain)".into(),
                y_desc: "fraction of uncensored tracks".into(),
                x_log: false,
                y_log: false,
                series,
            },
            "line_lifetimes",
            "How long the transient shear lines live: the distribution of the uncensored tracks' lifetimes, in strain (pairs × strain per pair), for every size.".into(),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The measured N = 1000 / 2000 / 4000 persistences hold; one run at 60 % does not;
    /// a run without two consecutive pairs of lines leaves the check unmade.
    #[test]
    fn the_transient_check_judges_each_run() {
        assert_eq!(transient_verdict(&[0.29, 0.37, 0.43]), "holds");
        assert_eq!(transient_verdict(&[0.29, 0.6]), "does not hold");
        assert!(transient_verdict(&[0.29, f64::NAN]).starts_with("not made"));
    }
}
