//! One pillar step (li-granular-pillars Sec. II.B) as phases that each write only a
//! range of grains, or the pair slots those grains own, so threads can share a step
//! without locks and without the answer depending on how the grains were split:
//!
//! 1. kick and drift (per grain), marking the grains at rest before the move;
//! 2. every pair's contact force into its own slot (per pair, half list);
//! 3. which grains are frozen (per grain, reading every grain's rest flag), each
//!    grain's sum over its slots in a fixed order (own slots, then the slots where it is
//!    the partner), the bars, the substrate and the second kick (per grain).
//!
//! Sums over grains (bar forces, dissipated power) are formed per [`CHUNK`] of grains
//! and the chunks added in order; threads get whole chunks. So every thread count gives
//! the same numbers, bit for bit.

use crate::dem::backend::simd::{Pos, Quad};
use crate::dem::law::{ContactLaw, Motion};
use std::ops::Range;

pub use crate::dem::pillar::reverse::{CHUNK, Reverse};

/// Grains in `range` frozen this step (at rest, every partner at rest, clear of both
/// bars by a margin of one step of bar travel); `frozen` and `y` hold the range's
/// values, `resting` and `radius` every grain's. Returns how many.
///
/// Worked from the other side: the range's grains at rest and clear of the bars are
/// marked, then every grain not at rest (anywhere) unmarks its partners in the range
/// (`Reverse::neighbour`, the same relation both ways). Most grains rest where marking
/// pays, so this touches a few partner lists instead of walking every grain's (that
/// walk, a loop exit to mispredict per grain, cost a fifth of a quasistatic step).
pub fn mark_frozen(
    range: Range<usize>,
    frozen: &mut [bool],
    resting: &[bool],
    y: &[f64],
    rev: &Reverse,
    (top, bottom, margin): (f64, f64, f64),
    radius: &[f64],
) -> usize {
    let lo = range.start;
    let frozen = &mut frozen[..range.len()];
    for ((f, i), &yi) in frozen.iter_mut().zip(range).zip(y) {
        *f = resting[i] & (top - yi > radius[i] + margin) & (yi - bottom > radius[i]);
    }
    // Only grains within the range's chunks' reach can unmark one of its grains.
    let chunks = lo / CHUNK..(lo + frozen.len()).div_ceil(CHUNK);
    let Some(first) = rev.reach[chunks.clone()].iter().map(|r| r.0).min() else {
        return 0;
    };
    let last = rev.reach[chunks].iter().map(|r| r.1).max().unwrap_or(first);
    let from = first as usize / 8 * 8;
    let span = &resting[from..resting.len().min(last as usize + 1)];
    // Eight rest flags (0 or 1) at a time: the grains not at rest are the zero bytes.
    const ONES: u64 = 0x0101_0101_0101_0101;
    for (w, flags) in span.chunks(8).enumerate() {
        let mut word = [1u8; 8];
        for (b, &r) in word.iter_mut().zip(flags) {
            *b = r as u8;
        }
        let mut moving = !u64::from_le_bytes(word) & ONES;
        while moving != 0 {
            let g = from + w * 8 + (moving.trailing_zeros() / 8) as usize;
            moving &= moving - 1;
            for &j in &rev.neighbour[rev.places_of(g)] {
                if let Some(f) = frozen.get_mut((j as usize).wrapping_sub(lo)) {
                    *f = false;
                }
            }
        }
    }
    frozen.iter().filter(|&&f| f).count()
}

/// Where the pair phase puts each slot's force and torque (f_x, f_y, T, 0) (N, N, N m):
/// into its owner's term
/// and, with x and y negated, into its partner's, in an array of per-grain terms in
/// which each grain's are contiguous, in the order the grain sums them (own slots, then
/// those where it is the partner, each ascending). The sums then read memory in order
/// instead of chasing the partner slots. Every thread's pair phase writes it at once;
/// each slot's two places are its own.
#[derive(Clone, Copy)]
pub struct TermSink<'a> {
    terms: *mut Quad,
    len: usize,
    /// `Reverse::term_own` and `term_partner` for the slots the phase computes (its
    /// first slot at index 0).
    own: &'a [u32],
    partner: &'a [u32],
}

