//! Lane helpers shared by the AVX2 kernels (`shear_avx2`, `pillar_avx2`): exact
//! operations only (sign flips, selects, shuffles), so kernels built from them round as
//! the scalar code does.

use std::arch::x86_64::*;

/// |v|, four lanes (the sign bit cleared, as `f64::abs`).
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn abs4(v: __m256d) -> __m256d {
    _mm256_andnot_pd(_mm256_set1_pd(-0.0), v)
}

/// −v, four lanes.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn neg4(v: __m256d) -> __m256d {
    _mm256_xor_pd(v, _mm256_set1_pd(-0.0))
}

/// `a` where `m`, else `b` (as `law::pick`).
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn pick4(m: __m256d, a: __m256d, b: __m256d) -> __m256d {
    _mm256_blendv_pd(b, a, m)
}

/// Rows (a, b, c, d) to columns: returns ([a0 b0 c0 d0], [a1 …], [a2 …], [a3 …]).
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn transpose(
    a: __m256d,
    b: __m256d,
    c: __m256d,
    d: __m256d,
) -> (__m256d, __m256d, __m256d, __m256d) {
    let t0 = _mm256_unpacklo_pd(a, b);
    let t1 = _mm256_unpackhi_pd(a, b);
    let t2 = _mm256_unpacklo_pd(c, d);
    let t3 = _mm256_unpackhi_pd(c, d);
    (
        _mm256_permute2f128_pd(t0, t2, 0x20),
        _mm256_permute2f128_pd(t1, t3, 0x20),
        _mm256_permute2f128_pd(t0, t2, 0x31),
        _mm256_permute2f128_pd(t1, t3, 0x31),
    )
}

/// `[f(0), f(1), f(2), f(3)]`, always inlined: an array's `map` in a kernel body built
/// for two instruction sets (`avx2_entry_point!`) stayed an out-of-line call.
#[inline(always)]
pub(crate) fn lanes<T>(mut f: impl FnMut(usize) -> T) -> [T; 4] {
    [f(0), f(1), f(2), f(3)]
}
