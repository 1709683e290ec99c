//! The sheared disks' force kernel (vagberg-sheared-disks Eqs. 1–3, 5–7, harmonic
//! α = 2) with 512-bit vectors: eight pair slots at a time, for processors with
//! AVX-512 F/VL/DQ. Otherwise as `shear_avx2` (which calls this one): grain records loaded whole and
//! transposed in registers, each lane doing the straight loop's operations in its order
//! (no fused multiply-add), masked-off lanes adding +0.0 or −0.0, and each grain's
//! force summed in slot order, so the same numbers bit for bit (tested).
//!
//! Why: a slot's chain of work (separation, image, square root, division, forces, sums)
//! is long, and the out-of-order window overlaps few of them. Eight slots per
//! instruction, and the separations of 64 slots computed before their forces (two
//! passes over a block), overlap more: the kernel alone 8.1 → 6.5 ns per grain and
//! evaluation at N = 1024 on the project's Intel machine.

use crate::dem::shear::integrate::{Pos, Quad};
use crate::dem::shear::near::{History, Slots};
use crate::dem::shear::pairs::PairParams;
use crate::dem::shear::params::Collisions;
use std::arch::x86_64::*;

/// `[f(0), …, f(7)]`, always inlined.
#[inline(always)]
fn lanes8<T>(mut f: impl FnMut(usize) -> T) -> [T; 8] {
    [f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7)]
}

/// Lane indices for `_mm512_permutex2var_pd` (8.. pick from the second operand).
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
fn idx([a, b, c, d, e, f, g, h]: [i64; 8]) -> __m512i {
    _mm512_set_epi64(h, g, f, e, d, c, b, a)
}

/// Nearest integer, ties to even (as `geom::rint` and `shear_avx2::rint4`).
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
fn rint8(v: __m512d) -> __m512d {
    _mm512_roundscale_pd::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(v)
}

/// −v, eight lanes.
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
fn neg8(v: __m512d) -> __m512d {
    _mm512_xor_pd(v, _mm512_set1_pd(-0.0))
}

/// The records (v_x, v_y, ω, R) of grains g[0..8] as four field vectors.
///
/// # Safety
/// Every g[l] in bounds of the array behind `p`.
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
unsafe fn gather8(p: *const Quad, g: [usize; 8]) -> [__m512d; 4] {
    unsafe {
        let q = |l: usize| _mm256_load_pd((*p.add(g[l])).0.as_ptr());
        let z = |a: usize, b: usize| _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(q(a)), q(b));
        // Records 0|4, 1|5, 2|6, 3|7 side by side; then per 128-bit lane a 4 × 4 transpose.
        let (z0, z1, z2, z3) = (z(0, 4), z(1, 5), z(2, 6), z(3, 7));
        let (t0, t1) = (_mm512_unpacklo_pd(z0, z1), _mm512_unpackhi_pd(z0, z1));
        let (t2, t3) = (_mm512_unpacklo_pd(z2, z3), _mm512_unpackhi_pd(z2, z3));
        let (even, odd) = (
            idx([0, 1, 8, 9, 4, 5, 12, 13]),
            idx([2, 3, 10, 11, 6, 7, 14, 15]),
        );
        [
            _mm512_permutex2var_pd(t0, even, t2),
            _mm512_permutex2var_pd(t1, even, t3),
            _mm512_permutex2var_pd(t0, odd, t2),
            _mm512_permutex2var_pd(t1, odd, t3),
        ]
    }
}

/// Eight records (a_l, b_l, c_l, 0), slot l's in lane l: returned as 256-bit vectors.
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
fn records8(a: __m512d, b: __m512d, c: __m512d) -> [__m256d; 8] {
    {
        let zero = _mm512_setzero_pd();
        let (u0, u1) = (_mm512_unpacklo_pd(a, b), _mm512_unpackhi_pd(a, b));
        let (u2, u3) = (_mm512_unpacklo_pd(c, zero), _mm512_unpackhi_pd(c, zero));
        let (lo, hi) = (
            idx([0, 1, 8, 9, 2, 3, 10, 11]),
            idx([4, 5, 12, 13, 6, 7, 14, 15]),
        );
        // Slots (0, 2), (1, 3), (4, 6), (5, 7), one per 256-bit half.
        let q02 = _mm512_permutex2var_pd(u0, lo, u2);
        let q13 = _mm512_permutex2var_pd(u1, lo, u3);
        let q46 = _mm512_permutex2var_pd(u0, hi, u2);
        let q57 = _mm512_permutex2var_pd(u1, hi, u3);
        let l = |q| _mm512_castpd512_pd256(q);
        let h = |q| _mm512_extractf64x4_pd::<1>(q);
        [
            l(q02),
            l(q13),
            h(q02),
            h(q13),
            l(q46),
            l(q57),
            h(q46),
            h(q57),
        ]
    }
}

