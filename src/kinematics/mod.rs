//! Local deformation of each particle between two frames (Li et al., Sec. III,
//! Eqs. 13–18): neighbours within R_c at time t, the best-fit affine transform J, the
//! non-affine residual D²min, the Lagrangian strain η, its deviatoric part η^s, the
//! rate J2 and the mean velocity. Pure kernels on slices: no I/O, no polars.

mod columns;
mod strain;

pub use columns::{F64_COLUMNS, FloatColumns, KinematicsColumns};
pub use strain::{LocalStrain, strain_from_j};

use crate::error::Result;
use crate::geom::{Mat2, SimBox, Vec2};
use crate::neighbors::{CellList, Cutoff};
use crate::tracks::{FrameView, UNKNOWN_SPECIES};
use rayon::prelude::*;
use serde::Serialize;

/// Whose definitions to follow. `Paper` is Li et al.; `Ovito` reproduces OVITO's
/// Atomic Strain modifier for cross-checks: cutoff inclusive (≤), D²min not divided by
/// N_i, shear strain √(η_xy² + (η_xx − η_yy)²/2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Convention {
    Paper,
    Ovito,
}

/// Parameters of one frame-pair computation.
#[derive(Debug, Clone, Copy)]
pub struct KinematicsParams {
    /// Neighbour cutoff R_c, length unit (paper: 1.25 D).
    pub rc: f64,
    pub convention: Convention,
}

/// Relative tolerance below which the neighbour matrix Y counts as singular
/// (|det Y| ≤ tol · ‖Y‖²_F): all neighbours on one line.
pub const SINGULAR_TOL: f64 = 1e-10;

/// Minimum neighbours for a 2D affine fit (Y has rank 2 only with ≥ 2 non-collinear).
pub const MIN_NEIGHBORS: usize = 2;

/// Whether a particle's deformation is determined, and if not, why.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Status {
    /// J, the strains and D²min are determined.
    Ok,
    /// Fewer than [`MIN_NEIGHBORS`] neighbours within R_c.
    #[default]
    TooFewNeighbours,
    /// The neighbour matrix Y is singular (all neighbours on one line).
    Singular,
}

impl Status {
    /// The name in the `status` column: `ok`, `too_few_neighbours`, `singular`.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::TooFewNeighbours => "too_few_neighbours",
            Status::Singular => "singular",
        }
    }
}

/// One particle's result. Where the deformation is undetermined (`status` not `Ok`),
/// J, the strains, J2 and D²min are NaN — never a number that looks like "no
/// deformation"; the velocity is still the particle's own.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ParticleKinematics {
    pub particle: i64,
    /// Position at t, length unit.
    pub pos: Vec2,
    pub species: i32,
    /// N_i: neighbours within R_c at t present in both frames.
    pub n_neighbors: u32,
    /// `status == Status::Ok`, kept as its own column for readers of older tables.
    pub valid: bool,
    pub status: Status,
    /// Best-fit affine transform J = X Y⁻¹ (Eq. 14), dimensionless.
    pub j: Mat2,
    pub strain: LocalStrain,
    /// J2 = η^s / Δt (Eq. 18), 1/time.
    pub j2: f64,
    /// D²min (Eq. 14), length²; divided by N_i in the paper convention.
    pub d2min: f64,
    /// Mean velocity (Eq. 13): displacement / Δt, length/time.
    pub velocity: Vec2,
}

/// Counts for the summary of one frame pair.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct PairCounts {
    /// Particles present in both frames (rows written).
    pub paired: usize,
    /// Present at t but missing at t+Δt, and the reverse (skipped).
    pub missing_at_end: usize,
    pub missing_at_start: usize,
    pub invalid_few_neighbors: usize,
    pub invalid_singular: usize,
}

impl PairCounts {
    pub fn add(&mut self, o: &PairCounts) {
        self.paired += o.paired;
        self.missing_at_end += o.missing_at_end;
        self.missing_at_start += o.missing_at_start;
        self.invalid_few_neighbors += o.invalid_few_neighbors;
        self.invalid_singular += o.invalid_singular;
    }
}

