//! The integrator of vagberg-sheared-disks Eqs. 21–24 for the AVX2 force kernel, four
//! grains at a time: the same operations as `shear_integrate::{predict, correct}`, lane
//! for lane and in the same order (no fused multiply-add), so the same numbers bit for
//! bit. Each writes the state it makes straight into the packed records the force
//! kernel reads (transposed in registers) and makes the near list's stray test as it
//! writes the positions; `correct` reads the predicted state's force sums from the
//! kernel's packed records and zeroes them for the next evaluation, and runs range by
//! range as the kernel completes each range of grains (`near::Done`), as does the
//! spreading of the final sums into arrays (`unpack_forces`): their memory traffic then
//! overlaps the kernel's arithmetic. The arrays of the predicted velocities are never
//! written.

use crate::dem::backend::avx2::transpose;
use crate::dem::shear::integrate::{Pos, Quad, Slices5};
use crate::dem::shear::near::StrayTest;
use std::arch::x86_64::*;

/// Four lanes of `s` from `i` on.
///
/// # Safety
/// `i + 4 <= s.len()`.
#[inline(always)]
unsafe fn ld(s: &[f64], i: usize) -> __m256d {
    debug_assert!(i + 4 <= s.len());
    unsafe { _mm256_loadu_pd(s.as_ptr().add(i)) }
}

/// Four lanes into `s` from `i` on.
///
/// # Safety
/// `i + 4 <= s.len()`.
#[inline(always)]
unsafe fn st(s: &mut [f64], i: usize, v: __m256d) {
    debug_assert!(i + 4 <= s.len());
    unsafe { _mm256_storeu_pd(s.as_mut_ptr().add(i), v) }
}

/// The force sums (f_x, f_y, T) of grains i..i+4 from the kernel's packed records,
/// as lanes, the records left zeroed for the next evaluation.
///
/// # Safety
/// `i + 4 <= f.len()`; AVX present.
#[inline(always)]
unsafe fn take4(f: &mut [Quad], i: usize) -> (__m256d, __m256d, __m256d) {
    debug_assert!(i + 4 <= f.len());
    unsafe {
        let p = f.as_mut_ptr().add(i).cast::<f64>();
        let q = |k: usize| _mm256_load_pd(p.add(4 * k));
        let (a, b, c, _) = transpose(q(0), q(1), q(2), q(3));
        for k in 0..4 {
            _mm256_store_pd(p.add(4 * k), _mm256_setzero_pd());
        }
        (a, b, c)
    }
}

/// Grains i..i+4 packed: positions (x, y) and records (v_x, v_y, ω, R).
///
/// # Safety
/// `i + 4 <=` both lengths.
#[inline(always)]
unsafe fn pack4(pos: &mut [Pos], vel: &mut [Quad], i: usize, [x, y, vx, vy, w, r]: [__m256d; 6]) {
    debug_assert!(i + 4 <= pos.len() && i + 4 <= vel.len());
    unsafe {
        // [x0 y0 x2 y2] and [x1 y1 x3 y3], then the 128-bit halves in grain order.
        let (lo, hi) = (_mm256_unpacklo_pd(x, y), _mm256_unpackhi_pd(x, y));
        let p = pos.as_mut_ptr().add(i) as *mut f64;
        _mm256_storeu_pd(p, _mm256_permute2f128_pd(lo, hi, 0x20));
        _mm256_storeu_pd(p.add(4), _mm256_permute2f128_pd(lo, hi, 0x31));
        let (a, b, c, d) = transpose(vx, vy, w, r);
        let q = vel.as_mut_ptr().add(i);
        for (k, v) in [a, b, c, d].into_iter().enumerate() {
            _mm256_store_pd((*q.add(k)).0.as_mut_ptr(), v);
        }
    }
}

