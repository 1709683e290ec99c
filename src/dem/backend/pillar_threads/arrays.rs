//! Raw views of the pillar's arrays for the threads of `pillar_par`, and each phase of
//! `pillar_phases` run on one thread's share through them.
//!
//! Safety: each phase writes only its own range of grains or pair slots (disjoint
//! between threads) and reads only what no thread writes in that phase; the barrier
//! between phases orders the writes before the reads (release/acquire). A thread's grain
//! phase and its next kick have no barrier between them, so both make slices of their
//! own range only (`part`, `view`) of the arrays a kick writes, and the rest flags are
//! two halves, one per step parity. Arrays are
//! reached through raw pointers refreshed by the first thread after any reallocation
//! (a list rebuild), while the others wait at the barrier.

#[cfg(target_arch = "x86_64")]
use crate::dem::backend::pillar_avx2::{PackedGrains, pair_slots as pair_slots_avx2};
use crate::dem::backend::simd::{Level, Pos, Quad, level};
use crate::dem::law::{ContactLaw, SubstrateFriction};
use crate::dem::pillar::dispatch::gather;
use crate::dem::pillar::dispatch::{kick_drift, substrate_chunks};
use crate::dem::pillar::kernels::{
    Drift, DriftInputs, GrainConsts, SubstrateInputs, SubstrateState, pack_grains,
};
use crate::dem::pillar::phases::{
    BarGrains, Bars, CHUNK, GrainState, Reverse, SlotRecord, TermSink, bar_contacts, mark_frozen,
    pair_slots,
};
use crate::dem::pillar::{PillarSim, top_y_at};
use std::cell::UnsafeCell;
use std::ops::Range;

#[derive(Clone, Copy)]
pub(crate) struct P<T>(*mut T, usize);
// SAFETY: a `P` hands out parts of one slice to the threads of one `advance`; the
// phases give each thread disjoint parts to write (see `Arrays`), so it is as safe to
// send and share as the elements are.
unsafe impl<T: Send> Send for P<T> {}
unsafe impl<T: Send + Sync> Sync for P<T> {}

impl<T> P<T> {
    fn of(v: &mut [T]) -> Self {
        P(v.as_mut_ptr(), v.len())
    }
    /// # Safety
    /// No thread writes any of it for the lifetime of the slice.
    unsafe fn all<'a>(self) -> &'a [T] {
        unsafe { std::slice::from_raw_parts(self.0, self.1) }
    }
    /// # Safety
    /// No thread writes `r` for the lifetime of the slice (others may write elsewhere:
    /// unlike `all`, the slice covers `r` only).
    pub(crate) unsafe fn view<'a>(self, r: Range<usize>) -> &'a [T] {
        assert!(
            r.start <= r.end && r.end <= self.1,
            "range within the array"
        );
        unsafe { std::slice::from_raw_parts(self.0.add(r.start), r.end - r.start) }
    }
    /// # Safety
    /// No other thread touches `r` for the lifetime of the slice.
    pub(crate) unsafe fn part<'a>(self, r: Range<usize>) -> &'a mut [T] {
        assert!(
            r.start <= r.end && r.end <= self.1,
            "range within the array"
        );
        unsafe { std::slice::from_raw_parts_mut(self.0.add(r.start), r.end - r.start) }
    }
}

