//! The sheared disks' force evaluation (vagberg-sheared-disks Eqs. 1–3, 5–7, harmonic
//! α = 2) written with AVX2 intrinsics, four pair slots at a time.
//!
//! Why by hand: per slot the kernel needs twelve numbers of two grains. Compiled from
//! scalar code they arrive as twelve loads and nine inserts per four slots and field;
//! here each grain's (x, y) and (v_x, v_y, ω, R) are packed side by side, so one load
//! fetches a grain's record and a 4 × 4 transpose turns four records into four field
//! vectors. The forces go back the same way: one vector add per grain and slot into
//! packed (f_x, f_y, T, 0) records.
//!
//! Same forces as the straight loop ([`crate::dem::shear::pairs::pair_loop`]) bit for bit, so
//! the same trajectories: every lane does the scalar code's operations in its order (no
//! fused multiply-add), masked-off lanes add ±0.0 (which leaves every sum as it is: a sum
//! that starts at +0.0 never becomes −0.0), and each grain's force is summed in slot
//! order. A test holds it to that.

use crate::dem::backend::avx2::{neg4, transpose};
use crate::dem::shear::integrate::{Pos, Quad};
use crate::dem::shear::near::{DONE_MIN, Done, History, Slots, contact_events};
use crate::dem::shear::pairs::PairParams;
use crate::dem::shear::params::Collisions;
use std::arch::x86_64::*;

crate::avx2_entry_point! {
/// As `shear_slots::evaluate` (α = 2 only), on a state packed grain by grain:
/// the force and torque sums (f_x, f_y, T, 0) into `acc` (overwritten), with `TRACK`
/// the history and collision counts.
///
/// # Safety
/// The processor must have AVX2. `slots` must come from `Slots::sync` for these grains
/// (indices < n, tables padded to a multiple of four), and `pos` and `vel` must hold n
/// grains, as `shear_slots` (the one caller) asserts. `zeroed`: `acc` already holds
/// zeros (for n grains; else it is refilled). `done`: see [`Done`], for the grains of
/// `window` alone (0..n, or a thread's share, whose sums are whole only when `slots`
/// holds every slot reaching them; what lands outside the window is never handed on).
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn evaluate<const TRACK: bool>(
    pos: &[Pos],
    vel: &[Quad],
    slots: &Slots,
    acc: &mut Vec<Quad>,
    zeroed: bool,
    hist: &mut History,
    pp: &PairParams,
    coll: &mut Collisions,
    window: std::ops::Range<usize>,
    done: Done,
) {
    let n = slots.n;
    debug_assert!(pp.alpha == 2.0 && hist.near.len() >= slots.len());
    debug_assert!(pos.len() == n && vel.len() == n && window.end <= n);
    debug_assert!(
        !zeroed || acc.len() != n || acc[window.clone()].iter().all(|q| q.0 == [0.0; 4])
    );
    if !(zeroed && acc.len() == n) {
        acc.clear();
        acc.resize(n, Quad::default());
    }
    // SAFETY: AVX2 is present (this function's contract); `Slots::sync` checked every
    // index against n and padded the tables to a multiple of four.
    unsafe {
        use crate::dem::backend::shear_avx512::slots_x8;
        // Eight slots at a time where the processor has AVX-512 (the level is Avx512
        // only then); the same numbers.
        let wide = crate::dem::backend::simd::level() == crate::dem::backend::simd::Level::Avx512;
        match (wide, pp.cdrot) {
            (true, true) => slots_x8::<TRACK, true>(pos, vel, acc, slots, hist, pp, coll, window, done),
            (true, false) => {
                slots_x8::<TRACK, false>(pos, vel, acc, slots, hist, pp, coll, window, done)
            }
            (false, true) => {
                slots_x4::<TRACK, true>(pos, vel, acc, slots, hist, pp, coll, window, done)
            }
            (false, false) => {
                slots_x4::<TRACK, false>(pos, vel, acc, slots, hist, pp, coll, window, done)
            }
        }
    }
}
}