/// Lanes of grains i..i+4 at (x, y) that strayed by `test` (see `Slots::stray_test`;
/// the same operations as `verlet::strays`, so the same answer), or'd into `far`.
///
/// # Safety
/// `i + 4 <=` the lengths of the test's arrays.
#[inline(always)]
unsafe fn strays4(test: &Option<StrayTest>, i: usize, x: __m256d, y: __m256d, far: &mut __m256d) {
    if let Some(t) = test {
        // SAFETY: this function's contract.
        unsafe {
            let (xr, yr) = (ld(t.x_ref, i), ld(t.y_ref, i));
            let ux = _mm256_sub_pd(
                _mm256_sub_pd(x, xr),
                _mm256_mul_pd(_mm256_set1_pd(t.dgamma), yr),
            );
            let uy = _mm256_sub_pd(y, yr);
            let d2 = _mm256_add_pd(_mm256_mul_pd(ux, ux), _mm256_mul_pd(uy, uy));
            let out = _mm256_cmp_pd::<_CMP_GT_OQ>(d2, _mm256_set1_pd(t.lim));
            *far = _mm256_or_pd(*far, out);
        }
    }
}

/// Whether grain i at (x, y) strayed by `test` (as `strays4`, one lane).
fn strays1(test: &Option<StrayTest>, i: usize, x: f64, y: f64) -> bool {
    test.is_some_and(|t| {
        let ux = x - t.x_ref[i] - t.dgamma * t.y_ref[i];
        let uy = y - t.y_ref[i];
        ux * ux + uy * uy > t.lim
    })
}

/// Whether any lane of `far` is set, or `tail`; `None` without a test.
///
/// # Safety
/// AVX present.
#[inline(always)]
unsafe fn answer(test: &Option<StrayTest>, far: __m256d, tail: bool) -> Option<bool> {
    // SAFETY: this function's contract.
    let any = unsafe { _mm256_movemask_pd(far) } != 0;
    test.map(|_| any || tail)
}

/// Eqs. 21–22 for four grains, lane by lane: the predicted (x, y, v_x, v_y, ω) from
/// (x, y, v_x, v_y, ω), f_0 = (f_x, f_y, T), 1/m and 1/I (read only when `rotate`; ω
/// is 0 otherwise), `dt4` = Δt in every lane. The one body of `predict_x4` and
/// `unpack_predict_x4` (and, lane for lane, of `predict1`), so that they make the same
/// bits as `shear_integrate::predict`.
///
/// # Safety
/// AVX present (every caller is compiled with AVX2).
#[inline(always)]
unsafe fn predict4(
    dt4: __m256d,
    rotate: bool,
    [x, y, vx, vy, w]: [__m256d; 5],
    [fx, fy, t]: [__m256d; 3],
    im: __m256d,
    ii: impl FnOnce() -> __m256d,
) -> [__m256d; 5] {
    // SAFETY: this function's contract.
    unsafe {
        let (add, mul) = (_mm256_add_pd, _mm256_mul_pd);
        let pvx = add(vx, mul(mul(fx, dt4), im));
        let pvy = add(vy, mul(mul(fy, dt4), im));
        let px = add(x, mul(vx, dt4));
        let py = add(y, mul(vy, dt4));
        let pw = if rotate {
            add(w, mul(mul(t, dt4), ii()))
        } else {
            _mm256_setzero_pd()
        };
        [px, py, pvx, pvy, pw]
    }
}

/// `predict4` for one grain (the loops' tails).
fn predict1(
    dt: f64,
    rotate: bool,
    [x, y, vx, vy, w]: [f64; 5],
    [fx, fy, t]: [f64; 3],
    im: f64,
    ii: f64,
) -> [f64; 5] {
    let pvx = vx + fx * dt * im;
    let pvy = vy + fy * dt * im;
    let pw = if rotate { w + t * dt * ii } else { 0.0 };
    [x + vx * dt, y + vy * dt, pvx, pvy, pw]
}

