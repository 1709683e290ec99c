//! The sheared disks' force evaluation (vagberg-sheared-disks Eqs. 1–7, 12–13) over a
//! flat list of pair slots, block by block of slots:
//!
//! - **separations**: every slot's minimum-image separation and contact test, branch-free
//!   and vectorised (AVX2), then the touching slots gathered into a short list;
//! - **contact forces**: force and torques of the touching slots only, vectorised; the
//!   square root and the division, which bound this pass, are not spent on the third of
//!   the slots that hold no contact;
//! - **sums**: the forces added into the grains, and with tracking the virial and the
//!   contact history, in slot order.
//!
//! No pass stores into a grain's array before the sums, so slots are independent and
//! nothing waits on a mispredicted contact test. Each lane rounds as the scalar straight
//! loop ([`super::shear_pairs::pair_loop`]) does and the sums add in its order, so the
//! results are the same bit for bit (a test holds them to it).

use super::shear::{Collisions, Virial, angle_bin};
use super::shear_pairs::{PairParams, StateSlices};
use super::verlet::{PairList, rint};

/// Slots per block: pass A's results for one block stay in L1 for pass B.
const BLOCK: usize = 128;

/// The pair list flattened into (i, j) per slot, in the list's order (so slot k's contact
/// history is `PairList::shear[k]`), with 1/(R_i + R_j) per slot (radii never change
/// while a list lives, and a stored quotient spares pass A one of its three divisions).
/// Indices are checked against `n` once, at build time, which lets the kernels index
/// without bounds checks.
#[derive(Debug, Clone, Default)]
pub struct Slots {
    i: Vec<u32>,
    j: Vec<u32>,
    /// 1/d_ij = 1/(R_i + R_j) (1/d_s).
    inv_dij: Vec<f64>,
    n: usize,
    /// `PairList::builds` this table was made from.
    builds: u64,
}

/// A cache of the pair list: two simulations never differ by it.
impl PartialEq for Slots {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Slots {
    /// Re-flatten when the list was rebuilt since the last call (`r`: radii, d_s).
    pub fn sync(&mut self, list: &PairList, r: &[f64]) {
        let n = r.len();
        if self.builds == list.builds && self.n == n && self.j.len() == list.j.len() {
            return;
        }
        self.i.clear();
        for a in 0..list.start.len().saturating_sub(1) {
            let len = list.start[a + 1] - list.start[a];
            self.i.extend(std::iter::repeat_n(a as u32, len as usize));
        }
        self.j.clone_from(&list.j);
        assert!(
            self.i.len() == self.j.len() && self.i.iter().chain(&self.j).all(|&v| (v as usize) < n),
            "pair list does not match the grains"
        );
        self.inv_dij.clear();
        let (si, sj) = (&self.i, &self.j);
        let inv = si
            .iter()
            .zip(sj)
            .map(|(&a, &b)| 1.0 / (r[a as usize] + r[b as usize]));
        self.inv_dij.extend(inv);
        self.n = n;
        self.builds = list.builds;
    }

    pub fn len(&self) -> usize {
        self.j.len()
    }
    pub fn is_empty(&self) -> bool {
        self.j.is_empty()
    }
}

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
    /// Elastic and dissipative parts, for the virial (Eqs. 12–13).
    ex: [f64; BLOCK],
    ey: [f64; BLOCK],
    ddx: [f64; BLOCK],
    ddy: [f64; BLOCK],
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
            ex: z,
            ey: z,
            ddx: z,
            ddy: z,
        })
    }
}