/// Raw views of every array a phase touches.
#[derive(Clone, Copy)]
pub(crate) struct Arrays {
    x: P<f64>,
    y: P<f64>,
    vx: P<f64>,
    vy: P<f64>,
    ax: P<f64>,
    ay: P<f64>,
    theta: P<f64>,
    omega: P<f64>,
    radius: P<f64>,
    x_ref: P<f64>,
    y_ref: P<f64>,
    start: P<u32>,
    js: P<u32>,
    shear: P<f64>,
    fx: P<f64>,
    fy: P<f64>,
    tq: P<f64>,
    sub_fx: P<f64>,
    sub_fy: P<f64>,
    top_shear: P<f64>,
    bottom_shear: P<f64>,
    resting: P<bool>,
    frozen: P<bool>,
    terms: P<Quad>,
    owner: P<u32>,
    packed_state: P<Quad>,
    packed_spin: P<Pos>,
    rec_fn: P<f64>,
    rec_ft: P<f64>,
    rec_touch: P<bool>,
    rec_bar: P<f64>,
    bar_sums: P<[f64; 3]>,
    near_bar: P<bool>,
    power: P<[f64; 2]>,
    pow_t: P<f64>,
    pow_r: P<f64>,
    pub(crate) moved2: P<f64>,
    skipped: P<u64>,
    frozen_count: P<usize>,
    pub(crate) busy: P<f64>,
    inv_mass: P<f64>,
    inv_inertia: P<f64>,
    f_max: P<f64>,
    f_max2: P<f64>,
    t_max: P<f64>,
    xi_omega: P<f64>,
    rev: *const Reverse,
    bounds: *const Vec<usize>,
    export_from: *const Vec<usize>,
    /// This step: slots between resting grains skipped; force snapshot wanted;
    /// second kick.
    freeze: bool,
    /// This step: frozen grains marked (and skipped), when enough of them were last
    /// time to pay for the marking (`Scratch::marking`).
    mark: bool,
    record: bool,
    kick: bool,
    /// The list's skin (m): the rebuild test of every thread uses the skin the list
    /// was built with, which a rebuild may change (`adapt_skin`).
    pub(crate) skin: f64,
    /// `StepBuffers::near_bar_until`: every thread rebuilds from that step on.
    pub(crate) near_bar_until: u64,
}
// SAFETY: every field is a `P` of `Send + Sync` numbers or a pointer to state the
// serial sections alone write; the phase functions' contracts keep writes disjoint.
unsafe impl Send for Arrays {}
unsafe impl Sync for Arrays {}

/// What the phases need of the simulation besides its arrays, copied once per
/// `advance` call, so no thread holds a reference to the simulation while the first
/// thread updates its totals during the pair phase.
#[derive(Clone, Copy)]
pub(crate) struct StepLaws {
    /// The grain–grain law.
    law: ContactLaw,
    /// The bars (their `top` set per step by [`StepLaws::bars_at`]).
    bars: Bars,
    sub: SubstrateFriction,
    /// δt (s); ξ_v² (m²/s², Eq. 11).
    pub(crate) dt: f64,
    xi_v2: f64,
    /// Top bar face at step 0 (m) and the bar speed (m/s).
    top_y0: f64,
    bar_speed: f64,
    /// Frozen grains stay two steps of bar travel (m) clear of the top bar.
    margin: f64,
}

impl StepLaws {
    pub(crate) fn of(s: &PillarSim) -> Self {
        let p = &s.params;
        let sub = s.substrate();
        let xi_v = sub.xi_v(p.dt);
        StepLaws {
            law: s.law(),
            bars: Bars {
                law: s.bar_law(),
                top: s.top_y(),
                bottom: s.bottom_y,
                v_bar: p.bar_speed,
                dt: p.dt,
            },
            sub,
            dt: p.dt,
            xi_v2: xi_v * xi_v,
            top_y0: s.top_y0,
            bar_speed: p.bar_speed,
            margin: 2.0 * p.bar_speed * p.dt,
        }
    }

    /// The bars at step `step` (the simulation's step count during that step's forces).
    fn bars_at(&self, step: u64) -> Bars {
        Bars {
            top: top_y_at(self.top_y0, self.bar_speed, self.dt, step),
            ..self.bars
        }
    }
}

/// What the serial sections publish to every thread (the arrays' view, a list build
/// under way), republished after each.
pub(crate) struct Shared<T>(pub(crate) UnsafeCell<T>);
// SAFETY (both): only the first thread writes the cell, in the serial sections, while
// the others wait at the barrier; they read it after the barrier publishes it. The
// arrays' raw pointers are dereferenced under the rules of the module notes; a build
// under way is itself `Sync` (each part's lists behind their own lock).
unsafe impl Sync for Shared<Arrays> {}
unsafe impl Sync for Shared<Option<crate::dem::base::verlet::PendingBuild>> {}
unsafe impl Sync for Shared<Option<super::layout::LayoutBuild>> {}
impl<T> Shared<T> {
    pub(crate) fn get(&self) -> *mut T {
        self.0.get()
    }
}

