//! The pillar's two hot kernels written with AVX2 intrinsics: the grain–grain contacts
//! (li-granular-pillars Eqs. 4, 7, 8) four pair slots at a time, and the substrate
//! (Sec. II.B.3, Eqs. 9–11) four grains at a time.
//!
//! Why by hand: compiled from the scalar code (`pillar::phases::slot_contact`,
//! `pillar::kernels::substrate_kick_scalar`) both stayed scalar, and their choices
//! (touching or not, sliding or not, moving or resting grain) became branches that
//! mispredicted, since such cases mix at random: three fifths of a flowing pillar's
//! step. Here every choice is a lane mask, and each grain's numbers for the pair kernel
//! come packed (x, y, v_x, v_y | ω, R), one load and a transpose per four grains.
//!
//! Same numbers as the scalar code bit for bit: each lane does its operations in its
//! order (no fused multiply-add; division and square root are correctly rounded in
//! both), with its NaN and signed-zero behaviour (`max` returns the second operand on a
//! NaN as `f64::max` returns the number; ordered compares are false on NaN as `<`,
//! `>` are; `!=` is unordered). What is left over past a multiple of four goes through
//! the scalar code. A test runs a pillar both ways and compares the state, forces and
//! contact history by bits.
//!
//! The pair kernel implements one law, `ContactLaw::is_linear_cundall_strack` (linear
//! spring, viscous normal damping, Cundall–Strack, midway contact point); the caller
//! runs the scalar reference for any other. Compiled for AVX2 only, also on AVX-512
//! processors: an AVX-512 build of these kernels gained 0–2.5 % per particle-step at
//! N = 1000–16,000 (alternating runs, 2026-11-25), under the 5 % a second copy must earn.

use crate::dem::backend::avx2::{abs4, lanes, neg4, pick4, transpose};
use crate::dem::backend::simd::{Pos, Quad};
use crate::dem::law::ContactLaw;
use crate::dem::pillar::kernels::{
    Drift, DriftInputs, SubstrateInputs, SubstrateState, kick_drift_scalar, substrate_kick_scalar,
};
use crate::dem::pillar::phases::{GrainState, TermSink, slot_contact};
use std::arch::x86_64::*;
use std::ops::Range;

/// Four lanes from `s[i..i + 4]`.
///
/// # Safety
/// AVX2 present; i + 4 ≤ s.len().
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn ld(s: &[f64], i: usize) -> __m256d {
    unsafe { _mm256_loadu_pd(s.as_ptr().add(i)) }
}

/// `v` into `s[i..i + 4]`.
///
/// # Safety
/// AVX2 present; i + 4 ≤ s.len().
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn st(s: &mut [f64], i: usize, v: __m256d) {
    unsafe { _mm256_storeu_pd(s.as_mut_ptr().add(i), v) }
}

/// Lanes all ones where `f[i + l]` (bools from a slice), else zero.
///
/// # Safety
/// AVX2 present; i + 4 ≤ f.len().
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn bool_mask(f: &[bool], i: usize) -> __m256d {
    unsafe {
        let bytes = (f.as_ptr().add(i) as *const u32).read_unaligned();
        let wide = _mm256_cvtepu8_epi64(_mm_cvtsi32_si128(bytes as i32));
        _mm256_castsi256_pd(_mm256_cmpgt_epi64(wide, _mm256_setzero_si256()))
    }
}

