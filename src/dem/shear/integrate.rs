//! The integrator of vagberg-sheared-disks Eqs. 21–24 as free functions over slices
//! (alias-free arguments keep the array pointers in registers; multiplying by stored
//! 1/m and 1/I instead of dividing saves ten divisions per grain and step).

pub use crate::dem::backend::simd::{Pos, Quad};

/// A state packed grain by grain for the AVX2 force kernel: (x, y) (d_s) and
/// (v_x, v_y, ω, R) (d_s/τ_e, d_s/τ_e, 1/τ_e, d_s). The packed integrator
/// (`shear_integrate_avx2`) writes it as it steps; `fill` packs the arrays' state for an
/// evaluation outside a step. A cache: never part of a simulation's value.
#[derive(Debug, Clone, Default)]
pub struct Packed {
    pub(crate) pos: Vec<Pos>,
    pub(crate) vel: Vec<Quad>,
}

impl PartialEq for Packed {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Packed {
    /// Whether the steps of `p` run packed: the vector force kernels (which implement
    /// the harmonic law only) and the packed integrator. Read once per step: the level
    /// is global, and tests switch it.
    pub fn used_for(p: &crate::dem::shear::params::ShearParams) -> bool {
        cfg!(target_arch = "x86_64")
            && p.law().is_harmonic_vagberg().is_some()
            && crate::dem::backend::simd::level() >= crate::dem::backend::simd::Level::Avx2
    }

    /// Pack the state (x, y, v_x, v_y, ω, R).
    pub fn fill(&mut self, (x, y, vx, vy, w, r): crate::dem::shear::params::StateSlices) {
        let n = x.len();
        self.pos.clear();
        self.pos.extend(x.iter().zip(y).map(|(&a, &b)| Pos([a, b])));
        self.vel.clear();
        self.vel
            .extend((0..n).map(|i| Quad([vx[i], vy[i], w[i], r[i]])));
    }

    /// Room for n grains, to be written by index.
    pub(crate) fn reserve(&mut self, n: usize) -> (&mut [Pos], &mut [Quad]) {
        self.pos.resize(n, Pos::default());
        self.vel.resize(n, Quad::default());
        (&mut self.pos[..n], &mut self.vel[..n])
    }
}

/// Positions x, y, velocities v_x, v_y and spins ω of one state.
pub type Slices5<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64], &'a [f64]);

crate::multiversion! {
/// Eqs. 21–22 (and the spin analogue of 21): the predicted state (p*) from the state
/// at t and its forces f0 (units d_s = m = τ_e = 1). Spins stay 0 when `!rotate`.
/// (`shear_integrate_avx2::predict` is the same, packed.)
#[allow(clippy::too_many_arguments)]
pub fn predict(
    dt: f64,
    rotate: bool,
    state: Slices5,
    inv: (&[f64], &[f64]),
    f0: (&[f64], &[f64], &[f64]),
    px: &mut [f64],
    py: &mut [f64],
    pvx: &mut [f64],
    pvy: &mut [f64],
    pw: &mut [f64],
) {
    let ((x, y, vx, vy, w), (inv_m, inv_i), (f0x, f0y, t0)) = (state, inv, f0);
    let n = x.len();
    let (y, vx, vy, w) = (&y[..n], &vx[..n], &vy[..n], &w[..n]);
    let (inv_m, inv_i, f0x, f0y, t0) = (&inv_m[..n], &inv_i[..n], &f0x[..n], &f0y[..n], &t0[..n]);
    let (px, py, pvx, pvy, pw) = (
        &mut px[..n],
        &mut py[..n],
        &mut pvx[..n],
        &mut pvy[..n],
        &mut pw[..n],
    );
    for i in 0..n {
        pvx[i] = vx[i] + f0x[i] * dt * inv_m[i];
        pvy[i] = vy[i] + f0y[i] * dt * inv_m[i];
        px[i] = x[i] + vx[i] * dt;
        py[i] = y[i] + vy[i] * dt;
        pw[i] = if rotate {
            w[i] + t0[i] * dt * inv_i[i]
        } else {
            0.0
        };
    }
}
}

crate::multiversion! {
/// Eqs. 23–24 (and their spin analogues): the state at t + Δt from the forces at t
/// (f0) and at the predicted state (f1). (`shear_integrate_avx2::correct` is the same,
/// packed.)
#[allow(clippy::too_many_arguments)]
pub fn correct(
    dt: f64,
    rotate: bool,
    inv: (&[f64], &[f64]),
    f0: (&[f64], &[f64], &[f64]),
    f1: (&[f64], &[f64], &[f64]),
    x: &mut [f64],
    y: &mut [f64],
    theta: &mut [f64],
    vx: &mut [f64],
    vy: &mut [f64],
    w: &mut [f64],
) {
    let ((inv_m, inv_i), (f0x, f0y, t0), (f1x, f1y, t1)) = (inv, f0, f1);
    let n = x.len();
    let (y, theta, vx, vy, w) = (
        &mut y[..n],
        &mut theta[..n],
        &mut vx[..n],
        &mut vy[..n],
        &mut w[..n],
    );
    let (inv_m, inv_i, f0x, f0y, t0) = (&inv_m[..n], &inv_i[..n], &f0x[..n], &f0y[..n], &t0[..n]);
    let (f1x, f1y, t1) = (&f1x[..n], &f1y[..n], &t1[..n]);
    for i in 0..n {
        let (vx0, vy0) = (vx[i], vy[i]);
        vx[i] = vx0 + (f0x[i] + f1x[i]) * dt * (0.5 * inv_m[i]);
        vy[i] = vy0 + (f0y[i] + f1y[i]) * dt * (0.5 * inv_m[i]);
        x[i] += (vx0 + vx[i]) * dt * 0.5;
        y[i] += (vy0 + vy[i]) * dt * 0.5;
    }
    if rotate {
        for i in 0..n {
            let w0 = w[i];
            w[i] = w0 + (t0[i] + t1[i]) * dt * (0.5 * inv_i[i]);
            theta[i] += (w0 + w[i]) * dt * 0.5;
        }
    }
}
}
