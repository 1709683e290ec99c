//! What a user should know about a tracks table before analysing it: coverage, gaps,
//! broken or short trajectories, suspicious jumps, species and radii.

use super::{LARGE, SMALL, Tracks};
use serde::Serialize;

/// A one-frame step longer than this fraction of D is counted as suspicious.
pub const JUMP_FRACTION: f64 = 0.3;

#[derive(Debug, Clone, Serialize)]
pub struct TracksSummary {
    pub rows: usize,
    pub frames: usize,
    pub first_frame: i64,
    pub last_frame: i64,
    pub particles_per_frame_min: usize,
    pub particles_per_frame_max: usize,
    pub particles_per_frame_mean: f64,
    pub trajectories: usize,
    /// Trajectories present in every frame.
    pub full_length_trajectories: usize,
    /// Trajectories present in fewer than half the frames.
    pub short_trajectories: usize,
    pub trajectories_starting_late: usize,
    pub trajectories_ending_early: usize,
    /// Trajectories with at least one missing frame between their first and last.
    pub trajectories_with_gaps: usize,
    /// Missing frames inside trajectories, in total.
    pub gap_frames: usize,
    /// Frame-to-frame steps longer than `JUMP_FRACTION` of a large-grain diameter (likely identity
    /// switches or linking errors).
    pub suspicious_jumps: usize,
    pub length_unit: String,
    pub time_unit: String,
    pub frame_time: Option<f64>,
    /// Trajectories per species (by the species of their first row).
    pub small_trajectories: usize,
    pub large_trajectories: usize,
    pub radius_small: Option<f64>,
    pub radius_large: Option<f64>,
    pub periodic_box: Option<String>,
}

