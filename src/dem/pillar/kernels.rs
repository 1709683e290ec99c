//! The pillar's per-grain loops (li-granular-pillars Sec. II.B.3–4) as free functions
//! over slices. Slice arguments cannot alias one another, so the compiler keeps every
//! array pointer in a register instead of reloading it after each store, and re-slicing
//! to one length drops the bounds checks: together about a third of a step's time.
//! Resting and moving grains mix at random, so choices between them are bit masks, not
//! branches that would mispredict.

use crate::dem::backend::simd::{Pos, Quad};
use crate::dem::law::{SubstrateFriction, pick};
use crate::dem::pillar::phases::GrainState;
use std::ops::Range;

/// `v` when `keep`, else +0, without a branch.
#[inline(always)]
pub fn keep_or_zero(v: f64, keep: bool) -> f64 {
    f64::from_bits(v.to_bits() & 0u64.wrapping_sub(keep as u64))
}

/// The arrays the first half kick and drift update, a range of grains each: positions
/// (m), angles (rad), velocities (m/s), and the rest flags they set.
pub struct Drift<'a> {
    pub x: &'a mut [f64],
    pub y: &'a mut [f64],
    pub theta: &'a mut [f64],
    pub vx: &'a mut [f64],
    pub vy: &'a mut [f64],
    pub resting: &'a mut [bool],
}

/// What the drift reads: accelerations (m/s²), spins (rad/s), radii (m), and the pair
/// list's build positions (m; empty when they do not match the grains).
pub struct DriftInputs<'a> {
    pub ax: &'a [f64],
    pub ay: &'a [f64],
    pub omega: &'a [f64],
    pub radius: &'a [f64],
    pub x_ref: &'a [f64],
    pub y_ref: &'a [f64],
}

/// `dispatch::kick_drift` in portable scalar code (the reference the AVX2 kernel matches, and
/// its tail); the largest move only when `refs_ok`, else 0.
pub fn kick_drift_scalar(
    dt: f64,
    d: Drift,
    inp: &DriftInputs,
    refs_ok: bool,
    state: &mut [Quad],
    spin: &mut [Pos],
) -> f64 {
    let n = d.x.len();
    let (x, y, theta) = (&mut d.x[..n], &mut d.y[..n], &mut d.theta[..n]);
    let (vx, vy, resting) = (&mut d.vx[..n], &mut d.vy[..n], &mut d.resting[..n]);
    let (ax, ay, omega) = (&inp.ax[..n], &inp.ay[..n], &inp.omega[..n]);
    for i in 0..n {
        resting[i] =
            (vx[i] == 0.0) & (vy[i] == 0.0) & (ax[i] == 0.0) & (ay[i] == 0.0) & (omega[i] == 0.0);
        vx[i] += 0.5 * dt * ax[i];
        vy[i] += 0.5 * dt * ay[i];
        x[i] += dt * vx[i];
        y[i] += dt * vy[i];
        theta[i] += dt * omega[i];
    }
    let g = GrainState {
        x,
        y,
        vx,
        vy,
        omega,
        radius: inp.radius,
    };
    pack_grains(g, state, spin);
    if !refs_ok {
        return 0.0;
    }
    let (x_ref, y_ref) = (&inp.x_ref[..n], &inp.y_ref[..n]);
    let mut moved2: f64 = 0.0;
    for i in 0..n {
        let (ex, ey) = (x[i] - x_ref[i], y[i] - y_ref[i]);
        moved2 = moved2.max(ex * ex + ey * ey);
    }
    moved2
}

/// The grains of `g` packed for the AVX2 pair kernel (`pillar_avx2::PackedGrains`):
/// (x, y, v_x, v_y) into `state`, (ω, R) into `spin`.
pub fn pack_grains(g: GrainState, state: &mut [Quad], spin: &mut [Pos]) {
    let n = state.len();
    let (state, spin) = (&mut state[..n], &mut spin[..n]);
    let (x, y, vx, vy) = (&g.x[..n], &g.y[..n], &g.vx[..n], &g.vy[..n]);
    let (omega, radius) = (&g.omega[..n], &g.radius[..n]);
    for i in 0..n {
        state[i] = Quad([x[i], y[i], vx[i], vy[i]]);
        spin[i] = Pos([omega[i], radius[i]]);
    }
}