pub(crate) struct SendPtr(pub(crate) *mut PillarSim);
// SAFETY: the simulation outlives the scoped threads of one `advance`. The first
// thread dereferences the pointer in the serial sections (the others waiting at the
// barrier); between the barriers around a list rebuild's listing, every thread reads
// through it and none writes.
unsafe impl Send for SendPtr {}
unsafe impl Sync for SendPtr {}
impl SendPtr {
    pub(crate) fn get(&self) -> *mut PillarSim {
        self.0
    }
}

impl PillarSim {
    /// The pair kernel the steps run, as manifests record it: `avx2` (the hand-written
    /// kernel of the linear Cundall–Strack law) or `scalar` (the law's reference, for
    /// any other law or processor). Steps that record a force snapshot always run the
    /// reference.
    pub fn pair_kernel(&self) -> &'static str {
        if cfg!(target_arch = "x86_64")
            && self.law().is_linear_cundall_strack().is_some()
            && level() >= Level::Avx2
        {
            "avx2"
        } else {
            "scalar"
        }
    }

    /// Whether steps may skip frozen grains and resting pairs at all: asked for, exact
    /// (only without normal damping; see `pair_slots`) and no force snapshot due (it
    /// records every slot). A step skips when, besides, the terms hold the current
    /// list's forces.
    pub(crate) fn frozen_skip_allowed(&self) -> bool {
        self.scratch.skip_frozen && self.params.damping_n == 0.0 && self.record.is_none()
    }

    /// Raw views of every array, and this step's switches (frozen skip, force
    /// snapshot, second kick).
    pub(crate) fn arrays(&mut self, kick: bool) -> Arrays {
        let listed = self.list.start.len() == self.grains.len() + 1;
        self.scratch.buffers.export_from = if listed {
            export_points(
                &self.scratch.buffers.bounds,
                &self.list.start,
                &self.list.j,
                &self.scratch.buffers.reverse.reach,
            )
        } else {
            self.scratch
                .buffers
                .bounds
                .iter()
                .skip(1)
                .copied()
                .collect()
        };
        let freeze = self.frozen_skip_allowed() && self.scratch.buffers.slots_valid && kick;
        let record = self.record.is_some();
        let mark = freeze && self.scratch.marking.now;
        self.scratch.marking.marked = mark;
        let g = &mut self.grains;
        let l = &mut self.list;
        let sc = &mut self.scratch;
        let c = &mut sc.consts;
        let b = &mut sc.buffers;
        Arrays {
            x: P::of(&mut g.x),
            y: P::of(&mut g.y),
            vx: P::of(&mut g.vx),
            vy: P::of(&mut g.vy),
            ax: P::of(&mut g.ax),
            ay: P::of(&mut g.ay),
            theta: P::of(&mut g.theta),
            omega: P::of(&mut g.omega),
            radius: P::of(&mut g.radius),
            x_ref: P::of(&mut l.x_ref),
            y_ref: P::of(&mut l.y_ref),
            start: P::of(&mut l.start),
            js: P::of(&mut l.j),
            shear: P::of(&mut l.shear),
            fx: P::of(&mut self.fx),
            fy: P::of(&mut self.fy),
            tq: P::of(&mut self.tq),
            sub_fx: P::of(&mut self.sub_fx),
            sub_fy: P::of(&mut self.sub_fy),
            top_shear: P::of(&mut self.top_shear),
            bottom_shear: P::of(&mut self.bottom_shear),
            resting: P::of(&mut sc.resting),
            frozen: P::of(&mut sc.frozen),
            terms: P::of(&mut b.terms),
            owner: P::of(&mut b.owner),
            packed_state: P::of(&mut b.packed_state),
            packed_spin: P::of(&mut b.packed_spin),
            rec_fn: P::of(&mut b.rec_fn),
            rec_ft: P::of(&mut b.rec_ft),
            rec_touch: P::of(&mut b.rec_touch),
            rec_bar: P::of(&mut b.rec_bar),
            bar_sums: P::of(&mut b.bar_sums),
            near_bar: P::of(&mut b.near_bar),
            power: P::of(&mut b.power),
            pow_t: P::of(&mut b.pow_t),
            pow_r: P::of(&mut b.pow_r),
            moved2: P::of(&mut b.moved2),
            skipped: P::of(&mut b.skipped),
            frozen_count: P::of(&mut b.frozen_count),
            busy: P::of(&mut b.busy),
            inv_mass: P::of(&mut c.inv_mass),
            inv_inertia: P::of(&mut c.inv_inertia),
            f_max: P::of(&mut c.f_max),
            f_max2: P::of(&mut c.f_max2),
            t_max: P::of(&mut c.t_max),
            xi_omega: P::of(&mut c.xi_omega),
            rev: &b.reverse,
            bounds: &b.bounds,
            export_from: &b.export_from,
            freeze,
            mark,
            record,
            kick,
            skin: l.skin,
            near_bar_until: b.near_bar_until,
        }
    }
}

