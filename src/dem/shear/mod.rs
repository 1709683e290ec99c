//! vagberg-sheared-disks Sec. II: frictionless bidisperse disks (d_b/d_s = 1.4, equal
//! masses) with harmonic repulsion (Eqs. 1–2), contact dissipation CD (Eq. 3) or CDrot
//! (Eqs. 5–7), sheared at rate γ̇ through Lees–Edwards boundaries, integrated with the
//! paper's modified velocity Verlet (Eqs. 21–24, spins too).
//!
//! Units: d_s = m = τ_e = 1, so k_e = 1 and k_d = 1/Q (Eqs. 8–9). Positions are kept
//! unwrapped (a grain that crossed the y boundary n times is where its image would be);
//! the pair loop maps separations to the minimum image and shifts the image's velocity
//! by n γ̇ L, which is the Lees–Edwards rule without any remapping of stored state.

pub mod checkpoint;
pub mod integrate;
pub mod near;
pub mod order;
pub mod pairs;
pub mod params;
pub mod slots;
#[cfg(target_arch = "x86_64")]
pub mod threads;

use crate::dem::base::grains::{Grains, LARGE, SMALL};
use crate::dem::base::verlet::{Boundary, PairList};
use crate::dem::shear::integrate::{Packed, Quad, correct, predict};
use crate::dem::shear::near::Slots;
use crate::dem::shear::pairs::{PairParams, add_virial, for_each_virial_term, pair_loop};
use crate::dem::shear::slots::evaluate;
#[cfg(target_arch = "x86_64")]
use crate::dem::shear::slots::{evaluate_packed, evaluate_packed_into};
use crate::rng::Rng;
pub use params::{
    ANGLE_BIN_DEG, ANGLE_BINS, ANGLE_BINS_AT_90, ANGLE_BINS_AT_MINUS_90, Collisions, Dissipation,
    DurationHistogram, ShearParams, Virial, angle_bin, angle_edge, cohort_half, collision_angle,
};

/// Whether the slot kernels implement `law`: CD or CDrot dissipation (any α). Any other
/// law (CDn) runs the straight loop over the law's scalar reference.
fn slot_law(law: &crate::dem::law::ContactLaw) -> bool {
    use crate::dem::law::Damping;
    matches!(law.damping(), Damping::Cd { .. } | Damping::CdRot { .. })
}

#[derive(Debug, Clone, PartialEq)]
pub struct ShearSim {
    pub p: ShearParams,
    pub g: Grains,
    pub l: f64,
    /// Contact history per pair slot: 0 when not touching, else 1 + the time the
    /// contact began (so that t = 0 is representable).
    pub list: PairList,
    pub time: f64,
    pub step: u64,
    /// Accumulated shear strain γ = ∫ γ̇ dt (the Lees–Edwards offset is γ L).
    pub gamma: f64,
    /// Force and torque at the current state (the f({r_0, v_0}) of Eq. 21).
    pub fx: Vec<f64>,
    pub fy: Vec<f64>,
    pub tq: Vec<f64>,
    pub coll: Collisions,
    /// Integrate spins (turning it off is exact for CD: rotation never feeds back).
    pub rotate: bool,
    /// Steps between re-sorts into cell order (0: never); see `shear_order`.
    pub resort_every: u64,
    /// The predicted state of Eq. 22 and the forces f_0 of Eq. 21 (reused buffers).
    pub pred: Predicted,
    /// The near list the force kernels read (the pairs of `list` within 0.05 d_s).
    pub slots: Slots,
    /// Which force kernel runs (both give the same numbers bit for bit).
    pub kernel: ShearKernel,
    /// The state to evaluate next, packed for the AVX2 kernel by the integrator
    /// (the predicted state, in a step).
    pub packed: Packed,
    /// The state at t + Δt packed by the corrector, while the kernel still reads the
    /// predicted one from `packed`.
    pub packed_now: Packed,
    /// Threads a step may use (0: one per core, see `threads_for_run`). Not part of the
    /// physics: any count gives the same numbers.
    pub threads: usize,
    /// The threads' tables and pool (a cache).
    #[cfg(target_arch = "x86_64")]
    pub par: threads::ShearThreads,
}