crate::avx2_entry_point! {
/// Eqs. 21–22 (and the spin analogue of 21), as `shear_integrate::predict`: the
/// predicted state packed into `pos`, `vel` (with the radii `r`). Spins stay 0 when
/// `!rotate`. Makes the near list's stray `test` on the predicted positions:
/// `Some(strayed)` with one.
///
/// # Safety
/// The processor must have AVX2, and every slice (the test's too) must have the length
/// of `state.0` (`predict_packed`, the one caller, asserts it).
unsafe fn predict_x4(
    dt: f64,
    rotate: bool,
    state: Slices5,
    r: &[f64],
    inv: (&[f64], &[f64]),
    f0: (&[f64], &[f64], &[f64]),
    pos: &mut [Pos],
    vel: &mut [Quad],
    test: Option<StrayTest>,
) -> Option<bool> {
    let ((x, y, vx, vy, w), (inv_m, inv_i), (f0x, f0y, t0)) = (state, inv, f0);
    let n = x.len();
    let body = n - n % 4;
    // SAFETY: AVX2 present (this function's contract).
    let mut far = unsafe { _mm256_setzero_pd() };
    // SAFETY: i + 4 <= n for every i below, and every slice has length n.
    unsafe {
        let dt4 = _mm256_set1_pd(dt);
        for i in (0..body).step_by(4) {
            let state = [ld(x, i), ld(y, i), ld(vx, i), ld(vy, i), ld(w, i)];
            let f0 = [ld(f0x, i), ld(f0y, i), ld(t0, i)];
            let [px, py, pvx, pvy, pw] = predict4(dt4, rotate, state, f0, ld(inv_m, i), || ld(inv_i, i));
            strays4(&test, i, px, py, &mut far);
            pack4(pos, vel, i, [px, py, pvx, pvy, pw, ld(r, i)]);
        }
    }
    let mut tail = false;
    for i in body..n {
        let state = [x[i], y[i], vx[i], vy[i], w[i]];
        let f0 = [f0x[i], f0y[i], t0[i]];
        let [px, py, pvx, pvy, pw] = predict1(dt, rotate, state, f0, inv_m[i], inv_i[i]);
        pos[i] = Pos([px, py]);
        vel[i] = Quad([pvx, pvy, pw, r[i]]);
        tail |= strays1(&test, i, px, py);
    }
    // SAFETY: AVX2 present (this function's contract).
    unsafe { answer(&test, far, tail) }
}
}

/// The state at t and its forces, as `correct_x4` reads and writes them.
pub(crate) struct Now<'a> {
    pub x: &'a mut [f64],
    pub y: &'a mut [f64],
    pub theta: &'a mut [f64],
    pub vx: &'a mut [f64],
    pub vy: &'a mut [f64],
    pub w: &'a mut [f64],
    pub r: &'a [f64],
    pub f0: (&'a [f64], &'a [f64], &'a [f64]),
}

