//! The sheared disks' force evaluation (vagberg-sheared-disks Eqs. 1–7, 12–13) over a
//! flat list of pair slots, in two passes per block of slots:
//!
//! - **pass A** computes every slot's force, torques and separation with no branch and
//!   no store into shared arrays, so slots are independent: the loop vectorises (AVX2 or
//!   AVX-512 where the processor has them) and nothing waits on a mispredicted contact
//!   test or on the previous slot's force store;
//! - **pass B** adds the slot forces into the grains in slot order and keeps the contact
//!   bookkeeping (history, collision counts, virial).
//!
//! Each lane rounds as the scalar straight loop ([`super::shear_pairs::pair_loop`]) does,
//! and pass B adds in the same order, so the results are the same bit for bit (a test
//! holds them to it). Non-contact slots contribute +0.0, which leaves every sum as it was.

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

/// Pass A's results for one block of slots.
struct Block {
    /// Total pair force on i (elastic + dissipative), −that on j.
    fx: [f64; BLOCK],
    fy: [f64; BLOCK],
    /// Torques on i and on j (Eq. 7).
    ti: [f64; BLOCK],
    tj: [f64; BLOCK],
    /// Elastic and dissipative parts (for the virial, Eqs. 12–13), zero off contact.
    ex: [f64; BLOCK],
    ey: [f64; BLOCK],
    ddx: [f64; BLOCK],
    ddy: [f64; BLOCK],
    /// Minimum-image separation r_i − r_j.
    dx: [f64; BLOCK],
    dy: [f64; BLOCK],
    touch: [bool; BLOCK],
}