impl<'a> TermSink<'a> {
    /// # Safety
    /// `terms` points at `len` terms; every index in `own` and `partner` is below `len`
    /// (`end_layout` checks it), and no other thread touches those places
    /// while the sink is used.
    pub unsafe fn new(terms: *mut Quad, len: usize, own: &'a [u32], partner: &'a [u32]) -> Self {
        assert_eq!(
            own.len(),
            partner.len(),
            "one owner and one partner term per slot"
        );
        TermSink {
            terms,
            len,
            own,
            partner,
        }
    }

    /// Slot s's force onto its owner and its partner.
    #[inline(always)]
    pub fn put(&self, s: usize, q: Quad) {
        let (a, b) = (self.own[s] as usize, self.partner[s] as usize);
        assert!(a < self.len && b < self.len, "term within the array");
        // SAFETY: in bounds (above); the places are this slot's alone (`new`).
        unsafe {
            *self.terms.add(a) = q;
            *self.terms.add(b) = Quad([-q.0[0], -q.0[1], q.0[2], q.0[3]]);
        }
    }

    /// The raw parts, for the vector kernel.
    pub(crate) fn parts(&self) -> (*mut Quad, usize, &'a [u32], &'a [u32]) {
        (self.terms, self.len, self.own, self.partner)
    }
}

/// Positions (m), velocities (m/s), spins (rad/s) and radii (m) of every grain.
#[derive(Clone, Copy)]
pub struct GrainState<'a> {
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub vx: &'a [f64],
    pub vy: &'a [f64],
    pub omega: &'a [f64],
    pub radius: &'a [f64],
}

/// Per-slot contact magnitudes for force snapshots: F_n (N), |F_t| (N), touching.
pub struct SlotRecord<'a> {
    pub f_n: &'a mut [f64],
    pub f_t: &'a mut [f64],
    pub touching: &'a mut [bool],
}

/// Phase 2: the contact of every pair slot owned by the grains in `range` (slots
/// `start[range.start]..start[range.end]`, which `shear`, `sink` and `rec` hold):
/// see [`slot_contact`]. A slot between two grains `resting` this step (v = a = ω = 0
/// before the drift, so neither moves, and no slip adds to the history) keeps last
/// step's values, which are then exactly what it would compute: the same positions, an
/// unchanged shear spring, and, without normal damping (the caller's condition), no
/// velocity term (its terms keep theirs too). Returns the slots skipped.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
pub fn pair_slots(
    range: Range<usize>,
    g: GrainState,
    (start, js): (&[u32], &[u32]),
    shear: &mut [f64],
    sink: TermSink,
    resting: Option<&[bool]>,
    laws: (&ContactLaw, f64),
    mut rec: Option<SlotRecord>,
) -> u64 {
    let k0 = start[range.start] as usize;
    let mut skipped = 0u64;
    for i in range {
        let fi = resting.is_some_and(|f| f[i]);
        for k in start[i] as usize..start[i + 1] as usize {
            let j = js[k] as usize;
            let s = k - k0;
            if fi && resting.is_some_and(|f| f[j]) {
                skipped += 1;
                continue;
            }
            let mut force = Quad::default();
            let contact = slot_contact(i, j, &g, &mut shear[s], &mut force, laws);
            sink.put(s, force);
            if let Some(r) = rec.as_mut() {
                r.touching[s] = contact.is_some();
                if let Some((f_n, f_t)) = contact {
                    r.f_n[s] = f_n;
                    r.f_t[s] = f_t.abs();
                }
            }
        }
    }
    skipped
}

