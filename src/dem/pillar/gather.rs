//! Phase 3a of a pillar step: each grain's contact force and torque, the sum of its
//! terms in order (own slots, then the slots where it is the partner, with x and y
//! negated: the torque T_ij = −½ r_ij × F_t acts alike on both).
//!
//! The terms lie grain after grain, padded with +0.0 to their chunk's width
//! ([`Reverse`]), so every grain of a chunk sums the same number of places: no loop
//! exit to mispredict per grain, which was most of this phase's cost. Padding changes
//! no sum (a sum that starts at +0.0 is never −0.0, and x + 0.0 = x otherwise).

use crate::dem::backend::simd::Quad;
use crate::dem::pillar::phases::{CHUNK, Reverse};
use std::ops::Range;

/// Grains `range` of the sums into `fx`, `fy` (N) and `tq` (N m), which hold the range's
/// values, as does `frozen`; frozen grains keep last step's sums (their terms are
/// unchanged). Runs the AVX2 kernel (same numbers) where the processor has it.
///
/// # Panics
/// If the terms do not hold `rev`'s layout or a slice is shorter than the range.
pub fn gather(
    range: Range<usize>,
    rev: &Reverse,
    terms: &[Quad],
    frozen: Option<&[bool]>,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
) {
    let lo = range.start;
    assert!(
        terms.len() == rev.places
            && range.end <= rev.width.len() * CHUNK
            && [fx.len(), fy.len(), tq.len()]
                .iter()
                .all(|&l| l >= range.len())
            && frozen.is_none_or(|f| f.len() >= range.len()),
        "gather: terms or sums that do not match the layout"
    );
    let mut g = range.start;
    while g < range.end {
        let c = g / CHUNK;
        let end = ((c + 1) * CHUNK).min(range.end);
        let w = rev.width[c] as usize;
        let from = rev.places_of(g).start;
        let t = &terms[from..from + (end - g) * w];
        let l = g - lo..end - lo;
        let out = (&mut fx[l.clone()], &mut fy[l.clone()], &mut tq[l.clone()]);
        let fz = frozen.map(|f| &f[l]);
        #[cfg(target_arch = "x86_64")]
        if crate::dem::backend::simd::level() >= crate::dem::backend::simd::Level::Avx2 {
            // SAFETY: AVX2 present (checked at run time); t holds w places per grain of
            // the chunk's part, and the outputs that part (sliced above).
            unsafe { avx2::sum_terms(w, t, fz, out) };
            g = end;
            continue;
        }
        sum_terms(w, t, fz, out);
        g = end;
    }
}

crate::multiversion! {
/// One chunk's sums, `w` places per grain: the reference the AVX2 kernel matches.
#[allow(clippy::needless_range_loop)]
pub fn sum_terms(
    w: usize,
    t: &[Quad],
    frozen: Option<&[bool]>,
    out: (&mut [f64], &mut [f64], &mut [f64]),
) {
    let (fx, fy, tq) = out;
    for q in 0..fx.len() {
        if frozen.is_some_and(|f| f[q]) {
            continue;
        }
        let mut s = [0.0; 4];
        for f in &t[q * w..q * w + w] {
            for l in 0..4 {
                s[l] += f.0[l];
            }
        }
        (fx[q], fy[q], tq[q]) = (s[0], s[1], s[2]);
    }
}
}

