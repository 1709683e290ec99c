//! The integrator of vagberg-sheared-disks Eqs. 21–24 as free functions over slices
//! (alias-free arguments keep the array pointers in registers; multiplying by stored
//! 1/m and 1/I instead of dividing saves ten divisions per grain and step).

/// Positions x, y, velocities v_x, v_y and spins ω of one state.
pub type Slices5<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64], &'a [f64]);

/// Eqs. 21–22 (and the spin analogue of 21): the predicted state (p*) from the state
/// at t and its forces f0 (units d_s = m = τ_e = 1). Spins stay 0 when `!rotate`.
#[allow(clippy::too_many_arguments)]
pub fn predict(
    dt: f64,
    rotate: bool,
    (x, y, vx, vy, w): Slices5,
    (inv_m, inv_i): (&[f64], &[f64]),
    (f0x, f0y, t0): (&[f64], &[f64], &[f64]),
    px: &mut [f64],
    py: &mut [f64],
    pvx: &mut [f64],
    pvy: &mut [f64],
    pw: &mut [f64],
) {
    let n = x.len();
    let (y, vx, vy, w) = (&y[..n], &vx[..n], &vy[..n], &w[..n]);
    let (inv_m, inv_i, f0x, f0y, t0) = (&inv_m[..n], &inv_i[..n], &f0x[..n], &f0y[..n], &t0[..n]);
    let (px, py, pvx, pvy, pw) = (
        &mut px[..n],
        &mut py[..n],
        &mut pvx[..n],
        &mut pvy[..n],
        &mut pw[..n],
    );
    for i in 0..n {
        pvx[i] = vx[i] + f0x[i] * dt * inv_m[i];
        pvy[i] = vy[i] + f0y[i] * dt * inv_m[i];
        px[i] = x[i] + vx[i] * dt;
        py[i] = y[i] + vy[i] * dt;
        pw[i] = if rotate {
            w[i] + t0[i] * dt * inv_i[i]
        } else {
            0.0
        };
    }
}

/// Eqs. 23–24 (and their spin analogues): the state at t + Δt from the forces at t
/// (f0) and at the predicted state (f1).
#[allow(clippy::too_many_arguments)]
pub fn correct(
    dt: f64,
    rotate: bool,
    (inv_m, inv_i): (&[f64], &[f64]),
    (f0x, f0y, t0): (&[f64], &[f64], &[f64]),
    (f1x, f1y, t1): (&[f64], &[f64], &[f64]),
    x: &mut [f64],
    y: &mut [f64],
    theta: &mut [f64],
    vx: &mut [f64],
    vy: &mut [f64],
    w: &mut [f64],
) {
    let n = x.len();
    let (y, theta, vx, vy, w) = (
        &mut y[..n],
        &mut theta[..n],
        &mut vx[..n],
        &mut vy[..n],
        &mut w[..n],
    );
    let (inv_m, inv_i, f0x, f0y, t0) = (&inv_m[..n], &inv_i[..n], &f0x[..n], &f0y[..n], &t0[..n]);
    let (f1x, f1y, t1) = (&f1x[..n], &f1y[..n], &t1[..n]);
    for i in 0..n {
        let (vx0, vy0) = (vx[i], vy[i]);
        vx[i] = vx0 + (f0x[i] + f1x[i]) * dt * (0.5 * inv_m[i]);
        vy[i] = vy0 + (f0y[i] + f1y[i]) * dt * (0.5 * inv_m[i]);
        x[i] += (vx0 + vx[i]) * dt * 0.5;
        y[i] += (vy0 + vy[i]) * dt * 0.5;
    }
    if rotate {
        for i in 0..n {
            let w0 = w[i];
            w[i] = w0 + (t0[i] + t1[i]) * dt * (0.5 * inv_i[i]);
            theta[i] += (w0 + w[i]) * dt * 0.5;
        }
    }
}