pub fn summarize(t: &Tracks) -> TracksSummary {
    let ranges = t.frame_ranges();
    let counts: Vec<usize> = ranges.iter().map(|(_, r)| r.len()).collect();
    let frames_sorted: Vec<i64> = ranges.iter().map(|(f, _)| *f).collect();
    // Sequential passes only: rows are sorted by (frame, particle), so per-particle
    // facts come from one sweep in frame order and a one-frame step from a merge of two
    // consecutive frames (a per-trajectory walk would jump a frame's length per row).
    let (dense, ids) = super::dense_ids(&t.particle);
    let np = ids.len();
    let nf = ranges.len();
    let (mut first, mut last, mut count) =
        (vec![usize::MAX; np], vec![0usize; np], vec![0usize; np]);
    let mut first_row = vec![0usize; np];
    for (k, (_, r)) in ranges.iter().enumerate() {
        for row in r.clone() {
            let p = dense[row] as usize;
            if first[p] == usize::MAX {
                first[p] = k;
                first_row[p] = row;
            }
            last[p] = k;
            count[p] += 1;
        }
    }
    let d_large = t.large_diameter().unwrap_or(f64::INFINITY);
    let limit2 = (JUMP_FRACTION * d_large).powi(2);
    let mut jumps = 0;
    for w in ranges.windows(2) {
        let (mut a, mut b) = (w[0].1.clone(), w[1].1.clone());
        while let (Some(ra), Some(rb)) = (a.clone().next(), b.clone().next()) {
            match t.particle[ra].cmp(&t.particle[rb]) {
                std::cmp::Ordering::Less => a.start += 1,
                std::cmp::Ordering::Greater => b.start += 1,
                std::cmp::Ordering::Equal => {
                    let (dx, dy) = (t.x[rb] - t.x[ra], t.y[rb] - t.y[ra]);
                    if dx * dx + dy * dy > limit2 {
                        jumps += 1;
                    }
                    a.start += 1;
                    b.start += 1;
                }
            }
        }
    }
    let (mut full, mut short, mut late, mut early, mut with_gaps, mut gap_frames) =
        (0, 0, 0, 0, 0, 0);
    let (mut n_small, mut n_large) = (0, 0);
    for p in 0..np {
        let (n, span) = (count[p], last[p] - first[p] + 1);
        full += (n == nf) as usize;
        short += (2 * n < nf) as usize;
        late += (first[p] > 0) as usize;
        early += (last[p] + 1 < nf) as usize;
        if span > n {
            with_gaps += 1;
            gap_frames += span - n;
        }
        match t.species.as_ref().map(|s| s[first_row[p]]) {
            Some(SMALL) => n_small += 1,
            Some(LARGE) => n_large += 1,
            _ => {}
        }
    }
    let radius_of = |sp: i32| -> Option<f64> {
        let s = t.species.as_ref()?;
        let v: Vec<f64> = (0..t.len())
            .filter(|&r| s[r] == sp)
            .map(|r| t.radius[r])
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let periodic_box = t.meta.boxes.first().map(|b| {
        format!(
            "Lx = {:.6} x Ly = {:.6}, periodic x: {}, y: {}, Lees-Edwards offset {:.6} .. {:.6}",
            b.lx,
            b.ly,
            b.periodic_x,
            b.periodic_y,
            b.xy,
            t.meta.boxes.last().map_or(b.xy, |l| l.xy)
        )
    });
    TracksSummary {
        rows: t.len(),
        frames: nf,
        first_frame: frames_sorted.first().copied().unwrap_or(0),
        last_frame: frames_sorted.last().copied().unwrap_or(0),
        particles_per_frame_min: counts.iter().copied().min().unwrap_or(0),
        particles_per_frame_max: counts.iter().copied().max().unwrap_or(0),
        particles_per_frame_mean: counts.iter().sum::<usize>() as f64 / nf.max(1) as f64,
        trajectories: np,
        full_length_trajectories: full,
        short_trajectories: short,
        trajectories_starting_late: late,
        trajectories_ending_early: early,
        trajectories_with_gaps: with_gaps,
        gap_frames,
        suspicious_jumps: jumps,
        length_unit: t.meta.length_unit.clone(),
        time_unit: t.meta.time_unit.clone(),
        frame_time: t.meta.frame_time,
        small_trajectories: n_small,
        large_trajectories: n_large,
        radius_small: radius_of(SMALL),
        radius_large: radius_of(LARGE),
        periodic_box,
    }
}

impl std::fmt::Display for TracksSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let u = &self.length_unit;
        writeln!(
            f,
            "frames        {} ({} .. {}), {} rows",
            self.frames, self.first_frame, self.last_frame, self.rows
        )?;
        writeln!(
            f,
            "particles     {} .. {} per frame (mean {:.1})",
            self.particles_per_frame_min,
            self.particles_per_frame_max,
            self.particles_per_frame_mean
        )?;
        writeln!(
            f,
            "trajectories  {} ({} full length, {} short (< half the frames), {} start late, {} end early)",
            self.trajectories,
            self.full_length_trajectories,
            self.short_trajectories,
            self.trajectories_starting_late,
            self.trajectories_ending_early
        )?;
        writeln!(
            f,
            "gaps          {} trajectories with gaps, {} missing frames inside trajectories",
            self.trajectories_with_gaps, self.gap_frames
        )?;
        writeln!(
            f,
            "jumps         {} one-frame steps > {JUMP_FRACTION} D (identity switches?)",
            self.suspicious_jumps
        )?;
        match self.frame_time {
            Some(dt) => writeln!(
                f,
                "units         length {u}, {dt} {} per frame",
                self.time_unit
            )?,
            None => writeln!(
                f,
                "units         length {u}, frame time unknown (times in frames)"
            )?,
        }
        if self.small_trajectories + self.large_trajectories > 0 {
            writeln!(
                f,
                "species       {} small (radius {:.5} {u}), {} large (radius {:.5} {u}) trajectories",
                self.small_trajectories,
                self.radius_small.unwrap_or(f64::NAN),
                self.large_trajectories,
                self.radius_large.unwrap_or(f64::NAN)
            )?;
        }
        match &self.periodic_box {
            Some(b) => write!(f, "box           {b}"),
            None => write!(f, "box           open (no periodic box)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Five frames; particle 1 full and still, 2 with a gap at frame 2 (and a long move
    /// across it, which is no one-frame jump), 3 late, 4 early and short, 5 full with one
    /// jump of 1 D between frames 1 and 2.
    #[test]
    fn counts_coverage_gaps_and_jumps_exactly() {
        let present: [(i64, &[i64]); 5] = [
            (1, &[0, 1, 2, 3, 4]),
            (2, &[0, 1, 3, 4]),
            (3, &[2, 3, 4]),
            (4, &[0, 1]),
            (5, &[0, 1, 2, 3, 4]),
        ];
        let mut t = Tracks::default();
        for f in 0..5i64 {
            for (p, frames) in present {
                if !frames.contains(&f) {
                    continue;
                }
                let x = match p {
                    2 if f >= 3 => 5.0,
                    5 if f >= 2 => 6.0,
                    _ => p as f64,
                };
                t.frame.push(f);
                t.particle.push(p);
                t.x.push(x);
                t.y.push(0.0);
                let large = [1, 2, 5].contains(&p);
                t.radius.push(if large { 0.5 } else { 0.35 });
                t.species
                    .get_or_insert_with(Vec::new)
                    .push(if large { LARGE } else { SMALL });
            }
        }
        let s = summarize(&t);
        assert_eq!((s.rows, s.frames, s.trajectories), (19, 5, 5));
        assert_eq!(
            (s.particles_per_frame_min, s.particles_per_frame_max),
            (3, 4)
        );
        assert_eq!(s.full_length_trajectories, 2);
        assert_eq!(s.short_trajectories, 1);
        assert_eq!(s.trajectories_starting_late, 1);
        assert_eq!(s.trajectories_ending_early, 1);
        assert_eq!((s.trajectories_with_gaps, s.gap_frames), (1, 1));
        assert_eq!(s.suspicious_jumps, 1);
        assert_eq!((s.small_trajectories, s.large_trajectories), (2, 3));
    }
}