impl Arrays {
    /// The same views with this step's frozen skip and marking (see `arrays`).
    pub(crate) fn with_flags(self, freeze: bool, mark: bool) -> Self {
        Arrays {
            freeze,
            mark,
            ..self
        }
    }
}

/// The `parity` half of a per-thread count kept per step parity (`threads` entries a
/// half): thread 0 folds last step's half in while this step's is written.
pub(crate) fn parity_half(threads: usize, parity: usize) -> Range<usize> {
    parity * threads..parity * threads + threads
}

/// Thread t's entry in the `parity` half of a count (see [`parity_half`]).
fn half(a: &Arrays, parity: usize, t: usize) -> Range<usize> {
    let k = parity_half(a.skipped.1 / 2, parity).start + t;
    k..k + 1
}

/// This step's rest flags (the other half of the array is the next step's, which a
/// thread ahead in its kick may be writing).
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
unsafe fn resting<'a>(a: &Arrays, parity: usize) -> &'a [bool] {
    let n = a.x.1;
    unsafe { a.resting.view(parity * n..parity * n + n) }
}

/// Thread t's grains.
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
unsafe fn range(a: &Arrays, t: usize) -> Range<usize> {
    let b = unsafe { &*a.bounds };
    b[t]..b[t + 1]
}

/// Which of a thread's pair slots a call computes: those of its grains from
/// `export_from` on (which reach later threads' grains, computed first so that those
/// threads wait little for their terms), or those before.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Slots {
    Exports,
    Rest,
}

/// The grains whose pair slots thread t computes in the `part` call.
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
unsafe fn pair_range(a: &Arrays, t: usize, part: Slots) -> Range<usize> {
    let r = unsafe { range(a, t) };
    let split = unsafe { (&*a.export_from)[t] }.clamp(r.start, r.end);
    match part {
        Slots::Exports => split..r.end,
        Slots::Rest => r.start..split,
    }
}

/// Per thread, the first grain of its range (`bounds`) that has a partner in a later
/// thread's range (the range's end if none): partners follow their owner in index
/// order (`PairList::build`), so only earlier threads write terms of a thread's grains.
/// `reach` is the list's per-chunk span of neighbours (`Reverse::reach`; empty when
/// there is none): the neighbours above a grain are its partners, so the first such
/// grain lies in the first chunk whose span reaches past the range, and the search
/// starts there instead of at the range's start (a range of 8000 grains, scanned
/// grain by grain at every rebalance, cost thread 0 some 10 µs while the others waited).
pub(crate) fn export_points(
    bounds: &[usize],
    start: &[u32],
    js: &[u32],
    reach: &[(u32, u32)],
) -> Vec<usize> {
    let n = start.len().saturating_sub(1);
    let spans = reach.len() == n.div_ceil(CHUNK);
    bounds
        .windows(2)
        .map(|w| {
            let from = if spans {
                (w[0] / CHUNK..w[1].div_ceil(CHUNK))
                    .find(|&c| reach[c].1 as usize >= w[1])
                    .map_or(w[1], |c| (c * CHUNK).max(w[0]))
            } else {
                w[0]
            };
            (from..w[1])
                .find(|&i| {
                    let (a, b) = (start[i] as usize, start[i + 1] as usize);
                    b > a && js[b - 1] as usize >= w[1]
                })
                .unwrap_or(w[1])
        })
        .collect()
}