crate::avx2_entry_point! {
/// Eqs. 23–24 (and their spin analogues), as `shear_integrate::correct`: the state at
/// t + Δt from the forces at t (`now.f0`) and the packed force sums at the predicted
/// state (`f1`, (f_x, f_y, T, ·) per grain, left zeroed for the next evaluation),
/// written to the arrays and packed into `pos`, `vel` (any range of grains). Makes the
/// near list's stray `test` on the new positions, as `predict_x4`.
///
/// # Safety
/// The processor must have AVX2, and every slice (the test's too) must have the length
/// of `now.x` (`correct_packed`, the one caller, asserts it).
unsafe fn correct_x4(
    dt: f64,
    rotate: bool,
    inv: (&[f64], &[f64]),
    now: Now,
    f1: &mut [Quad],
    pos: &mut [Pos],
    vel: &mut [Quad],
    test: Option<StrayTest>,
) -> Option<bool> {
    let Now { x, y, theta, vx, vy, w, r, f0: (f0x, f0y, t0) } = now;
    let (inv_m, inv_i) = inv;
    let n = x.len();
    let body = n - n % 4;
    // SAFETY: AVX2 present (this function's contract).
    let mut far = unsafe { _mm256_setzero_pd() };
    // SAFETY: i + 4 <= n for every i below, and every slice has length n.
    unsafe {
        let (dt4, half) = (_mm256_set1_pd(dt), _mm256_set1_pd(0.5));
        let add = _mm256_add_pd;
        let mul = _mm256_mul_pd;
        for i in (0..body).step_by(4) {
            let (f1x, f1y, t1) = take4(f1, i);
            let (vx0, vy0) = (ld(vx, i), ld(vy, i));
            let hm = mul(half, ld(inv_m, i));
            let vx1 = add(vx0, mul(mul(add(ld(f0x, i), f1x), dt4), hm));
            let vy1 = add(vy0, mul(mul(add(ld(f0y, i), f1y), dt4), hm));
            let xi = add(ld(x, i), mul(mul(add(vx0, vx1), dt4), half));
            let yi = add(ld(y, i), mul(mul(add(vy0, vy1), dt4), half));
            st(vx, i, vx1);
            st(vy, i, vy1);
            st(x, i, xi);
            st(y, i, yi);
            strays4(&test, i, xi, yi, &mut far);
            let mut wi = ld(w, i);
            if rotate {
                let w0 = wi;
                let hi = mul(half, ld(inv_i, i));
                wi = add(w0, mul(mul(add(ld(t0, i), t1), dt4), hi));
                st(w, i, wi);
                st(theta, i, add(ld(theta, i), mul(mul(add(w0, wi), dt4), half)));
            }
            pack4(pos, vel, i, [xi, yi, vx1, vy1, wi, ld(r, i)]);
        }
    }
    let mut tail = false;
    for i in body..n {
        let [f1x, f1y, t1, _] = std::mem::take(&mut f1[i]).0;
        let (vx0, vy0) = (vx[i], vy[i]);
        vx[i] = vx0 + (f0x[i] + f1x) * dt * (0.5 * inv_m[i]);
        vy[i] = vy0 + (f0y[i] + f1y) * dt * (0.5 * inv_m[i]);
        x[i] += (vx0 + vx[i]) * dt * 0.5;
        y[i] += (vy0 + vy[i]) * dt * 0.5;
        if rotate {
            let w0 = w[i];
            w[i] = w0 + (t0[i] + t1) * dt * (0.5 * inv_i[i]);
            theta[i] += (w0 + w[i]) * dt * 0.5;
        }
        pos[i] = Pos([x[i], y[i]]);
        vel[i] = Quad([vx[i], vy[i], w[i], r[i]]);
        tail |= strays1(&test, i, x[i], y[i]);
    }
    // SAFETY: AVX2 present (this function's contract).
    unsafe { answer(&test, far, tail) }
}
}

/// Eqs. 21–22 packed (see `predict_x4`); panics unless every slice has n = `state.0`'s
/// length and the processor has AVX2.
#[allow(clippy::too_many_arguments)]
pub(crate) fn predict_packed(
    dt: f64,
    rotate: bool,
    state: Slices5,
    r: &[f64],
    inv: (&[f64], &[f64]),
    f0: (&[f64], &[f64], &[f64]),
    packed: &mut crate::dem::shear::integrate::Packed,
    test: Option<StrayTest>,
) -> Option<bool> {
    // `predict_packed_into` checks the lengths and AVX2.
    let (pos, vel) = packed.reserve(state.0.len());
    predict_packed_into(dt, rotate, state, r, inv, f0, (pos, vel), test)
}

/// As [`predict_packed`] for the grains of the slices (any range of grains: the packed
/// state goes to `pos`, `vel`, of their length).
#[allow(clippy::too_many_arguments)]
pub(crate) fn predict_packed_into(
    dt: f64,
    rotate: bool,
    state: Slices5,
    r: &[f64],
    inv: (&[f64], &[f64]),
    f0: (&[f64], &[f64], &[f64]),
    (pos, vel): (&mut [Pos], &mut [Quad]),
    test: Option<StrayTest>,
) -> Option<bool> {
    let n = state.0.len();
    let lens = [
        state.1, state.2, state.3, state.4, r, inv.0, inv.1, f0.0, f0.1, f0.2,
    ];
    assert!(
        std::is_x86_feature_detected!("avx2")
            && lens.iter().all(|s| s.len() == n)
            && pos.len() == n
            && vel.len() == n
            && test.is_none_or(|t| t.x_ref.len() == n && t.y_ref.len() == n),
        "predict_packed: slices of unequal length, or no AVX2"
    );
    // SAFETY: AVX2 present and every length n (checked above).
    unsafe { predict_x4(dt, rotate, state, r, inv, f0, pos, vel, test) }
}