/// Groups of eight slots per block: the separations of a block's groups are all
/// computed (pass A) before any of its forces (pass B). Interleaved in one loop, each
/// group's chain (separations, image, root, division, forces, sums) was longer than
/// the processor's window could overlap: two passes measured 14 % faster.
const GROUPS: usize = 8;

/// Pass A's results for one block, per group.
struct Seps {
    dx: [__m512d; GROUPS],
    dy: [__m512d; GROUPS],
    img: [__m512d; GROUPS],
    r2: [__m512d; GROUPS],
    touch: [__mmask8; GROUPS],
}

/// Loop invariants of the kernel, broadcast.
struct Consts {
    ll: __m512d,
    inv_l: __m512d,
    offset: __m512d,
    shear_v: __m512d,
    minus_kd: __m512d,
    one: __m512d,
}

/// Grain indices i and j of the eight slots from k on.
///
/// # Safety
/// `k + 8 <=` the slot tables' (padded) length.
#[inline(always)]
unsafe fn pairs8(slots: &Slots, k: usize) -> ([usize; 8], [usize; 8]) {
    debug_assert!(k + 8 <= slots.i.len() && k + 8 <= slots.j.len());
    let (si, sj) = (slots.i.as_ptr(), slots.j.as_ptr());
    // SAFETY: this function's contract.
    unsafe {
        (
            lanes8(|l| *si.add(k + l) as usize),
            lanes8(|l| *sj.add(k + l) as usize),
        )
    }
}

/// Pass A for the eight slots from k on: minimum-image separation (as
/// `Boundary::delta_image`), the y image index, r² and the contact test ("not apart",
/// so a NaN separation counts, as the straight loop); with `TRACK`, the contact events.
///
/// # Safety
/// As [`slots_x8`], and `k + 8 <=` the tables' padded length.
#[allow(clippy::too_many_arguments)]
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
unsafe fn separations8<const TRACK: bool>(
    pos: *const Pos,
    vel: &[Quad],
    slots: &Slots,
    k: usize,
    c: &Consts,
    hist: &mut History,
    pp: &PairParams,
    coll: &mut Collisions,
) -> (__m512d, __m512d, __m512d, __m512d, __mmask8) {
    let (add, sub, mul) = (_mm512_add_pd, _mm512_sub_pd, _mm512_mul_pd);
    // SAFETY: indices < n and k + 8 within the padded tables (this function's contract).
    unsafe {
        let (i, j) = pairs8(slots, k);
        // Raw separations r_i − r_j, one 128-bit subtraction per slot, then the eight
        // (dx, dy) pairs split into a dx and a dy vector.
        let d = lanes8(|l| {
            let pi = _mm_load_pd((*pos.add(i[l])).0.as_ptr());
            _mm_sub_pd(pi, _mm_load_pd((*pos.add(j[l])).0.as_ptr()))
        });
        let half = |a: usize| {
            let lo = _mm256_set_m128d(d[a + 1], d[a]);
            let hi = _mm256_set_m128d(d[a + 3], d[a + 2]);
            _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(lo), hi)
        };
        let (z0, z1) = (half(0), half(4));
        let dx = _mm512_permutex2var_pd(z0, idx([0, 2, 4, 6, 8, 10, 12, 14]), z1);
        let dy = _mm512_permutex2var_pd(z0, idx([1, 3, 5, 7, 9, 11, 13, 15]), z1);
        let img = rint8(mul(dy, c.inv_l));
        let dy = sub(dy, mul(img, c.ll));
        let dx = sub(dx, mul(img, c.offset));
        let dx = sub(dx, mul(c.ll, rint8(mul(dx, c.inv_l))));
        let r2 = add(mul(dx, dx), mul(dy, dy));
        let dij2 = _mm512_loadu_pd(slots.dij2.as_ptr().add(k));
        let touch = _mm512_cmp_pd_mask::<_CMP_NGE_UQ>(r2, dij2);
        if TRACK {
            // Padding slots hold no history and never touch: eight lanes compare.
            let h = _mm512_loadu_pd(hist.near.as_ptr().add(k));
            let held = _mm512_cmp_pd_mask::<_CMP_NEQ_UQ>(h, _mm512_setzero_pd());
            if held != touch {
                let (mut dxs, mut dys, mut imgs) = ([0.0f64; 8], [0.0f64; 8], [0.0f64; 8]);
                _mm512_storeu_pd(dxs.as_mut_ptr(), dx);
                _mm512_storeu_pd(dys.as_mut_ptr(), dy);
                _mm512_storeu_pd(imgs.as_mut_ptr(), img);
                let count = (slots.len() - k).min(8);
                let t = touch as u32;
                crate::dem::shear::near::contact_events(
                    k,
                    count,
                    t,
                    (&dxs, &dys, &imgs),
                    (slots, vel, pp.shear_v),
                    hist,
                    pp.now,
                    coll,
                );
            }
        }
        (dx, dy, img, r2, touch)
    }
}