/// The contact of grains i and j by the law's scalar reference
/// ([`ContactLaw::pair`]): into `out` the force on i (N, x and y), the torque on each
/// grain (N m; the laws the pillar uses give both grains the same) and a zero; `shear`
/// is the slot's tangential spring (m). Separated pairs forget their history and hold
/// zeros (and return `None`); touching ones return (F_n, F_t) (N).
#[inline(always)]
pub fn slot_contact(
    i: usize,
    j: usize,
    g: &GrainState,
    shear: &mut f64,
    out: &mut Quad,
    (law, dt): (&ContactLaw, f64),
) -> Option<(f64, f64)> {
    let m = Motion {
        dvx: g.vx[i] - g.vx[j],
        dvy: g.vy[i] - g.vy[j],
        w_i: g.omega[i],
        w_j: g.omega[j],
    };
    let d = (g.x[i] - g.x[j], g.y[i] - g.y[j]);
    match law.pair(d, (g.radius[i], g.radius[j]), m, shear, dt) {
        None => {
            *out = Quad([0.0; 4]);
            None
        }
        Some(c) => {
            debug_assert!(
                c.t_i == c.t_j,
                "the pillar's sink stores one torque per slot"
            );
            *out = Quad([c.fx, c.fy, c.t_i, 0.0]);
            Some((c.f_n, c.f_t))
        }
    }
}

/// The bars as grains of infinite radius with 2 k_n and 2 k_t and friction μ_bar
/// (Sec. II.B.2): the top face at height `top` (m) moving down at `v_bar` (m/s), the
/// bottom face at `bottom` (m), fixed; time step `dt` (s).
#[derive(Clone, Copy)]
pub struct Bars {
    /// The grain–bar law ([`crate::dem::pillar::params::PillarParams::bar_law`]).
    pub law: ContactLaw,
    pub top: f64,
    pub bottom: f64,
    pub v_bar: f64,
    pub dt: f64,
}

/// One grain's view for the bar contacts (its slices of the range).
pub struct BarGrains<'a> {
    pub y: &'a [f64],
    pub vx: &'a [f64],
    pub vy: &'a [f64],
    pub omega: &'a [f64],
    pub radius: &'a [f64],
    pub frozen: Option<&'a [bool]>,
    pub top_shear: &'a mut [f64],
    pub bottom_shear: &'a mut [f64],
    /// On force-snapshot steps: each grain's normal force from the top bar (N), zero
    /// where it does not touch it (li-granular-pillars Fig. 10c's contact pressure).
    pub top_fn: Option<&'a mut [f64]>,
}

/// Phase 3b: grain–bar contacts of a range (all slices are the range's), added into
/// `fx`, `fy`, `tq`; returns Σ F_n on the top bar, on the bottom bar, and Σ of the
/// bars' tangential forces on the grains (N).
pub fn bar_contacts(
    b: &Bars,
    mut g: BarGrains,
    fx: &mut [f64],
    fy: &mut [f64],
    tq: &mut [f64],
) -> [f64; 3] {
    let (mut top_force, mut bottom_force, mut shear_force) = (0.0, 0.0, 0.0);
    let n = g.y.len();
    let clear = |i: usize| b.top - g.y[i] >= g.radius[i] && g.y[i] - b.bottom >= g.radius[i];
    let mut i = 0;
    while i < n {
        // Four grains at once clear of both bars (most of a pillar): what the loop below
        // does to each, with one test and no branch per grain.
        if i + 4 <= n && (clear(i) & clear(i + 1) & clear(i + 2) & clear(i + 3)) {
            g.top_shear[i..i + 4].fill(0.0);
            g.bottom_shear[i..i + 4].fill(0.0);
            i += 4;
            continue;
        }
        let r = g.radius[i];
        if g.frozen.is_some_and(|f| f[i]) || clear(i) {
            // Clear of both bars (frozen grains are by definition).
            g.top_shear[i] = 0.0;
            g.bottom_shear[i] = 0.0;
            i += 1;
            continue;
        }
        // n points from the bar into the grain.
        let mut top_fn = g.top_fn.as_deref_mut().map(|f| &mut f[i]);
        for (face, ny, bar_vy, shear, total, own) in [
            (
                b.top,
                -1.0,
                -b.v_bar,
                &mut g.top_shear[i],
                &mut top_force,
                top_fn.take(),
            ),
            (
                b.bottom,
                1.0,
                0.0,
                &mut g.bottom_shear[i],
                &mut bottom_force,
                None,
            ),
        ] {
            let gap = (g.y[i] - face) * ny;
            let motion = (g.vx[i], g.vy[i] - bar_vy, g.omega[i]);
            if let Some(c) = b.law.wall(gap, (0.0, ny), r, motion, shear, b.dt) {
                fx[i] += c.fx;
                shear_force += c.fx;
                fy[i] += c.fy;
                tq[i] += c.t_i;
                *total += c.f_n;
                if let Some(own) = own {
                    *own = c.f_n;
                }
            }
        }
        i += 1;
    }
    [top_force, bottom_force, shear_force]
}

