//! li-granular-pillars Sec. II.B: grains on a frictional substrate between a fixed
//! bottom bar and a top bar moving down at v_c.
//!
//! One step (velocity Verlet for positions, explicit finite difference for spins):
//! 1. v ← v + ½ δt a; r ← r + δt v; θ ← θ + δt ω; the top bar moves to y_top(t + δt);
//! 2. contact forces and torques at the new positions (grain–grain, grain–bar) with the
//!    mid-step velocities;
//! 3. substrate friction from those (Sec. II.B.3: opposite the motion, or cancelling
//!    the contact force of a grain at rest up to m g μ); a ← (F + f)/m; v ← v + ½ δt a;
//!    ω ← ω + δt (T + T_μ)/I;
//! 4. the ξ rule of Eq. 11: a grain slower than ξ_v whose contact force is within
//!    m g μ is stopped (v = 0, a = 0); likewise for spins with ξ_ω and (2/3) m g μ R.
//!
//! The substrate's static test uses grain–grain and grain–bar forces only.

pub mod checkpoint;
pub mod dispatch;
pub mod gather;
pub mod kernels;
pub mod pack;
pub mod params;
pub mod phases;
pub mod reverse;
pub mod stress;

use crate::dem::base::forces::ContactRecord;
use crate::dem::base::grains::{Grains, LARGE};
use crate::dem::base::verlet::{Boundary, PairList};
use crate::dem::law::{ContactLaw, SubstrateFriction};
use crate::dem::pillar::params::PillarParams;
use crate::dem::pillar::phases::StepBuffers;

/// Sums over an output interval (for averages the paper's σ and κ use).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Interval {
    pub steps: u64,
    /// Σ over steps of the top/bottom bar force (N).
    pub top_force: f64,
    pub bottom_force: f64,
    /// Σ over steps of the substrate's translational / rotational dissipation
    /// Σ_i |f_i · v_i|, Σ_i |T_μ,i ω_i| (W).
    pub substrate_power: f64,
    pub substrate_power_rot: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PillarSim {
    pub params: PillarParams,
    pub grains: Grains,
    pub list: PairList,
    /// Bottom bar face (m), fixed.
    pub bottom_y: f64,
    /// Top bar face at step 0 (m); y_top(step) = top_y0 − v_c δt step.
    pub top_y0: f64,
    /// Tangential springs of each grain's contact with the top / bottom bar (m).
    pub top_shear: Vec<f64>,
    pub bottom_shear: Vec<f64>,
    pub step: u64,
    /// Contact force (N) and torque (N m) on each grain at the last evaluation.
    pub fx: Vec<f64>,
    pub fy: Vec<f64>,
    pub tq: Vec<f64>,
    /// Substrate friction force on each grain at the last step (N).
    pub sub_fx: Vec<f64>,
    pub sub_fy: Vec<f64>,
    /// Force of the grains on the top bar (N, positive pushing it up) and on the
    /// bottom bar (positive pushing it down), last step.
    pub top_force: f64,
    pub bottom_force: f64,
    /// Σ of the bars' tangential (x) forces on the grains, last step (N).
    pub bar_shear_force: f64,
    pub interval: Interval,
    /// Filled during the next force evaluation when set (force snapshots).
    pub record: Option<ContactRecord>,
    /// Derived data that saves work (not state: equal runs compare equal without it).
    pub scratch: Scratch,
}

/// Which grains are frozen this step (at rest, every partner at rest, clear of both
/// bars): their forces cannot change, so they need no work (exactly the same results;
/// see `pillar_phases`).
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    /// Skip frozen grains (default on; off for comparison runs).
    pub skip_frozen: bool,
    /// Test every chunk of grains against the bars, not only those that may touch
    /// one before the list's next rebuild (off by default; on for comparison runs).
    pub all_bar_chunks: bool,
    pub resting: Vec<bool>,
    pub frozen: Vec<bool>,
    /// Whether frozen grains are being marked (see [`Marking`]).
    pub marking: Marking,
    /// Grain-steps and pair evaluations skipped since the start (diagnostics).
    pub frozen_grain_steps: u64,
    pub skipped_pairs: u64,
    /// Per-grain constants of the substrate and the integrator (see [`Consts`]).
    pub consts: Consts,
    /// Per-step buffers of the phases (`pillar_par`).
    pub buffers: StepBuffers,
    /// Threads for `advance` (0: one per core, at most one per 256 grains).
    pub threads: usize,
    /// Never finish an `advance` on one thread when waits grow long (tests that must
    /// really run split).
    pub no_fallback: bool,
    /// `advance` calls that finished on one thread because waits kept being long.
    pub fallbacks: u64,
    /// Tests: microseconds the last thread sleeps after each step's barrier in
    /// `advance`, so that the others run ahead as past a descheduled thread.
    #[cfg(test)]
    pub pause_after_barrier_us: u64,
    /// Step of the last pair-list build in this session (for [`adapt_skin`]).
    pub last_build: Option<u64>,
    /// The largest move since its build (m) that any list saw at its rebuild, over
    /// half its skin: 1 within a step's travel when every rebuild test used the
    /// list's own skin (diagnostics, for the tests).
    pub rebuild_overshoot: f64,
}

