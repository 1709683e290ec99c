//! The sheared disks' force evaluation (vagberg-sheared-disks Eqs. 1–7) over a
//! flat list of pair slots, block by block of slots:
//!
//! - **separations**: every slot's minimum-image separation and contact test, branch-free
//!   and vectorised (AVX2), then the touching slots gathered into a short list;
//! - **contact forces**: force and torques of the touching slots only, vectorised; the
//!   square root and the division, which bound this pass, are not spent on the third of
//!   the slots that hold no contact;
//! - **sums**: the forces added into the grains, and with tracking the contact history,
//!   in slot order.
//!
//! No pass stores into a grain's array before the sums, so slots are independent and
//! nothing waits on a mispredicted contact test. Each lane rounds as the scalar straight
//! loop ([`crate::dem::shear::pairs::pair_loop`]) does and the sums add in its order, so the
//! results are the same bit for bit (a test holds them to it).

use crate::dem::law::{ContactLaw, ContactPoint, Damping, Motion, Normal, Tangential};
use crate::dem::shear::near::{History, Slots};
use crate::dem::shear::pairs::PairParams;
use crate::dem::shear::params::Collisions;
use crate::dem::shear::params::StateSlices;

/// Slots per block: pass A's results for one block stay in L1 for pass B.
const BLOCK: usize = 128;

/// One block's separations: per slot (`k`), then the touching slots listed.
struct Seps {
    /// Minimum-image separation r_i − r_j and the y image index of j.
    dx: [f64; BLOCK],
    dy: [f64; BLOCK],
    img: [f64; BLOCK],
    touch: [bool; BLOCK],
    /// Slot (within the block) of the m-th touching pair; `contacts` of them.
    slot: [u32; BLOCK],
    contacts: usize,
}

/// One block's contact forces, per touching slot (`m`). Kept apart from [`Seps`] so the
/// kernel's reads and writes are provably disjoint (else it does not vectorise).
struct Forces {
    /// Total pair force on i (elastic + dissipative), −that on j.
    fx: [f64; BLOCK],
    fy: [f64; BLOCK],
    /// Torques on i and on j (Eq. 7).
    ti: [f64; BLOCK],
    tj: [f64; BLOCK],
}

impl Seps {
    fn new() -> Box<Seps> {
        let z = [0.0; BLOCK];
        Box::new(Seps {
            dx: z,
            dy: z,
            img: z,
            touch: [false; BLOCK],
            slot: [0; BLOCK],
            contacts: 0,
        })
    }
}

impl Forces {
    fn new() -> Box<Forces> {
        let z = [0.0; BLOCK];
        Box::new(Forces {
            fx: z,
            fy: z,
            ti: z,
            tj: z,
        })
    }
}

/// Forces and torques of every slot's contacts into `fx`, `fy`, `tq` (overwritten); with
/// `TRACK`, the near list's contact history and the collision counters. Same
/// numbers as `pair_loop`.
#[allow(clippy::too_many_arguments)]
pub fn evaluate<const TRACK: bool>(
    st: StateSlices,
    slots: &mut Slots,
    packed: &mut crate::dem::shear::integrate::Packed,
    all_hist: &mut [f64],
    pp: &PairParams,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    coll: &mut Collisions,
) {
    let n = slots.n;
    let (x, y, vx, vy, w, r) = st;
    assert!(
        [x.len(), y.len(), vx.len(), vy.len(), w.len(), r.len()]
            .iter()
            .chain(&[fx.len(), fy.len(), tq.len()])
            .all(|&l| l == n)
            && slots.hist.len() >= slots.len(),
        "state does not match the slot table"
    );
    // The vector kernels implement the harmonic law only.
    let harmonic = pp.law.is_harmonic_vagberg().is_some();
    #[cfg(target_arch = "x86_64")]
    if harmonic && crate::dem::backend::simd::level() >= crate::dem::backend::simd::Level::Avx2 {
        packed.fill(st);
        evaluate_packed_into::<TRACK>(packed, slots, all_hist, pp, coll, (fx, fy, tq));
        return;
    }
    for v in [&mut *fx, &mut *fy, &mut *tq] {
        v.fill(0.0);
    }
    let (mut sep, mut frc) = (Seps::new(), Forces::new());
    slots.with_history(all_hist, |slots, hist| {
        for b0 in (0..slots.len()).step_by(BLOCK) {
            let b1 = (b0 + BLOCK).min(slots.len());
            let (si, sj) = (&slots.i[b0..b1], &slots.j[b0..b1]);
            let (inv, dij2) = (&slots.inv_dij[b0..b1], &slots.dij2[b0..b1]);
            separations((x, y), si, sj, dij2, pp, &mut sep);
            let f = &mut frc;
            match (pp.cdrot, harmonic) {
                (true, true) => forces_cdrot_harmonic(st, si, sj, inv, pp, &sep, f),
                (false, true) => forces_cd_harmonic(st, si, sj, inv, pp, &sep, f),
                (true, false) => forces_cdrot_general(st, si, sj, inv, pp, &sep, f),
                (false, false) => forces_cd_general(st, si, sj, inv, pp, &sep, f),
            }
            sums::<TRACK>(
                si,
                sj,
                &sep,
                &frc,
                (hist, b0),
                (vx, vy),
                pp,
                fx,
                fy,
                tq,
                coll,
            );
        }
    });
}