impl Block {
    fn new() -> Box<Block> {
        Box::new(Block {
            fx: [0.0; BLOCK],
            fy: [0.0; BLOCK],
            ti: [0.0; BLOCK],
            tj: [0.0; BLOCK],
            ex: [0.0; BLOCK],
            ey: [0.0; BLOCK],
            ddx: [0.0; BLOCK],
            ddy: [0.0; BLOCK],
            dx: [0.0; BLOCK],
            dy: [0.0; BLOCK],
            touch: [false; BLOCK],
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
    let st = (x, y, vx, vy, w, r);
    let mut blk = Block::new();
    let mut acc = Virial::default();
    let harmonic = pp.alpha == 2.0;
    for b0 in (0..slots.len()).step_by(BLOCK) {
        let b1 = (b0 + BLOCK).min(slots.len());
        let (si, sj) = (&slots.i[b0..b1], &slots.j[b0..b1]);
        let inv = &slots.inv_dij[b0..b1];
        match (pp.cdrot, harmonic) {
            (true, true) => pass_a_cdrot_harmonic(st, si, sj, inv, pp, &mut blk),
            (false, true) => pass_a_cd_harmonic(st, si, sj, inv, pp, &mut blk),
            (true, false) => pass_a_cdrot_general(st, si, sj, inv, pp, &mut blk),
            (false, false) => pass_a_cd_general(st, si, sj, inv, pp, &mut blk),
        }
        pass_b::<TRACK>(
            si,
            sj,
            &blk,
            &mut hist[b0..b1],
            pp.now,
            fx,
            fy,
            tq,
            coll,
            &mut acc,
        );
    }
    if TRACK {
        *vir = acc;
    }
}

macro_rules! pass_a_variant {
    ($name:ident, $cdrot:expr, $harmonic:expr) => {
        crate::multiversion! {
            fn $name(
                st: StateSlices,
                si: &[u32],
                sj: &[u32],
                inv_dij: &[f64],
                pp: &PairParams,
                blk: &mut Block,
            ) {
                pass_a::<{ $cdrot }, { $harmonic }>(st, si, sj, inv_dij, pp, blk)
            }
        }
    };
}
pass_a_variant!(pass_a_cdrot_harmonic, true, true);
pass_a_variant!(pass_a_cd_harmonic, false, true);
pass_a_variant!(pass_a_cdrot_general, true, false);
pass_a_variant!(pass_a_cd_general, false, false);

/// Pass A over one block: every slot's force, branch-free (contact or not is a select).
#[inline(always)]
fn pass_a<const CDROT: bool, const HARMONIC: bool>(
    (x, y, vx, vy, w, r): StateSlices,
    si: &[u32],
    sj: &[u32],
    inv_dij: &[f64],
    pp: &PairParams,
    b: &mut Block,
) {
    let (kd, alpha, shear_v) = (pp.kd, pp.alpha, pp.shear_v);
    let (ll, inv_l, offset) = (pp.ll, pp.inv_l, pp.offset);
    let len = si.len().min(sj.len()).min(inv_dij.len()).min(BLOCK);
    let n = x.len();
    for k in 0..len {
        let (i, j) = (si[k] as usize, sj[k] as usize);
        // SAFETY: `Slots::sync` checked every index against n, and `evaluate` that
        // every state slice has length n.
        debug_assert!(i < n && j < n);
        let at = |a: &[f64], m: usize| unsafe { *a.get_unchecked(m) };
        // Minimum image, Lees–Edwards (as Boundary::delta_image).
        let (dx, dy) = (at(x, i) - at(x, j), at(y, i) - at(y, j));
        let img = rint(dy * inv_l);
        let dy = dy - img * ll;
        let dx = dx - img * offset;
        let dx = dx - ll * rint(dx * inv_l);
        let (ri, rj) = (at(r, i), at(r, j));
        let dij = ri + rj;
        let r2 = dx * dx + dy * dy;
        let touch = r2 < dij * dij;
        let dist = r2.sqrt();
        let inv_dist = 1.0 / dist;
        let inv_dij = inv_dij[k];
        let (nx, ny) = (dx * inv_dist, dy * inv_dist);
        // Eq. 2 with d_ij = R_i + R_j and k_e = 1.
        let overlap = 1.0 - dist * inv_dij;
        let fe = if HARMONIC {
            overlap * inv_dij
        } else {
            // powf of a negative overlap is NaN; such lanes are masked below.
            overlap.max(0.0).powf(alpha - 1.0) * inv_dij
        };
        let (ex, ey) = (fe * nx, fe * ny);
        let (mut dvx, mut dvy) = (at(vx, i) - at(vx, j) - img * shear_v, at(vy, i) - at(vy, j));
        let (s_i, s_j) = (ri * inv_dij, rj * inv_dij);
        let (six, siy, sjx, sjy) = (-dx * s_i, -dy * s_i, dx * s_j, dy * s_j);
        if CDROT {
            let (wi, wj) = (at(w, i), at(w, j));
            dvx += -wi * siy + wj * sjy;
            dvy += wi * six - wj * sjx;
        }
        let (ddx, ddy) = (-kd * dvx, -kd * dvy);
        let sel = |v: f64| if touch { v } else { 0.0 };
        b.fx[k] = sel(ex + ddx);
        b.fy[k] = sel(ey + ddy);
        b.ti[k] = sel(six * ddy - siy * ddx);
        b.tj[k] = sel(sjx * (-ddy) - sjy * (-ddx));
        b.ex[k] = sel(ex);
        b.ey[k] = sel(ey);
        b.ddx[k] = sel(ddx);
        b.ddy[k] = sel(ddy);
        b.dx[k] = dx;
        b.dy[k] = dy;
        b.touch[k] = touch;
    }
}

/// Pass B over one block: slot forces into the grains in slot order (as the straight
/// loop adds them), and with `TRACK` the contact bookkeeping and the virial.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn pass_b<const TRACK: bool>(
    si: &[u32],
    sj: &[u32],
    b: &Block,
    hist: &mut [f64],
    now: f64,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
    coll: &mut Collisions,
    vir: &mut Virial,
) {
    let len = si.len().min(sj.len()).min(hist.len()).min(BLOCK);
    for k in 0..len {
        let (i, j) = (si[k] as usize, sj[k] as usize);
        fx[i] += b.fx[k];
        fy[i] += b.fy[k];
        fx[j] -= b.fx[k];
        fy[j] -= b.fy[k];
        tq[i] += b.ti[k];
        tq[j] += b.tj[k];
        if TRACK {
            let touch = b.touch[k];
            vir.contacts += touch as usize;
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
            let (ex, ey, ddx, ddy) = (b.ex[k], b.ey[k], b.ddx[k], b.ddy[k]);
            let (dx, dy) = (b.dx[k], b.dy[k]);
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