/// The pair list's skin, in units of the large diameter D: between these bounds, set
/// at each build from the steps since the last one ([`adapt_skin`]).
pub const SKIN_MIN: f64 = 0.01;
pub const SKIN_MAX: f64 = 0.05;

/// The skin (m) for the next build, from the current one and the steps since the last
/// build: thicker when rebuilds come more often than every 200 steps, thinner when
/// rarer than every 1000, within [`SKIN_MIN`] D .. [`SKIN_MAX`] D. A thin skin holds
/// fewer slots, which the vector pair kernel pays for touching or not (0.15 D held 2.4
/// slots per grain, 0.05 D 2.1, with 1.6 touching); a thick one rebuilds less often.
/// The quasistatic `paper` pillar rebuilds every ~2e4 steps at 0.01 D (its run 3 %
/// faster than at 0.05 D), a pillar loaded to ε = 0.02 every ~1100 (5 % faster than
/// at 0.05 D, every ~5500); a fast-loaded N = 16,000 one every 12 steps at 0.01 D
/// (40 % slower than at 0.05 D, every 57). The forces never depend on the skin: each
/// grain's partners are kept sorted and non-touching slots add +0.0, so any skin gives
/// the same numbers bit for bit.
pub fn adapt_skin(skin: f64, d: f64, since_last_build: Option<u64>) -> f64 {
    match since_last_build {
        Some(k) if k < 200 => (skin * 1.5).min(SKIN_MAX * d),
        Some(k) if k > 1000 => (skin / 1.5).max(SKIN_MIN * d),
        _ => skin,
    }
}

/// Marking frozen grains walks every grain's partners, which costs more than it
/// saves when few are frozen (a flowing pillar): marking stops while fewer than
/// `MARK_FRACTION` of the grains were frozen at the last marked step, and is tried
/// again every `MARK_RETRY` steps. Results are the same either way (a grain not marked
/// is computed, and gives the numbers it kept).
#[derive(Debug, Clone)]
pub struct Marking {
    /// Mark the next step.
    pub now: bool,
    /// Whether the step under way marks.
    pub marked: bool,
    /// Steps since the last marked one.
    pub idle: u64,
}

impl Default for Marking {
    fn default() -> Self {
        Marking {
            now: true,
            marked: false,
            idle: 0,
        }
    }
}

/// Top bar face (m) after `step` steps of δt = `dt` (s) at `bar_speed` (m/s) from
/// `top_y0` (m): one expression for every caller, so threads that compute it from the
/// step number get the bits [`PillarSim::top_y`] gives.
#[inline]
pub fn top_y_at(top_y0: f64, bar_speed: f64, dt: f64, step: u64) -> f64 {
    top_y0 - bar_speed * dt * step as f64
}

/// Fraction of the grains frozen at a marked step below which marking pauses.
/// Measured on the `paper` N = 1000 pillar (`bench dem --checkpoint`, one thread):
/// at 48 % and 58 % frozen, marking made a step 15.2 and 14.5 µs against 12.9 without
/// it (the slots between resting grains are skipped either way); at 83 %, 9.3–10.0
/// against 10.5–11.1. It was 0.4.
pub const MARK_FRACTION: f64 = 0.75;
/// Steps without marking before it is tried again.
pub const MARK_RETRY: u64 = 32;

impl Marking {
    /// After a step that found `frozen` of `n` grains frozen (when it marked).
    pub fn after(&mut self, frozen: usize, n: usize) {
        if self.marked {
            self.now = frozen as f64 >= MARK_FRACTION * n as f64;
            self.idle = 0;
        } else {
            self.idle += 1;
            self.now = self.idle >= MARK_RETRY;
        }
    }
}