/// As [`evaluate`] (α = 2, AVX2 only) on a state packed grain by grain: the force and
/// torque sums (f_x, f_y, T, ·) per grain into `slots.acc`, handed to `done` range by
/// range as they are complete (see `near::Done`). The packed integrator
/// (`shear_integrate_avx2`) reads them there, sparing a pass that would spread them
/// into arrays. Same numbers as [`evaluate`].
#[cfg(target_arch = "x86_64")]
pub(crate) fn evaluate_packed<const TRACK: bool>(
    packed: &crate::dem::shear::integrate::Packed,
    slots: &mut Slots,
    all_hist: &mut [f64],
    pp: &PairParams,
    coll: &mut Collisions,
    done: crate::dem::shear::near::Done,
) {
    let n = slots.n;
    assert!(
        std::is_x86_feature_detected!("avx2")
            && pp.alpha == 2.0
            && packed.pos.len() == n
            && packed.vel.len() == n
            && slots.hist.len() >= slots.len(),
        "packed state does not match the slot table, or no AVX2"
    );
    let mut acc = std::mem::take(&mut slots.acc);
    let zeroed = std::mem::take(&mut slots.acc_zeroed);
    // SAFETY: the processor has AVX2 and the packed state holds the slots' n grains
    // (both checked above); `Slots::sync` checked the slots' indices.
    slots.with_history(all_hist, |slots, hist| unsafe {
        crate::dem::backend::shear_avx2::evaluate::<TRACK>(
            &packed.pos,
            &packed.vel,
            slots,
            &mut acc,
            zeroed,
            hist,
            pp,
            coll,
            0..n,
            done,
        );
    });
    slots.acc = acc;
}

/// [`evaluate_packed`] with the sums spread into `fx`, `fy`, `tq` (overwritten) range by
/// range as they are complete, and left zeroed for the next evaluation.
#[cfg(target_arch = "x86_64")]
pub(crate) fn evaluate_packed_into<const TRACK: bool>(
    packed: &crate::dem::shear::integrate::Packed,
    slots: &mut Slots,
    all_hist: &mut [f64],
    pp: &PairParams,
    coll: &mut Collisions,
    (fx, fy, tq): (&mut [f64], &mut [f64], &mut [f64]),
) {
    use crate::dem::backend::shear_integrate_avx2::unpack_forces;
    let mut unpack =
        |r: std::ops::Range<usize>, f: &mut [crate::dem::shear::integrate::Quad], _: &Slots| {
            unpack_forces(f, (&mut fx[r.clone()], &mut fy[r.clone()], &mut tq[r]));
        };
    evaluate_packed::<TRACK>(packed, slots, all_hist, pp, coll, &mut unpack);
    slots.acc_zeroed = true;
}

/// Reads `a[m]` without a bounds check.
///
/// # Safety
/// `m < a.len()`. At every call below, m is a grain index from the near list (checked
/// against n by `Slots::select`, with every state slice of length n checked by
/// `evaluate`) or a slot of the current block that `separations` listed.
#[inline(always)]
unsafe fn at<T: Copy>(a: &[T], m: usize) -> T {
    debug_assert!(m < a.len());
    unsafe { *a.get_unchecked(m) }
}

crate::multiversion! {
/// Minimum-image separations (`geom::MinImage`) and contact tests of one block,
/// then the touching slots listed in order.
fn separations(
    xy: (&[f64], &[f64]),
    si: &[u32],
    sj: &[u32],
    dij2: &[f64],
    pp: &PairParams,
    b: &mut Seps,
) {
    let (x, y) = xy;
    let image = pp.image;
    let len = si.len().min(sj.len()).min(dij2.len()).min(BLOCK);
    for k in 0..len {
        let (i, j) = (si[k] as usize, sj[k] as usize);
        // SAFETY: see `at`.
        let (dx, dy) = unsafe { (at(x, i) - at(x, j), at(y, i) - at(y, j)) };
        let (dx, dy, img) = image.with_index(dx, dy);
        b.dx[k] = dx;
        b.dy[k] = dy;
        b.img[k] = img;
        // "Not apart", as the straight loop tests it (a NaN separation counts).
        b.touch[k] = !(dx * dx + dy * dy >= dij2[k]);
    }
    let mut m = 0;
    for k in 0..len {
        b.slot[m] = k as u32;
        m += b.touch[k] as usize;
    }
    b.contacts = m;
}
}