/// Nearest integer, ties to even, four lanes: the same value as `geom::rint` (which
/// keeps a zero's sign as this does) for every |v| < 2^51, in one instruction.
#[inline]
#[target_feature(enable = "avx2")]
fn rint4(v: __m256d) -> __m256d {
    _mm256_round_pd::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(v)
}

/// The records of grains g[0..4] as four field vectors: halves of records loaded
/// straight into the upper lanes, then one unpack per field (cheaper than a full 4 × 4
/// transpose of whole records, whose cross-lane shuffles compete for one port).
///
/// # Safety
/// Every g[l] in bounds of the array behind `p`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn gather_quads(p: *const Quad, g: [usize; 4]) -> (__m256d, __m256d, __m256d, __m256d) {
    unsafe {
        let half = |l: usize, h: usize| _mm_load_pd((*p.add(g[l])).0.as_ptr().add(2 * h));
        let pair = |a: usize, b: usize, h: usize| {
            _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(half(a, h)), half(b, h))
        };
        // [f0 f1 of grains 0, 2] and [… of grains 1, 3], for the halves h = 0, 1.
        let (lo02, lo13) = (pair(0, 2, 0), pair(1, 3, 0));
        let (hi02, hi13) = (pair(0, 2, 1), pair(1, 3, 1));
        (
            _mm256_unpacklo_pd(lo02, lo13),
            _mm256_unpackhi_pd(lo02, lo13),
            _mm256_unpacklo_pd(hi02, hi13),
            _mm256_unpackhi_pd(hi02, hi13),
        )
    }
}

/// The first stage's results for one group of four slots.
#[derive(Clone, Copy)]
struct Stage1 {
    i: [usize; 4],
    j: [usize; 4],
    dx: __m256d,
    dy: __m256d,
    img: __m256d,
    dist: __m256d,
    inv_dist: __m256d,
    touch: __m256d,
    mask: u32,
}