/// Particles present in both frames: (index at t, index at t+Δt), by ascending id.
/// Both views are sorted by particle id, so this is a merge join.
fn pair_rows(a: &FrameView, b: &FrameView) -> (Vec<(usize, usize)>, usize, usize) {
    let (mut i, mut k) = (0, 0);
    let mut out = Vec::with_capacity(a.len().min(b.len()));
    let (mut miss_end, mut miss_start) = (0, 0);
    while i < a.len() && k < b.len() {
        match a.particle[i].cmp(&b.particle[k]) {
            std::cmp::Ordering::Equal => {
                out.push((i, k));
                i += 1;
                k += 1;
            }
            std::cmp::Ordering::Less => {
                miss_end += 1;
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                miss_start += 1;
                k += 1;
            }
        }
    }
    miss_end += a.len() - i;
    miss_start += b.len() - k;
    (out, miss_end, miss_start)
}

fn delta(b: Option<SimBox>, d: Vec2) -> Vec2 {
    match b {
        Some(b) => b.min_image(d),
        None => d,
    }
}

/// Kinematics of every particle present in frames `a` (time t) and `b` (t + `dt`), in
/// ascending particle order whatever the thread count. `dt` in the tracks' time unit.
///
/// Displacements are unwrapped with the minimum image of `b`'s box (a particle must
/// move less than half a box side between the frames); neighbour vectors at t use
/// `a`'s box, at t+Δt they are r_ji(t) + d_j − d_i, so no second image search is
/// needed, except that a neighbour seen through n_y Lees–Edwards images moves with
/// the offset: r_ji(t+Δt) −= n_y (xy(t+Δt) − xy(t)) in x.
pub fn frame_pair(
    a: &FrameView,
    b: &FrameView,
    dt: f64,
    p: &KinematicsParams,
) -> Result<(Vec<ParticleKinematics>, PairCounts)> {
    let setup = PairSetup::new(a, b, p)?;
    let out: Vec<ParticleKinematics> = (0..setup.len())
        .into_par_iter()
        .with_min_len(256)
        .map_init(Vec::new, |buf, n| {
            setup.particle(n, a, buf, dt, p.convention)
        })
        .collect();
    let counts = setup.counts(out.iter().map(|k| k.status));
    Ok((out, counts))
}

/// As [`frame_pair`], written straight into the table's columns: no per-particle
/// records in between, so one pass and one allocation per column (what the
/// `kinematics` command writes; 1 M particles are 140 MB of records otherwise).
pub fn frame_pair_columns(
    a: &FrameView,
    b: &FrameView,
    dt: f64,
    p: &KinematicsParams,
) -> Result<(KinematicsColumns, PairCounts)> {
    let pair = FramePair::new(*a, b, dt, p)?;
    let cols = pair.columns(0..pair.len());
    let mut counts = pair.pairing_counts();
    counts.add(&FramePair::block_counts(&cols));
    Ok((cols, counts))
}

/// A frame pair ready to compute in blocks of rows: the pairing, the displacements and
/// the cell list built once, then [`FramePair::columns`] for any range of rows. The
/// `kinematics` command computes and writes one Parquet row group at a time, so a
/// million-particle pair never holds all its output columns at once (fewer fresh pages
/// to fault in, and the writing of one block overlaps the computing of the next).
pub struct FramePair<'a> {
    setup: PairSetup,
    a: FrameView<'a>,
    dt: f64,
    conv: Convention,
}

impl<'a> FramePair<'a> {
    /// Pairs frames `a` (time t) and `b` (t + `dt`); see [`frame_pair`].
    pub fn new(a: FrameView<'a>, b: &FrameView, dt: f64, p: &KinematicsParams) -> Result<Self> {
        Ok(FramePair {
            setup: PairSetup::new(&a, b, p)?,
            a,
            dt,
            conv: p.convention,
        })
    }

