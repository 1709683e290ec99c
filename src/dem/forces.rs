//! The pair-force loop shared by every model: generic over the contact laws, so each
//! model's loop is compiled with its own laws inlined.

use super::contact::{NormalLaw, TangentialLaw};
use super::grains::Grains;
use super::verlet::{Boundary, PairList};

/// Per-grain contact statistics for force snapshots (li-granular-pillars Fig. 6).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactRecord {
    /// Σ |F_n| over the grain's grain–grain contacts (N).
    pub f_n: Vec<f64>,
    /// Σ |F_t| over the grain's grain–grain contacts (N).
    pub f_t: Vec<f64>,
    /// Number of grain–grain contacts.
    pub contacts: Vec<u32>,
}

impl ContactRecord {
    pub fn zeroed(n: usize) -> Self {
        ContactRecord {
            f_n: vec![0.0; n],
            f_t: vec![0.0; n],
            contacts: vec![0; n],
        }
    }
}

/// Add every grain–grain contact force (N) and torque (N m) into `fx`, `fy`, `tq`.
///
/// Normal along n = r_ij/|r_ij| (Eq. 4); tangential along t̂ = ẑ × n from the contact
/// history (Eq. 7). Lever arms are ½|r_ij| for both grains, in the torque (Eq. 8:
/// T_ij = −½ r_ij × F_t, the same on i and j) and in the contact-point velocity, so the
/// tangential spring does no spurious work. Separated pairs forget their history.
#[allow(clippy::too_many_arguments)]
pub fn pair_forces<N: NormalLaw, T: TangentialLaw>(
    g: &Grains,
    list: &mut PairList,
    b: Boundary,
    normal: &N,
    tangential: &T,
    dt: f64,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    mut record: Option<&mut ContactRecord>,
) {
    let (x, y, r, vx, vy, w) = (
        &g.x[..],
        &g.y[..],
        &g.radius[..],
        &g.vx[..],
        &g.vy[..],
        &g.omega[..],
    );
    let n = x.len();
    for i in 0..n {
        let (xi, yi, ri, vxi, vyi, wi) = (x[i], y[i], r[i], vx[i], vy[i], w[i]);
        let (mut fxi, mut fyi, mut tqi) = (0.0, 0.0, 0.0);
        let range = list.start[i] as usize..list.start[i + 1] as usize;
        for k in range {
            let j = list.j[k] as usize;
            let (dx, dy) = b.delta(xi - x[j], yi - y[j]);
            let rs = ri + r[j];
            let r2 = dx * dx + dy * dy;
            if r2 >= rs * rs {
                if T::HAS_HISTORY {
                    list.shear[k] = 0.0;
                }
                continue;
            }
            let dist = r2.sqrt();
            let (nx, ny) = (dx / dist, dy / dist);
            let (dvx, dvy) = (vxi - vx[j], vyi - vy[j]);
            let f_n = normal.force(rs - dist, dvx * nx + dvy * ny);
            let vt = dvy * nx - dvx * ny - 0.5 * dist * (wi + w[j]);
            let f_t = tangential.force(&mut list.shear[k], vt, dt, f_n);
            let (px, py) = (f_n * nx - f_t * ny, f_n * ny + f_t * nx);
            fxi += px;
            fyi += py;
            fx[j] -= px;
            fy[j] -= py;
            let t = -0.5 * dist * f_t;
            tqi += t;
            tq[j] += t;
            if let Some(rec) = record.as_deref_mut() {
                for m in [i, j] {
                    rec.f_n[m] += f_n;
                    rec.f_t[m] += f_t.abs();
                    rec.contacts[m] += 1;
                }
            }
        }
        fx[i] += fxi;
        fy[i] += fyi;
        tq[i] += tqi;
    }
}

/// As [`pair_forces`] for grains of which some are `frozen`: at rest (v = 0, a = 0,
/// ω = 0) with every list partner at rest too, so nothing acting on them changes this
/// step. A pair of two frozen grains is skipped and a frozen grain's sums are kept from
/// the last step (its `fx`, `fy`, `tq` must not be zeroed by the caller); every other
/// pair is computed as in the full loop — a pair of two resting grains gives the very
/// same numbers (same positions, zero slip, the Coulomb truncation is idempotent) — and
/// added in the same order, so results are bit-identical to [`pair_forces`].
#[allow(clippy::too_many_arguments)]
pub fn pair_forces_frozen<N: NormalLaw, T: TangentialLaw>(
    g: &Grains,
    list: &mut PairList,
    b: Boundary,
    normal: &N,
    tangential: &T,
    dt: f64,
    frozen: &[bool],
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
) -> u64 {
    let (x, y, r, vx, vy, w) = (
        &g.x[..],
        &g.y[..],
        &g.radius[..],
        &g.vx[..],
        &g.vy[..],
        &g.omega[..],
    );
    let mut skipped = 0u64;
    for i in 0..x.len() {
        let fi = frozen[i];
        let (xi, yi, ri, vxi, vyi, wi) = (x[i], y[i], r[i], vx[i], vy[i], w[i]);
        let (mut fxi, mut fyi, mut tqi) = (0.0, 0.0, 0.0);
        for k in list.start[i] as usize..list.start[i + 1] as usize {
            let j = list.j[k] as usize;
            let fj = frozen[j];
            if fi && fj {
                skipped += 1;
                continue;
            }
            let (dx, dy) = b.delta(xi - x[j], yi - y[j]);
            let rs = ri + r[j];
            let r2 = dx * dx + dy * dy;
            if r2 >= rs * rs {
                if T::HAS_HISTORY {
                    list.shear[k] = 0.0;
                }
                continue;
            }
            let dist = r2.sqrt();
            let (nx, ny) = (dx / dist, dy / dist);
            let (dvx, dvy) = (vxi - vx[j], vyi - vy[j]);
            let f_n = normal.force(rs - dist, dvx * nx + dvy * ny);
            let vt = dvy * nx - dvx * ny - 0.5 * dist * (wi + w[j]);
            let f_t = tangential.force(&mut list.shear[k], vt, dt, f_n);
            let (px, py) = (f_n * nx - f_t * ny, f_n * ny + f_t * nx);
            let t = -0.5 * dist * f_t;
            fxi += px;
            fyi += py;
            tqi += t;
            if !fj {
                fx[j] -= px;
                fy[j] -= py;
                tq[j] += t;
            }
        }
        if !fi {
            fx[i] += fxi;
            fy[i] += fyi;
            tq[i] += tqi;
        }
    }
    skipped
}
