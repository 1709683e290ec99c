//! The pillar's per-grain contact sums (`pillar::gather::sum_terms`, phase 3a) with AVX2
//! intrinsics: the same numbers. No contact law here: it adds terms. Compiled for AVX2
//! only: an AVX-512 build of the pillar's kernels gained 0–2.5 % (docs/performance.md),
//! under the 5 % a second copy must earn.

use crate::dem::backend::avx2::transpose;
use crate::dem::backend::simd::Quad;
use std::arch::x86_64::*;

/// As [`crate::dem::pillar::gather::sum_terms`] (same results): four grains at a time, one
/// vector add per place and grain, the four sums transposed into f_x, f_y, T.
///
/// # Safety
/// The processor must have AVX2; `t` holds `w` places per grain of `fx`, and `fy`,
/// `tq` and `frozen` are as long as `fx`.
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments, unused_unsafe)]
pub(crate) unsafe fn sum_terms(
    w: usize,
    t: &[Quad],
    frozen: Option<&[bool]>,
    out: (&mut [f64], &mut [f64], &mut [f64]),
) {
    // The common widths as constants: each sum unrolled, no branch inside.
    unsafe {
        match w {
            0 => sums_x4::<0>(t, frozen, out),
            1 => sums_x4::<1>(t, frozen, out),
            2 => sums_x4::<2>(t, frozen, out),
            3 => sums_x4::<3>(t, frozen, out),
            4 => sums_x4::<4>(t, frozen, out),
            5 => sums_x4::<5>(t, frozen, out),
            6 => sums_x4::<6>(t, frozen, out),
            7 => sums_x4::<7>(t, frozen, out),
            8 => sums_x4::<8>(t, frozen, out),
            _ => crate::dem::pillar::gather::sum_terms(w, t, frozen, out),
        }
    }
}
/// # Safety
/// AVX2 present; as `sum_terms` with `w = W`. (Compiled into each entry point.)
#[inline(always)]
unsafe fn sums_x4<const W: usize>(
    t: &[Quad],
    frozen: Option<&[bool]>,
    (fx, fy, tq): (&mut [f64], &mut [f64], &mut [f64]),
) {
    let n = fx.len();
    assert!(t.len() == n * W && fy.len() == n && tq.len() == n);
    assert!(frozen.is_none_or(|f| f.len() == n));
    let n4 = n / 4 * 4;
    unsafe {
        let p = t.as_ptr();
        for q in (0..n4).step_by(4) {
            // Frozen grains keep their sums: a whole frozen group is skipped, a mixed
            // one stored lane by lane.
            let fz = frozen.map_or([false; 4], |f| [f[q], f[q + 1], f[q + 2], f[q + 3]]);
            if fz == [true; 4] {
                continue;
            }
            // Four running sums (no closure: one stayed out of line).
            let mut s = [_mm256_setzero_pd(); 4];
            let g = p.add(q * W);
            for m in 0..W {
                s[0] = _mm256_add_pd(s[0], _mm256_load_pd((*g.add(m)).0.as_ptr()));
                s[1] = _mm256_add_pd(s[1], _mm256_load_pd((*g.add(W + m)).0.as_ptr()));
                s[2] = _mm256_add_pd(s[2], _mm256_load_pd((*g.add(2 * W + m)).0.as_ptr()));
                s[3] = _mm256_add_pd(s[3], _mm256_load_pd((*g.add(3 * W + m)).0.as_ptr()));
            }
            let (x, y, z, _) = transpose(s[0], s[1], s[2], s[3]);
            if fz == [false; 4] {
                _mm256_storeu_pd(fx.as_mut_ptr().add(q), x);
                _mm256_storeu_pd(fy.as_mut_ptr().add(q), y);
                _mm256_storeu_pd(tq.as_mut_ptr().add(q), z);
                continue;
            }
            let mut v = [[0.0; 4]; 3];
            for (o, src) in v.iter_mut().zip([x, y, z]) {
                _mm256_storeu_pd(o.as_mut_ptr(), src);
            }
            for l in (0..4).filter(|&l| !fz[l]) {
                (fx[q + l], fy[q + l], tq[q + l]) = (v[0][l], v[1][l], v[2][l]);
            }
        }
        let rest = (&mut fx[n4..], &mut fy[n4..], &mut tq[n4..]);
        crate::dem::pillar::gather::sum_terms(W, &t[n4 * W..], frozen.map(|f| &f[n4..]), rest);
    }
}
