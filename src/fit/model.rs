//! The crossover law of Li et al., Eq. 19: D²min/R² = 4Θη − 4Θη_c (1 − e^{−η/η_c}),
//! ballistic (2Θη²/η_c) below η_c and diffusive (4Θη) above it.

/// x − (1 − e^{−x}), accurate for small x (where the difference cancels).
#[inline]
pub fn crossover_shape(x: f64) -> f64 {
    if x < 1e-3 {
        x * x * (0.5 - x * (1.0 / 6.0 - x / 24.0))
    } else {
        x + (-x).exp_m1()
    }
}

/// Eq. 19: the predicted D²min/R² (dimensionless) at deviatoric strain `eta` for
/// temperature-like Θ `theta` and crossover strain `eta_c`.
#[inline]
pub fn d2min_over_r2(eta: f64, theta: f64, eta_c: f64) -> f64 {
    4.0 * theta * eta_c * crossover_shape(eta / eta_c)
}

/// ln of [`crossover_shape`] at x = e^u, from a table of values and slopes every 1/128 in
/// u ∈ [−30, 30] with cubic Hermite interpolation (relative error of the shape below
/// 1e-10; checked against the direct formula in the tests), the direct formula outside.
/// The log-space fits evaluate it once per sample per trial η_c: a lookup instead of an
/// `exp_m1` and a `ln` (about 5× faster for the `points` estimator).
#[inline]
pub fn ln_shape_of_ln(u: f64) -> f64 {
    ln_shape_in(shape_table(), u)
}

const U0: f64 = -30.0;
const PER: f64 = 128.0;
const TABLE_NODES: usize = 60 * 128 + 1;

/// The table of [`ln_shape_of_ln`]: (ln s, d ln s / d ln x) at each node.
fn shape_table() -> &'static [(f64, f64); TABLE_NODES] {
    static TABLE: std::sync::OnceLock<Box<[(f64, f64); TABLE_NODES]>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        Box::new(std::array::from_fn(|i| {
            let x = (U0 + i as f64 / PER).exp();
            let s = crossover_shape(x);
            // d ln s / d ln x = x s'(x) / s(x), s'(x) = 1 − e^{−x}.
            (s.ln(), -x * (-x).exp_m1() / s)
        }))
    })
}

/// Outside the table (far from any fitted η_c).
#[cold]
#[inline(never)]
fn ln_shape_direct(u: f64) -> f64 {
    crossover_shape(u.exp()).ln()
}

/// ln shape at u by the table, and whether u lies in it (else the value is garbage
/// and [`ln_shape_direct`] is the answer). No branch: loops over samples vectorise.
#[inline(always)]
fn ln_shape_tabled(table: &[(f64, f64); TABLE_NODES], u: f64) -> (f64, bool) {
    let t = (u - U0) * PER;
    let inside = t >= 0.0 && t < (TABLE_NODES - 1) as f64;
    let t = if inside { t } else { 0.0 };
    // t < TABLE_NODES − 1, so the bound only tells the compiler that i + 1 is in the
    // table; i is t's integer part, whether cast through i32 or usize.
    let i = (t as i32 as usize).min(TABLE_NODES - 2);
    let f = t - i as f64;
    let ((f0, d0), (f1, d1)) = (table[i], table[i + 1]);
    let h = 1.0 / PER;
    let (f2, f3) = (f * f, f * f * f);
    (
        (2.0 * f3 - 3.0 * f2 + 1.0) * f0
            + (f3 - 2.0 * f2 + f) * h * d0
            + (-2.0 * f3 + 3.0 * f2) * f1
            + (f3 - f2) * h * d1,
        inside,
    )
}

#[inline(always)]
fn ln_shape_in(table: &[(f64, f64); TABLE_NODES], u: f64) -> f64 {
    match ln_shape_tabled(table, u) {
        (v, true) => v,
        _ => ln_shape_direct(u),
    }
}

/// (Σ r, Σ r²) over samples in order, r = `residual(ln y, ln shape(ln η − ln η_c))`:
/// the log fits' pass over every sample at one trial η_c (the `points` estimator makes
/// some three thousand of them over 4 M samples). A chunk's residuals are computed
/// before they are summed: summed in the same loop, the two running sums chained every
/// sample's table lookup to the last, and the loop could not vectorise. The same
/// additions in the same order: the same sums.
pub(super) fn residual_sums(
    ln_y: &[f64],
    ln_eta: &[f64],
    ln_eta_c: f64,
    residual: impl Fn(f64, f64) -> f64,
) -> (f64, f64) {
    let [s, _] = residual_sums_pair([(ln_y, ln_eta), (&[], &[])], ln_eta_c, residual);
    s
}

