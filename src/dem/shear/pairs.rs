//! The sheared disks' pair loop (vagberg-sheared-disks Eqs. 1–7, 12–13) as a free
//! function over slices: slice arguments cannot alias, so the compiler keeps the array
//! pointers in registers instead of reloading them after every force store. `HISTORY`:
//! actual states keep the contact bookkeeping (the predictor of Eq. 22 needs forces
//! only); `VIRIAL`: the virial, only at the states the outputs sample.

use crate::dem::law::{ContactLaw, Damping, Motion};
use crate::dem::shear::near::contact_event;
use crate::dem::shear::params::{Collisions, StateSlices, Virial};
use crate::geom::MinImage;

/// Everything the pair loop reads besides the state (units d_s = m = τ_e = 1).
#[derive(Debug, Clone, Copy)]
pub struct PairParams {
    /// The contact law (Eqs. 2–3 or 5–7): the vector kernels implement the harmonic
    /// one (`ContactLaw::is_harmonic_vagberg`), the reference loop any.
    pub law: ContactLaw,
    /// The law's k_d = 1/Q and exponent α of Eq. 1, for the kernels.
    pub kd: f64,
    pub alpha: f64,
    /// γ̇ L, the velocity jump across the Lees–Edwards boundary.
    pub shear_v: f64,
    /// The law is CDrot (contact-point velocities, Eq. 6) rather than CD.
    pub cdrot: bool,
    /// The box's minimum image (`geom::MinImage`), and for the vector kernels its
    /// side L, 1/L and Lees–Edwards offset γ L.
    pub image: MinImage,
    pub ll: f64,
    pub inv_l: f64,
    pub offset: f64,
    /// Current time; contact start times are stored as 1 + t.
    pub now: f64,
}

impl PairParams {
    /// For `p` in a box of side `l` with Lees–Edwards offset `offset` at time `now`.
    pub fn new(p: &crate::dem::shear::params::ShearParams, l: f64, offset: f64, now: f64) -> Self {
        let law = p.law();
        let (k_d, cdrot) = match law.damping() {
            Damping::CdRot { k_d } => (k_d, true),
            Damping::Cd { k_d } => (k_d, false),
            // Laws the vector kernels do not implement run the reference loop.
            Damping::None | Damping::ViscousNormal { .. } | Damping::CdNormal { .. } => {
                (0.0, false)
            }
        };
        PairParams {
            law,
            kd: k_d,
            alpha: p.alpha,
            shear_v: p.rate * l,
            cdrot,
            image: MinImage::new(l, l, offset),
            ll: l,
            inv_l: 1.0 / l,
            offset,
            now,
        }
    }
}