/// The sheared disks' force kernels: the same numbers, different speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ShearKernel {
    /// The near list's slots: the AVX2 kernel (`shear_avx2`) where the processor has it
    /// and α = 2, else the portable two-pass kernel (`shear_slots`).
    #[default]
    Slots,
    /// One straight loop over the Verlet list with a branch per contact
    /// (`shear_pairs::pair_loop`): the reference the tests compare to.
    Straight,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Predicted {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub vx: Vec<f64>,
    pub vy: Vec<f64>,
    pub w: Vec<f64>,
    pub f0x: Vec<f64>,
    pub f0y: Vec<f64>,
    pub t0: Vec<f64>,
    /// 1/m and 1/I per grain (storage order; cleared when the grains are re-sorted).
    pub inv_m: Vec<f64>,
    pub inv_i: Vec<f64>,
}

/// A step's prediction (Eqs. 21–22) made by the step before it, in `packed` (see
/// [`ShearSim::steps`]): for n grains, with the near list's stray test's answer for
/// it (`None`: no test, re-select).
#[derive(Debug, Clone, Copy)]
struct Ahead {
    n: usize,
    strayed: Option<bool>,
}

/// A state to evaluate forces at.
struct State<'a> {
    x: &'a [f64],
    y: &'a [f64],
    vx: &'a [f64],
    vy: &'a [f64],
    w: &'a [f64],
}

impl ShearSim {
    /// Random positions at φ (overlaps allowed: soft disks), half big half small, and
    /// the affine flow v_x = γ̇ y.
    pub fn new(p: ShearParams) -> Self {
        let l = p.box_side();
        let mut rng = Rng::new(p.seed);
        let mut g = Grains::default();
        for k in 0..p.n {
            let (s, d) = if k % 2 == 0 {
                (LARGE, 1.4)
            } else {
                (SMALL, 1.0)
            };
            let (x, y) = (rng.uniform() * l, rng.uniform() * l);
            g.push(k as i64, s, 0.5 * d, 1.0, x, y);
            g.vx[k] = p.rate * y;
        }
        g.sort_spatially(1.4);
        Self::from_grains(p, g, l)
    }

    /// Given grains in a box of side `l` (tests build exact configurations).
    pub fn from_grains(p: ShearParams, g: Grains, l: f64) -> Self {
        let n = g.len();
        let mut s = ShearSim {
            list: PairList::new(0.3),
            p,
            g,
            l,
            time: 0.0,
            step: 0,
            gamma: 0.0,
            fx: vec![0.0; n],
            fy: vec![0.0; n],
            tq: vec![0.0; n],
            coll: Collisions::default(),
            rotate: true,
            resort_every: crate::dem::shear::order::RESORT_EVERY,
            pred: Predicted::default(),
            slots: Slots::default(),
            kernel: ShearKernel::default(),
            packed: Packed::default(),
            packed_now: Packed::default(),
            threads: 0,
            #[cfg(target_arch = "x86_64")]
            par: Default::default(),
        };
        s.refresh();
        s
    }

    /// Forces and contact bookkeeping at the current state.
    pub fn refresh(&mut self) {
        self.evaluate(false);
    }

    /// The Lees–Edwards boundary at the current accumulated strain.
    pub fn boundary(&self) -> Boundary {
        Boundary::LeesEdwards {
            lx: self.l,
            ly: self.l,
            offset: self.gamma * self.l,
        }
    }

    /// Accumulated strain γ = γ̇ t.
    pub fn strain(&self) -> f64 {
        self.gamma
    }