/// Phase 1: kick and drift of thread t's grains, packed for the pair kernel; their
/// largest move since the build.
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
pub(crate) unsafe fn phase_kick(a: &Arrays, t: usize, dt: f64, parity: usize) -> f64 {
    unsafe {
        let r = range(a, t);
        let n = a.x.1;
        let refs_ok = a.x_ref.1 == a.x.1;
        let (xr, yr): (&[f64], &[f64]) = if refs_ok {
            (&a.x_ref.all()[r.clone()], &a.y_ref.all()[r.clone()])
        } else {
            (&[], &[])
        };
        kick_drift(
            dt,
            Drift {
                x: a.x.part(r.clone()),
                y: a.y.part(r.clone()),
                theta: a.theta.part(r.clone()),
                vx: a.vx.part(r.clone()),
                vy: a.vy.part(r.clone()),
                resting: a.resting.part(parity * n + r.start..parity * n + r.end),
            },
            &DriftInputs {
                ax: a.ax.view(r.clone()),
                ay: a.ay.view(r.clone()),
                omega: a.omega.view(r.clone()),
                radius: a.radius.view(r.clone()),
                x_ref: xr,
                y_ref: yr,
            },
            a.packed_state.part(r.clone()),
            a.packed_spin.part(r),
        )
    }
}

/// All grains packed for the AVX2 pair kernel (where no drift did it).
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
pub(crate) unsafe fn phase_pack(a: &Arrays) {
    unsafe {
        let r = 0..a.x.1;
        pack_grains(
            GrainState {
                x: a.x.view(r.clone()),
                y: a.y.view(r.clone()),
                vx: a.vx.view(r.clone()),
                vy: a.vy.view(r.clone()),
                omega: a.omega.view(r.clone()),
                radius: a.radius.view(r.clone()),
            },
            a.packed_state.part(r.clone()),
            a.packed_spin.part(r),
        );
    }
}

/// Frozen flags of thread t's grains (each reads every grain's rest flag).
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
unsafe fn phase_frozen(a: &Arrays, t: usize, laws: &StepLaws, bars: &Bars, parity: usize) {
    unsafe {
        let r = range(a, t);
        let out = a.frozen.part(r.clone());
        if !a.mark {
            out.fill(false);
            return;
        }
        let c = mark_frozen(
            r.clone(),
            out,
            resting(a, parity),
            a.y.part(r),
            &*a.rev,
            (bars.top, bars.bottom, laws.margin),
            a.radius.all(),
        );
        a.frozen_count.part(half(a, parity, t))[0] = c;
    }
}