/// Forces and torques of every slot's contact added into `fx`, `fy`, `tq` (zeroed by
/// the caller); with `TRACK`, the history `hist` (0, or 1 + start time), the collision
/// counters and the virial sums Σ f ⊗ r_ij into `vir`. Same numbers as `pair_loop`.
#[allow(clippy::too_many_arguments)]
pub fn evaluate<const TRACK: bool>(
    st: StateSlices,
    slots: &Slots,
    hist: &mut [f64],
    pp: &PairParams,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    coll: &mut Collisions,
    vir: &mut Virial,
) {
    let n = slots.n;
    let (x, y, vx, vy, w, r) = st;
    assert!(
        [x.len(), y.len(), vx.len(), vy.len(), w.len(), r.len()]
            .iter()
            .chain(&[fx.len(), fy.len(), tq.len()])
            .all(|&l| l == n)
            && hist.len() == slots.len(),
        "state does not match the slot table"
    );
    let (mut sep, mut frc) = (Seps::new(), Forces::new());
    let mut acc = Virial::default();
    let harmonic = pp.alpha == 2.0;
    for b0 in (0..slots.len()).step_by(BLOCK) {
        let b1 = (b0 + BLOCK).min(slots.len());
        let (si, sj) = (&slots.i[b0..b1], &slots.j[b0..b1]);
        let inv = &slots.inv_dij[b0..b1];
        separations((x, y, r), si, sj, pp, &mut sep);
        let f = &mut frc;
        match (pp.cdrot, harmonic) {
            (true, true) => forces_cdrot_harmonic(st, si, sj, inv, pp, &sep, f),
            (false, true) => forces_cd_harmonic(st, si, sj, inv, pp, &sep, f),
            (true, false) => forces_cdrot_general(st, si, sj, inv, pp, &sep, f),
            (false, false) => forces_cd_general(st, si, sj, inv, pp, &sep, f),
        }
        let hist = &mut hist[b0..b1];
        sums::<TRACK>(si, sj, &sep, &frc, hist, pp.now, fx, fy, tq, coll, &mut acc);
    }
    if TRACK {
        *vir = acc;
    }
}

/// Reads a grain's value without a bounds check.
///
/// SAFETY (of every call): `Slots::sync` checked every index against n, and `evaluate`
/// that every state slice has length n.
#[inline(always)]
fn at<T: Copy>(a: &[T], m: usize) -> T {
    debug_assert!(m < a.len());
    unsafe { *a.get_unchecked(m) }
}