    /// Forces and torques at the given state and the current `self.time` into
    /// `self.fx/fy/tq`; with `track`, also the contact bookkeeping (only for actual
    /// states, not the predictor of Eq. 22).
    fn evaluate(&mut self, predicted: bool) {
        let track = !predicted;
        #[cfg(target_arch = "x86_64")]
        self.par.history_changed();
        let b = self.boundary();
        let ShearSim {
            g,
            pred,
            list,
            fx,
            fy,
            tq,
            coll,
            p,
            time,
            slots,
            kernel,
            packed,
            ..
        } = self;
        let st = if predicted {
            State {
                x: &pred.x,
                y: &pred.y,
                vx: &pred.vx,
                vy: &pred.vy,
                w: &pred.w,
            }
        } else {
            State {
                x: &g.x,
                y: &g.y,
                vx: &g.vx,
                vy: &g.vy,
                w: &g.omega,
            }
        };
        let (x, y, vx, vy, w) = (st.x, st.y, st.vx, st.vy, st.w);
        let pp = PairParams::new(p, self.l, b.offset(), *time);
        let st = (x, y, vx, vy, w, &g.radius[..]);
        if *kernel == ShearKernel::Straight || !slot_law(&pp.law) {
            list.update(x, y, &g.radius, b);
            slots.invalidate();
            let (start, js, hist) = (&list.start[..], &list.j[..], &mut list.shear[..]);
            let mut none = Virial::default();
            if track {
                pair_loop::<true, false>(st, start, js, hist, &pp, fx, fy, tq, coll, &mut none);
            } else {
                pair_loop::<false, false>(st, start, js, hist, &pp, fx, fy, tq, coll, &mut none);
            }
        } else {
            // Checks (and rebuilds) the Verlet list too, when it re-selects.
            slots.sync(list, &g.radius, (x, y), b);
            let hist = &mut list.shear[..];
            if track {
                evaluate::<true>(st, slots, packed, hist, &pp, fx, fy, tq, coll);
            } else {
                evaluate::<false>(st, slots, packed, hist, &pp, fx, fy, tq, coll);
            }
        }
    }

