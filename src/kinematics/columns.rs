//! A frame pair's results as columns (the `kinematics` table's layout), filled in
//! parallel row blocks straight from the per-particle kernel.

use super::{ParticleKinematics, Status};
use crate::geom::Vec2;
use rayon::prelude::*;

/// The floating-point columns of the `kinematics` table, in the order of
/// [`KinematicsColumns::f64s`].
pub const F64_COLUMNS: [&str; 16] = [
    "x", "y", "j11", "j12", "j21", "j22", "eta_xx", "eta_xy", "eta_yy", "eta_m", "eta_s", "j2",
    "d2min", "vx", "vy", "speed",
];

/// Which floating-point columns ([`F64_COLUMNS`] order) a fill stores; the others stay
/// empty (`kinematics --columns`: a column nobody asked for costs its memory, its pages
/// and its encoding).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FloatColumns(pub [bool; 16]);

impl FloatColumns {
    pub const ALL: FloatColumns = FloatColumns([true; 16]);
}

/// Rows per parallel block: large enough to amortise the scheduling, small enough
/// that two threads stay balanced on a few thousand particles.
const BLOCK: usize = 2048;

/// One frame pair's rows, column by column, in ascending particle order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KinematicsColumns {
    pub particle: Vec<i64>,
    pub species: Vec<i32>,
    pub n_neighbors: Vec<i32>,
    pub valid: Vec<bool>,
    pub status: Vec<Status>,
    /// The floating-point columns, named by [`F64_COLUMNS`].
    pub f64s: [Vec<f64>; 16],
}

impl ParticleKinematics {
    /// This particle's floating-point values in [`F64_COLUMNS`] order.
    fn f64_values(&self) -> [f64; 16] {
        let (j, s) = (&self.j, &self.strain);
        [
            self.pos.x,
            self.pos.y,
            j.a11,
            j.a12,
            j.a21,
            j.a22,
            s.eta_xx,
            s.eta_xy,
            s.eta_yy,
            s.eta_m,
            s.eta_s,
            self.j2,
            self.d2min,
            self.velocity.x,
            self.velocity.y,
            self.velocity.norm(),
        ]
    }
}

/// One block's slices of every column.
struct Block<'a> {
    start: usize,
    particle: &'a mut [i64],
    species: &'a mut [i32],
    n_neighbors: &'a mut [i32],
    valid: &'a mut [bool],
    status: &'a mut [Status],
    f64s: Vec<&'a mut [f64]>,
}

impl KinematicsColumns {
    pub fn len(&self) -> usize {
        self.particle.len()
    }

    pub fn is_empty(&self) -> bool {
        self.particle.is_empty()
    }

    /// Rows `rows` from `row(n, buf)` (`buf`: a neighbour buffer reused within a
    /// thread), at `0..rows.len()` here, of the float columns in `keep` (the others
    /// empty). Each row is computed once, by one thread, into its own place, so the
    /// columns are the same whatever the thread count.
    pub(crate) fn fill<F>(rows: std::ops::Range<usize>, keep: FloatColumns, row: F) -> Self
    where
        F: Fn(usize, &mut Vec<(Vec2, Vec2)>) -> ParticleKinematics + Sync,
    {
        let (first, n) = (rows.start, rows.len());
        let mut c = KinematicsColumns {
            particle: vec![0; n],
            species: vec![0; n],
            n_neighbors: vec![0; n],
            valid: vec![false; n],
            status: vec![Status::Ok; n],
            f64s: std::array::from_fn(|c| if keep.0[c] { vec![0.0; n] } else { Vec::new() }),
        };
        let mut f64_blocks: Vec<_> = c.f64s.iter_mut().map(|v| v.chunks_mut(BLOCK)).collect();
        let blocks: Vec<Block> = c
            .particle
            .chunks_mut(BLOCK)
            .zip(c.species.chunks_mut(BLOCK))
            .zip(c.n_neighbors.chunks_mut(BLOCK))
            .zip(c.valid.chunks_mut(BLOCK))
            .zip(c.status.chunks_mut(BLOCK))
            .enumerate()
            .map(
                |(b, ((((particle, species), n_neighbors), valid), status))| Block {
                    start: b * BLOCK,
                    particle,
                    species,
                    n_neighbors,
                    valid,
                    status,
                    // A column not kept is empty: its blocks are empty slices, which
                    // the rows skip.
                    f64s: f64_blocks
                        .iter_mut()
                        .map(|it| it.next().unwrap_or_default())
                        .collect(),
                },
            )
            .collect();
        blocks
            .into_par_iter()
            .for_each_init(Vec::new, |buf, mut b| {
                for r in 0..b.particle.len() {
                    let k = row(first + b.start + r, buf);
                    b.particle[r] = k.particle;
                    b.species[r] = k.species;
                    b.n_neighbors[r] = k.n_neighbors as i32;
                    b.valid[r] = k.valid;
                    b.status[r] = k.status;
                    for (col, v) in b.f64s.iter_mut().zip(k.f64_values()) {
                        // Empty: a column not kept (every kept one has the block's rows).
                        if let Some(c) = col.get_mut(r) {
                            *c = v;
                        }
                    }
                }
            });
        c
    }
}