/// Phase 2: the `part` of the pair slots of thread t's grains (the slots skipped are
/// added to this step's count).
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
pub(crate) unsafe fn phase_pairs(
    a: &Arrays,
    t: usize,
    laws: &StepLaws,
    parity: usize,
    part: Slots,
) {
    unsafe {
        let r = pair_range(a, t, part);
        let start = a.start.all();
        let slots = start[r.start] as usize..start[r.end] as usize;
        let g = GrainState {
            x: a.x.all(),
            y: a.y.all(),
            vx: a.vx.all(),
            vy: a.vy.all(),
            omega: a.omega.all(),
            radius: a.radius.all(),
        };
        let rec = a.record.then(|| SlotRecord {
            f_n: a.rec_fn.part(slots.clone()),
            f_t: a.rec_ft.part(slots.clone()),
            touching: a.rec_touch.part(slots.clone()),
        });
        let skipped = a.skipped.part(half(a, parity, t));
        let (law, dt) = (&laws.law, laws.dt);
        let rev = &*a.rev;
        // SAFETY: each slot's two term places are its own (`Reverse::build`), checked
        // in bounds by `end_layout`; no phase reads the terms while pairs run.
        let sink = TermSink::new(
            a.terms.0,
            a.terms.1,
            &rev.term_own[slots.clone()],
            &rev.term_partner[slots.clone()],
        );
        let rest = a.freeze.then(|| resting(a, parity));
        let n = a.x.1;
        #[cfg(target_arch = "x86_64")]
        if let Some(coeffs) = law.is_linear_cundall_strack().filter(|_| rec.is_none())
            && level() >= Level::Avx2
        {
            let packed = PackedGrains {
                state: a.packed_state.all(),
                spin: a.packed_spin.all(),
            };
            // `end_layout` checked every owner and partner index against n.
            assert!(packed.state.len() == n && packed.spin.len() == n);
            assert!(rest.is_none_or(|f| f.len() == n));
            // SAFETY: AVX2 present; indices and lengths checked (above and at the list's
            // check); the kick (or `phase_pack`) packed this state.
            skipped[0] += pair_slots_avx2(
                slots.clone(),
                g,
                packed,
                (a.owner.all(), a.js.all()),
                a.shear.part(slots.clone()),
                sink,
                rest,
                (coeffs, law, dt),
            );
            return;
        }
        skipped[0] += pair_slots(
            r,
            g,
            (start, a.js.all()),
            a.shear.part(slots.clone()),
            sink,
            rest,
            (law, dt),
            rec,
        );
    }
}

