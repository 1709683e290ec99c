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
    // Rows are sorted by frame, so each particle's rows come out in frame order.
    let per = super::ByParticle::new(&t.particle);
    let mut fpos = vec![0usize; t.len()];
    for (k, (_, r)) in ranges.iter().enumerate() {
        fpos[r.clone()].fill(k);
    }
    let nf = ranges.len();
    let d_large = t.large_diameter().unwrap_or(f64::INFINITY);
    let (mut full, mut short, mut late, mut early, mut with_gaps, mut gap_frames, mut jumps) =
        (0, 0, 0, 0, 0, 0, 0);
    let (mut n_small, mut n_large) = (0, 0);
    for k in 0..per.len() {
        let rows = per.rows_of(k);
        let pos: Vec<usize> = rows.iter().map(|&r| fpos[r]).collect();
        let span = pos[pos.len() - 1] - pos[0] + 1;
        if rows.len() == nf {
            full += 1;
        }
        if 2 * rows.len() < nf {
            short += 1;
        }
        if pos[0] > 0 {
            late += 1;
        }
        if pos[pos.len() - 1] + 1 < nf {
            early += 1;
        }
        if span > rows.len() {
            with_gaps += 1;
            gap_frames += span - rows.len();
        }
        for w in rows.windows(2) {
            let (a, b) = (w[0], w[1]);
            if fpos[b] == fpos[a] + 1 {
                let d = ((t.x[b] - t.x[a]).powi(2) + (t.y[b] - t.y[a]).powi(2)).sqrt();
                if d > JUMP_FRACTION * d_large {
                    jumps += 1;
                }
            }
        }
        match t.species.as_ref().map(|s| s[rows[0]]) {
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
        trajectories: per.len(),
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