/// Forces and torques of the contacts in the half list (`start`, `js`) into `fx`, `fy`,
/// `tq` (overwritten); with `HISTORY`, per-pair history `hist` (0, or 1 + start time) and
/// the collision counters; with `VIRIAL`, the contact count and the virial sums
/// Σ f ⊗ r_ij into `out_vir` (units m d_s²/τ_e²; the reference the sampled virial's
/// ranges, [`for_each_virial_term`], are tested against).
#[allow(clippy::too_many_arguments)]
pub fn pair_loop<const HISTORY: bool, const VIRIAL: bool>(
    (x, y, vx, vy, w, r): StateSlices,
    start: &[u32],
    js: &[u32],
    hist: &mut [f64],
    pp: &PairParams,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    coll: &mut Collisions,
    out_vir: &mut Virial,
) {
    for v in [&mut *fx, &mut *fy, &mut *tq] {
        v.fill(0.0);
    }
    let mut vir = Virial::default();
    let track = HISTORY;
    let (law, shear_v) = (&pp.law, pp.shear_v);
    let (image, now) = (pp.image, pp.now);
    for i in 0..x.len() {
        for k in start[i] as usize..start[i + 1] as usize {
            let j = js[k] as usize;
            let ((dx, dy), m) = separation_and_motion((x, y, vx, vy, w), (i, j), image, shear_v);
            let mut no_history = 0.0;
            let c = law.pair((dx, dy), (r[i], r[j]), m, &mut no_history, 0.0);
            if track {
                hist[k] = contact_event(hist[k], c.is_some(), (dx, dy), (m.dvx, m.dvy), now, coll);
            }
            let Some(c) = c else { continue };
            if VIRIAL {
                vir.contacts += 1;
            }
            fx[i] += c.fx;
            fy[i] += c.fy;
            fx[j] -= c.fx;
            fy[j] -= c.fy;
            tq[i] += c.t_i;
            tq[j] += c.t_j;
            if VIRIAL {
                // f ⊗ r_ij (Eqs. 12–13), per unit area later.
                let (ex, ey) = (c.f_n * c.n.0, c.f_n * c.n.1);
                let (ddx, ddy) = c.dis;
                vir.el[0] += ex * dx;
                vir.el[1] += ex * dy;
                vir.el[2] += ey * dx;
                vir.el[3] += ey * dy;
                vir.dis[0] += ddx * dx;
                vir.dis[1] += ddx * dy;
                vir.dis[2] += ddy * dx;
                vir.dis[3] += ddy * dy;
            }
        }
    }
    if VIRIAL {
        *out_vir = vir;
    }
}

/// The separation r_i − r_j of pair (i, j) (its minimum image) and their relative
/// motion: j's image moves img·γ̇L faster along x (`shear_v` = γ̇L).
#[inline(always)]
fn separation_and_motion(
    (x, y, vx, vy, w): crate::dem::shear::integrate::Slices5,
    (i, j): (usize, usize),
    image: MinImage,
    shear_v: f64,
) -> ((f64, f64), Motion) {
    let (dx, dy, img) = image.with_index(x[i] - x[j], y[i] - y[j]);
    let m = Motion {
        dvx: vx[i] - vx[j] - img * shear_v,
        dvy: vy[i] - vy[j],
        w_i: w[i],
        w_j: w[j],
    };
    ((dx, dy), m)
}

/// The virial terms of the contacts of grains `grains` (their slots of the half list
/// `start`, `js`), each to `f` in slot order: per contact f^el ⊗ r_ij, then
/// f^dis ⊗ r_ij (Eqs. 12–13, each xx, xy, yx, yy), as `pair_loop` with `VIRIAL` adds
/// them. Added in order over every grain ([`add_virial`]) they give its sums bit for
/// bit, however the grains were split (ranges computed apart, on any threads).
pub fn for_each_virial_term(
    (x, y, vx, vy, w, r): StateSlices,
    (start, js): (&[u32], &[u32]),
    pp: &PairParams,
    grains: std::ops::Range<usize>,
    mut f: impl FnMut([f64; 8]),
) {
    let (law, shear_v, image) = (&pp.law, pp.shear_v, pp.image);
    for i in grains {
        for &j in &js[start[i] as usize..start[i + 1] as usize] {
            let j = j as usize;
            let ((dx, dy), m) = separation_and_motion((x, y, vx, vy, w), (i, j), image, shear_v);
            let mut no_history = 0.0;
            let Some(c) = law.pair((dx, dy), (r[i], r[j]), m, &mut no_history, 0.0) else {
                continue;
            };
            let (ex, ey) = (c.f_n * c.n.0, c.f_n * c.n.1);
            let (ddx, ddy) = c.dis;
            f([
                ex * dx,
                ex * dy,
                ey * dx,
                ey * dy,
                ddx * dx,
                ddx * dy,
                ddy * dx,
                ddy * dy,
            ]);
        }
    }
}

/// One contact's virial terms ([`for_each_virial_term`]) added to `vir`.
pub fn add_virial(vir: &mut Virial, t: [f64; 8]) {
    vir.contacts += 1;
    for a in 0..4 {
        vir.el[a] += t[a];
        vir.dis[a] += t[4 + a];
    }
}