/// Eqs. 23–24 packed (see `correct_x4`) for the grains of the slices (any range of
/// grains: the packed state goes to `pos`, `vel`); panics unless every slice has
/// n = `now.x`'s length and the processor has AVX2.
pub(crate) fn correct_packed(
    dt: f64,
    rotate: bool,
    inv: (&[f64], &[f64]),
    now: Now,
    f1: &mut [Quad],
    (pos, vel): (&mut [Pos], &mut [Quad]),
    test: Option<StrayTest>,
) -> Option<bool> {
    let n = now.x.len();
    let lens = [
        now.y.len(),
        now.theta.len(),
        now.vx.len(),
        now.vy.len(),
        now.w.len(),
        now.r.len(),
        now.f0.0.len(),
        now.f0.1.len(),
        now.f0.2.len(),
        inv.0.len(),
        inv.1.len(),
        f1.len(),
        pos.len(),
        vel.len(),
    ];
    assert!(
        std::is_x86_feature_detected!("avx2")
            && lens.iter().all(|&l| l == n)
            && test.is_none_or(|t| t.x_ref.len() == n && t.y_ref.len() == n),
        "correct_packed: slices of unequal length, or no AVX2"
    );
    // SAFETY: AVX2 present and every length n (checked above).
    unsafe { correct_x4(dt, rotate, inv, now, f1, pos, vel, test) }
}

crate::avx2_entry_point! {
/// The packed force sums (f_x, f_y, T, ·) of each grain into the arrays `fx`, `fy`,
/// `tq`, four grains per transpose, leaving `f` zeroed for the next evaluation.
///
/// # Safety
/// The processor must have AVX2, and `fx`, `fy`, `tq` must have the length of `f`
/// (`unpack_forces`, the one caller, asserts it).
unsafe fn unpack_x4(f: &mut [Quad], fx: &mut [f64], fy: &mut [f64], tq: &mut [f64]) {
    let n = f.len();
    let body = n - n % 4;
    // SAFETY: i + 4 <= n for every i below, and every slice has length n.
    unsafe {
        for i in (0..body).step_by(4) {
            let (a, b, c) = take4(f, i);
            st(fx, i, a);
            st(fy, i, b);
            st(tq, i, c);
        }
    }
    for i in body..n {
        [fx[i], fy[i], tq[i], _] = std::mem::take(&mut f[i]).0;
    }
}
}

/// The packed force sums `f` into the arrays, `f` left zeroed (see `unpack_x4`);
/// panics unless the lengths agree and the processor has AVX2.
pub(crate) fn unpack_forces(f: &mut [Quad], (fx, fy, tq): (&mut [f64], &mut [f64], &mut [f64])) {
    let n = f.len();
    assert!(
        std::is_x86_feature_detected!("avx2") && fx.len() == n && fy.len() == n && tq.len() == n,
        "unpack_forces: slices of unequal length, or no AVX2"
    );
    // SAFETY: AVX2 present and every length n (checked above).
    unsafe { unpack_x4(f, fx, fy, tq) }
}

/// The state at t packed (the corrector's records: (x, y) and (v_x, v_y, ω, R)) and
/// 1/m, 1/I of some grains: what the next step's prediction reads besides the forces.
pub(crate) struct Packed0<'a> {
    pub pos: &'a [Pos],
    pub vel: &'a [Quad],
    pub inv_m: &'a [f64],
    pub inv_i: &'a [f64],
}