/// As [`crate::dem::pillar::kernels::substrate_kick_scalar`] (same arguments, same results).
///
/// # Safety
/// The processor must have AVX2. Every slice but `frozen` must have length
/// `out.vx.len()`; `frozen` that length or none (the dispatcher asserts both).
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments, unused_unsafe)]
pub(crate) unsafe fn substrate_kick(inp: &SubstrateInputs, out: SubstrateState) {
    let mut out = out;
    unsafe {
        let SubstrateInputs {
            kick,
            dt,
            xi_v2,
            c,
            frozen,
            fx,
            fy,
            tq,
            ..
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
        } = &mut out;
        let n = vx.len();
        let n4 = n / 4 * 4;
        let skip = kick && frozen.len() == n;
        let zero = _mm256_setzero_pd();
        let one = _mm256_set1_pd(1.0);
        let min_pos = _mm256_set1_pd(f64::MIN_POSITIVE);
        let (half_dt, dt4, xi_v2_4) = (
            _mm256_set1_pd(0.5 * dt),
            _mm256_set1_pd(dt),
            _mm256_set1_pd(xi_v2),
        );
        // SAFETY (every load and store below): i + 4 ≤ n4 ≤ n and every slice has length n
        // (this function's contract).
        for i in (0..n4).step_by(4) {
            unsafe {
                let hold = if skip { bool_mask(frozen, i) } else { zero };
                let (f_x, f_y, v_x, v_y) = (ld(fx, i), ld(fy, i), ld(vx, i), ld(vy, i));
                let (f_max, f_max2) = (ld(c.f_max, i), ld(c.f_max2, i));
                let f2 = _mm256_add_pd(_mm256_mul_pd(f_x, f_x), _mm256_mul_pd(f_y, f_y));
                let (a_x, a_y) = if _mm256_movemask_pd(hold) == 0b1111 {
                    // Four frozen grains keep everything but the power (zero): what the
                    // masks below give, without the square root and division (frozen
                    // grains come in runs in a quasistatic pillar).
                    st(pow_t, i, zero);
                    (ld(ax, i), ld(ay, i))
                } else {
                    // SubstrateFriction::force_with.
                    let v2 = _mm256_add_pd(_mm256_mul_pd(v_x, v_x), _mm256_mul_pd(v_y, v_y));
                    let moving = _mm256_cmp_pd::<_CMP_GT_OQ>(v2, zero);
                    let q = pick4(moving, v2, f2);
                    let k_q = _mm256_div_pd(f_max, _mm256_sqrt_pd(_mm256_max_pd(q, min_pos)));
                    let big = _mm256_cmp_pd::<_CMP_GT_OQ>(f2, f_max2);
                    let k = neg4(pick4(_mm256_or_pd(moving, big), k_q, one));
                    let sx = _mm256_mul_pd(k, pick4(moving, v_x, f_x));
                    let sy = _mm256_mul_pd(k, pick4(moving, v_y, f_y));
                    let p = _mm256_add_pd(_mm256_mul_pd(sx, v_x), _mm256_mul_pd(sy, v_y));
                    st(pow_t, i, _mm256_andnot_pd(hold, abs4(p)));
                    st(sub_fx, i, pick4(hold, ld(sub_fx, i), sx));
                    st(sub_fy, i, pick4(hold, ld(sub_fy, i), sy));
                    let inv_m = ld(c.inv_mass, i);
                    let a_x = _mm256_mul_pd(_mm256_add_pd(f_x, sx), inv_m);
                    let a_y = _mm256_mul_pd(_mm256_add_pd(f_y, sy), inv_m);
                    (pick4(hold, ld(ax, i), a_x), pick4(hold, ld(ay, i), a_y))
                };
                if !kick {
                    st(ax, i, a_x);
                    st(ay, i, a_y);
                    continue;
                }
                // Second half kick and the ξ_v rule.
                let v_x = _mm256_add_pd(v_x, _mm256_mul_pd(half_dt, a_x));
                let v_y = _mm256_add_pd(v_y, _mm256_mul_pd(half_dt, a_y));
                let vv = _mm256_add_pd(_mm256_mul_pd(v_x, v_x), _mm256_mul_pd(v_y, v_y));
                let stop = _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_LT_OQ>(vv, xi_v2_4),
                    _mm256_cmp_pd::<_CMP_LE_OQ>(f2, f_max2),
                );
                st(vx, i, _mm256_andnot_pd(stop, v_x));
                st(vy, i, _mm256_andnot_pd(stop, v_y));
                st(ax, i, _mm256_andnot_pd(stop, a_x));
                st(ay, i, _mm256_andnot_pd(stop, a_y));
            }
        }
        // The spins in a loop of their own: the loop above is one long chain of latencies
        // (square root, division) per group, and a shorter body lets the processor overlap
        // more groups (measured 3 % faster on a flowing pillar).
        for i in (0..n4).step_by(4) {
            if !kick {
                break;
            }
            // SAFETY: as above.
            unsafe {
                let hold = if skip { bool_mask(frozen, i) } else { zero };
                if _mm256_movemask_pd(hold) == 0b1111 {
                    // Four frozen grains keep their spins; no power.
                    st(pow_r, i, zero);
                    continue;
                }
                // SubstrateFriction::torque_with, the kick and the ξ_ω rule.
                let (t, w, t_m) = (ld(tq, i), ld(omega, i), ld(c.t_max, i));
                let sign = _mm256_and_pd(w, _mm256_set1_pd(-0.0));
                let spinning = neg4(_mm256_or_pd(abs4(t_m), sign));
                let neg_t_m = neg4(t_m);
                let r = neg4(t);
                let r = pick4(_mm256_cmp_pd::<_CMP_LT_OQ>(r, neg_t_m), neg_t_m, r);
                let at_rest = pick4(_mm256_cmp_pd::<_CMP_GT_OQ>(r, t_m), t_m, r);
                let ts = pick4(_mm256_cmp_pd::<_CMP_NEQ_UQ>(w, zero), spinning, at_rest);
                st(pow_r, i, _mm256_andnot_pd(hold, abs4(_mm256_mul_pd(ts, w))));
                let kick_w = _mm256_mul_pd(
                    _mm256_mul_pd(dt4, _mm256_add_pd(t, ts)),
                    ld(c.inv_inertia, i),
                );
                let w_new = _mm256_add_pd(w, kick_w);
                let stop_w = _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_LT_OQ>(abs4(w_new), ld(c.xi_omega, i)),
                    _mm256_cmp_pd::<_CMP_LE_OQ>(abs4(t), t_m),
                );
                st(omega, i, pick4(hold, w, _mm256_andnot_pd(stop_w, w_new)));
            }
        }
        if !kick {
            pow_r.fill(0.0);
        }
        if n4 < n {
            substrate_kick_scalar(&inp.range(n4..n), out.range(n4..n));
        }
    }
}
/// Grains g[0..4]'s (x, y, v_x, v_y) and (ω, R) records as six field vectors.
///
/// # Safety
/// AVX2 present; every g[l] in bounds of both arrays.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load_grains(state: *const Quad, spin: *const Pos, g: [usize; 4]) -> [__m256d; 6] {
    unsafe {
        let q = g.map(|l| _mm256_load_pd((*state.add(l)).0.as_ptr()));
        let (x, y, vx, vy) = transpose(q[0], q[1], q[2], q[3]);
        let p = g.map(|l| _mm_load_pd((*spin.add(l)).0.as_ptr()));
        let p02 = _mm256_set_m128d(p[2], p[0]);
        let p13 = _mm256_set_m128d(p[3], p[1]);
        [
            x,
            y,
            vx,
            vy,
            _mm256_unpacklo_pd(p02, p13),
            _mm256_unpackhi_pd(p02, p13),
        ]
    }
}