/// Pass B for the eight slots from k on, given pass A's results: the pair forces
/// (Eqs. 2, 5–7) added into `acc`, (f_x, f_y, T_i, 0) onto i and (−f_x, −f_y, T_j, 0)
/// onto j, slot by slot.
///
/// # Safety
/// As [`slots_x8`], and `k + 8 <=` the tables' padded length.
#[allow(clippy::too_many_arguments)]
#[inline]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
unsafe fn forces8<const CDROT: bool>(
    vel: *const Quad,
    acc: *mut Quad,
    slots: &Slots,
    k: usize,
    c: &Consts,
    (dx, dy, img, r2, touch): (__m512d, __m512d, __m512d, __m512d, __mmask8),
) {
    let (add, sub, mul) = (_mm512_add_pd, _mm512_sub_pd, _mm512_mul_pd);
    // SAFETY: indices < n and k + 8 within the padded tables (this function's contract).
    unsafe {
        let (i, j) = pairs8(slots, k);
        let dist = _mm512_sqrt_pd(r2);
        let inv_dist = _mm512_div_pd(c.one, dist);
        let inv_dij = _mm512_loadu_pd(slots.inv_dij.as_ptr().add(k));
        let (nx, ny) = (mul(dx, inv_dist), mul(dy, inv_dist));
        // Eq. 2 with d_ij = R_i + R_j and k_e = 1.
        let overlap = sub(c.one, mul(dist, inv_dij));
        let fe = mul(overlap, inv_dij);
        let (ex, ey) = (mul(fe, nx), mul(fe, ny));
        let [vxi, vyi, wi, ri] = gather8(vel, i);
        let [vxj, vyj, wj, rj] = gather8(vel, j);
        // Relative velocity; j's image moves img·γ̇L faster along x.
        let mut dvx = sub(sub(vxi, vxj), mul(img, c.shear_v));
        let mut dvy = sub(vyi, vyj);
        // Moment arms s_ji = −r_ij R_i/d_ij, s_ij = r_ij R_j/d_ij.
        let (s_i, s_j) = (mul(ri, inv_dij), mul(rj, inv_dij));
        let (six, siy) = (mul(neg8(dx), s_i), mul(neg8(dy), s_i));
        let (sjx, sjy) = (mul(dx, s_j), mul(dy, s_j));
        if CDROT {
            // v_i + ω_i ẑ×s_ji − (v_j + ω_j ẑ×s_ij), Eq. 6.
            dvx = add(dvx, add(mul(neg8(wi), siy), mul(wj, sjy)));
            dvy = add(dvy, sub(mul(wi, six), mul(wj, sjx)));
        }
        let (ddx, ddy) = (mul(c.minus_kd, dvx), mul(c.minus_kd, dvy));
        // Lanes without contact give +0.0, as the AND with the mask in shear_avx2.
        let keep = |v: __m512d| _mm512_maskz_mov_pd(touch, v);
        let f_x = keep(add(ex, ddx));
        let f_y = keep(add(ey, ddy));
        // Eq. 7: torques of the dissipative force about each centre.
        let t_i = keep(sub(mul(six, ddy), mul(siy, ddx)));
        let t_j = keep(sub(mul(sjx, neg8(ddy)), mul(sjy, neg8(ddx))));
        let on_i = records8(f_x, f_y, t_i);
        let on_j = records8(neg8(f_x), neg8(f_y), t_j);
        for l in 0..8 {
            let a = (*acc.add(i[l])).0.as_mut_ptr();
            _mm256_store_pd(a, _mm256_add_pd(_mm256_load_pd(a), on_i[l]));
            let b = (*acc.add(j[l])).0.as_mut_ptr();
            _mm256_store_pd(b, _mm256_add_pd(_mm256_load_pd(b), on_j[l]));
        }
    }
}

