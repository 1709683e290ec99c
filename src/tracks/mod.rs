//! The canonical trajectory table (`data_schema/tracks.schema.json`) as columns in
//! memory, its sidecar metadata, validation and the per-frame view that the analysis
//! kernels consume. No file I/O here (that is `io`).

mod dense;
mod detached;
mod meta;
mod species;
mod summary;
mod validate;

pub use dense::{ByParticle, dense_ids};
pub use detached::{detached_trajectories, drop_trajectories};
pub use meta::{FrameBox, Provenance, TracksMeta};
pub use species::{estimate_radii, otsu, split_by_size};
pub use summary::{TracksSummary, summarize};
pub use validate::{MAX_ABS_COORD, RowLocator, beyond_bound, finalize};

use crate::geom::{SimBox, Vec2};
use std::ops::Range;

/// Species codes of the `species` column.
pub const SMALL: i32 = 0;
pub const LARGE: i32 = 1;
/// Species unknown (kinematics output only).
pub const UNKNOWN_SPECIES: i32 = -1;

/// Trajectories as columns, sorted by (frame, particle) once `finalize`d.
#[derive(Debug, Clone, Default)]
pub struct Tracks {
    pub frame: Vec<i64>,
    pub particle: Vec<i64>,
    /// Centre x, length unit of `meta.length_unit`.
    pub x: Vec<f64>,
    /// Centre y, y up.
    pub y: Vec<f64>,
    /// Radius, length unit.
    pub radius: Vec<f64>,
    /// Time of the frame, `meta.time_unit`.
    pub time: Option<Vec<f64>>,
    /// 0 small, 1 large.
    pub species: Option<Vec<i32>>,
    /// Orientation, rad.
    pub theta: Option<Vec<f64>>,
    pub meta: TracksMeta,
}

/// One frame's rows: contiguous slices of the sorted table (particle ids ascending).
#[derive(Debug, Clone, Copy)]
pub struct FrameView<'a> {
    pub frame: i64,
    pub particle: &'a [i64],
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub radius: &'a [f64],
    pub species: Option<&'a [i32]>,
    /// Periodic box of this frame, if any.
    pub simbox: Option<SimBox>,
}

impl FrameView<'_> {
    pub fn len(&self) -> usize {
        self.particle.len()
    }
    pub fn is_empty(&self) -> bool {
        self.particle.is_empty()
    }
    pub fn pos(&self, i: usize) -> Vec2 {
        Vec2::new(self.x[i], self.y[i])
    }
}

impl Tracks {
    pub fn len(&self) -> usize {
        self.frame.len()
    }
    pub fn is_empty(&self) -> bool {
        self.frame.is_empty()
    }

    /// Row ranges of each frame, in frame order. Requires sorted rows.
    pub fn frame_ranges(&self) -> Vec<(i64, Range<usize>)> {
        let mut out = Vec::new();
        let mut start = 0;
        for i in 1..=self.frame.len() {
            if i == self.frame.len() || self.frame[i] != self.frame[start] {
                out.push((self.frame[start], start..i));
                start = i;
            }
        }
        out
    }

    /// The view of rows `r` (one frame).
    pub fn view(&self, frame: i64, r: Range<usize>) -> FrameView<'_> {
        FrameView {
            frame,
            particle: &self.particle[r.clone()],
            x: &self.x[r.clone()],
            y: &self.y[r.clone()],
            radius: &self.radius[r.clone()],
            species: self.species.as_ref().map(|s| &s[r]),
            simbox: self.meta.box_at(frame),
        }
    }

    /// Large-grain diameter D (length unit): twice the largest radius; the paper's
    /// R_c = 1.25 D and D²min/R² (R = D/2) are built on it.
    pub fn large_diameter(&self) -> Option<f64> {
        let m = self.radius.iter().copied().fold(f64::NAN, f64::max);
        m.is_finite().then_some(2.0 * m)
    }

    /// Reorder every column by the permutation `perm` (new row k = old row perm[k]).
    pub fn permute(&mut self, perm: &[usize]) {
        fn apply<T: Copy>(v: &mut Vec<T>, perm: &[usize]) {
            *v = perm.iter().map(|&i| v[i]).collect();
        }
        apply(&mut self.frame, perm);
        apply(&mut self.particle, perm);
        apply(&mut self.x, perm);
        apply(&mut self.y, perm);
        apply(&mut self.radius, perm);
        if let Some(t) = self.time.as_mut() {
            apply(t, perm);
        }
        if let Some(s) = self.species.as_mut() {
            apply(s, perm);
        }
        if let Some(t) = self.theta.as_mut() {
            apply(t, perm);
        }
    }
}