/// Per-grain constants derived from masses, radii and parameters, so the per-step
/// loops multiply instead of divide.
#[derive(Debug, Clone, Default)]
pub struct Consts {
    /// (δt, g, μ) they were computed for, and the grain count.
    key: (f64, f64, f64, usize),
    /// 1/m (1/kg), 1/I (1/(kg m²)).
    pub inv_mass: Vec<f64>,
    pub inv_inertia: Vec<f64>,
    /// m g μ (N) and its square; (2/3) m g μ R (N m), Eq. 9.
    pub f_max: Vec<f64>,
    pub f_max2: Vec<f64>,
    pub t_max: Vec<f64>,
    /// ξ_ω = 4 g μ δt / (3 R) (rad/s), Eq. 11.
    pub xi_omega: Vec<f64>,
}

impl Consts {
    pub(crate) fn refresh(&mut self, g: &Grains, sub: &SubstrateFriction, dt: f64) {
        let key = (dt, sub.g, sub.mu, g.len());
        if self.key == key && !self.inv_mass.is_empty() {
            return;
        }
        self.key = key;
        self.inv_mass = g.mass.iter().map(|m| 1.0 / m).collect();
        self.inv_inertia = g.inertia.iter().map(|m| 1.0 / m).collect();
        self.f_max = g.mass.iter().map(|&m| m * sub.g * sub.mu).collect();
        self.f_max2 = self.f_max.iter().map(|f| f * f).collect();
        self.t_max = (0..g.len())
            .map(|i| sub.torque_max(g.mass[i], g.radius[i]))
            .collect();
        self.xi_omega = g.radius.iter().map(|&r| sub.xi_omega(dt, r)).collect();
        // The scalar clamp(−T_max, T_max) panics otherwise; the AVX2 kernel would not.
        assert!(
            self.t_max.iter().all(|&t| t >= 0.0),
            "substrate torque limits (2/3) m g μ R must be ≥ 0"
        );
    }
}

impl PartialEq for Scratch {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl PillarSim {
    /// A pillar from grain centres (m) and species; bars touch the lowest and highest
    /// grains (initial bar force zero).
    pub fn new(params: PillarParams, x: &[f64], y: &[f64], species: &[i32], ids: &[i64]) -> Self {
        let mut g = Grains::default();
        for k in 0..x.len() {
            let large = species[k] == LARGE;
            let (r, m) = if large {
                (0.5 * params.d_large, params.m_large)
            } else {
                (0.5 * params.d_small, params.m_small)
            };
            g.push(ids[k], species[k], r, m, x[k], y[k]);
        }
        let bottom = (0..g.len())
            .map(|i| g.y[i] - g.radius[i])
            .fold(f64::INFINITY, f64::min);
        let top = (0..g.len())
            .map(|i| g.y[i] + g.radius[i])
            .fold(f64::NEG_INFINITY, f64::max);
        Self::with_bars(params, g, bottom, top)
    }

    /// Grains as given, bars where given (tests put them far away).
    pub fn with_bars(params: PillarParams, mut grains: Grains, bottom_y: f64, top_y0: f64) -> Self {
        let d = params.d_large;
        grains.sort_spatially(d);
        let n = grains.len();
        let mut s = PillarSim {
            // Thin to start with; `adapt_skin` thickens it where rebuilds come often.
            list: PairList::new(SKIN_MIN * d),
            params,
            grains,
            bottom_y,
            top_y0,
            top_shear: vec![0.0; n],
            bottom_shear: vec![0.0; n],
            step: 0,
            fx: vec![0.0; n],
            fy: vec![0.0; n],
            tq: vec![0.0; n],
            sub_fx: vec![0.0; n],
            sub_fy: vec![0.0; n],
            top_force: 0.0,
            bottom_force: 0.0,
            bar_shear_force: 0.0,
            interval: Interval::default(),
            record: None,
            scratch: Scratch {
                skip_frozen: true,
                ..Scratch::default()
            },
        };
        s.list
            .build(&s.grains.x, &s.grains.y, &s.grains.radius, Boundary::Open);
        s.refresh_forces();
        s
    }