/// [`residual_sums`] of two lists at once, each summed in its own order: one list's
/// sums wait on each addition (four cycles each, in order), and two lists' additions
/// interleave. The same sums as two calls.
pub(super) fn residual_sums_pair(
    lists: [(&[f64], &[f64]); 2],
    ln_eta_c: f64,
    residual: impl Fn(f64, f64) -> f64,
) -> [(f64, f64); 2] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: this CPU has AVX2, checked just above.
        return unsafe { residual_sums_avx2(lists, ln_eta_c, residual) };
    }
    residual_sums_any(lists, ln_eta_c, residual)
}

/// [`residual_sums_any`] compiled for AVX2 (four lanes, gathers for the table).
/// Rust never fuses a multiply and an add, so the numbers are those of any CPU.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn residual_sums_avx2(
    lists: [(&[f64], &[f64]); 2],
    ln_eta_c: f64,
    residual: impl Fn(f64, f64) -> f64,
) -> [(f64, f64); 2] {
    residual_sums_any(lists, ln_eta_c, residual)
}

const CHUNK: usize = 256;

/// One chunk's residuals into `r` (its first `ln_y.len()` entries).
#[inline(always)]
fn residual_chunk(
    table: &[(f64, f64); TABLE_NODES],
    ln_y: &[f64],
    ln_eta: &[f64],
    ln_eta_c: f64,
    residual: &impl Fn(f64, f64) -> f64,
    r: &mut [f64; CHUNK],
) {
    let mut outside = false;
    for ((r, &ly), &le) in r.iter_mut().zip(ln_y).zip(ln_eta) {
        let (shape, inside) = ln_shape_tabled(table, le - ln_eta_c);
        outside |= !inside;
        *r = residual(ly, shape);
    }
    if outside {
        for ((r, &ly), &le) in r.iter_mut().zip(ln_y).zip(ln_eta) {
            *r = residual(ly, ln_shape_in(table, le - ln_eta_c));
        }
    }
}

#[inline(always)]
fn residual_sums_any(
    lists: [(&[f64], &[f64]); 2],
    ln_eta_c: f64,
    residual: impl Fn(f64, f64) -> f64,
) -> [(f64, f64); 2] {
    let table = shape_table();
    let [(ya, ea), (yb, eb)] = lists;
    let (na, nb) = (ya.len().min(ea.len()), yb.len().min(eb.len()));
    let (mut ra, mut rb) = ([0.0f64; CHUNK], [0.0f64; CHUNK]);
    let (mut a1, mut a2, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0);
    // Both lists' chunks while both last, then the longer one's rest.
    let both = na.min(nb);
    let mut at = 0;
    while at < both {
        let end = (at + CHUNK).min(both);
        residual_chunk(
            table,
            &ya[at..end],
            &ea[at..end],
            ln_eta_c,
            &residual,
            &mut ra,
        );
        residual_chunk(
            table,
            &yb[at..end],
            &eb[at..end],
            ln_eta_c,
            &residual,
            &mut rb,
        );
        for (&x, &z) in ra[..end - at].iter().zip(&rb[..end - at]) {
            a1 += x;
            a2 += x * x;
            b1 += z;
            b2 += z * z;
        }
        at = end;
    }
    for (y, e, s1, s2) in [(ya, ea, &mut a1, &mut a2), (yb, eb, &mut b1, &mut b2)] {
        let n = y.len().min(e.len());
        let mut at = both;
        while at < n {
            let end = (at + CHUNK).min(n);
            residual_chunk(
                table,
                &y[at..end],
                &e[at..end],
                ln_eta_c,
                &residual,
                &mut ra,
            );
            for &x in &ra[..end - at] {
                *s1 += x;
                *s2 += x * x;
            }
            at = end;
        }
    }
    [(a1, a2), (b1, b2)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tabulated_ln_shape_matches_the_formula() {
        let mut worst: f64 = 0.0;
        let mut u: f64 = -35.0;
        while u < 35.0 {
            let direct = crossover_shape(u.exp()).ln();
            worst = worst.max((ln_shape_of_ln(u) - direct).abs());
            u += 0.000_731;
        }
        // An error in ln s is the relative error of s.
        assert!(worst < 1e-10, "{worst:e}");
    }

    #[test]
    fn limits_of_eq19() {
        let (th, ec) = (0.3, 0.05);
        // ballistic: 2Θη²/η_c
        let e = 1e-5;
        let b = d2min_over_r2(e, th, ec);
        assert!((b / (2.0 * th * e * e / ec) - 1.0).abs() < 1e-3);
        // diffusive: 4Θ(η − η_c)
        let e = 5.0;
        assert!((d2min_over_r2(e, th, ec) / (4.0 * th * (e - ec)) - 1.0).abs() < 1e-12);
        // series branch joins the direct formula continuously
        let x: f64 = 1e-3;
        let direct = x - (1.0 - (-x).exp());
        assert!((crossover_shape(x) / direct - 1.0).abs() < 1e-8);
    }
}