macro_rules! forces_variant {
    ($name:ident, $cdrot:expr, $harmonic:expr) => {
        crate::multiversion! {
            fn $name(
                st: StateSlices,
                si: &[u32],
                sj: &[u32],
                inv_dij: &[f64],
                pp: &PairParams,
                sep: &Seps,
                out: &mut Forces,
            ) {
                contact_forces::<{ $cdrot }, { $harmonic }>(st, si, sj, inv_dij, pp, sep, out)
            }
        }
    };
}
forces_variant!(forces_cdrot_harmonic, true, true);
forces_variant!(forces_cd_harmonic, false, true);
forces_variant!(forces_cdrot_general, true, false);
forces_variant!(forces_cd_general, false, false);

/// Force and torques of each touching slot of one block by the law's scalar reference
/// ([`ContactLaw::pair`], Eqs. 2, 3 or 5–7), with the law rebuilt from the constants
/// so that its choices fold away.
#[inline(always)]
fn contact_forces<const CDROT: bool, const HARMONIC: bool>(
    (_, _, vx, vy, w, r): StateSlices,
    si: &[u32],
    sj: &[u32],
    inv_dij: &[f64],
    pp: &PairParams,
    b: &Seps,
    o: &mut Forces,
) {
    let k_d = pp.kd;
    let law = ContactLaw::rebuilt(
        Normal::RelativePowerLaw {
            alpha: if HARMONIC { 2.0 } else { pp.alpha },
        },
        if CDROT {
            Damping::CdRot { k_d }
        } else {
            Damping::Cd { k_d }
        },
        Tangential::None,
        ContactPoint::RadiusRatio,
    );
    debug_assert!(law == pp.law);
    let shear_v = pp.shear_v;
    // Every listed slot k < the block's length (`separations` wrote them), and every
    // slice here holds the block: `at` may skip the bounds checks.
    debug_assert!(si.len() <= BLOCK && sj.len() == si.len() && inv_dij.len() == si.len());
    for m in 0..b.contacts.min(BLOCK) {
        let k = b.slot[m] as usize % BLOCK;
        debug_assert!(k < si.len());
        // SAFETY (this and the reads below): see `at`.
        let (i, j) = unsafe { (at(si, k) as usize, at(sj, k) as usize) };
        let (dx, dy, img) = (b.dx[k], b.dy[k], b.img[k]);
        // j's image moves img·γ̇L faster along x.
        let motion = unsafe {
            Motion {
                dvx: at(vx, i) - at(vx, j) - img * shear_v,
                dvy: at(vy, i) - at(vy, j),
                w_i: at(w, i),
                w_j: at(w, j),
            }
        };
        let radii = unsafe { (at(r, i), at(r, j)) };
        let mut no_history = 0.0;
        // `separations` listed the slot as touching, by the same test.
        let inv = unsafe { at(inv_dij, k) };
        let c = law.in_contact((dx, dy), radii, inv, motion, &mut no_history, 0.0);
        o.fx[m] = c.fx;
        o.fy[m] = c.fy;
        o.ti[m] = c.t_i;
        o.tj[m] = c.t_j;
    }
}

/// The block's contact forces into the grains in slot order (as the straight loop adds
/// them), and with `TRACK` the contact bookkeeping.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sums<const TRACK: bool>(
    si: &[u32],
    sj: &[u32],
    b: &Seps,
    o: &Forces,
    (hist, b0): (&mut History, usize),
    (vx, vy): (&[f64], &[f64]),
    pp: &PairParams,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    coll: &mut Collisions,
) {
    let len = si.len().min(sj.len());
    let nc = b.contacts.min(BLOCK);
    let pair = |m: usize| {
        let k = b.slot[m] as usize % BLOCK;
        debug_assert!(k < len);
        // SAFETY: see `at`.
        unsafe { (at(si, k) as usize, at(sj, k) as usize, k) }
    };
    // Grain q receives its j-side terms (slots (i', q), i' < q) before its own slots
    // (q, j) in slot order, so adding all j-side terms of the block first, then all
    // i-side ones, keeps every grain's order of additions: the same sums. Split, the
    // i-side additions of a grain's run of slots no longer wait behind j-side stores.
    for m in 0..nc {
        let (_, j, _) = pair(m);
        fx[j] -= o.fx[m];
        fy[j] -= o.fy[m];
        tq[j] += o.tj[m];
    }
    for m in 0..nc {
        let (i, _, _) = pair(m);
        fx[i] += o.fx[m];
        fy[i] += o.fy[m];
        tq[i] += o.ti[m];
    }
    if TRACK {
        for k in 0..len.min(BLOCK) {
            // As `contact_forces`' Motion: j's image moves img·γ̇L faster along x.
            let dv = || {
                let (i, j) = (si[k] as usize, sj[k] as usize);
                (vx[i] - vx[j] - b.img[k] * pp.shear_v, vy[i] - vy[j])
            };
            hist.update(b0 + k, b.touch[k], (b.dx[k], b.dy[k]), dv, pp.now, coll);
        }
    }
}
