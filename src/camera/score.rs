//! How well located (and linked) grains match a ground truth, in the terms of the
//! shared sample's `tracking_error.json`: per frame, truth and detections are paired
//! one to one, nearest first, within a tolerance; then the position error, the grains
//! lost, the spurious detections, and for linked tracks the identity switches (a
//! trajectory whose matched true grain changes between consecutive matched frames) and
//! the breaks (a true grain followed by more than one trajectory).

use super::Feature;
use std::collections::HashMap;

/// One true grain in one frame, px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Truth {
    pub frame: i64,
    pub particle: i64,
    pub x: f64,
    pub y: f64,
}

/// The comparison; lengths in px.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct TrackingScore {
    pub match_tolerance_px: f64,
    pub truth: usize,
    pub detections: usize,
    pub matched: usize,
    pub lost: usize,
    pub spurious: usize,
    pub rms_error_px: f64,
    pub median_error_px: f64,
    pub p99_error_px: f64,
    pub max_error_px: f64,
    /// rms error of the one-frame displacement of matched pairs (what D²min sees).
    pub rms_displacement_error_px_lag1: f64,
    /// Linked tracks only: consecutive matched frames of a trajectory on different true
    /// grains.
    pub id_switches: Option<usize>,
    /// Linked tracks only: trajectories per true grain beyond the first.
    pub trajectory_breaks: Option<usize>,
}