/// Per-grain constants (see `pillar::Consts`) as slices: 1/m (1/kg), 1/I
/// (1/(kg m²)), m g μ (N) and its square (N²), T_max = (2/3) m g μ R (N m), ξ_ω (rad/s).
#[derive(Clone, Copy)]
pub struct GrainConsts<'a> {
    pub inv_mass: &'a [f64],
    pub inv_inertia: &'a [f64],
    pub f_max: &'a [f64],
    pub f_max2: &'a [f64],
    pub t_max: &'a [f64],
    pub xi_omega: &'a [f64],
}

impl<'a> GrainConsts<'a> {
    /// The grains `r` of these.
    pub fn range(&self, r: Range<usize>) -> GrainConsts<'a> {
        GrainConsts {
            inv_mass: &self.inv_mass[r.clone()],
            inv_inertia: &self.inv_inertia[r.clone()],
            f_max: &self.f_max[r.clone()],
            f_max2: &self.f_max2[r.clone()],
            t_max: &self.t_max[r.clone()],
            xi_omega: &self.xi_omega[r],
        }
    }
}

/// What the substrate kernel reads, a range of grains each: whether to kick (second
/// half kick and spin update), δt (s), ξ_v² (m²/s², Eq. 11), the law, the per-grain
/// constants, frozen flags (empty when none are), contact forces (N) and torques
/// (N m).
#[derive(Clone, Copy)]
pub struct SubstrateInputs<'a> {
    pub kick: bool,
    pub dt: f64,
    pub xi_v2: f64,
    pub sub: &'a SubstrateFriction,
    pub c: GrainConsts<'a>,
    pub frozen: &'a [bool],
    pub fx: &'a [f64],
    pub fy: &'a [f64],
    pub tq: &'a [f64],
}

/// What it writes: velocities (m/s), accelerations (m/s²), spins (rad/s), substrate
/// forces (N), and per grain the dissipated power |f·v| and |T_μ ω| (W).
pub struct SubstrateState<'a> {
    pub vx: &'a mut [f64],
    pub vy: &'a mut [f64],
    pub ax: &'a mut [f64],
    pub ay: &'a mut [f64],
    pub omega: &'a mut [f64],
    pub sub_fx: &'a mut [f64],
    pub sub_fy: &'a mut [f64],
    pub pow_t: &'a mut [f64],
    pub pow_r: &'a mut [f64],
}

impl<'a> SubstrateInputs<'a> {
    /// The grains `r` of these (frozen flags too, when there are any).
    pub fn range(&self, r: Range<usize>) -> SubstrateInputs<'a> {
        SubstrateInputs {
            c: self.c.range(r.clone()),
            frozen: if self.frozen.is_empty() {
                &[]
            } else {
                &self.frozen[r.clone()]
            },
            fx: &self.fx[r.clone()],
            fy: &self.fy[r.clone()],
            tq: &self.tq[r],
            ..*self
        }
    }
}

impl SubstrateState<'_> {
    /// The grains `r` of these.
    pub fn range(&mut self, r: Range<usize>) -> SubstrateState<'_> {
        SubstrateState {
            vx: &mut self.vx[r.clone()],
            vy: &mut self.vy[r.clone()],
            ax: &mut self.ax[r.clone()],
            ay: &mut self.ay[r.clone()],
            omega: &mut self.omega[r.clone()],
            sub_fx: &mut self.sub_fx[r.clone()],
            sub_fy: &mut self.sub_fy[r.clone()],
            pow_t: &mut self.pow_t[r.clone()],
            pow_r: &mut self.pow_r[r],
        }
    }
}