/// The grains' state packed for [`pair_slots`]: (x, y, v_x, v_y) (m, m/s) and (ω, R)
/// (rad/s, m) per grain.
pub struct PackedGrains<'a> {
    pub state: &'a [Quad],
    pub spin: &'a [Pos],
}

/// As [`crate::dem::pillar::phases::pair_slots`] without a force record, four slots at a
/// time: slots `slots` (of the whole list), owned by `ids.0[k]`, partnered by `ids.1[k]`;
/// `shear` and `sink` hold the range's slots. The last slots short of a multiple
/// of four go through the scalar `slot_contact` with `g`. Returns the slots skipped.
///
/// # Safety
/// The processor must have AVX2; `packed` holds the state `g` holds, and both and
/// `resting` cover every grain that the owners and partners name over `slots` (the
/// caller asserts both); the sink's term places are in bounds (`end_layout`
/// checks every one after each rebuild).
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments, unused_unsafe)]
pub(crate) unsafe fn pair_slots(
    slots: Range<usize>,
    g: GrainState,
    packed: PackedGrains,
    ids: (&[u32], &[u32]),
    shear: &mut [f64],
    sink: TermSink,
    resting: Option<&[bool]>,
    laws: ((f64, f64, f64, f64), &ContactLaw, f64),
) -> u64 {
    // The coefficients are `law.is_linear_cundall_strack()`'s: the law this kernel
    // implements (the caller checks); the tail runs the law's scalar reference.
    let ((owner, js), ((k_n, gamma_n, k_t, mu), law, dt)) = (ids, laws);
    unsafe {
        let len = slots.len();
        let len4 = len / 4 * 4;
        let (owner, js) = (&owner[slots.clone()], &js[slots.clone()]);
        let shear = &mut shear[..len];
        let (terms, n_terms, term_own, term_partner) = sink.parts();
        assert!(term_own.len() == len && term_partner.len() == len);
        // The partner's term: x and y negated.
        let flip = _mm256_set_pd(0.0, 0.0, -0.0, -0.0);
        let (state, spin) = (packed.state.as_ptr(), packed.spin.as_ptr());
        let zero = _mm256_setzero_pd();
        let (k_n, damping) = (_mm256_set1_pd(k_n), _mm256_set1_pd(gamma_n));
        let (k_t, minus_k_t, mu_over_k_t) = (
            _mm256_set1_pd(k_t),
            _mm256_set1_pd(-k_t),
            _mm256_set1_pd(mu / k_t),
        );
        let (mu, dt4) = (_mm256_set1_pd(mu), _mm256_set1_pd(dt));
        let one = _mm256_set1_pd(1.0);
        let (half, minus_half) = (_mm256_set1_pd(0.5), _mm256_set1_pd(-0.5));
        let sign_bit = _mm256_set1_pd(-0.0);
        let mut skipped = 0u64;
        for s in (0..len4).step_by(4) {
            // SAFETY: s + 4 ≤ len4 ≤ len, the length of every per-slot slice here; grain
            // indices are in bounds of `packed` and `resting` (this function's contract).
            unsafe {
                let i = lanes(|l| *owner.get_unchecked(s + l) as usize);
                let j = lanes(|l| *js.get_unchecked(s + l) as usize);
                // Slots between two resting grains keep their values (see pair_slots).
                let (both, n_both) = match resting {
                    Some(r) => {
                        let b = lanes(|l| *r.get_unchecked(i[l]) && *r.get_unchecked(j[l]));
                        let m = lanes(|l| -(b[l] as i64));
                        let mask = _mm256_castsi256_pd(_mm256_set_epi64x(m[3], m[2], m[1], m[0]));
                        (mask, b.iter().filter(|&&v| v).count() as u64)
                    }
                    None => (zero, 0),
                };
                skipped += n_both;
                if n_both == 4 {
                    // A quasistatic pillar's resting grains come in runs (slots are in
                    // owner order): whole groups are common there.
                    continue;
                }
                let [xi, yi, vxi, vyi, wi, ri] = load_grains(state, spin, i);
                let [xj, yj, vxj, vyj, wj, rj] = load_grains(state, spin, j);
                let (dx, dy) = (_mm256_sub_pd(xi, xj), _mm256_sub_pd(yi, yj));
                let rs = _mm256_add_pd(ri, rj);
                let r2 = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
                // "Not apart" (unordered: a NaN separation goes the contact way, as in the
                // scalar code).
                let touch = _mm256_cmp_pd::<_CMP_NGE_UQ>(r2, _mm256_mul_pd(rs, rs));
                let dist = _mm256_sqrt_pd(r2);
                let inv_dist = _mm256_div_pd(one, dist);
                let (nx, ny) = (_mm256_mul_pd(dx, inv_dist), _mm256_mul_pd(dy, inv_dist));
                let (dvx, dvy) = (_mm256_sub_pd(vxi, vxj), _mm256_sub_pd(vyi, vyj));
                // Hooke::force, clipped at zero.
                let vn = _mm256_add_pd(_mm256_mul_pd(dvx, nx), _mm256_mul_pd(dvy, ny));
                let f = _mm256_sub_pd(
                    _mm256_mul_pd(k_n, _mm256_sub_pd(rs, dist)),
                    _mm256_mul_pd(damping, vn),
                );
                let f_n = _mm256_and_pd(f, _mm256_cmp_pd::<_CMP_GT_OQ>(f, zero));
                // CundallStrack::force.
                let vt = _mm256_sub_pd(
                    _mm256_sub_pd(_mm256_mul_pd(dvy, nx), _mm256_mul_pd(dvx, ny)),
                    _mm256_mul_pd(_mm256_mul_pd(half, dist), _mm256_add_pd(wi, wj)),
                );
                let old_s = _mm256_loadu_pd(shear.as_ptr().add(s));
                let u = _mm256_add_pd(old_s, _mm256_mul_pd(vt, dt4));
                let f_max = _mm256_mul_pd(mu, f_n);
                let slide = _mm256_cmp_pd::<_CMP_GT_OQ>(_mm256_mul_pd(k_t, abs4(u)), f_max);
                let held = _mm256_or_pd(
                    abs4(_mm256_mul_pd(f_n, mu_over_k_t)),
                    _mm256_and_pd(u, sign_bit),
                );
                let u = pick4(slide, held, u);
                let f_t = _mm256_mul_pd(minus_k_t, u);
                // Separated pairs: zeros; resting pairs: last step's values.
                let keep = |v: __m256d| _mm256_and_pd(v, touch);
                let new_s = pick4(both, old_s, keep(u));
                _mm256_storeu_pd(shear.as_mut_ptr().add(s), new_s);
                let f_x = keep(_mm256_sub_pd(
                    _mm256_mul_pd(f_n, nx),
                    _mm256_mul_pd(f_t, ny),
                ));
                let f_y = keep(_mm256_add_pd(
                    _mm256_mul_pd(f_n, ny),
                    _mm256_mul_pd(f_t, nx),
                ));
                let t = keep(_mm256_mul_pd(_mm256_mul_pd(minus_half, dist), f_t));
                let (o0, o1, o2, o3) = transpose(f_x, f_y, t, zero);
                // Both terms of each slot, but for slots between resting grains (theirs
                // keep last step's values).
                let keep_old = _mm256_movemask_pd(both);
                for (l, v) in [o0, o1, o2, o3].into_iter().enumerate() {
                    if keep_old >> l & 1 == 1 {
                        continue;
                    }
                    let (a, b) = (
                        *term_own.get_unchecked(s + l) as usize,
                        *term_partner.get_unchecked(s + l) as usize,
                    );
                    debug_assert!(a < n_terms && b < n_terms);
                    _mm256_store_pd((*terms.add(a)).0.as_mut_ptr(), v);
                    _mm256_store_pd((*terms.add(b)).0.as_mut_ptr(), _mm256_xor_pd(v, flip));
                }
            }
        }
        for s in len4..len {
            let (i, j) = (owner[s] as usize, js[s] as usize);
            if resting.is_some_and(|r| r[i] && r[j]) {
                skipped += 1;
                continue;
            }
            let mut force = Quad::default();
            slot_contact(i, j, &g, &mut shear[s], &mut force, (law, dt));
            sink.put(s, force);
        }
        skipped
    }
}
/// As [`crate::dem::pillar::kernels::kick_drift_scalar`] (same arguments, same results).
///
/// # Safety
/// The processor must have AVX2; every slice of `d`, `inp` (the references when
/// `refs_ok`), `state` and `spin` has length `d.x.len()` (the dispatcher asserts it).
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments, unused_unsafe)]
pub(crate) unsafe fn kick_drift(
    dt: f64,
    d: Drift,
    inp: &DriftInputs,
    refs_ok: bool,
    state: &mut [Quad],
    spin: &mut [Pos],
) -> f64 {
    unsafe {
        let n = d.x.len();
        let n4 = n / 4 * 4;
        let zero = _mm256_setzero_pd();
        let (half_dt, dt4) = (_mm256_set1_pd(0.5 * dt), _mm256_set1_pd(dt));
        let mut moved2 = zero;
        for i in (0..n4).step_by(4) {
            // SAFETY: i + 4 ≤ n4 ≤ n, every slice's length (this function's contract).
            unsafe {
                let (v_x, v_y, a_x, a_y) = (ld(d.vx, i), ld(d.vy, i), ld(inp.ax, i), ld(inp.ay, i));
                let w = ld(inp.omega, i);
                let eq = |v: __m256d| _mm256_cmp_pd::<_CMP_EQ_OQ>(v, zero);
                let rest = _mm256_and_pd(
                    _mm256_and_pd(
                        _mm256_and_pd(eq(v_x), eq(v_y)),
                        _mm256_and_pd(eq(a_x), eq(a_y)),
                    ),
                    eq(w),
                );
                let bits = _mm256_movemask_pd(rest);
                for l in 0..4 {
                    *d.resting.get_unchecked_mut(i + l) = bits >> l & 1 == 1;
                }
                let v_x = _mm256_add_pd(v_x, _mm256_mul_pd(half_dt, a_x));
                let v_y = _mm256_add_pd(v_y, _mm256_mul_pd(half_dt, a_y));
                let x = _mm256_add_pd(ld(d.x, i), _mm256_mul_pd(dt4, v_x));
                let y = _mm256_add_pd(ld(d.y, i), _mm256_mul_pd(dt4, v_y));
                st(d.vx, i, v_x);
                st(d.vy, i, v_y);
                st(d.x, i, x);
                st(d.y, i, y);
                st(
                    d.theta,
                    i,
                    _mm256_add_pd(ld(d.theta, i), _mm256_mul_pd(dt4, w)),
                );
                let (q0, q1, q2, q3) = transpose(x, y, v_x, v_y);
                let out = state.as_mut_ptr().add(i);
                for (l, q) in [q0, q1, q2, q3].into_iter().enumerate() {
                    _mm256_store_pd((*out.add(l)).0.as_mut_ptr(), q);
                }
                let r = ld(inp.radius, i);
                let (w02, w13) = (_mm256_unpacklo_pd(w, r), _mm256_unpackhi_pd(w, r));
                let sp = spin.as_mut_ptr().add(i);
                _mm_store_pd((*sp).0.as_mut_ptr(), _mm256_castpd256_pd128(w02));
                _mm_store_pd((*sp.add(1)).0.as_mut_ptr(), _mm256_castpd256_pd128(w13));
                _mm_store_pd((*sp.add(2)).0.as_mut_ptr(), _mm256_extractf128_pd::<1>(w02));
                _mm_store_pd((*sp.add(3)).0.as_mut_ptr(), _mm256_extractf128_pd::<1>(w13));
                if refs_ok {
                    let ex = _mm256_sub_pd(x, ld(inp.x_ref, i));
                    let ey = _mm256_sub_pd(y, ld(inp.y_ref, i));
                    let e2 = _mm256_add_pd(_mm256_mul_pd(ex, ex), _mm256_mul_pd(ey, ey));
                    // On a NaN `max` returns its second operand: the running maximum, as
                    // f64::max ignores a NaN.
                    moved2 = _mm256_max_pd(e2, moved2);
                }
            }
        }
        let mut lanes = [0.0; 4];
        // SAFETY: four lanes into four doubles.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), moved2) };
        // Maxima of numbers are exact, so any order gives the scalar loop's value.
        let m = lanes.iter().fold(0.0f64, |a, &b| a.max(b));
        if n4 == n {
            return m;
        }
        let r = n4..n;
        let tail = Drift {
            x: &mut d.x[r.clone()],
            y: &mut d.y[r.clone()],
            theta: &mut d.theta[r.clone()],
            vx: &mut d.vx[r.clone()],
            vy: &mut d.vy[r.clone()],
            resting: &mut d.resting[r.clone()],
        };
        let refs = if refs_ok { r.clone() } else { 0..0 };
        let inputs = DriftInputs {
            ax: &inp.ax[r.clone()],
            ay: &inp.ay[r.clone()],
            omega: &inp.omega[r.clone()],
            radius: &inp.radius[r.clone()],
            x_ref: &inp.x_ref[refs.clone()],
            y_ref: &inp.y_ref[refs],
        };
        let t = kick_drift_scalar(
            dt,
            tail,
            &inputs,
            refs_ok,
            &mut state[r.clone()],
            &mut spin[r],
        );
        m.max(t)
    }
}