    /// Δt between the frames, the tracks' time unit.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Rows (particles present in both frames).
    pub fn len(&self) -> usize {
        self.setup.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Rows `rows` of the pair's table, the same numbers whatever the blocks and the
    /// thread count.
    pub fn columns(&self, rows: std::ops::Range<usize>) -> KinematicsColumns {
        self.columns_of(rows, FloatColumns::ALL)
    }

    /// As [`FramePair::columns`], storing only the float columns in `keep`.
    pub fn columns_of(
        &self,
        rows: std::ops::Range<usize>,
        keep: FloatColumns,
    ) -> KinematicsColumns {
        assert!(rows.end <= self.len(), "rows within the pair");
        KinematicsColumns::fill(rows, keep, |n, buf| {
            self.setup.particle(n, &self.a, buf, self.dt, self.conv)
        })
    }

    /// The counts of one block's undetermined rows only (to add up over blocks).
    pub fn block_counts(c: &KinematicsColumns) -> PairCounts {
        let mut k = PairCounts::default();
        for s in &c.status {
            match s {
                Status::Ok => {}
                Status::TooFewNeighbours => k.invalid_few_neighbors += 1,
                Status::Singular => k.invalid_singular += 1,
            }
        }
        k
    }

    /// The pair's counts apart from the undetermined rows (see [`Self::block_counts`]).
    pub fn pairing_counts(&self) -> PairCounts {
        self.setup.counts(std::iter::empty())
    }
}

/// Rows from which a pair's fits are computed in cell order when its rows are not in
/// spatial order: below, the whole pair sits in cache anyway.
const CELL_ORDER_MIN_ROWS: usize = 1 << 15;

/// Whether rows follow space closely enough that searching their neighbours in row
/// order stays in cache: most consecutive rows sit within a few cells of each other
/// in the cell list's order (`rank`: each row's place in it). A lattice or tracker
/// scan order is; a shuffled LAMMPS dump or this project's pillar tracks are not.
fn spatially_ordered(rank: &[u32]) -> bool {
    if rank.len() < 2 {
        return true;
    }
    let near = rank
        .windows(2)
        .filter(|w| w[0].abs_diff(w[1]) <= 64)
        .count();
    2 * near >= rank.len() - 1
}

/// What every particle of a frame pair shares: the pairing, positions at t,
/// displacements and the cell list.
struct PairSetup {
    pairs: Vec<(usize, usize)>,
    pos0: Vec<Vec2>,
    disp: Vec<Vec2>,
    /// `disp` in the cell list's order: a neighbour's displacement is then read beside
    /// its position, not from a random place (a cache miss per neighbour when the
    /// particles' order is not spatial, as in a LAMMPS dump).
    disp_sorted: Vec<Vec2>,
    cells: Option<CellList>,
    seam: Option<(f64, f64)>,
    /// A large pair whose rows are not in spatial order: every row's fit, computed
    /// in the cell list's order (each particle's neighbours then sit in cache beside
    /// the last one's), and each row's place in that order. Rows then read their fit
    /// instead of searching their neighbours in a random place of memory each.
    fits: Option<(Vec<Fit>, Vec<u32>)>,
    missing_at_end: usize,
    missing_at_start: usize,
}

impl PairSetup {
    fn new(a: &FrameView, b: &FrameView, p: &KinematicsParams) -> Result<Self> {
        let (pairs, missing_at_end, missing_at_start) = pair_rows(a, b);
        let pos0: Vec<Vec2> = pairs.iter().map(|&(i, _)| a.pos(i)).collect();
        let disp: Vec<Vec2> = pairs
            .iter()
            .map(|&(i, k)| delta(b.simbox, b.pos(k) - a.pos(i)))
            .collect();
        let kind = match p.convention {
            Convention::Paper => Cutoff::Strict,
            Convention::Ovito => Cutoff::Inclusive,
        };
        let seam = match (a.simbox, b.simbox) {
            (Some(ba), Some(bb)) if ba.periodic_y && bb.xy != ba.xy => Some((ba.ly, bb.xy - ba.xy)),
            _ => None,
        };
        let cells = if pos0.is_empty() {
            None
        } else {
            Some(CellList::new(&pos0, p.rc, kind, a.simbox)?)
        };
        let disp_sorted = cells.as_ref().map_or_else(Vec::new, |c| {
            c.cell_order().iter().map(|&j| disp[j as usize]).collect()
        });
        let mut setup = Self {
            pairs,
            pos0,
            disp,
            disp_sorted,
            cells,
            seam,
            fits: None,
            missing_at_end,
            missing_at_start,
        };
        setup.fits = setup.fits_in_cell_order(p.convention);
        if setup.fits.is_some() {
            // Rows read their fits now: the search's arrays are done with.
            setup.cells = None;
            setup.disp_sorted = Vec::new();
        }
        Ok(setup)
    }