/// Pairs each frame's truth and detections one to one, shortest distance first, within
/// `tol`; returns for each detection the index of its truth row (or None).
fn match_frame(
    truth: &[(usize, f64, f64)],
    det: &[(usize, f64, f64)],
    tol: f64,
) -> Vec<(usize, usize, f64)> {
    let cell = tol.max(1e-9);
    let key = |x: f64, y: f64| ((x / cell).floor() as i64, (y / cell).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (k, &(_, x, y)) in truth.iter().enumerate() {
        grid.entry(key(x, y)).or_default().push(k);
    }
    let mut pairs = Vec::new();
    for (j, &(_, x, y)) in det.iter().enumerate() {
        let (kx, ky) = key(x, y);
        for gx in kx - 1..=kx + 1 {
            for gy in ky - 1..=ky + 1 {
                for &k in grid.get(&(gx, gy)).into_iter().flatten() {
                    let d = (truth[k].1 - x).hypot(truth[k].2 - y);
                    if d <= tol {
                        pairs.push((d, k, j));
                    }
                }
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut t_used, mut d_used) = (vec![false; truth.len()], vec![false; det.len()]);
    let mut out = Vec::new();
    for (d, k, j) in pairs {
        if !t_used[k] && !d_used[j] {
            t_used[k] = true;
            d_used[j] = true;
            out.push((truth[k].0, det[j].0, d));
        }
    }
    out
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    sorted[lo] + (pos - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Scores `found` (with its `particle` ids when linked) against `truth`.
pub fn score(
    truth: &[Truth],
    found: &[Feature],
    particle: Option<&[i64]>,
    tol: f64,
) -> TrackingScore {
    let mut by_frame_t: HashMap<i64, Vec<(usize, f64, f64)>> = HashMap::new();
    for (i, t) in truth.iter().enumerate() {
        by_frame_t.entry(t.frame).or_default().push((i, t.x, t.y));
    }
    let mut by_frame_d: HashMap<i64, Vec<(usize, f64, f64)>> = HashMap::new();
    for (i, f) in found.iter().enumerate() {
        by_frame_d.entry(f.frame).or_default().push((i, f.x, f.y));
    }
    let mut frames: Vec<i64> = by_frame_t
        .keys()
        .chain(by_frame_d.keys())
        .copied()
        .collect();
    frames.sort_unstable();
    frames.dedup();
    let empty = Vec::new();
    // (truth index, detection index, error) of every match, frame by frame.
    let mut matches = Vec::new();
    for f in &frames {
        let t = by_frame_t.get(f).unwrap_or(&empty);
        let d = by_frame_d.get(f).unwrap_or(&empty);
        matches.extend(match_frame(t, d, tol));
    }
    let mut errs: Vec<f64> = matches.iter().map(|m| m.2).collect();
    errs.sort_by(f64::total_cmp);
    let rms = |v: &[f64]| (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt();
    // One-frame displacement errors: the same true grain matched in frames f and f+1.
    let mut at: HashMap<(i64, i64), (usize, usize)> = HashMap::new();
    for &(ti, di, _) in &matches {
        at.insert((truth[ti].particle, truth[ti].frame), (ti, di));
    }
    let mut disp = Vec::new();
    for &(ti, di, _) in &matches {
        let t = truth[ti];
        if let Some(&(tj, dj)) = at.get(&(t.particle, t.frame + 1)) {
            let t1 = truth[tj];
            let (ex, ey) = (
                (found[dj].x - found[di].x) - (t1.x - t.x),
                (found[dj].y - found[di].y) - (t1.y - t.y),
            );
            disp.push(ex.hypot(ey));
        }
    }
    let (id_switches, trajectory_breaks) = match particle {
        None => (None, None),
        Some(pid) => {
            // Each trajectory's matched true grains in frame order.
            let mut seq: HashMap<i64, Vec<(i64, i64)>> = HashMap::new();
            let mut per_truth: HashMap<i64, Vec<i64>> = HashMap::new();
            for &(ti, di, _) in &matches {
                seq.entry(pid[di])
                    .or_default()
                    .push((found[di].frame, truth[ti].particle));
                per_truth
                    .entry(truth[ti].particle)
                    .or_default()
                    .push(pid[di]);
            }
            let mut switches = 0;
            for s in seq.values_mut() {
                s.sort_unstable();
                switches += s.windows(2).filter(|w| w[0].1 != w[1].1).count();
            }
            let breaks = per_truth
                .values_mut()
                .map(|v| {
                    v.sort_unstable();
                    v.dedup();
                    v.len() - 1
                })
                .sum();
            (Some(switches), Some(breaks))
        }
    };
    TrackingScore {
        match_tolerance_px: tol,
        truth: truth.len(),
        detections: found.len(),
        matched: matches.len(),
        lost: truth.len() - matches.len(),
        spurious: found.len() - matches.len(),
        rms_error_px: rms(&errs),
        median_error_px: quantile(&errs, 0.5),
        p99_error_px: quantile(&errs, 0.99),
        max_error_px: errs.last().copied().unwrap_or(f64::NAN),
        rms_displacement_error_px_lag1: rms(&disp),
        id_switches,
        trajectory_breaks,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feat(frame: i64, x: f64, y: f64) -> Feature {
        Feature {
            frame,
            x,
            y,
            ..Default::default()
        }
    }

    #[test]
    fn counts_by_hand() {
        // Two grains over three frames; grain 1 lost in frame 1; a spurious detection in
        // frame 2; the linker swaps the two ids at frame 2.
        let truth: Vec<Truth> = (0..3)
            .flat_map(|f| {
                [(0, 10.0), (1, 40.0)].map(|(p, x)| Truth {
                    frame: f,
                    particle: p,
                    x: x + f as f64,
                    y: 5.0,
                })
            })
            .collect();
        let found = vec![
            feat(0, 10.3, 5.0),
            feat(0, 40.0, 5.4),
            feat(1, 11.0, 5.0),
            feat(2, 12.0, 5.0),
            feat(2, 42.0, 5.0),
            feat(2, 80.0, 5.0),
        ];
        let pid = [0, 1, 0, 1, 0, 7];
        let s = score(&truth, &found, Some(&pid), 3.0);
        assert_eq!(
            (s.truth, s.detections, s.matched, s.lost, s.spurious),
            (6, 6, 5, 1, 1)
        );
        let rms = ((0.09 + 0.16) / 5.0f64).sqrt();
        assert!((s.rms_error_px - rms).abs() < 1e-12);
        assert!((s.max_error_px - 0.4).abs() < 1e-12);
        // Trajectory 0: grain 0, 0, then grain 1: one switch; trajectory 1: grain 1 then 0.
        assert_eq!(s.id_switches, Some(2));
        // Grain 0 was followed by trajectories 0 and 1, grain 1 by 1 and 0.
        assert_eq!(s.trajectory_breaks, Some(2));
        // Displacements: grain 0 frame 0→1: found 0.7 vs true 1 (error 0.3); 1→2: exact.
        let d = ((0.09 + 0.0) / 2.0f64).sqrt();
        assert!((s.rms_displacement_error_px_lag1 - d).abs() < 1e-12);
        assert_eq!(score(&truth, &found, None, 3.0).id_switches, None);
    }
}