/// # Safety
/// AVX2 present; every slot index (padding included) < the arrays' length n.
/// (No target feature of its own: it is compiled into each entry point of `evaluate`.)
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn slots_x4<const TRACK: bool, const CDROT: bool>(
    pos: &[Pos],
    vel: &[Quad],
    acc: &mut [Quad],
    slots: &Slots,
    hist: &mut History,
    pp: &PairParams,
    coll: &mut Collisions,
    window: std::ops::Range<usize>,
    done: Done,
) {
    unsafe {
        let (ll, inv_l) = (_mm256_set1_pd(pp.ll), _mm256_set1_pd(pp.inv_l));
        let offset = _mm256_set1_pd(pp.offset);
        let shear_v = _mm256_set1_pd(pp.shear_v);
        let minus_kd = _mm256_set1_pd(-pp.kd);
        let one = _mm256_set1_pd(1.0);
        let zero = _mm256_setzero_pd();
        let len = slots.len();
        let (si, sj) = (slots.i.as_ptr(), slots.j.as_ptr());
        let (inv_dij_p, dij2_p) = (slots.inv_dij.as_ptr(), slots.dij2.as_ptr());
        let (n, sums) = (window.end, acc);
        let vel_all = vel;
        let (pos, vel) = (pos.as_ptr(), vel.as_ptr());
        let mut acc: *mut Quad;
        let mut dxs = [0.0f64; 4];
        let mut dys = [0.0f64; 4];
        // Stage 1: separations, contact test, history, roots. Stage 2: forces and sums.
        // Macros, not closures: a closure may stay an out-of-line call taking its
        // vectors through memory.
        macro_rules! stage1 {
            ($k:expr) => {{
                let k: usize = $k;
                let i = [0, 1, 2, 3].map(|l| *si.add(k + l) as usize);
                let j = [0, 1, 2, 3].map(|l| *sj.add(k + l) as usize);
                // Raw separations r_i − r_j, two lanes per 128-bit subtraction.
                let d = [0, 1, 2, 3].map(|l| {
                    let pi = _mm_load_pd((*pos.add(i[l])).0.as_ptr());
                    let pj = _mm_load_pd((*pos.add(j[l])).0.as_ptr());
                    _mm_sub_pd(pi, pj)
                });
                let d02 = _mm256_set_m128d(d[2], d[0]);
                let d13 = _mm256_set_m128d(d[3], d[1]);
                let dx = _mm256_unpacklo_pd(d02, d13);
                let dy = _mm256_unpackhi_pd(d02, d13);
                // Minimum image, Lees–Edwards (as Boundary::delta_image).
                let img = rint4(_mm256_mul_pd(dy, inv_l));
                let dy = _mm256_sub_pd(dy, _mm256_mul_pd(img, ll));
                let dx = _mm256_sub_pd(dx, _mm256_mul_pd(img, offset));
                let dx = _mm256_sub_pd(dx, _mm256_mul_pd(ll, rint4(_mm256_mul_pd(dx, inv_l))));
                let r2 = _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy));
                // "Not apart" (unordered: a NaN separation counts), as the straight loop.
                let touch = _mm256_cmp_pd::<_CMP_NGE_UQ>(r2, _mm256_loadu_pd(dij2_p.add(k)));
                let mask = _mm256_movemask_pd(touch) as u32;
                if TRACK {
                    // Contacts that began or ended: where the touch mask and the history
                    // (slot holds a start time) disagree; rare, so tested four at a time.
                    let held = if k + 4 <= len {
                        let h = _mm256_loadu_pd(hist.near.as_ptr().add(k));
                        _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NEQ_UQ>(h, zero)) as u32
                    } else {
                        (k..len)
                            .map(|q| ((hist.near[q] != 0.0) as u32) << (q - k))
                            .sum()
                    };
                    if held != mask {
                        let mut imgs = [0.0f64; 4];
                        _mm256_storeu_pd(dxs.as_mut_ptr(), dx);
                        _mm256_storeu_pd(dys.as_mut_ptr(), dy);
                        _mm256_storeu_pd(imgs.as_mut_ptr(), img);
                        let count = (len - k).min(4);
                        let v = (slots, vel_all, pp.shear_v);
                        contact_events(k, count, mask, (&dxs, &dys, &imgs), v, hist, pp.now, coll);
                    }
                }
                let dist = _mm256_sqrt_pd(r2);
                let inv_dist = _mm256_div_pd(one, dist);
                Stage1 {
                    i,
                    j,
                    dx,
                    dy,
                    img,
                    dist,
                    inv_dist,
                    touch,
                    mask,
                }
            }};
        }
        macro_rules! stage2 {
            ($k:expr, $g:expr) => {{
                let (k, g): (usize, &Stage1) = ($k, $g);
                let Stage1 {
                    i,
                    j,
                    dx,
                    dy,
                    img,
                    dist,
                    inv_dist,
                    touch,
                    ..
                } = *g;
                let inv_dij = _mm256_loadu_pd(inv_dij_p.add(k));
                let nx = _mm256_mul_pd(dx, inv_dist);
                let ny = _mm256_mul_pd(dy, inv_dist);
                // Eq. 2 with d_ij = R_i + R_j and k_e = 1.
                let overlap = _mm256_sub_pd(one, _mm256_mul_pd(dist, inv_dij));
                let fe = _mm256_mul_pd(overlap, inv_dij);
                let (ex, ey) = (_mm256_mul_pd(fe, nx), _mm256_mul_pd(fe, ny));
                let (vxi, vyi, wi, ri) = gather_quads(vel, i);
                let (vxj, vyj, wj, rj) = gather_quads(vel, j);
                // Relative velocity; j's image moves img·γ̇L faster along x.
                let mut dvx = _mm256_sub_pd(_mm256_sub_pd(vxi, vxj), _mm256_mul_pd(img, shear_v));
                let mut dvy = _mm256_sub_pd(vyi, vyj);
                // Moment arms s_ji = −r_ij R_i/d_ij, s_ij = r_ij R_j/d_ij.
                let (s_i, s_j) = (_mm256_mul_pd(ri, inv_dij), _mm256_mul_pd(rj, inv_dij));
                let (six, siy) = (_mm256_mul_pd(neg4(dx), s_i), _mm256_mul_pd(neg4(dy), s_i));
                let (sjx, sjy) = (_mm256_mul_pd(dx, s_j), _mm256_mul_pd(dy, s_j));
                if CDROT {
                    // v_i + ω_i ẑ×s_ji − (v_j + ω_j ẑ×s_ij), Eq. 6.
                    let tx = _mm256_add_pd(_mm256_mul_pd(neg4(wi), siy), _mm256_mul_pd(wj, sjy));
                    let ty = _mm256_sub_pd(_mm256_mul_pd(wi, six), _mm256_mul_pd(wj, sjx));
                    dvx = _mm256_add_pd(dvx, tx);
                    dvy = _mm256_add_pd(dvy, ty);
                }
                let (ddx, ddy) = (_mm256_mul_pd(minus_kd, dvx), _mm256_mul_pd(minus_kd, dvy));
                let keep = |v: __m256d| _mm256_and_pd(v, touch);
                let f_x = keep(_mm256_add_pd(ex, ddx));
                let f_y = keep(_mm256_add_pd(ey, ddy));
                // Eq. 7: torques of the dissipative force about each centre.
                let t_i = keep(_mm256_sub_pd(
                    _mm256_mul_pd(six, ddy),
                    _mm256_mul_pd(siy, ddx),
                ));
                let t_j = keep(_mm256_sub_pd(
                    _mm256_mul_pd(sjx, neg4(ddy)),
                    _mm256_mul_pd(sjy, neg4(ddx)),
                ));
                // Per slot (f_x, f_y, T_i, 0) onto i and (−f_x, −f_y, T_j, 0) onto j, in
                // slot order (f − g and f + (−g) round the same); lanes without contact
                // add ±0.0 (no change), cheaper than a branch that mispredicts.
                let on_i = transpose(f_x, f_y, t_i, zero);
                let on_j = transpose(neg4(f_x), neg4(f_y), t_j, zero);
                let on_i = [on_i.0, on_i.1, on_i.2, on_i.3];
                let on_j = [on_j.0, on_j.1, on_j.2, on_j.3];
                for l in 0..4 {
                    let a = (*acc.add(i[l])).0.as_mut_ptr();
                    _mm256_store_pd(a, _mm256_add_pd(_mm256_load_pd(a), on_i[l]));
                    let b = (*acc.add(j[l])).0.as_mut_ptr();
                    _mm256_store_pd(b, _mm256_add_pd(_mm256_load_pd(b), on_j[l]));
                }
            }};
        }
        // Stage 1 for a block of 16 groups, then stage 2 for them: the processor's
        // window then overlaps more of the groups' long chains (3 % faster than
        // alternating; the AVX-512 kernel's notes).
        const G: usize = 16;
        let mut block = [const { std::mem::MaybeUninit::<Stage1>::uninit() }; G];
        let padded = len.next_multiple_of(4);
        let mut complete = window.start;
        for k0 in (0..padded).step_by(4 * G) {
            acc = sums.as_mut_ptr();
            let groups = ((padded - k0) / 4).min(G);
            for (g, b) in block.iter_mut().enumerate().take(groups) {
                b.write(stage1!(k0 + 4 * g));
            }
            for (g, b) in block.iter().enumerate().take(groups) {
                // SAFETY: written just above (g < groups).
                let cur = b.assume_init_ref();
                if cur.mask != 0 {
                    stage2!(k0 + 4 * g, cur);
                }
            }
            // Slots are in order of i (and j > i): grains below the next slot's i are done.
            let next = k0 + 4 * G;
            let limit = if next < len {
                (*si.add(next) as usize).min(n)
            } else {
                n
            };
            if limit >= complete + DONE_MIN {
                done(complete..limit, &mut sums[complete..limit], slots);
                complete = limit;
            }
        }
        if complete < n {
            done(complete..n, &mut sums[complete..n], slots);
        }
    }
}