    /// The fits of every row in cell order and each row's rank in it, for a pair of
    /// at least [`CELL_ORDER_MIN_ROWS`] rows that are not in spatial order (see
    /// `fits`); `None` otherwise. The same numbers either way: each fit is the same
    /// function of the same neighbours in the same order.
    fn fits_in_cell_order(&self, conv: Convention) -> Option<(Vec<Fit>, Vec<u32>)> {
        let cells = self.cells.as_ref()?;
        let order = cells.cell_order();
        if order.len() < CELL_ORDER_MIN_ROWS {
            return None;
        }
        let mut rank = vec![0u32; order.len()];
        for (k, &n) in order.iter().enumerate() {
            rank[n as usize] = k as u32;
        }
        if spatially_ordered(&rank) {
            return None;
        }
        // Each particle's own position in cell order too (its displacement already
        // is): in row order, each fit would start with a read from a random place,
        // which it waits for (a fit is too long for the processor to run ahead).
        // (In an open box the cell list holds them already.)
        let copied: Vec<Vec2>;
        let pos_sorted = match cells.positions_as_given() {
            Some(p) => p,
            None => {
                copied = order.iter().map(|&n| self.pos0[n as usize]).collect();
                &copied
            }
        };
        let fits = order
            .par_iter()
            .enumerate()
            .with_min_len(1024)
            .map_init(Vec::new, |buf, (k, &n)| {
                fit(
                    (n as usize, pos_sorted[k], self.disp_sorted[k]),
                    (pos_sorted, Index::Places),
                    &self.disp_sorted,
                    cells,
                    self.seam,
                    buf,
                    conv,
                )
            })
            .collect();
        Some((fits, rank))
    }

    fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Pair row `n`'s result (`buf` is the caller's reusable neighbour buffer).
    fn particle(
        &self,
        n: usize,
        a: &FrameView,
        buf: &mut Vec<(Vec2, Vec2)>,
        dt: f64,
        conv: Convention,
    ) -> ParticleKinematics {
        let f = match &self.fits {
            Some((fits, rank)) => fits[rank[n] as usize],
            None => {
                let cells = self
                    .cells
                    .as_ref()
                    .expect("cells exist when rows do (or fits do)");
                fit(
                    (n, self.pos0[n], self.disp[n]),
                    (&self.pos0, Index::Rows),
                    &self.disp_sorted,
                    cells,
                    self.seam,
                    buf,
                    conv,
                )
            }
        };
        let (i, _) = self.pairs[n];
        let mut k = row(f, self.pos0[n], self.disp[n], dt, conv);
        k.particle = a.particle[i];
        k.species = a.species.map_or(UNKNOWN_SPECIES, |s| s[i]);
        k
    }

    fn counts(&self, status: impl Iterator<Item = Status>) -> PairCounts {
        let mut c = PairCounts {
            paired: self.len(),
            missing_at_end: self.missing_at_end,
            missing_at_start: self.missing_at_start,
            ..Default::default()
        };
        for s in status {
            match s {
                Status::Ok => {}
                Status::TooFewNeighbours => c.invalid_few_neighbors += 1,
                Status::Singular => c.invalid_singular += 1,
            }
        }
        c
    }
}