/// Phase 3: thread t's grains: frozen flags, contact sums, bars, substrate and second
/// kick.
///
/// No barrier separates this from the next step's kick, so it reads other threads'
/// grains only in arrays no kick writes (the terms, radii, the list).
///
/// # Safety
/// `a` is this step's view of the simulation (`PillarSim::arrays`), unchanged since the
/// step's serial section, and the caller is thread `t` of the team running the phases
/// in order with a barrier between them, so that no other thread writes what this
/// one reads or writes (each writes only its own grains or pair slots).
pub(crate) unsafe fn phase_grains(a: &Arrays, t: usize, laws: &StepLaws, step: u64, parity: usize) {
    unsafe {
        let r = range(a, t);
        if r.is_empty() {
            return;
        }
        let bars = laws.bars_at(step);
        phase_frozen(a, t, laws, &bars, parity);
        let frozen: &[bool] = a.frozen.part(r.clone());
        let fz = a.mark.then_some(frozen);
        let (fx, fy, tq) = (
            a.fx.part(r.clone()),
            a.fy.part(r.clone()),
            a.tq.part(r.clone()),
        );
        gather(r.clone(), &*a.rev, a.terms.all(), fz, fx, fy, tq);
        let chunks = r.start / CHUNK..r.end.div_ceil(CHUNK);
        let sums = a.bar_sums.part(chunks.clone());
        // Own-range views only: other threads write their ranges of these arrays now.
        let (vx, vy, omega) = (
            a.vx.part(r.clone()),
            a.vy.part(r.clone()),
            a.omega.part(r.clone()),
        );
        let (ys, rs): (&[f64], &[f64]) = (a.y.part(r.clone()), &a.radius.all()[r.clone()]);
        let (top_shear, bottom_shear) =
            (a.top_shear.part(r.clone()), a.bottom_shear.part(r.clone()));
        let top_fn: Option<&mut [f64]> = a.record.then(|| a.rec_bar.part(r.clone()));
        let mut top_fn = top_fn;
        let near_bar = a.near_bar.view(chunks.clone());
        for (k, ch) in chunks.clone().enumerate() {
            if !near_bar[k] {
                // What `bar_contacts` gives a chunk clear of both bars.
                sums[k] = [0.0; 3];
                continue;
            }
            let cr = ch * CHUNK..((ch + 1) * CHUNK).min(r.end);
            let local = cr.start - r.start..cr.end - r.start;
            sums[k] = bar_contacts(
                &bars,
                BarGrains {
                    y: &ys[local.clone()],
                    vx: &vx[local.clone()],
                    vy: &vy[local.clone()],
                    omega: &omega[local.clone()],
                    radius: &rs[local.clone()],
                    frozen: fz.map(|f| &f[local.clone()]),
                    top_shear: &mut top_shear[local.clone()],
                    bottom_shear: &mut bottom_shear[local.clone()],
                    top_fn: top_fn.as_deref_mut().map(|f| &mut f[local.clone()]),
                },
                &mut fx[local.clone()],
                &mut fy[local.clone()],
                &mut tq[local],
            );
        }
        let consts = GrainConsts {
            inv_mass: a.inv_mass.all(),
            inv_inertia: a.inv_inertia.all(),
            f_max: a.f_max.all(),
            f_max2: a.f_max2.all(),
            t_max: a.t_max.all(),
            xi_omega: a.xi_omega.all(),
        };
        substrate_chunks(
            &SubstrateInputs {
                kick: a.kick,
                dt: laws.dt,
                xi_v2: laws.xi_v2,
                sub: &laws.sub,
                c: consts.range(r.clone()),
                frozen: fz.unwrap_or(&[]),
                fx,
                fy,
                tq,
            },
            SubstrateState {
                vx,
                vy,
                ax: a.ax.part(r.clone()),
                ay: a.ay.part(r.clone()),
                omega,
                sub_fx: a.sub_fx.part(r.clone()),
                sub_fy: a.sub_fy.part(r.clone()),
                pow_t: a.pow_t.part(r.clone()),
                pow_r: a.pow_r.part(r),
            },
            a.power.part(chunks),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::export_points;
    use crate::dem::pillar::phases::Reverse;
    use crate::dem::pillar::reverse::tests::half_list;

    #[test]
    fn export_points_find_the_first_grain_reaching_a_later_range() {
        // Grains 0..6 in two ranges, 0..3 and 3..6; partners follow their owners.
        // 0: [1]; 1: [2, 4] (reaches range 1); 2: [3] (reaches it too); 3: [5]; 4: []; 5: [].
        let start = [0u32, 1, 3, 4, 5, 5, 5];
        let js = [1u32, 2, 4, 3, 5];
        let reach = Reverse::build(6, &start, &js).reach;
        for r in [&[][..], &reach[..]] {
            assert_eq!(export_points(&[0, 3, 6], &start, &js, r), vec![1, 6]);
            // No grain of range 0 reaches past 2 when it ends at 5.
            assert_eq!(export_points(&[0, 5, 6], &start, &js, r), vec![3, 6]);
            // One range: nothing to export.
            assert_eq!(export_points(&[0, 6], &start, &js, r), vec![6]);
        }
    }

    /// The search from the first chunk reaching past a range finds the grain the scan
    /// from the range's start finds, for lists with near partners (a row or two
    /// ahead, as in a pillar) and a few far ones, and splits of any shape.
    #[test]
    fn export_points_from_the_chunks_reach_are_the_full_scan_s() {
        let mut rng = crate::rng::Rng::new(7);
        for (n, far_one_in) in [(300, 0), (1000, 500), (1000, 20), (97, 3)] {
            let (start, js) = half_list(n, n as u64 + far_one_in as u64, far_one_in);
            let reach = Reverse::build(n, &start, &js).reach;
            assert_eq!(
                reach.len(),
                n.div_ceil(super::CHUNK),
                "spans the search uses"
            );
            for _ in 0..50 {
                let mut cuts: Vec<usize> =
                    (0..1 + rng.below(4)).map(|_| rng.below(n + 1)).collect();
                cuts.extend([0, n]);
                cuts.sort_unstable();
                let full = export_points(&cuts, &start, &js, &[]);
                assert_eq!(export_points(&cuts, &start, &js, &reach), full, "{cuts:?}");
            }
        }
    }
}
