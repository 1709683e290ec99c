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
use crate::dem::pillar::phases::{CHUNK, Reverse};
use std::ops::Range;

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
            unsafe { crate::dem::backend::pillar_gather_avx2::sum_terms(w, t, fz, out) };
            g = end;
            continue;
        }
        crate::dem::pillar::gather::sum_terms(w, t, fz, out);
        g = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::pillar::phases::{CHUNK, Reverse};

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

    /// A layout rebuilt in another's buffers (larger, so stale entries would show) is
    /// the one built fresh.
    #[test]
    fn a_layout_rebuilt_in_used_buffers_is_the_one_built_fresh() {
        let (start, js) = random_list(130, 1);
        let mut used = Reverse::build(130, &start, &js);
        for (n, seed) in [(70, 2), (33, 3), (1, 4), (0, 5)] {
            let (start, js) = if n > 1 {
                random_list(n, seed)
            } else {
                (vec![0; n + 1], vec![])
            };
            used.rebuild(n, &start, &js);
            let fresh = Reverse::build(n, &start, &js);
            assert_eq!(
                (&used.start, &used.term_own, &used.term_partner, &used.width),
                (
                    &fresh.start,
                    &fresh.term_own,
                    &fresh.term_partner,
                    &fresh.width
                ),
                "{n} grains"
            );
            assert_eq!(
                (&used.chunk_base, used.places, &used.neighbour, &used.reach),
                (
                    &fresh.chunk_base,
                    fresh.places,
                    &fresh.neighbour,
                    &fresh.reach
                ),
                "{n} grains"
            );
        }
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
