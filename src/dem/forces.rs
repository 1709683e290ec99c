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

/// Each pair's last contribution, so pairs of two resting grains need no work.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PairCache {
    /// Force on the first grain (N) and torque on both (N m), per list slot.
    pub px: Vec<f64>,
    pub py: Vec<f64>,
    pub t: Vec<f64>,
    /// Whether the slots hold values for the current list (false right after a build).
    pub valid: bool,
    /// Pairs reused / computed since the counters were last reset.
    pub reused: u64,
    pub computed: u64,
}

/// As [`pair_forces`], but a pair whose two grains both rest (v = 0, a = 0, ω = 0 at
/// the start of the step, so neither moved) reuses its cached contribution. Such a
/// pair's force is bit-identical when recomputed — same positions, zero slip, the
/// Coulomb truncation is idempotent — and contributions are added in the same order
/// as the full loop, so results are exactly those of [`pair_forces`].
#[allow(clippy::too_many_arguments)]
pub fn pair_forces_resting<N: NormalLaw, T: TangentialLaw>(
    g: &Grains,
    list: &mut PairList,
    b: Boundary,
    normal: &N,
    tangential: &T,
    dt: f64,
    resting: &[bool],
    cache: &mut PairCache,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
) {
    let nslots = list.j.len();
    if !cache.valid || cache.px.len() != nslots {
        cache.px = vec![0.0; nslots];
        cache.py = vec![0.0; nslots];
        cache.t = vec![0.0; nslots];
    }
    let use_cache = cache.valid;
    let (x, y, r, vx, vy, w) = (
        &g.x[..],
        &g.y[..],
        &g.radius[..],
        &g.vx[..],
        &g.vy[..],
        &g.omega[..],
    );
    let (mut reused, mut computed) = (0u64, 0u64);
    for i in 0..x.len() {
        let (xi, yi, ri, vxi, vyi, wi) = (x[i], y[i], r[i], vx[i], vy[i], w[i]);
        let (mut fxi, mut fyi, mut tqi) = (0.0, 0.0, 0.0);
        let rest_i = use_cache && resting[i];
        for k in list.start[i] as usize..list.start[i + 1] as usize {
            let j = list.j[k] as usize;
            let (px, py, t) = if rest_i && resting[j] {
                reused += 1;
                (cache.px[k], cache.py[k], cache.t[k])
            } else {
                computed += 1;
                let (dx, dy) = b.delta(xi - x[j], yi - y[j]);
                let rs = ri + r[j];
                let r2 = dx * dx + dy * dy;
                let v = if r2 >= rs * rs {
                    if T::HAS_HISTORY {
                        list.shear[k] = 0.0;
                    }
                    (0.0, 0.0, 0.0)
                } else {
                    let dist = r2.sqrt();
                    let (nx, ny) = (dx / dist, dy / dist);
                    let (dvx, dvy) = (vxi - vx[j], vyi - vy[j]);
                    let f_n = normal.force(rs - dist, dvx * nx + dvy * ny);
                    let vt = dvy * nx - dvx * ny - 0.5 * dist * (wi + w[j]);
                    let f_t = tangential.force(&mut list.shear[k], vt, dt, f_n);
                    (f_n * nx - f_t * ny, f_n * ny + f_t * nx, -0.5 * dist * f_t)
                };
                cache.px[k] = v.0;
                cache.py[k] = v.1;
                cache.t[k] = v.2;
                v
            };
            if px == 0.0 && py == 0.0 && t == 0.0 {
                continue; // not in contact: the full loop adds nothing either
            }
            fxi += px;
            fyi += py;
            fx[j] -= px;
            fy[j] -= py;
            tqi += t;
            tq[j] += t;
        }
        fx[i] += fxi;
        fy[i] += fyi;
        tq[i] += tqi;
    }
    cache.valid = true;
    cache.reused += reused;
    cache.computed += computed;
}