/// As `shear_avx2::slots_x4`, eight slots at a time: the force sums into `acc` (zeroed
/// by the caller), with `TRACK` the history and collision counts; `done` as the sums of
/// each block's grains are complete.
///
/// # Safety
/// The processor must have AVX-512 F, VL and DQ; every slot index (padding included,
/// `Slots` pads to a multiple of eight) < n = the length of `pos`, `vel` and `acc`.
#[allow(clippy::too_many_arguments)]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq")]
pub(crate) unsafe fn slots_x8<const TRACK: bool, const CDROT: bool>(
    pos: &[Pos],
    vel: &[Quad],
    acc: &mut [Quad],
    slots: &Slots,
    hist: &mut History,
    pp: &PairParams,
    coll: &mut Collisions,
    window: std::ops::Range<usize>,
    done: crate::dem::shear::near::Done,
) {
    let c = Consts {
        ll: _mm512_set1_pd(pp.ll),
        inv_l: _mm512_set1_pd(pp.inv_l),
        offset: _mm512_set1_pd(pp.offset),
        shear_v: _mm512_set1_pd(pp.shear_v),
        minus_kd: _mm512_set1_pd(-pp.kd),
        one: _mm512_set1_pd(1.0),
    };
    let (n, sums) = (window.end, acc);
    let vel_all = vel;
    let (pos, vel) = (pos.as_ptr(), vel.as_ptr());
    let zero = _mm512_setzero_pd();
    let mut a = Seps {
        dx: [zero; GROUPS],
        dy: [zero; GROUPS],
        img: [zero; GROUPS],
        r2: [zero; GROUPS],
        touch: [0; GROUPS],
    };
    let len = slots.len();
    let padded = len.next_multiple_of(8);
    let mut complete = window.start;
    for k0 in (0..padded).step_by(8 * GROUPS) {
        let acc = sums.as_mut_ptr();
        let groups = ((padded - k0) / 8).min(GROUPS);
        for g in 0..groups {
            // SAFETY: k0 + 8 g + 8 <= padded, and this function's contract.
            let s = unsafe {
                separations8::<TRACK>(pos, vel_all, slots, k0 + 8 * g, &c, hist, pp, coll)
            };
            (a.dx[g], a.dy[g], a.img[g], a.r2[g], a.touch[g]) = s;
        }
        for g in 0..groups {
            if a.touch[g] != 0 {
                let s = (a.dx[g], a.dy[g], a.img[g], a.r2[g], a.touch[g]);
                // SAFETY: as above.
                unsafe { forces8::<CDROT>(vel, acc, slots, k0 + 8 * g, &c, s) };
            }
        }
        // Slots are in order of i (and j > i): grains below the next slot's i are done.
        let next = k0 + 8 * GROUPS;
        let limit = if next < len {
            (slots.i[next] as usize).min(n)
        } else {
            n
        };
        if limit >= complete + crate::dem::shear::near::DONE_MIN {
            done(complete..limit, &mut sums[complete..limit], slots);
            complete = limit;
        }
    }
    if complete < n {
        done(complete..n, &mut sums[complete..n], slots);
    }
}