/// The sums with AVX2 intrinsics (compiled for AVX2 and AVX-512, `avx2_entry_point!`).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use crate::dem::backend::avx2::transpose;
    use crate::dem::backend::simd::Quad;
    use std::arch::x86_64::*;

    crate::avx2_entry_point! {
    /// As [`super::sum_terms`] (same results): four grains at a time, one
    /// vector add per place and grain, the four sums transposed into f_x, f_y, T.
    ///
    /// # Safety
    /// The processor must have AVX2; `t` holds `w` places per grain of `fx`, and `fy`,
    /// `tq` and `frozen` are as long as `fx`.
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
                _ => super::sum_terms(w, t, frozen, out),
            }
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
            super::sum_terms(W, &t[n4 * W..], frozen.map(|f| &f[n4..]), rest);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random half list of n grains: `start` and `j` (partners anywhere but i).
    fn random_list(n: usize, seed: u64) -> (Vec<u32>, Vec<u32>) {
        let mut rng = crate::rng::Rng::new(seed);
        let (mut start, mut js) = (vec![0u32], vec![]);
        for i in 0..n {
            for _ in 0..rng.below(5) {
                let j = (i + 1 + rng.below(n - 1)) % n;
                js.push(j as u32);
            }
            start.push(js.len() as u32);
        }
        (start, js)
    }

    #[test]
    fn padded_terms_sum_as_each_grain_s_own_terms_in_order() {
        // 70 grains: two whole chunks and a part one, so three widths.
        let n = 70;
        let (start, js) = random_list(n, 3);
        let rev = Reverse::build(n, &start, &js);
        // Every slot's two places are distinct, in range, and each grain's terms are
        // its own slots in order, then its partner slots in order.
        let mut seen = vec![false; rev.places];
        for &m in rev.term_own.iter().chain(&rev.term_partner) {
            assert!(
                !std::mem::replace(&mut seen[m as usize], true),
                "place {m} twice"
            );
        }
        for i in 0..n {
            let own = (start[i]..start[i + 1]).map(|k| rev.term_own[k as usize]);
            let partner = (0..js.len())
                .filter(|&k| js[k] as usize == i)
                .map(|k| rev.term_partner[k]);
            let places: Vec<usize> = own.chain(partner).map(|m| m as usize).collect();
            let range = rev.terms_of(&start, i);
            assert_eq!(places, range.clone().collect::<Vec<_>>(), "grain {i}");
            assert!(range.len() <= rev.width[i / CHUNK] as usize);
        }
        assert!(rev.width.iter().any(|&w| w >= 3), "{:?}", rev.width);
        // Terms with all bits in use at the real places; the padding stays +0.0.
        let mut rng = crate::rng::Rng::new(9);
        let mut terms = vec![Quad::default(); rev.places];
        for (m, t) in terms.iter_mut().enumerate() {
            if seen[m] {
                *t = Quad([(); 4].map(|_| rng.normal() * 1e-3));
            }
        }
        let frozen: Vec<bool> = (0..n).map(|i| i % 13 == 5).collect();
        let expect = |i: usize| {
            let mut s = [0.0; 4];
            for t in &terms[rev.terms_of(&start, i)] {
                (0..4).for_each(|c| s[c] += t.0[c]);
            }
            [s[0], s[1], s[2]].map(f64::to_bits)
        };
        // Whole range and two parts (as two threads would), frozen grains or not.
        for cut in [n, 32] {
            let parts = [0..cut, cut..n];
            for fz in [None, Some(&frozen[..])] {
                let (mut fx, mut fy, mut tq) = (vec![7.0; n], vec![7.0; n], vec![7.0; n]);
                for r in &parts {
                    let fr = fz.map(|f| &f[r.clone()]);
                    let (a, b, c) = (&mut fx[r.clone()], &mut fy[r.clone()], &mut tq[r.clone()]);
                    gather(r.clone(), &rev, &terms, fr, a, b, c);
                }
                for i in 0..n {
                    let got = [fx[i], fy[i], tq[i]];
                    if fz.is_some_and(|f| f[i]) {
                        assert_eq!(got, [7.0; 3], "frozen grain {i} kept its sums");
                    } else {
                        assert_eq!(got.map(f64::to_bits), expect(i), "grain {i}");
                    }
                }
            }
        }
    }

    #[test]
    fn frozen_grains_rest_clear_of_the_bars_with_every_partner_at_rest() {
        use crate::dem::pillar::phases::mark_frozen;
        let n = 70;
        let (start, js) = random_list(n, 5);
        let rev = Reverse::build(n, &start, &js);
        let mut rng = crate::rng::Rng::new(11);
        let resting: Vec<bool> = (0..n).map(|_| rng.uniform() < 0.85).collect();
        let y: Vec<f64> = (0..n).map(|_| rng.uniform()).collect();
        let radius = vec![0.05; n];
        let (top, bottom, margin) = (0.95, 0.05, 0.01);
        // The definition, straight from the list.
        let expect: Vec<bool> = (0..n)
            .map(|i| {
                let own = start[i] as usize..start[i + 1] as usize;
                resting[i]
                    && top - y[i] > radius[i] + margin
                    && y[i] - bottom > radius[i]
                    && js[own].iter().all(|&j| resting[j as usize])
                    && (0..n).all(|o| {
                        let r = start[o] as usize..start[o + 1] as usize;
                        !js[r].contains(&(i as u32)) || resting[o]
                    })
            })
            .collect();
        let count = expect.iter().filter(|&&f| f).count();
        assert!(
            count > 5 && count < n - 20,
            "{count} frozen: a test of both sides"
        );
        for cut in [n, 32, 64] {
            let parts = [0..cut, cut..n];
            let mut frozen = vec![true; n];
            let mut got = 0;
            for r in parts {
                let (f, yr) = (&mut frozen[r.clone()], &y[r.clone()]);
                got += mark_frozen(r, f, &resting, yr, &rev, (top, bottom, margin), &radius);
            }
            assert_eq!(frozen, expect);
            assert_eq!(got, count);
        }
    }
}