/// How an array of per-particle values is indexed: by pair row, or by place in the
/// cell list's order.
#[derive(Debug, Clone, Copy)]
enum Index {
    Rows,
    Places,
}

/// What of a particle's row needs its neighbours: N_i, the status, J and D²min. The
/// rest (strains, J2, velocity, position) follows from these and its own displacement
/// ([`row`]).
#[derive(Debug, Clone, Copy)]
struct Fit {
    n_neighbors: u32,
    status: Status,
    j: Mat2,
    d2min: f64,
}

/// One particle's neighbourhood fit: gather (r_ji(t), r_ji(t+Δt)) into `buf`, fit J,
/// then D²min exactly as the residual sum (a second pass over the buffer, no
/// cancellation). `me` is the particle (row `n`, at `pi` with displacement `di`); a
/// neighbour's displacement is read in cell order, and under Lees–Edwards its
/// position too, from `seam_pos`: by row with `Rows`, by place in cell order with
/// `Places`.
#[inline]
#[allow(clippy::too_many_arguments)]
fn fit(
    (n, pi, di): (usize, Vec2, Vec2),
    seam_pos: (&[Vec2], Index),
    disp_sorted: &[Vec2],
    cells: &CellList,
    seam: Option<(f64, f64)>,
    buf: &mut Vec<(Vec2, Vec2)>,
    conv: Convention,
) -> Fit {
    buf.clear();
    cells.for_each_within_at(pi, |j, k, r0| {
        if j != n {
            let mut r1 = r0 + disp_sorted[k] - di;
            if let Some((ly, dxy)) = seam {
                let pj = match seam_pos.1 {
                    Index::Rows => seam_pos.0[j],
                    Index::Places => seam_pos.0[k],
                };
                let images = ((pj.y - pi.y - r0.y) / ly).round();
                r1.x -= images * dxy;
            }
            buf.push((r0, r1));
        }
    });
    let mut f = Fit {
        n_neighbors: buf.len() as u32,
        status: Status::TooFewNeighbours,
        j: Mat2::ZERO,
        d2min: 0.0,
    };
    if buf.len() < MIN_NEIGHBORS {
        return f;
    }
    let (mut x, mut y) = (Mat2::ZERO, Mat2::ZERO);
    for &(r0, r1) in buf.iter() {
        x = x + Mat2::outer(r1, r0);
        y = y + Mat2::outer(r0, r0);
    }
    let Some(yinv) = y.inverse(SINGULAR_TOL) else {
        f.status = Status::Singular;
        return f;
    };
    let j = x * yinv;
    let mut d2 = 0.0;
    for &(r0, r1) in buf.iter() {
        d2 += (r1 - j * r0).norm2();
    }
    if conv == Convention::Paper {
        d2 /= buf.len() as f64;
    }
    f.status = Status::Ok;
    f.j = j;
    f.d2min = d2;
    f
}

/// A particle's result from its fit, its position at t and its displacement `di`.
#[inline]
fn row(f: Fit, pos: Vec2, di: Vec2, dt: f64, conv: Convention) -> ParticleKinematics {
    let mut k = ParticleKinematics {
        pos,
        n_neighbors: f.n_neighbors,
        velocity: di * (1.0 / dt),
        status: f.status,
        ..Default::default()
    };
    if f.status != Status::Ok {
        let nan = f64::NAN;
        k.j = Mat2 {
            a11: nan,
            a12: nan,
            a21: nan,
            a22: nan,
        };
        k.strain = LocalStrain {
            eta_xx: nan,
            eta_xy: nan,
            eta_yy: nan,
            eta_m: nan,
            eta_s: nan,
        };
        k.j2 = nan;
        k.d2min = nan;
        return k;
    }
    k.valid = true;
    k.j = f.j;
    k.strain = strain_from_j(&f.j, conv);
    k.j2 = k.strain.eta_s / dt;
    k.d2min = f.d2min;
    k
}

#[cfg(test)]
mod tests;