/// `dispatch::substrate_kick` in portable scalar code: the reference the AVX2 kernel matches
/// bit for bit, and its tail.
pub fn substrate_kick_scalar(inp: &SubstrateInputs, out: SubstrateState) {
    let SubstrateInputs {
        kick,
        dt,
        xi_v2,
        sub,
        c,
        frozen,
        fx,
        fy,
        tq,
    } = *inp;
    let SubstrateState {
        vx,
        vy,
        ax,
        ay,
        omega,
        sub_fx,
        sub_fy,
        pow_t,
        pow_r,
    } = out;
    let n = vx.len();
    let (pow_t, pow_r) = (&mut pow_t[..n], &mut pow_r[..n]);
    let (fx, fy, tq, vy) = (&fx[..n], &fy[..n], &tq[..n], &mut vy[..n]);
    let (ax, ay, omega) = (&mut ax[..n], &mut ay[..n], &mut omega[..n]);
    let (sub_fx, sub_fy) = (&mut sub_fx[..n], &mut sub_fy[..n]);
    let (inv_m, inv_i) = (&c.inv_mass[..n], &c.inv_inertia[..n]);
    let (f_max, f_max2) = (&c.f_max[..n], &c.f_max2[..n]);
    let (t_max, xi_omega) = (&c.t_max[..n], &c.xi_omega[..n]);
    let skip = kick && frozen.len() == n;
    // Three short passes rather than one long one: each iteration's dependency chain
    // (square root, division, kick, test) is long, and short bodies let the processor
    // overlap many more iterations. Frozen grains keep their values (a mask, not a
    // branch).
    for i in 0..n {
        let (f_x, f_y, v_x, v_y) = (fx[i], fy[i], vx[i], vy[i]);
        let (sx, sy) = sub.force_with(f_max[i], f_max2[i], v_x, v_y, f_x, f_y);
        let hold = skip && frozen[i];
        pow_t[i] = keep_or_zero((sx * v_x + sy * v_y).abs(), !hold);
        sub_fx[i] = pick(hold, sub_fx[i], sx);
        sub_fy[i] = pick(hold, sub_fy[i], sy);
        ax[i] = pick(hold, ax[i], (f_x + sx) * inv_m[i]);
        ay[i] = pick(hold, ay[i], (f_y + sy) * inv_m[i]);
    }
    if !kick {
        pow_r.fill(0.0);
        return;
    }
    for i in 0..n {
        let (f_x, f_y) = (fx[i], fy[i]);
        let v_x = vx[i] + 0.5 * dt * ax[i];
        let v_y = vy[i] + 0.5 * dt * ay[i];
        // Frozen grains are at rest: v = a = 0 stays so either way.
        let keep = !((v_x * v_x + v_y * v_y < xi_v2) & (f_x * f_x + f_y * f_y <= f_max2[i]));
        vx[i] = keep_or_zero(v_x, keep);
        vy[i] = keep_or_zero(v_y, keep);
        ax[i] = keep_or_zero(ax[i], keep);
        ay[i] = keep_or_zero(ay[i], keep);
    }
    for i in 0..n {
        let (t, w, t_m) = (tq[i], omega[i], t_max[i]);
        let ts = sub.torque_with(t_m, w, t);
        let hold = skip && frozen[i];
        pow_r[i] = keep_or_zero((ts * w).abs(), !hold);
        let w_new = w + dt * (t + ts) * inv_i[i];
        let w_new = keep_or_zero(w_new, !((w_new.abs() < xi_omega[i]) & (t.abs() <= t_m)));
        omega[i] = pick(hold, w, w_new);
    }
}

/// Σ v in a fixed order that vectorises: four running sums over every fourth element,
/// then (s0 + s1) + (s2 + s3).
#[inline(always)]
pub fn sum4(v: &[f64]) -> f64 {
    let mut a = [0.0; 4];
    let mut c = v.chunks_exact(4);
    for q in &mut c {
        for l in 0..4 {
            a[l] += q[l];
        }
    }
    for (l, x) in c.remainder().iter().enumerate() {
        a[l] += x;
    }
    (a[0] + a[1]) + (a[2] + a[3])
}
