//! Which frames the report's maps show. Li et al. show experiment and simulation at the
//! same labelled stages of deformation (Figs. 4–6), so when a data set's strain is known
//! its map frames are the ones nearest to strains shared by all data sets; otherwise
//! frames are spread evenly over the run.

use crate::error::Result;
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::tracks::Tracks;
use std::collections::BTreeMap;
use std::path::Path;

/// Engineering strain ε = ΔH/H0 by frame for one data set.
#[derive(Debug, Clone)]
pub struct StrainIndex {
    pub by_frame: BTreeMap<i64, f64>,
    /// True when estimated from the bar speed and the initial pillar height rather than
    /// measured (experiments: the bar positions are not in the tracks).
    pub estimated: bool,
}

impl StrainIndex {
    /// From a table with `frame` and `strain` columns (the simulator's stress–strain).
    pub fn from_table(p: &Path) -> Result<StrainIndex> {
        let t = read_table(p, &[("frame", Expect::Int), ("strain", Expect::Float)])?;
        t.require(&["frame", "strain"])?;
        let by_frame = t.i64("frame")?.into_iter().zip(t.f64("strain")?).collect();
        Ok(StrainIndex {
            by_frame,
            estimated: false,
        })
    }

    /// ε(t) = v_c (t − t₀) / H0 with v_c the bar speed of the tracks' metadata and H0 the
    /// pillar's height (radii included) in the first frame: assumes the bar touches the
    /// pillar and moves from the first frame on. `rows`: row indices by frame. None
    /// without a bar speed or frame times.
    pub fn from_tracks(t: &Tracks, rows: &BTreeMap<i64, Vec<usize>>) -> Option<StrainIndex> {
        let vc = t.meta.bar_speed.filter(|v| *v > 0.0)?;
        let (f0, r0) = rows.iter().next()?;
        let (lo, hi) = r0.iter().fold((f64::MAX, f64::MIN), |a, &i| {
            (a.0.min(t.y[i] - t.radius[i]), a.1.max(t.y[i] + t.radius[i]))
        });
        let h0 = hi - lo;
        if h0.is_nan() || h0 <= 0.0 {
            return None;
        }
        // Time of a frame in the unit of v_c's denominator (the tracks' time unit).
        let time = |f: i64, r: &[usize]| match (&t.time, t.meta.frame_time) {
            (Some(tt), _) => Some(tt[r[0]]),
            (None, Some(ft)) => Some(f as f64 * ft),
            _ => None,
        };
        let t0 = time(*f0, r0)?;
        let by_frame = rows
            .iter()
            .filter_map(|(f, r)| time(*f, r).map(|tf| (*f, vc * (tf - t0) / h0)))
            .collect();
        Some(StrainIndex {
            by_frame,
            estimated: true,
        })
    }

    /// Strain at `frame`, or at the nearest frame that has one.
    pub fn at(&self, frame: i64) -> Option<f64> {
        let after = self.by_frame.range(frame..).next();
        let before = self.by_frame.range(..frame).next_back();
        match (before, after) {
            (Some(b), Some(a)) if frame - b.0 < a.0 - frame => Some(*b.1),
            (_, Some(a)) => Some(*a.1),
            (Some(b), None) => Some(*b.1),
            (None, None) => None,
        }
    }

    /// "ε = 0.05" (measured) or "ε ≈ 0.05" (estimated) at `frame`.
    pub fn label(&self, frame: i64) -> Option<String> {
        let e = self.at(frame)?;
        let text = format!("{e:.3}");
        let text = text.trim_end_matches('0').trim_end_matches('.');
        let text = if text.is_empty() || text == "-" {
            "0"
        } else {
            text
        };
        Some(format!(
            "ε {} {text}",
            if self.estimated { "≈" } else { "=" }
        ))
    }
}