/// Per-step work the serial sections share with the phases (not state).
#[derive(Debug, Clone, Default)]
pub struct StepBuffers {
    /// Each grain's contact terms, contiguous (`Reverse::terms_of`), padded to its
    /// chunk's width with zeros: per slot it takes part in, the contact force (x, y, N)
    /// on it and the torque (N m), and a zero.
    pub terms: Vec<Quad>,
    /// Whether `terms` holds this list's forces (a slot between resting grains is
    /// then left as it is).
    pub slots_valid: bool,
    pub reverse: Reverse,
    /// The grain that owns each pair slot (for kernels that run over slots).
    pub(crate) owner: Vec<u32>,
    /// The grains packed for the AVX2 pair kernel after each drift: (x, y, v_x, v_y)
    /// (m, m/s) and (ω, R) (rad/s, m).
    pub(crate) packed_state: Vec<Quad>,
    pub(crate) packed_spin: Vec<Pos>,
    /// F_n, |F_t| (N) and touching per slot, filled on force-snapshot steps.
    pub rec_fn: Vec<f64>,
    pub rec_ft: Vec<f64>,
    pub rec_touch: Vec<bool>,
    /// Per grain: the top bar's normal force (N), filled on force-snapshot steps.
    pub rec_bar: Vec<f64>,
    /// Per chunk: whether a grain of it may touch a bar before the list's next
    /// rebuild (`PillarSim::mark_near_bars`); chunks that may not skip the bar
    /// contacts, which would only write the zeros their grains' bar springs hold.
    pub near_bar: Vec<bool>,
    /// The first step whose forces the marking in `near_bar` no longer covers (the
    /// top bar will have travelled half the list's skin since it was made): the list
    /// is rebuilt then (`u64::MAX`: never, or `near_bar` marks every chunk).
    pub near_bar_until: u64,
    /// What `near_bar` was made for: the list build and the bars' parameters (bits).
    pub near_bar_key: Option<(u64, [u64; 4])>,
    /// Per chunk: Σ F_n top, Σ F_n bottom, Σ bar shear (N); substrate power (W).
    pub bar_sums: Vec<[f64; 3]>,
    pub power: Vec<[f64; 2]>,
    /// Per grain: |f·v| and |T_μ ω| (W), summed per chunk into `power`.
    pub pow_t: Vec<f64>,
    pub pow_r: Vec<f64>,
    /// Per step parity and thread (`parity_half` of the thread plumbing): largest
    /// squared move since the list build (m²), slots skipped, frozen grains.
    pub moved2: Vec<f64>,
    pub skipped: Vec<u64>,
    pub frozen_count: Vec<usize>,
    /// Thread t works on grains bounds[t]..bounds[t + 1] (chunk multiples) and on
    /// the pair slots they own. One split for every phase: a grain's data then stays
    /// in one core's cache, and the threads meet once a step (see the thread plumbing).
    pub bounds: Vec<usize>,
    /// Per thread: the first of its grains with a partner in a later thread's range
    /// (its range's end if none). The slots from there on are computed first, so the
    /// later threads' terms are ready early (see the thread plumbing).
    pub export_from: Vec<usize>,
    /// Seconds each thread spent working (not waiting) in each timed step since the
    /// last rebalance, a window of slots per thread (0: not timed; see the thread
    /// plumbing's `shift_bounds`).
    pub busy: Vec<f64>,
}