    /// The force kernel the steps run, as manifests record it: `reference` (the
    /// straight loop over the law's scalar reference), `avx512` or `avx2` (the
    /// hand-written kernels of the harmonic law), or `portable` (the slot loop over the
    /// scalar reference, for any other law or processor).
    pub fn kernel_name(&self) -> &'static str {
        if self.kernel == ShearKernel::Straight || !slot_law(&self.p.law()) {
            "reference"
        } else if crate::dem::shear::integrate::Packed::used_for(&self.p) {
            crate::dem::backend::simd::level().name()
        } else {
            "portable"
        }
    }

    /// The state as the pair loops read it: x, y, v_x, v_y, ω, R.
    pub fn state_slices(&self) -> crate::dem::shear::params::StateSlices<'_> {
        let g = &self.g;
        (&g.x, &g.y, &g.vx, &g.vy, &g.omega, &g.radius)
    }

    /// Threads the steps run on: `threads_for_run()` where the steps run packed (the
    /// harmonic law's vector kernels), else one.
    pub fn step_threads_used(&self) -> usize {
        #[cfg(target_arch = "x86_64")]
        if self.kernel == ShearKernel::Slots && Packed::used_for(&self.p) {
            return self.threads_for_run();
        }
        1
    }

    /// Steps that ran on one thread although more were asked for, because the
    /// threads' waits were long (a busy machine; see `threads`). Never changes the
    /// numbers.
    pub fn solo_steps(&self) -> u64 {
        #[cfg(target_arch = "x86_64")]
        return self.par.solo_steps;
        #[cfg(not(target_arch = "x86_64"))]
        0
    }

    /// End the threads kept for the steps (a later threaded step starts new ones): a
    /// simulation kept but no longer stepped then holds no sleeping threads.
    pub fn end_threads(&mut self) {
        #[cfg(target_arch = "x86_64")]
        self.par.end_threads();
    }

    /// Start times (τ_e) of the contacts open now, from the pair histories (each
    /// holds 1 + its contact's start time, 0 when apart): the censored part of the
    /// duration cohort (`Collisions::window_start`).
    pub fn open_contact_starts(&self) -> Vec<f64> {
        self.list
            .shear
            .iter()
            .filter(|&&h| h != 0.0)
            .map(|&h| h - 1.0)
            .collect()
    }

    /// The virial sums Σ f ⊗ r_ij (Eqs. 12–13) and the contact count of the current
    /// state, computed when asked: only the states the outputs sample need them, so the
    /// step does not carry them. The straight loop's terms over the near list (or, with
    /// the straight kernel, the Verlet list), made valid for the state first, in ranges
    /// of grains on the steps' threads: the same sums, in the same order, as the
    /// straight loop over every pair.
    pub fn virial(&mut self) -> Virial {
        // Ranges of grains on the steps' threads, summed in order: the sums of one
        // pass, bit for bit (`pairs::for_each_virial_term`), for any number of threads.
        let threads = self.step_threads_used();
        let team = self.lent_team();
        let b = self.boundary();
        let g = &self.g;
        let pp = PairParams::new(&self.p, self.l, b.offset(), self.time);
        let (start, js) = if self.kernel == ShearKernel::Straight {
            self.list.update(&g.x, &g.y, &g.radius, b);
            (&self.list.start[..], &self.list.j[..])
        } else {
            self.slots.sync(&mut self.list, &g.radius, (&g.x, &g.y), b);
            (&self.slots.start[..], &self.slots.j[..self.slots.len()])
        };
        let ranges = crate::dem::base::verlet::even_ranges(g.len(), threads);
        let (pp, list, st) = (&pp, (start, js), self.state_slices());
        // The first range sums as it goes; the others keep their terms, added after.
        let parts = ranges.into_iter().enumerate().collect();
        let run = || {
            crate::dem::backend::team::chunked(team.as_deref(), parts, |(k, grains)| {
                let (mut vir, mut terms) = (Virial::default(), Vec::new());
                if k == 0 {
                    for_each_virial_term(st, list, pp, grains, |t| add_virial(&mut vir, t));
                } else {
                    for_each_virial_term(st, list, pp, grains, |t| terms.push(t));
                }
                (vir, terms)
            })
        };
        let parts = match team.as_deref() {
            Some(t) => t.uncounted(run),
            None => run(),
        };
        let mut parts = parts.into_iter();
        let (mut vir, _) = parts.next().unwrap_or_default();
        for (_, terms) in parts {
            terms.into_iter().for_each(|t| add_virial(&mut vir, t));
        }
        vir
    }

    /// The steps' team, lent to work between steps (none on one thread).
    fn lent_team(&mut self) -> Option<std::sync::Arc<crate::dem::backend::team::Team>> {
        // (The threads' cache exists only on x86_64.)
        #[cfg(target_arch = "x86_64")]
        let team = {
            let threads = self.step_threads_used();
            self.par.lend_team(threads, self.step)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let team = None;
        team
    }

    /// One step of Eqs. 21–24.
    pub fn step(&mut self) {
        self.step_ahead(None, false);
    }

    /// `k` steps: `step` k times, the same numbers bit for bit. On threads (the packed
    /// kernels) each step but the last also makes the next one's prediction (Eqs.
    /// 21–22) as its final force sums come out of the kernel: the threads then meet
    /// once less a step, and the state is read once less.
    /// Nothing can change the state between two steps of one call, which is what lets
    /// the prediction be carried (a step that re-sorts is never predicted ahead).
    pub fn steps(&mut self, k: u64) {
        let mut ahead = None;
        for left in (0..k).rev() {
            ahead = self.step_ahead(ahead, left > 0);
        }
    }

    /// One step, from the prediction `ahead` made by the step before when given;
    /// with `fuse`, returns this step's prediction of the next one where it made one.
    fn step_ahead(&mut self, mut ahead: Option<Ahead>, fuse: bool) -> Option<Ahead> {
        if self.resort_every > 0 && self.step > 0 && self.step.is_multiple_of(self.resort_every) {
            self.resort();
            // (Never the case: the step before would not have predicted ahead.)
            ahead = None;
        }
        // The next step re-sorts first: this one's prediction would be for the old
        // order.
        let fuse =
            fuse && !(self.resort_every > 0 && (self.step + 1).is_multiple_of(self.resort_every));
        let n = self.g.len();
        let (g, pr) = (&self.g, &mut self.pred);
        for v in [&mut pr.x, &mut pr.y, &mut pr.vx, &mut pr.vy, &mut pr.w] {
            v.resize(n, 0.0);
        }
        if pr.inv_m.len() != n {
            pr.inv_m = g.mass.iter().map(|m| 1.0 / m).collect();
            pr.inv_i = g.inertia.iter().map(|i| 1.0 / i).collect();
        }
        // f_0 of Eq. 21 moves to the predictor's buffers; the evaluations below
        // overwrite every force.
        std::mem::swap(&mut pr.f0x, &mut self.fx);
        std::mem::swap(&mut pr.f0y, &mut self.fy);
        std::mem::swap(&mut pr.t0, &mut self.tq);
        for v in [&mut self.fx, &mut self.fy, &mut self.tq] {
            v.resize(n, 0.0);
        }
        #[cfg(target_arch = "x86_64")]
        if self.kernel == ShearKernel::Slots && Packed::used_for(&self.p) {
            let ahead = ahead.filter(|a| a.n == n && self.packed.pos.len() == n);
            return match self.threads_for_run() {
                // Also while the threads have fallen back (a busy machine): the same
                // numbers.
                t if t == 1 || self.par.solo(self.step) => {
                    self.par.history_changed();
                    self.step_packed(ahead)
                }
                t => self.step_threads(t, ahead, fuse),
            };
        }
        let _ = (ahead, fuse);
        let (dt, rotate) = (self.p.dt, self.rotate);
        let (g, pr) = (&self.g, &mut self.pred);
        predict(
            dt,
            rotate,
            (&g.x, &g.y, &g.vx, &g.vy, &g.omega),
            (&pr.inv_m, &pr.inv_i),
            (&pr.f0x, &pr.f0y, &pr.t0),
            &mut pr.x,
            &mut pr.y,
            &mut pr.vx,
            &mut pr.vy,
            &mut pr.w,
        );
        self.advance_clock();
        self.evaluate(true);
        let (g, pr) = (&mut self.g, &self.pred);
        correct(
            dt,
            rotate,
            (&pr.inv_m, &pr.inv_i),
            (&pr.f0x, &pr.f0y, &pr.t0),
            (&self.fx, &self.fy, &self.tq),
            &mut g.x,
            &mut g.y,
            &mut g.theta,
            &mut g.vx,
            &mut g.vy,
            &mut g.omega,
        );
        self.evaluate(false);
        None
    }

    /// The step's clock: step count, time and strain at t + Δt.
    fn advance_clock(&mut self) {
        self.step += 1;
        self.time = self.step as f64 * self.p.dt;
        self.gamma = self.next_gamma();
    }

    /// The strain the next step's clock will reach.
    fn next_gamma(&self) -> f64 {
        self.gamma + self.p.rate * self.p.dt
    }

    /// The boundary at the next step's strain (that step's stray test is made ahead).
    fn next_boundary(&self) -> Boundary {
        Boundary::LeesEdwards {
            lx: self.l,
            ly: self.l,
            offset: self.next_gamma() * self.l,
        }
    }

    /// `step` with the AVX2 kernel (α = 2): the same operations in the same order,
    /// the state handed between integrator and kernel packed grain by grain
    /// (`shear_integrate_avx2`). f_0 is in `pred.f0x/f0y/t0`.
    #[cfg(target_arch = "x86_64")]
    fn step_packed(&mut self, ahead: Option<Ahead>) -> Option<Ahead> {
        use crate::dem::backend::shear_integrate_avx2::{Now, correct_packed, predict_packed};
        let (dt, rotate, n) = (self.p.dt, self.rotate, self.g.len());
        // The clock first: the near list's stray test, made as the predictor writes
        // the positions, is for the boundary at t + Δt.
        self.advance_clock();
        let b = self.boundary();
        let pp = PairParams::new(&self.p, self.l, b.offset(), self.time);
        let (g, pr) = (&self.g, &mut self.pred);
        let strayed = match ahead {
            Some(a) => a.strayed,
            None => predict_packed(
                dt,
                rotate,
                (&g.x, &g.y, &g.vx, &g.vy, &g.omega),
                &g.radius,
                (&pr.inv_m, &pr.inv_i),
                (&pr.f0x, &pr.f0y, &pr.t0),
                &mut self.packed,
                self.slots.stray_test(self.list.builds, n, b),
            ),
        };
        if !self.slots.current(&self.list, n, b, strayed) {
            // The predicted positions, as arrays, only for a re-selection.
            let pr = &mut self.pred;
            pr.x.clear();
            pr.y.clear();
            pr.x.extend(self.packed.pos.iter().map(|p| p.0[0]));
            pr.y.extend(self.packed.pos.iter().map(|p| p.0[1]));
        }
        let ShearSim {
            g,
            pred: pr,
            list,
            slots,
            coll,
            packed,
            packed_now,
            fx,
            fy,
            tq,
            ..
        } = self;
        let r = &g.radius;
        slots.sync_tested(list, r, (&pr.x, &pr.y), b, strayed);
        // Forces at the predicted state; Eqs. 23–24 for each range of grains as its
        // sums are complete, while the kernel goes on (the corrector's memory traffic
        // overlaps the kernel's arithmetic). The state at t + Δt goes to `packed_now`:
        // the kernel still reads the predicted one.
        let builds = list.builds;
        packed_now.reserve(n);
        let (mut tested, mut far) = (true, false);
        let mut correct = |range: std::ops::Range<usize>, f1: &mut [Quad], s: &Slots| {
            let test = s.stray_test(builds, n, b).map(|t| t.range(range.clone()));
            tested &= test.is_some();
            let rr = || range.clone();
            let now = Now {
                x: &mut g.x[rr()],
                y: &mut g.y[rr()],
                theta: &mut g.theta[rr()],
                vx: &mut g.vx[rr()],
                vy: &mut g.vy[rr()],
                w: &mut g.omega[rr()],
                r: &g.radius[rr()],
                f0: (&pr.f0x[rr()], &pr.f0y[rr()], &pr.t0[rr()]),
            };
            let inv = (&pr.inv_m[rr()], &pr.inv_i[rr()]);
            let out = (&mut packed_now.pos[rr()], &mut packed_now.vel[rr()]);
            far |= correct_packed(dt, rotate, inv, now, f1, out, test) == Some(true);
        };
        let hist = &mut list.shear[..];
        evaluate_packed::<false>(packed, slots, hist, &pp, coll, &mut correct);
        // Every predicted sum was read and zeroed by the corrector.
        slots.acc_zeroed = true;
        let strayed = tested.then_some(far);
        slots.sync_tested(list, &g.radius, (&g.x, &g.y), b, strayed);
        // Forces at t + Δt (f_0 of the next step), spread into the arrays range by
        // range as they are complete. (The next step's prediction is not made here
        // ahead, as the threads make it: on one thread that was no faster at
        // N = 16,384 and 6 % slower at 65,536, where writing the predicted records
        // during the kernel costs the kernel its cache; docs/performance.md.)
        let hist = &mut list.shear[..];
        let forces = (&mut fx[..], &mut fy[..], &mut tq[..]);
        evaluate_packed_into::<true>(packed_now, slots, hist, &pp, coll, forces);
        None
    }

    /// Pressure tensor parts (Eqs. 12–15) at the current state: (el, dis, kin), each
    /// [xx, xy, yx, yy] in m/τ_e². The kinetic part uses fluctuations about v_x = γ̇ y.
    pub fn pressure_tensor(&mut self) -> ([f64; 4], [f64; 4], [f64; 4]) {
        let vir = self.virial();
        self.pressure_tensor_of(&vir)
    }

    /// As [`ShearSim::pressure_tensor`], with the virial of the current state given.
    pub fn pressure_tensor_of(&self, vir: &Virial) -> ([f64; 4], [f64; 4], [f64; 4]) {
        let a = self.l * self.l;
        let el = vir.el.map(|v| v / a);
        let dis = vir.dis.map(|v| v / a);
        let mut kin = [0.0; 4];
        let g = &self.g;
        for i in 0..g.len() {
            let (dvx, dvy) = (g.vx[i] - self.p.rate * g.y[i], g.vy[i]);
            kin[0] += g.mass[i] * dvx * dvx;
            kin[1] += g.mass[i] * dvx * dvy;
            kin[2] += g.mass[i] * dvy * dvx;
            kin[3] += g.mass[i] * dvy * dvy;
        }
        (el, dis, kin.map(|v| v / a))
    }

    /// Change the strain rate to `rate`, rescaling every velocity and spin by the ratio
    /// so the new rate holds throughout the bulk at once (vagberg-sheared-disks
    /// Eqs. 40–41), then re-evaluate the forces (the dissipative ones depend on v).
    pub fn set_rate(&mut self, rate: f64) {
        let k = rate / self.p.rate;
        for v in [&mut self.g.vx, &mut self.g.vy, &mut self.g.omega] {
            v.iter_mut().for_each(|x| *x *= k);
        }
        self.p.rate = rate;
        self.refresh();
    }

    /// Contact-velocity components of every current contact (vagberg-sheared-disks
    /// Eqs. 30–34), in units of d_s γ̇: [V_T, V^R, V^C_T, V_N] with r̂_ji the outward
    /// normal of i at the contact and t̂_ji = ẑ × r̂_ji. V^R uses Eq. 6's moment arms
    /// (|s_ji| = d_i/2 at contact), i.e. Eq. 31 with the radii: V^C = V + V^R is then the
    /// exact contact-point velocity difference the CDrot force acts on.
    pub fn contact_velocities(&self) -> Vec<[f64; 4]> {
        let b = self.boundary();
        let (g, shear_v, rate) = (&self.g, self.p.rate * self.l, self.p.rate);
        let mut out = Vec::new();
        for i in 0..g.len() {
            for k in self.list.start[i] as usize..self.list.start[i + 1] as usize {
                let j = self.list.j[k] as usize;
                let (dx, dy, img) = b.delta_image(g.x[i] - g.x[j], g.y[i] - g.y[j]);
                let dij = g.radius[i] + g.radius[j];
                let r2 = dx * dx + dy * dy;
                if r2 >= dij * dij {
                    continue;
                }
                let d = r2.sqrt();
                // r̂_ji points from i to j.
                let (nx, ny) = (-dx / d, -dy / d);
                let (tx, ty) = (-ny, nx);
                let (vx, vy) = (
                    (g.vx[i] - g.vx[j] - img * shear_v) / rate,
                    (g.vy[i] - g.vy[j]) / rate,
                );
                let v_r = (g.omega[i] * g.radius[i] + g.omega[j] * g.radius[j]) / rate;
                let v_t = vx * tx + vy * ty;
                out.push([v_t, v_r, v_t + v_r, vx * nx + vy * ny]);
            }
        }
        out
    }

    /// Positions mapped into the primary cell [0, L)², Lees–Edwards aware.
    pub fn wrapped(&self, i: usize) -> (f64, f64) {
        let off = self.gamma * self.l;
        let (mut x, mut y) = (self.g.x[i], self.g.y[i]);
        let n = (y / self.l).floor();
        y -= n * self.l;
        x -= n * off;
        x -= (x / self.l).floor() * self.l;
        (x, y)
    }

    /// Total momentum (m d_s/τ_e).
    pub fn momentum(&self) -> (f64, f64) {
        self.g.momentum()
    }
}