    /// The grain–grain contact law ([`PillarParams::grain_law`]).
    ///
    /// # Panics
    /// If the parameters do not validate: every way into a run (options, checkpoints)
    /// validates them first.
    pub fn law(&self) -> ContactLaw {
        self.params
            .grain_law()
            .expect("pillar parameters are validated before a run")
    }

    /// The grain–bar contact law ([`PillarParams::bar_law`]); panics as [`Self::law`].
    pub fn bar_law(&self) -> ContactLaw {
        self.params
            .bar_law()
            .expect("pillar parameters are validated before a run")
    }
    pub fn substrate(&self) -> SubstrateFriction {
        SubstrateFriction {
            g: self.params.g,
            mu: self.params.mu,
        }
    }

    /// Top bar face at the current step (m).
    pub fn top_y(&self) -> f64 {
        top_y_at(
            self.top_y0,
            self.params.bar_speed,
            self.params.dt,
            self.step,
        )
    }

    /// Time since the bar started (s).
    pub fn time(&self) -> f64 {
        self.params.dt * self.step as f64
    }

    /// Engineering strain ε = ΔH/H0 (Sec. III), H0 the initial bar separation.
    pub fn strain(&self) -> f64 {
        stress::strain(self.top_y0, self.bottom_y, self.top_y())
    }

    /// The bar state [`stress::stress_point`] turns into ε, σ and P_in, with the top
    /// bar force `top_force` (N).
    pub fn bar_state(&self, top_force: f64) -> stress::BarState {
        stress::BarState {
            top_y0: self.top_y0,
            bottom_y: self.bottom_y,
            top_y: self.top_y(),
            top_force,
        }
    }

    /// Advance one time step δt (on this thread; `advance` runs many on several).
    ///
    /// 1. v ← v + ½ δt a; r ← r + δt v; θ ← θ + δt ω; the top bar moves;
    /// 2. contact forces and torques at the new positions (grain–grain, grain–bar);
    /// 3. substrate friction, a ← (F + f)/m, v ← v + ½ δt a, ω ← ω + δt (T + T_μ)/I;
    /// 4. the ξ rule of Eq. 11.
    pub fn step(&mut self) {
        self.advance_with(1, 1);
    }

    /// Grain–grain elastic energy (J), for tests and diagnostics.
    pub fn contact_energy(&self) -> f64 {
        let law = self.law();
        let k_t = match law.tangential() {
            crate::dem::law::Tangential::CundallStrack { k_t, .. } => k_t,
            crate::dem::law::Tangential::None => 0.0,
        };
        let g = &self.grains;
        let mut e = 0.0;
        for i in 0..g.len() {
            for k in self.list.start[i] as usize..self.list.start[i + 1] as usize {
                let j = self.list.j[k] as usize;
                let (dx, dy) = (g.x[i] - g.x[j], g.y[i] - g.y[j]);
                let (rs, dist) = (g.radius[i] + g.radius[j], (dx * dx + dy * dy).sqrt());
                if dist < rs {
                    e += law.energy(dist, rs);
                    e += 0.5 * k_t * self.list.shear[k] * self.list.shear[k];
                }
            }
        }
        e
    }

    /// Number of grain–grain contacts (pairs with overlap > 0).
    pub fn contacts(&self) -> usize {
        let g = &self.grains;
        let mut c = 0;
        for i in 0..g.len() {
            for k in self.list.start[i] as usize..self.list.start[i + 1] as usize {
                let j = self.list.j[k] as usize;
                let (dx, dy) = (g.x[i] - g.x[j], g.y[i] - g.y[j]);
                let rs = g.radius[i] + g.radius[j];
                if dx * dx + dy * dy < rs * rs {
                    c += 1;
                }
            }
        }
        c
    }

    /// Lateral extent (m), radii included, of the grains whose centres lie within
    /// `band` of the top bar (the paper's pillar width W at the top edge).
    pub fn width_near_top(&self, band: f64) -> f64 {
        let g = &self.grains;
        stress::width_near_top(&g.x, &g.y, &g.radius, self.top_y(), band)
    }

    /// Span (m), radii included, of the grains touching the top bar.
    pub fn contact_span_top(&self) -> f64 {
        let top = self.top_y();
        let g = &self.grains;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..g.len() {
            if top - g.y[i] < g.radius[i] {
                lo = lo.min(g.x[i] - g.radius[i]);
                hi = hi.max(g.x[i] + g.radius[i]);
            }
        }
        if hi > lo { hi - lo } else { 0.0 }
    }
}