crate::avx2_entry_point! {
/// `unpack_x4`, and from the same sums (f_0 of the next step) and the state at t
/// (`now`, as the corrector packed it) that step's Eqs. 21–22 into `pos`, `vel`, with
/// its stray `test`: `predict_x4`'s operations lane for lane on the same values (the
/// sums are what `fx`, `fy`, `tq` receive, the records hold the arrays' state), so
/// the same bits, without a pass over the arrays.
///
/// # Safety
/// The processor must have AVX2, and every slice (the test's too) must have the length
/// of `f` (`unpack_and_predict`, the one caller, asserts it).
unsafe fn unpack_predict_x4(
    dt: f64,
    rotate: bool,
    f: &mut [Quad],
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    now: Packed0,
    pos: &mut [Pos],
    vel: &mut [Quad],
    test: Option<StrayTest>,
) -> Option<bool> {
    let Packed0 { pos: now_pos, vel: now_vel, inv_m, inv_i } = now;
    let n = f.len();
    let body = n - n % 4;
    // SAFETY: AVX2 present (this function's contract).
    let mut far = unsafe { _mm256_setzero_pd() };
    // SAFETY: i + 4 <= n for every i below, and every slice has length n.
    unsafe {
        let dt4 = _mm256_set1_pd(dt);
        for i in (0..body).step_by(4) {
            let (f0x, f0y, t0) = take4(f, i);
            st(fx, i, f0x);
            st(fy, i, f0y);
            st(tq, i, t0);
            let v = now_vel.as_ptr().add(i);
            let rec = |k: usize| _mm256_load_pd((*v.add(k)).0.as_ptr());
            let (vxi, vyi, wi, ri) = transpose(rec(0), rec(1), rec(2), rec(3));
            // [x0 y0 x1 y1] and [x2 y2 x3 y3] to [x0 x1 x2 x3] and [y0 y1 y2 y3].
            let s = now_pos.as_ptr().add(i).cast::<f64>();
            let (a, b) = (_mm256_loadu_pd(s), _mm256_loadu_pd(s.add(4)));
            let xi = _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpacklo_pd(a, b));
            let yi = _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_unpackhi_pd(a, b));
            let state = [xi, yi, vxi, vyi, wi];
            let im = ld(inv_m, i);
            let [px, py, pvx, pvy, pw] = predict4(dt4, rotate, state, [f0x, f0y, t0], im, || ld(inv_i, i));
            strays4(&test, i, px, py, &mut far);
            pack4(pos, vel, i, [px, py, pvx, pvy, pw, ri]);
        }
    }
    let mut tail = false;
    for i in body..n {
        let [f0x, f0y, t0, _] = std::mem::take(&mut f[i]).0;
        (fx[i], fy[i], tq[i]) = (f0x, f0y, t0);
        let ([x, y], [vx, vy, w, r]) = (now_pos[i].0, now_vel[i].0);
        let state = [x, y, vx, vy, w];
        let [px, py, pvx, pvy, pw] = predict1(dt, rotate, state, [f0x, f0y, t0], inv_m[i], inv_i[i]);
        pos[i] = Pos([px, py]);
        vel[i] = Quad([pvx, pvy, pw, r]);
        tail |= strays1(&test, i, px, py);
    }
    // SAFETY: AVX2 present (this function's contract).
    unsafe { answer(&test, far, tail) }
}
}

/// [`unpack_forces`] that also makes the next step's prediction from the sums (see
/// `unpack_predict_x4`) for the grains of `f` (any range: `now`, `out` and the test's
/// arrays that range's): the test's answer, as [`predict_packed`]'s. Panics unless
/// every length is `f`'s and the processor has AVX2.
#[allow(clippy::too_many_arguments)]
pub(crate) fn unpack_and_predict(
    dt: f64,
    rotate: bool,
    f: &mut [Quad],
    (fx, fy, tq): (&mut [f64], &mut [f64], &mut [f64]),
    now: Packed0,
    (pos, vel): (&mut [Pos], &mut [Quad]),
    test: Option<StrayTest>,
) -> Option<bool> {
    let n = f.len();
    let lens = [
        fx.len(),
        fy.len(),
        tq.len(),
        now.pos.len(),
        now.vel.len(),
        now.inv_m.len(),
        now.inv_i.len(),
        pos.len(),
        vel.len(),
    ];
    assert!(
        std::is_x86_feature_detected!("avx2")
            && lens.iter().all(|&l| l == n)
            && test.is_none_or(|t| t.x_ref.len() == n && t.y_ref.len() == n),
        "unpack_and_predict: slices of unequal length, or no AVX2"
    );
    // SAFETY: AVX2 present and every length n (checked above).
    unsafe { unpack_predict_x4(dt, rotate, f, fx, fy, tq, now, pos, vel, test) }
}
