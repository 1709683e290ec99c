//! Phase 3a of a pillar step: each grain's contact force and torque, the sum of its
//! terms in order (own slots, then the slots where it is the partner, with x and y
//! negated: the torque T_ij = −½ r_ij × F_t acts alike on both).
//!
//! The terms lie grain after grain, padded with +0.0 to their chunk's width
//! ([`Reverse`]), so every grain of a chunk sums the same number of places: no loop
//! exit to mispredict per grain, which was most of this phase's cost. Padding changes
//! no sum (a sum that starts at +0.0 is never −0.0, and x + 0.0 = x otherwise).

use crate::dem::backend::simd::Quad;

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
