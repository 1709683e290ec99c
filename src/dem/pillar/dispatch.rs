//! Which kernel runs each per-grain phase of the pillar's step: the hand-written AVX2
//! kernel (`backend::pillar_avx2`) where the processor has AVX2, else the portable
//! scalar loop in [`crate::dem::pillar::kernels`] that it matches bit for bit. The
//! pair phase's choice, which also depends on the contact law, is made in
//! `arrays::phase_pairs`.

use crate::dem::backend::simd::{Pos, Quad};
use crate::dem::pillar::kernels::{
    Drift, DriftInputs, SubstrateInputs, SubstrateState, kick_drift_scalar, substrate_kick_scalar,
    sum4,
};
use crate::dem::pillar::phases::CHUNK;

/// First half kick and drift of velocity Verlet (time step `dt`, s); marks the grains
/// at rest before the move, packs the moved grains for the AVX2 pair kernel into
/// `state`, `spin` (see `pack_grains`), and returns the largest squared displacement
/// (m²) since the pair list's build positions (infinite when those do not match). Runs
/// the AVX2 kernel (`pillar_avx2::kick_drift`, same numbers) where the processor has it.
///
/// # Panics
/// If the slices' lengths differ (`x_ref`, `y_ref` may also be empty).
pub fn kick_drift(
    dt: f64,
    d: Drift,
    inp: &DriftInputs,
    state: &mut [Quad],
    spin: &mut [Pos],
) -> f64 {
    let n = d.x.len();
    let lens = [
        d.y.len(),
        d.theta.len(),
        d.vx.len(),
        d.vy.len(),
        d.resting.len(),
        inp.ax.len(),
        inp.ay.len(),
        inp.omega.len(),
        inp.radius.len(),
        state.len(),
        spin.len(),
    ];
    assert!(
        lens.iter().all(|&l| l == n),
        "kick_drift: slices of one length"
    );
    let refs_ok = inp.x_ref.len() == n && inp.y_ref.len() == n;
    #[cfg(target_arch = "x86_64")]
    if crate::dem::backend::simd::level() >= crate::dem::backend::simd::Level::Avx2 {
        // SAFETY: the processor has AVX2 (checked at run time); lengths checked above.
        let m = unsafe {
            crate::dem::backend::pillar_avx2::kick_drift(dt, d, inp, refs_ok, state, spin)
        };
        return if refs_ok { m } else { f64::INFINITY };
    }
    let m = kick_drift_scalar(dt, d, inp, refs_ok, state, spin);
    if refs_ok { m } else { f64::INFINITY }
}

/// Substrate friction from the contact forces, new accelerations, and when `kick` the
/// second half kick, the spin update and the ξ rule of Eq. 11. Frozen grains (when
/// `kick`) are left as they are. Each grain's dissipated power goes into `pow_t` and
/// `pow_r` (summed by the caller in a fixed order, so these loops carry no sum). Runs
/// the AVX2 kernel (`pillar_avx2`, same numbers) where the processor has it.
///
/// # Panics
/// If the slices' lengths differ (`frozen` may also be empty).
pub fn substrate_kick(inp: &SubstrateInputs, out: SubstrateState) {
    let n = out.vx.len();
    let (c, o) = (&inp.c, &out);
    let lens = [
        c.inv_mass.len(),
        c.inv_inertia.len(),
        c.f_max.len(),
        c.f_max2.len(),
        c.t_max.len(),
        c.xi_omega.len(),
        inp.fx.len(),
        inp.fy.len(),
        inp.tq.len(),
        o.vy.len(),
        o.ax.len(),
        o.ay.len(),
        o.omega.len(),
        o.sub_fx.len(),
        o.sub_fy.len(),
        o.pow_t.len(),
        o.pow_r.len(),
    ];
    assert!(
        lens.iter().all(|&l| l == n) && (inp.frozen.is_empty() || inp.frozen.len() == n),
        "substrate_kick: slices of one length"
    );
    #[cfg(target_arch = "x86_64")]
    if crate::dem::backend::simd::level() >= crate::dem::backend::simd::Level::Avx2 {
        // SAFETY: the processor has AVX2 (checked at run time); lengths checked above.
        unsafe { crate::dem::backend::pillar_avx2::substrate_kick(inp, out) };
        return;
    }
    substrate_kick_scalar(inp, out);
}

/// The substrate and the second half kick of a range (the range starting on a chunk
/// boundary; see [`substrate_kick`]), then per chunk of `CHUNK` grains Σ|f·v| and
/// Σ|T_μ ω| (W) into `power`.
pub fn substrate_chunks(inp: &SubstrateInputs, mut out: SubstrateState, power: &mut [[f64; 2]]) {
    let n = out.vx.len();
    substrate_kick(inp, out.range(0..n));
    let (pow_t, pow_r) = (&*out.pow_t, &*out.pow_r);
    for (ch, p) in power.iter_mut().enumerate() {
        let r = ch * CHUNK..((ch + 1) * CHUNK).min(n);
        *p = [sum4(&pow_t[r.clone()]), sum4(&pow_r[r])];
    }
}