/// Target strains per data set: `stages` strains evenly spaced over (lo, hi], the range
/// every data set with strain covers (where those ranges do not overlap, each its own).
/// The start is left out: at ε = 0 nothing has moved yet and the forces are zero.
/// `ranges[k]` is data set k's (min, max) strain over its candidate frames.
pub fn strain_targets(ranges: &[Option<(f64, f64)>], stages: usize) -> Vec<Option<Vec<f64>>> {
    let spread = |(lo, hi): (f64, f64)| -> Vec<f64> {
        let n = stages.max(1);
        (0..n)
            .map(|k| lo + (hi - lo) * (k + 1) as f64 / n as f64)
            .collect()
    };
    let known: Vec<(f64, f64)> = ranges.iter().flatten().copied().collect();
    let common = known
        .iter()
        .fold((f64::MIN, f64::MAX), |a, r| (a.0.max(r.0), a.1.min(r.1)));
    let shared = !known.is_empty() && common.1 > common.0;
    ranges
        .iter()
        .map(|r| r.map(|r| spread(if shared { common } else { r })))
        .collect()
}

/// (min, max) strain over `frames`, None when unknown.
pub fn strain_range(strain: Option<&StrainIndex>, frames: &[i64]) -> Option<(f64, f64)> {
    let s = strain?;
    let v: Vec<f64> = frames.iter().filter_map(|&f| s.at(f)).collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (lo <= hi).then_some((lo, hi))
}

/// The frames to show among `frames` (sorted): nearest in strain to each target when
/// both are known, else `stages` frames spread evenly.
pub fn pick_frames(
    frames: &[i64],
    strain: Option<&StrainIndex>,
    targets: Option<&[f64]>,
    stages: usize,
) -> Vec<i64> {
    if frames.is_empty() {
        return Vec::new();
    }
    if let (Some(s), Some(targets)) = (strain, targets) {
        let eps: Vec<(i64, f64)> = frames
            .iter()
            .filter_map(|&f| s.at(f).map(|e| (f, e)))
            .collect();
        if !eps.is_empty() {
            return targets
                .iter()
                .map(|&t| {
                    eps.iter()
                        .min_by(|a, b| (a.1 - t).abs().total_cmp(&(b.1 - t).abs()))
                        .map(|p| p.0)
                        .expect("non-empty")
                })
                .collect();
        }
    }
    if frames.len() <= stages {
        return frames.to_vec();
    }
    (0..stages)
        .map(|k| frames[k * (frames.len() - 1) / (stages - 1).max(1)])
        .collect()
}

/// For each of `wanted`, the frame of `have` (sorted) nearest to it.
pub fn nearest_frames(have: &[i64], wanted: &[i64]) -> Vec<i64> {
    wanted
        .iter()
        .filter_map(|&w| have.iter().copied().min_by_key(|&h| (h - w).abs()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn index(pairs: &[(i64, f64)]) -> StrainIndex {
        StrainIndex {
            by_frame: pairs.iter().copied().collect(),
            estimated: false,
        }
    }

    #[test]
    fn stages_match_in_strain_across_data_sets() {
        // Experiment: 0.01 per frame over 20 frames; simulation: 0.02 per frame over 7.
        let exp = index(&(0..20).map(|f| (f, 0.01 * f as f64)).collect::<Vec<_>>());
        let sim = index(&(0..7).map(|f| (f, 0.02 * f as f64)).collect::<Vec<_>>());
        let (fe, fs): (Vec<i64>, Vec<i64>) = ((0..20).collect(), (0..7).collect());
        let ranges = [strain_range(Some(&exp), &fe), strain_range(Some(&sim), &fs)];
        let t = strain_targets(&ranges, 3);
        assert_eq!(t[0], t[1]);
        let t0 = t[0].as_deref().unwrap();
        assert!(
            t0.iter()
                .zip([0.04, 0.08, 0.12])
                .all(|(a, b)| (a - b).abs() < 1e-12)
        );
        let pe = pick_frames(&fe, Some(&exp), t[0].as_deref(), 3);
        let ps = pick_frames(&fs, Some(&sim), t[1].as_deref(), 3);
        assert_eq!(pe, vec![4, 8, 12]);
        assert_eq!(ps, vec![2, 4, 6]);
        assert_eq!(sim.label(5).as_deref(), Some("ε = 0.1"));
        assert_eq!(sim.label(0).as_deref(), Some("ε = 0"));
    }

    #[test]
    fn unknown_strain_spreads_frames_evenly() {
        let f: Vec<i64> = (0..10).collect();
        assert_eq!(pick_frames(&f, None, None, 3), vec![0, 4, 9]);
        assert_eq!(strain_targets(&[None], 3), vec![None]);
        assert_eq!(nearest_frames(&[0, 5, 10], &[1, 4, 9]), vec![0, 5, 10]);
    }
}
