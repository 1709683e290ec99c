//! The sheared disks' pair loop (vagberg-sheared-disks Eqs. 1–7, 12–13) as a free
//! function over slices: slice arguments cannot alias, so the compiler keeps the array
//! pointers in registers instead of reloading them after every force store. `HISTORY`:
//! actual states keep the contact bookkeeping (the predictor of Eq. 22 needs forces
//! only); `VIRIAL`: the virial, only at the states the outputs sample.

use super::shear::{Collisions, Virial};
use super::shear_near::contact_event;
use super::verlet::rint;

/// Everything the pair loop reads besides the state (units d_s = m = τ_e = 1).
#[derive(Debug, Clone, Copy)]
pub struct PairParams {
    /// k_d = 1/Q.
    pub kd: f64,
    /// Exponent α of Eq. 1.
    pub alpha: f64,
    /// γ̇ L, the velocity jump across the Lees–Edwards boundary.
    pub shear_v: f64,
    /// CDrot (contact-point velocities, Eq. 6) rather than CD.
    pub cdrot: bool,
    /// Box side L, 1/L, Lees–Edwards offset γ L.
    pub ll: f64,
    pub inv_l: f64,
    pub offset: f64,
    /// Current time; contact start times are stored as 1 + t.
    pub now: f64,
}

impl PairParams {
    /// For `p` in a box of side `l` with Lees–Edwards offset `offset` at time `now`.
    pub fn new(p: &super::shear::ShearParams, l: f64, offset: f64, now: f64) -> Self {
        PairParams {
            kd: 1.0 / p.q,
            alpha: p.alpha,
            shear_v: p.rate * l,
            cdrot: p.model == super::shear::Dissipation::Cdrot,
            ll: l,
            inv_l: 1.0 / l,
            offset,
            now,
        }
    }
}

/// Positions, velocities, spins and radii of one state: x, y, v_x, v_y, ω, R.
pub type StateSlices<'a> = (
    &'a [f64],
    &'a [f64],
    &'a [f64],
    &'a [f64],
    &'a [f64],
    &'a [f64],
);

/// Forces and torques of the contacts in the half list (`start`, `js`) into `fx`, `fy`,
/// `tq` (overwritten); with `HISTORY`, per-pair history `hist` (0, or 1 + start time) and
/// the collision counters; with `VIRIAL`, the contact count and the virial sums
/// Σ f ⊗ r_ij into `out_vir`.
#[allow(clippy::too_many_arguments)]
pub fn pair_loop<const HISTORY: bool, const VIRIAL: bool>(
    (x, y, vx, vy, w, r): StateSlices,
    start: &[u32],
    js: &[u32],
    hist: &mut [f64],
    pp: &PairParams,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    coll: &mut Collisions,
    out_vir: &mut Virial,
) {
    for v in [&mut *fx, &mut *fy, &mut *tq] {
        v.fill(0.0);
    }
    let mut vir = Virial::default();
    let track = HISTORY;
    let (kd, alpha, shear_v, cdrot) = (pp.kd, pp.alpha, pp.shear_v, pp.cdrot);
    let (ll, inv_l, offset, now) = (pp.ll, pp.inv_l, pp.offset, pp.now);
    for i in 0..x.len() {
        for k in start[i] as usize..start[i + 1] as usize {
            let j = js[k] as usize;
            // Minimum image, Lees–Edwards (as Boundary::delta_image, with the
            // divisions by L hoisted out of the loop).
            let (dx, dy) = (x[i] - x[j], y[i] - y[j]);
            let img = rint(dy * inv_l);
            let dy = dy - img * ll;
            let dx = dx - img * offset;
            let dx = dx - ll * rint(dx * inv_l);
            let dij = r[i] + r[j];
            let r2 = dx * dx + dy * dy;
            let touch = !(r2 >= dij * dij);
            if track {
                hist[k] = contact_event(hist[k], touch, (dx, dy), now, coll);
            }
            if !touch {
                continue;
            }
            if VIRIAL {
                vir.contacts += 1;
            }
            let dist = r2.sqrt();
            let inv_dist = 1.0 / dist;
            let inv_dij = 1.0 / dij;
            let (nx, ny) = (dx * inv_dist, dy * inv_dist);
            // Eq. 2 with d_ij = (d_i + d_j)/2 = R_i + R_j and k_e = 1.
            let overlap = 1.0 - dist * inv_dij;
            let fe = if alpha == 2.0 {
                overlap * inv_dij
            } else {
                overlap.powf(alpha - 1.0) * inv_dij
            };
            let (ex, ey) = (fe * nx, fe * ny);
            // Relative velocity; j's image moves img·γ̇L faster along x.
            let (mut dvx, mut dvy) = (vx[i] - vx[j] - img * shear_v, vy[i] - vy[j]);
            // Moment arms s_ji (i to contact) = −r_ij R_i/d_ij, s_ij = r_ij R_j/d_ij.
            let (si, sj) = (r[i] * inv_dij, r[j] * inv_dij);
            let (six, siy, sjx, sjy) = (-dx * si, -dy * si, dx * sj, dy * sj);
            if cdrot {
                // v_i + ω_i ẑ×s_ji − (v_j + ω_j ẑ×s_ij), Eq. 6.
                dvx += -w[i] * siy + w[j] * sjy;
                dvy += w[i] * six - w[j] * sjx;
            }
            let (ddx, ddy) = (-kd * dvx, -kd * dvy);
            fx[i] += ex + ddx;
            fy[i] += ey + ddy;
            fx[j] -= ex + ddx;
            fy[j] -= ey + ddy;
            // Eq. 7: torques of the dissipative force about each centre.
            tq[i] += six * ddy - siy * ddx;
            tq[j] += sjx * (-ddy) - sjy * (-ddx);
            if VIRIAL {
                // f ⊗ r_ij (Eqs. 12–13), per unit area later.
                vir.el[0] += ex * dx;
                vir.el[1] += ex * dy;
                vir.el[2] += ey * dx;
                vir.el[3] += ey * dy;
                vir.dis[0] += ddx * dx;
                vir.dis[1] += ddx * dy;
                vir.dis[2] += ddy * dx;
                vir.dis[3] += ddy * dy;
            }
        }
    }
    if VIRIAL {
        *out_vir = vir;
    }
}