crate::multiversion! {
/// Minimum-image separations (as Boundary::delta_image) and contact tests of one block,
/// then the touching slots listed in order.
fn separations(
    xyr: (&[f64], &[f64], &[f64]),
    si: &[u32],
    sj: &[u32],
    pp: &PairParams,
    b: &mut Seps,
) {
    let (x, y, r) = xyr;
    let (ll, inv_l, offset) = (pp.ll, pp.inv_l, pp.offset);
    let len = si.len().min(sj.len()).min(BLOCK);
    for k in 0..len {
        let (i, j) = (si[k] as usize, sj[k] as usize);
        let (dx, dy) = (at(x, i) - at(x, j), at(y, i) - at(y, j));
        let img = rint(dy * inv_l);
        let dy = dy - img * ll;
        let dx = dx - img * offset;
        let dx = dx - ll * rint(dx * inv_l);
        let dij = at(r, i) + at(r, j);
        b.dx[k] = dx;
        b.dy[k] = dy;
        b.img[k] = img;
        b.touch[k] = dx * dx + dy * dy < dij * dij;
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

/// Force and torques of each touching slot of one block (Eqs. 2, 3 or 5–7).
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
    let (kd, alpha, shear_v) = (pp.kd, pp.alpha, pp.shear_v);
    // Every listed slot k < the block's length (`separations` wrote them), and every
    // slice here holds the block: `at` may skip the bounds checks that would keep this
    // loop from vectorising.
    debug_assert!(si.len() <= BLOCK && sj.len() == si.len() && inv_dij.len() == si.len());
    for m in 0..b.contacts.min(BLOCK) {
        let k = b.slot[m] as usize % BLOCK;
        debug_assert!(k < si.len());
        let (i, j) = (at(si, k) as usize, at(sj, k) as usize);
        let (dx, dy, img) = (b.dx[k], b.dy[k], b.img[k]);
        let r2 = dx * dx + dy * dy;
        let dist = r2.sqrt();
        let inv_dist = 1.0 / dist;
        let inv_dij = at(inv_dij, k);
        let (nx, ny) = (dx * inv_dist, dy * inv_dist);
        // Eq. 2 with d_ij = R_i + R_j and k_e = 1.
        let overlap = 1.0 - dist * inv_dij;
        let fe = if HARMONIC {
            overlap * inv_dij
        } else {
            overlap.powf(alpha - 1.0) * inv_dij
        };
        let (ex, ey) = (fe * nx, fe * ny);
        // Relative velocity; j's image moves img·γ̇L faster along x.
        let (mut dvx, mut dvy) = (at(vx, i) - at(vx, j) - img * shear_v, at(vy, i) - at(vy, j));
        // Moment arms s_ji (i to contact) = −r_ij R_i/d_ij, s_ij = r_ij R_j/d_ij.
        let (s_i, s_j) = (at(r, i) * inv_dij, at(r, j) * inv_dij);
        let (six, siy, sjx, sjy) = (-dx * s_i, -dy * s_i, dx * s_j, dy * s_j);
        if CDROT {
            // v_i + ω_i ẑ×s_ji − (v_j + ω_j ẑ×s_ij), Eq. 6.
            let (wi, wj) = (at(w, i), at(w, j));
            dvx += -wi * siy + wj * sjy;
            dvy += wi * six - wj * sjx;
        }
        let (ddx, ddy) = (-kd * dvx, -kd * dvy);
        o.fx[m] = ex + ddx;
        o.fy[m] = ey + ddy;
        // Eq. 7: torques of the dissipative force about each centre.
        o.ti[m] = six * ddy - siy * ddx;
        o.tj[m] = sjx * (-ddy) - sjy * (-ddx);
        o.ex[m] = ex;
        o.ey[m] = ey;
        o.ddx[m] = ddx;
        o.ddy[m] = ddy;
    }
}

/// The block's contact forces into the grains in slot order (as the straight loop adds
/// them), and with `TRACK` the virial and the contact bookkeeping.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sums<const TRACK: bool>(
    si: &[u32],
    sj: &[u32],
    b: &Seps,
    o: &Forces,
    hist: &mut [f64],
    now: f64,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    coll: &mut Collisions,
    vir: &mut Virial,
) {
    let len = si.len().min(sj.len()).min(hist.len());
    let nc = b.contacts.min(BLOCK);
    let pair = |m: usize| {
        let k = b.slot[m] as usize % BLOCK;
        debug_assert!(k < len);
        (at(si, k) as usize, at(sj, k) as usize, k)
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
        // f ⊗ r_ij (Eqs. 12–13), per unit area later; each component summed in slot
        // order, four at a time.
        let (mut el, mut dis) = (vir.el, vir.dis);
        for m in 0..nc {
            let (_, _, k) = pair(m);
            let (ex, ey, ddx, ddy) = (o.ex[m], o.ey[m], o.ddx[m], o.ddy[m]);
            let (dx, dy) = (b.dx[k], b.dy[k]);
            let e = [ex * dx, ex * dy, ey * dx, ey * dy];
            let d = [ddx * dx, ddx * dy, ddy * dx, ddy * dy];
            for c in 0..4 {
                el[c] += e[c];
                dis[c] += d[c];
            }
        }
        (vir.el, vir.dis) = (el, dis);
    }
    if TRACK {
        vir.contacts += b.contacts;
        for k in 0..len.min(BLOCK) {
            let touch = b.touch[k];
            if touch != (hist[k] != 0.0) {
                let (dx, dy) = (b.dx[k], b.dy[k]);
                if touch {
                    coll.begun += 1;
                    coll.angle_making[angle_bin(dx, dy)] += 1;
                    hist[k] = 1.0 + now;
                } else {
                    coll.ended += 1;
                    coll.angle_breaking[angle_bin(dx, dy)] += 1;
                    coll.duration_sum += now - (hist[k] - 1.0);
                    hist[k] = 0.0;
                }
            }
        }
    }
}
