//! Analytic and conservation checks of the DEM (issue 5's correctness list).

use crate::dem::base::forces::ContactRecord;
use crate::dem::base::grains::{Grains, LARGE, SMALL};
use crate::dem::base::verlet::Boundary;
use crate::dem::pillar::PillarSim;
use crate::dem::pillar::pack::{Lj, PackOptions, pack};
use crate::dem::pillar::params::PillarParams;

/// One grain far from both bars.
fn lone(params: PillarParams, species: i32) -> PillarSim {
    let mut g = Grains::default();
    let (r, m) = if species == LARGE {
        (0.5 * params.d_large, params.m_large)
    } else {
        (0.5 * params.d_small, params.m_small)
    };
    g.push(0, species, r, m, 0.0, 0.0);
    PillarSim::with_bars(params, g, -1.0, 1.0)
}

fn still_bars(mut p: PillarParams) -> PillarParams {
    p.bar_speed = 0.0;
    p
}

#[test]
fn lone_grain_slides_v2_over_2_g_mu() {
    for (v, species) in [(0.05, LARGE), (0.013, SMALL)] {
        let p = still_bars(PillarParams::paper());
        let mut s = lone(p.clone(), species);
        s.grains.vx[0] = v * 0.6;
        s.grains.vy[0] = v * 0.8;
        s.step(); // the first step sets the friction acceleration from the motion
        let mut steps = 1;
        while s.grains.vx[0] != 0.0 || s.grains.vy[0] != 0.0 {
            s.step();
            steps += 1;
            assert!(steps < 10_000_000);
        }
        let dist = (s.grains.x[0].powi(2) + s.grains.y[0].powi(2)).sqrt();
        let want = v * v / (2.0 * p.g * p.mu);
        // Within one step's travel at the start speed.
        assert!((dist - want).abs() < v * p.dt, "{dist} vs {want}");
        let t_stop = v / (p.g * p.mu);
        assert!((steps as f64 * p.dt - t_stop).abs() <= 2.0 * p.dt);
        // It stays stopped, exactly.
        let x = s.grains.x[0];
        for _ in 0..1000 {
            s.step();
        }
        assert_eq!(s.grains.x[0], x);
    }
}

#[test]
fn spinning_lone_grain_stops_at_3_r_omega_over_4_g_mu() {
    let p = still_bars(PillarParams::paper());
    let mut s = lone(p.clone(), LARGE);
    let w0 = 20.0;
    s.grains.omega[0] = w0;
    let mut steps = 0u64;
    while s.grains.omega[0] != 0.0 {
        s.step();
        steps += 1;
        assert!(steps < 10_000_000);
    }
    let r = 0.5 * p.d_large;
    let want = 3.0 * r * w0 / (4.0 * p.g * p.mu);
    assert!(
        (steps as f64 * p.dt - want).abs() <= 2.0 * p.dt,
        "{} vs {want}",
        steps as f64 * p.dt
    );
    // Spinning alone moves nothing.
    assert_eq!((s.grains.x[0], s.grains.y[0]), (0.0, 0.0));
}

/// Two small grains overlapping by `delta`: repulsion k_n δ against m g μ.
fn pair(delta: f64) -> PillarSim {
    let p = still_bars(PillarParams::paper());
    let r = 0.5 * p.d_small;
    let mut g = Grains::default();
    g.push(0, SMALL, r, p.m_small, 0.0, 0.0);
    g.push(1, SMALL, r, p.m_small, 2.0 * r - delta, 0.0);
    PillarSim::with_bars(p, g, -1.0, 1.0)
}

#[test]
fn a_push_below_m_g_mu_never_moves_a_grain_and_above_it_does() {
    let p = PillarParams::paper();
    let f_static = p.m_small * p.g * p.mu;
    let below = 0.9 * f_static / p.k_n;
    let mut s = pair(below);
    let x0 = s.grains.x.clone();
    for _ in 0..20_000 {
        s.step();
    }
    assert_eq!(s.grains.x, x0, "held by the substrate");
    assert_eq!(s.grains.vx, vec![0.0, 0.0]);
    let start = 1.5 * f_static / p.k_n;
    let mut s = pair(start);
    for _ in 0..20_000 {
        s.step();
    }
    // Pushed apart until the repulsion no longer beats the substrate, then held.
    let overlap = p.d_small - (s.grains.x[1] - s.grains.x[0]).abs();
    assert!(
        overlap < 0.99 * start,
        "moved: overlap {overlap} of {start}"
    );
    assert!(
        p.k_n * overlap <= f_static,
        "stopped only once k_n δ ≤ m g μ"
    );
    assert_eq!(s.grains.vx, vec![0.0, 0.0]);
}

/// The α = 5/2 option in a whole pillar step: two small grains held by the substrate
/// exactly while k δ^{3/2} ≤ m g μ. At 0.9 of the Hertzian threshold overlap the
/// linear law would push (k_n δ > m g μ there), the Hertzian law must not; from 1.5
/// of it they separate until the Hertzian force no longer beats the substrate.
#[test]
fn hertzian_contacts_hold_exactly_below_m_g_mu() {
    use crate::dem::pillar::params::NormalLawName;
    let mut p = still_bars(PillarParams::paper());
    p.normal_law = NormalLawName::Hertz;
    p.validate().unwrap();
    let k = p.hertz_k();
    let f_static = p.m_small * p.g * p.mu;
    let threshold = (f_static / k).powf(2.0 / 3.0);
    let hertz_pair = |delta: f64| {
        let r = 0.5 * p.d_small;
        let mut g = Grains::default();
        g.push(0, SMALL, r, p.m_small, 0.0, 0.0);
        g.push(1, SMALL, r, p.m_small, 2.0 * r - delta, 0.0);
        PillarSim::with_bars(p.clone(), g, -1.0, 1.0)
    };
    let below = 0.9 * threshold;
    assert!(p.k_n * below > f_static, "the linear law would move these");
    let mut s = hertz_pair(below);
    assert_eq!(
        s.pair_kernel(),
        "scalar",
        "no vector kernel implements Hertz"
    );
    let x0 = s.grains.x.clone();
    for _ in 0..20_000 {
        s.step();
    }
    assert_eq!(s.grains.x, x0, "held by the substrate");
    let start = 1.5 * threshold;
    let mut s = hertz_pair(start);
    for _ in 0..20_000 {
        s.step();
    }
    let overlap = p.d_small - (s.grains.x[1] - s.grains.x[0]).abs();
    assert!(
        overlap < 0.99 * start,
        "moved: overlap {overlap} of {start}"
    );
    assert!(
        k * overlap.powf(1.5) <= f_static * (1.0 + 1e-12),
        "stopped only once k δ^3/2 ≤ m g μ: overlap {overlap}, threshold {threshold}"
    );
    assert_eq!(s.grains.vx, vec![0.0, 0.0]);
}

#[test]
fn frictionless_collision_conserves_momentum_and_energy() {
    let mut p = still_bars(PillarParams::paper());
    p.mu = 0.0;
    p.mu_g = 0.0;
    let (rl, rs) = (0.5 * p.d_large, 0.5 * p.d_small);
    let mut g = Grains::default();
    g.push(0, LARGE, rl, p.m_large, 0.0, 0.0);
    g.push(1, SMALL, rs, p.m_small, 0.02, 0.003);
    let mut s = PillarSim::with_bars(p, g, -1.0, 1.0);
    s.grains.vx[1] = -0.3;
    s.grains.omega[0] = 5.0;
    let p0 = s.grains.momentum();
    let e0 = s.grains.kinetic_energy();
    let mut touched = false;
    for _ in 0..20_000 {
        s.step();
        touched |= s.contacts() > 0;
        let e = s.grains.kinetic_energy() + s.contact_energy();
        assert!((e - e0).abs() < 1e-3 * e0, "energy drift {}", (e - e0) / e0);
    }
    assert!(touched, "the grains collided");
    assert_eq!(s.contacts(), 0, "and separated");
    let p1 = s.grains.momentum();
    let scale = p0.0.abs() + p0.1.abs();
    assert!(
        (p1.0 - p0.0).abs() < 1e-14 * scale && (p1.1 - p0.1).abs() < 1e-14 * scale,
        "{p0:?} {p1:?}"
    );
    // No friction: spins are untouched.
    assert_eq!(s.grains.omega[0], 5.0);
    assert!(s.grains.vy[0] != 0.0, "an oblique collision deflects");
}

/// A pillar of `n` grains from the packing protocol (`seed`), with parameters `p`.
fn packed_pillar(n: usize, seed: u64, p: PillarParams) -> PillarSim {
    let pk = pack(
        &PackOptions {
            n,
            seed,
            ..Default::default()
        },
        |_, _| {},
    )
    .expect("no signal in the tests");
    let d = p.d_large;
    let x: Vec<f64> = pk.x.iter().map(|v| v * d).collect();
    let y: Vec<f64> = pk.y.iter().map(|v| v * d).collect();
    let ids: Vec<i64> = (0..n as i64).collect();
    PillarSim::new(p, &x, &y, &pk.species, &ids)
}

/// A small pillar from the packing protocol (fast preset), compressed for a while.
fn small_pillar(n: usize, steps: usize, mut each: impl FnMut(&PillarSim)) -> PillarSim {
    let mut s = packed_pillar(n, 3, PillarParams::fast());
    // Speed the bar up so a short test compresses noticeably.
    s.params.bar_speed *= 20.0;
    for _ in 0..steps {
        s.step();
        each(&s);
    }
    s
}

#[test]
fn coulomb_limit_holds_at_every_contact_every_step_and_forces_balance() {
    let mut checked = 0usize;
    let s = small_pillar(120, 6000, |s| {
        let g = &s.grains;
        let (kn, kt, mu) = (
            s.params.k_n,
            s.params.kt_over_kn * s.params.k_n,
            s.params.mu_g,
        );
        let (mut sx, mut sy) = (0.0, 0.0);
        for i in 0..g.len() {
            for k in s.list.start[i] as usize..s.list.start[i + 1] as usize {
                let j = s.list.j[k] as usize;
                let dist = ((g.x[i] - g.x[j]).powi(2) + (g.y[i] - g.y[j]).powi(2)).sqrt();
                let delta = g.radius[i] + g.radius[j] - dist;
                if delta > 0.0 {
                    assert!(kt * s.list.shear[k].abs() <= mu * kn * delta * (1.0 + 1e-12));
                    checked += 1;
                } else {
                    assert_eq!(s.list.shear[k], 0.0);
                }
            }
            sx += s.fx[i];
            sy += s.fy[i];
        }
        // Internal forces cancel: the contact forces sum to what the bars exert.
        let scale = s.top_force.abs() + s.bottom_force.abs() + 1e-12;
        assert!(
            (sx - s.bar_shear_force).abs() < 1e-12 * scale.max(1e-3),
            "Σ F_x = {sx}"
        );
        assert!(
            (sy - (s.bottom_force - s.top_force)).abs() < 1e-9 * scale.max(1e-3),
            "Σ F_y = {sy}"
        );
    });
    assert!(checked > 1000, "contacts checked: {checked}");
    assert!(s.top_force > 0.0, "the bar is loaded");
}

#[test]
fn packing_is_at_jamming_without_overlaps() {
    let n = 150;
    let pk = pack(
        &PackOptions {
            n,
            seed: 11,
            ..Default::default()
        },
        |_, _| {},
    )
    .expect("no signal in the tests");
    assert!(pk.pressure < 1e-10, "p = {}", pk.pressure);
    assert!(pk.phi > 0.80 && pk.phi < 0.87, "phi = {}", pk.phi);
    assert!(pk.growth_steps > 3);
    let r: Vec<f64> = pk
        .species
        .iter()
        .map(|&s| if s == LARGE { 0.5 } else { 0.375 })
        .collect();
    let b = Boundary::Periodic {
        lx: pk.lx,
        ly: pk.ly,
    };
    let mut closest: f64 = f64::INFINITY;
    for i in 0..n {
        for j in i + 1..n {
            let (dx, dy) = b.delta(pk.x[i] - pk.x[j], pk.y[i] - pk.y[j]);
            closest = closest.min((dx * dx + dy * dy).sqrt() / (r[i] + r[j]));
        }
    }
    assert!(closest > 1.0 - 1e-9, "closest pair at {closest} of contact");
    assert!(closest < 1.0 + 1e-3, "grains touch");
    // The mixture is 50:50.
    assert_eq!(
        pk.species.iter().filter(|&&s| s == LARGE).count(),
        n.div_ceil(2)
    );
    // Minimisation: a hand-made overlap is removed.
    let mut lj = Lj::new(vec![0.5, 0.5], Boundary::Open);
    let (mut x, mut y) = (vec![0.0, 0.9], vec![0.0, 0.0]);
    lj.minimise(&mut x, &mut y, 1e-12, 0.0);
    assert!(x[1] - x[0] > 1.0 - 1e-9);
}

#[test]
fn checkpoint_round_trip_is_bit_exact() {
    let mut s = small_pillar(60, 300, |_| {});
    let bytes = s.save(b"extra");
    let (mut t, extra) = PillarSim::load(&bytes).unwrap();
    assert_eq!(extra, b"extra");
    assert_eq!(t, s);
    for _ in 0..500 {
        s.step();
        t.step();
    }
    assert_eq!(t, s);
    assert!(PillarSim::load(&bytes[..bytes.len() - 3]).is_err());
    assert!(PillarSim::load(b"garbage!").is_err());
}

#[test]
fn skipping_frozen_grains_gives_exactly_the_same_run() {
    let mut a = packed_pillar(150, 5, PillarParams::fast());
    a.scratch.skip_frozen = true;
    let mut b = a.clone();
    b.scratch.skip_frozen = false;
    // Marking switched on and off at random (as `Marking` does when the frozen fraction
    // crosses its threshold) changes nothing either.
    let mut c = a.clone();
    let mut rng = crate::rng::Rng::new(17);
    let mut toggled = 0;
    for _ in 0..30_000 {
        a.step();
        b.step();
        let now = rng.uniform() < 0.5;
        toggled += (now != c.scratch.marking.now) as u32;
        c.scratch.marking.now = now;
        c.step();
    }
    assert!(toggled > 1000);
    assert_eq!(a.grains, b.grains);
    assert_eq!(a.grains, c.grains);
    assert_eq!((&a.fx, &a.fy, &a.tq), (&c.fx, &c.fy, &c.tq));
    assert_eq!(a.list, b.list);
    assert_eq!(
        (a.fx.clone(), a.fy.clone(), a.tq.clone()),
        (b.fx.clone(), b.fy.clone(), b.tq.clone())
    );
    assert_eq!(a.interval, b.interval);
    let (frozen, skipped) = (a.scratch.frozen_grain_steps, a.scratch.skipped_pairs);
    assert!(
        frozen > 0 && skipped > 0,
        "some grains were frozen: {frozen} grain-steps, {skipped} pairs skipped"
    );
}

#[test]
fn frozen_grains_are_marked_only_while_enough_were_frozen() {
    use crate::dem::pillar::{MARK_RETRY, Marking};
    let mut m = Marking::default();
    assert!(m.now, "marks from the start");
    // A marked step that found 10 % frozen: stop marking...
    m.marked = true;
    m.after(100, 1000);
    assert!(!m.now);
    // ...until MARK_RETRY unmarked steps have passed.
    m.marked = false;
    for k in 1..MARK_RETRY {
        m.after(0, 1000);
        assert!(!m.now, "step {k}");
    }
    m.after(0, 1000);
    assert!(m.now);
    // Enough frozen: keep marking.
    m.marked = true;
    m.after(900, 1000);
    assert!(m.now);
}

#[test]
fn any_thread_count_gives_the_same_run_bit_for_bit() {
    let mut p = PillarParams::fast();
    p.bar_speed *= 5.0; // enough motion for list rebuilds within the test
    let start = packed_pillar(400, 9, p);
    let run = |threads: usize| {
        let mut s = start.clone();
        s.scratch.no_fallback = true; // really split, however busy the machine
        s.advance_with(3_000, threads);
        // A force snapshot on the last step, split across the threads too.
        s.record = Some(ContactRecord::default());
        s.advance_with(1, threads);
        s
    };
    let one = run(1);
    assert!(
        one.list.builds > start.list.builds,
        "the list was rebuilt on the way"
    );
    assert!(
        one.scratch.frozen_grain_steps > 0,
        "some grains were frozen"
    );
    for threads in [2, 3] {
        let other = run(threads);
        assert_eq!(other.scratch.fallbacks, 0, "ran split on {threads} threads");
        assert_eq!(one.grains, other.grains, "{threads} threads");
        assert_eq!(one.list, other.list);
        assert_eq!(
            (&one.fx, &one.fy, &one.tq),
            (&other.fx, &other.fy, &other.tq)
        );
        assert_eq!(one.interval, other.interval);
        assert_eq!(
            (one.top_force, one.bottom_force, one.bar_shear_force),
            (other.top_force, other.bottom_force, other.bar_shear_force)
        );
        assert_eq!(one.record, other.record);
    }
    // And a run that switches thread counts half-way (as a resume on another machine).
    let mut mixed = start.clone();
    mixed.scratch.no_fallback = true;
    mixed.advance_with(2_500, 2);
    mixed.advance_with(500, 1);
    mixed.record = Some(ContactRecord::default());
    mixed.advance_with(1, 3);
    assert_eq!(one.grains, mixed.grains);
    assert_eq!(one.record, mixed.record);
}

/// Shares of `LARGE_SHARE` grains or more on several threads are rebalanced every 8
/// steps, one thread and smaller shares every 128: a pillar of 9000 grains, loaded
/// fast enough for list rebuilds, gives the one-thread run's bits on two and three
/// threads, whose slow steps (rebalances) then come at other steps than one thread's.
#[test]
fn large_shares_rebalanced_often_give_the_one_thread_run() {
    use crate::dem::backend::pillar_threads::rebalance_every;
    use crate::dem::pillar::phases::CHUNK;
    let mut p = PillarParams::fast();
    p.bar_speed *= 20.0;
    let (x, y, species) = crate::bench::dem::tiled_packing(3, 2, p.d_large).expect("packed");
    let ids: Vec<i64> = (0..x.len() as i64).collect();
    let start = PillarSim::new(p, &x, &y, &species, &ids);
    let n = x.len();
    assert_eq!(
        [1, 2, 3].map(|t| rebalance_every(n, t)),
        [128, 8, 8],
        "the cadences this test compares"
    );
    let steps = 600;
    let mut one = start.clone();
    one.advance_with(steps, 1);
    assert!(
        one.list.builds > start.list.builds + 1,
        "the list was rebuilt on the way"
    );
    for threads in [2, 3] {
        let mut other = start.clone();
        other.scratch.no_fallback = true;
        // A lopsided split (32 chunks for each but the last thread), which `prepare`
        // keeps and the rebalances must move: boundaries that move for certain.
        let skewed: Vec<usize> = (0..threads).map(|t| t * 32 * CHUNK).chain([n]).collect();
        other.scratch.buffers.bounds = skewed.clone();
        // Calls of uneven length: a call's first step is slow too, off the 8-step grid.
        other.advance_with(5, threads);
        other.advance_with(steps - 5, threads);
        assert_eq!(other.scratch.fallbacks, 0, "ran split on {threads} threads");
        assert_ne!(other.scratch.buffers.bounds, skewed, "the shares moved");
        same_run_bits(&one, &other);
    }
}

/// The force snapshot's per-grain top-bar force (the contact pressure of
/// li-granular-pillars Fig. 10c) adds up to the step's bar force, is non-zero exactly
/// for the grains that overlap the bar, and is the same split over any thread count.
#[test]
fn snapshot_bar_forces_add_up_to_the_bar_force() {
    let mut p = PillarParams::fast();
    p.bar_speed *= 20.0;
    let start = packed_pillar(300, 4, p);
    let mut runs = Vec::new();
    for threads in [1, 2] {
        let mut s = start.clone();
        s.scratch.no_fallback = true;
        s.advance_with(6_000, threads);
        s.record = Some(ContactRecord::default());
        s.advance_with(1, threads);
        let rec = s.record.clone().expect("recorded");
        let total: f64 = rec.f_bar.iter().sum();
        assert!(s.top_force > 0.0, "the bar is loaded");
        assert!(
            (total - s.top_force).abs() <= 1e-12 * s.top_force,
            "Σ f_bar {total} vs top force {}",
            s.top_force
        );
        // Positions after the step: the forces are of the state before it, so a grain
        // that was just leaving (or arriving at) the bar may differ; count the rest.
        let top = s.top_y();
        let g = &s.grains;
        let touching = (0..g.len()).filter(|&i| rec.f_bar[i] > 0.0).count();
        let overlap = (0..g.len()).filter(|&i| top - g.y[i] < g.radius[i]).count();
        assert!(touching >= 3, "{touching} grains touch the bar");
        assert!(
            touching.abs_diff(overlap) <= 1,
            "{touching} loaded, {overlap} overlap"
        );
        assert!(rec.f_bar.iter().all(|&f| f >= 0.0 && f.is_finite()));
        runs.push(rec);
    }
    assert_eq!(runs[0], runs[1], "one and two threads");
}

/// Each grain's contact force and torque is the sum of its own contacts: an
/// independent pass over every slot of the list (`slot_contact` from the same contact
/// history), summed per grain in the documented order (its own slots, then those where
/// it is the partner, with x and y negated), gives the simulation's numbers bit for bit.
/// The global force balance cannot see a term delivered to the wrong grain; this can.
#[test]
fn each_grain_sums_exactly_its_own_contacts() {
    use crate::dem::backend::simd::Quad;
    use crate::dem::pillar::phases::{GrainState, slot_contact};
    let mut p = PillarParams::fast();
    p.bar_speed *= 5.0;
    let mut sim = packed_pillar(300, 5, p);
    sim.advance(2_000);
    let before = sim.clone();
    // Forces of the current state, from `before`'s contact history.
    sim.refresh_forces();
    let g = &before.grains;
    let state = GrainState {
        x: &g.x,
        y: &g.y,
        vx: &g.vx,
        vy: &g.vy,
        omega: &g.omega,
        radius: &g.radius,
    };
    let law = before.law();
    let l = &before.list;
    let mut force = vec![Quad::default(); l.len()];
    let laws = (&law, before.params.dt);
    for i in 0..g.len() {
        let own = l.start[i] as usize..l.start[i + 1] as usize;
        for ((out, &j), &shear) in force[own.clone()]
            .iter_mut()
            .zip(&l.j[own.clone()])
            .zip(&l.shear[own])
        {
            let mut shear = shear;
            slot_contact(i, j as usize, &state, &mut shear, out, laws);
        }
    }
    let (top, bottom) = (sim.top_y(), sim.bottom_y);
    let (mut checked, mut loaded) = (0, 0);
    for i in 0..g.len() {
        if top - g.y[i] < g.radius[i] || g.y[i] - bottom < g.radius[i] {
            continue; // touches a bar, whose force is added on top
        }
        let mut s = [0.0; 4];
        for f in &force[l.start[i] as usize..l.start[i + 1] as usize] {
            (0..4).for_each(|c| s[c] += f.0[c]);
        }
        for (f, _) in force.iter().zip(&l.j).filter(|&(_, &j)| j as usize == i) {
            let f = [-f.0[0], -f.0[1], f.0[2], f.0[3]];
            (0..4).for_each(|c| s[c] += f[c]);
        }
        let got = [sim.fx[i], sim.fy[i], sim.tq[i]];
        assert_eq!(
            got.map(f64::to_bits),
            [s[0], s[1], s[2]].map(f64::to_bits),
            "grain {i}"
        );
        checked += 1;
        loaded += (s[0] != 0.0 || s[1] != 0.0) as usize;
    }
    assert!(
        checked > 200 && loaded > 50,
        "{checked} grains, {loaded} loaded"
    );
}

/// Most steps of an `advance` call are fast (no serial part: thread 0 folds the last
/// step's totals in while the pairs run); a lone `step` is always slow (the first of
/// its call). The two must agree on everything, bookkeeping included: the interval
/// sums, the bar forces, the skip counters and the frozen marking.
/// Chunks of grains far from both bars skip the bar contacts until the list's next
/// rebuild, which the top bar's travel forces: a bar that starts two diameters above a
/// pillar at rest (nothing else rebuilds the list) and comes down onto it gives the
/// same run, bit for bit, as one that tests every chunk.
#[test]
fn skipping_chunks_far_from_the_bars_changes_nothing() {
    let mut p = PillarParams::fast();
    p.bar_speed *= 100.0;
    let d = p.d_large;
    let mut start = packed_pillar(300, 4, p);
    start.top_y0 += 2.0 * d;
    let steps = 5_000;
    let mut every = start.clone();
    every.scratch.all_bar_chunks = true;
    every.advance_with(steps, 1);
    assert!(every.top_force > 0.0, "the bar reached the pillar");
    for threads in [1, 2] {
        let mut run = start.clone();
        run.scratch.no_fallback = true;
        let mut skipped = false;
        for _ in 0..50 {
            run.advance_with(steps / 50, threads);
            skipped |= run.scratch.buffers.near_bar.iter().any(|&near| !near);
        }
        assert!(skipped, "some chunks skipped the bars ({threads} threads)");
        assert!(
            run.grains == every.grains,
            "{threads} threads: the grains differ"
        );
        assert_eq!(run.top_shear, every.top_shear);
        assert_eq!(run.bottom_shear, every.bottom_shear);
        assert_eq!(
            (run.top_force, run.bottom_force, run.bar_shear_force),
            (every.top_force, every.bottom_force, every.bar_shear_force)
        );
        assert!(
            run.list.builds > start.list.builds + 1,
            "the bar's travel rebuilt the list"
        );
    }
}

/// With one barrier a step a thread may run a step ahead of one that was descheduled
/// after the barrier (here: each thread in turn pauses there). The one behind must
/// still decide the step from this step's numbers (the list's rebuild test reads the
/// threads' moves, which the one ahead rewrites in its next kick), or the threads
/// take different paths: a hang or other numbers. Run on a thread of its own, so a
/// hang fails the test instead of stalling it.
#[test]
fn a_thread_running_a_step_ahead_changes_nothing() {
    // A pillar squeezed by 1 % about its centre: every grain pushes out at once, so
    // the grains of either thread can be the ones that force a rebuild.
    let mut start = packed_pillar(300, 4, PillarParams::fast());
    let g = &mut start.grains;
    let n = g.x.len() as f64;
    let (cx, cy) = (g.x.iter().sum::<f64>() / n, g.y.iter().sum::<f64>() / n);
    g.x.iter_mut().for_each(|x| *x = cx + 0.99 * (*x - cx));
    g.y.iter_mut().for_each(|y| *y = cy + 0.99 * (*y - cy));
    let steps = 3_000;
    let mut one = start.clone();
    one.advance_with(steps, 1);
    assert!(
        one.list.builds > start.list.builds + 2,
        "the list was rebuilt"
    );
    let (tx, rx) = std::sync::mpsc::channel();
    let mut two = start.clone();
    std::thread::spawn(move || {
        two.scratch.pause_after_barrier_us = 100;
        two.scratch.no_fallback = true;
        two.advance_with(steps, 2);
        let _ = tx.send(two);
    });
    let two = rx
        .recv_timeout(std::time::Duration::from_secs(120))
        .expect("two threads finished (a hang means they took different paths)");
    assert!(two.grains == one.grains, "two threads gave other numbers");
    assert_eq!(two.list.builds, one.list.builds);
}

#[test]
fn fast_steps_keep_the_books_as_serial_steps_do() {
    let mut p = PillarParams::fast();
    p.bar_speed *= 5.0;
    let start = packed_pillar(300, 4, p);
    let mut serial = start.clone();
    for _ in 0..1_500 {
        serial.step();
    }
    assert!(
        serial.scratch.frozen_grain_steps > 0,
        "some grains were frozen"
    );
    assert!(
        serial.scratch.skipped_pairs > 0,
        "some pair slots were skipped"
    );
    assert!(
        serial.list.builds > start.list.builds,
        "the list was rebuilt"
    );
    for threads in [1, 2] {
        let mut fast = start.clone();
        fast.scratch.no_fallback = true;
        fast.advance_with(1_500, threads);
        assert_eq!(fast.step, serial.step, "{threads} threads");
        assert_eq!(fast.grains, serial.grains);
        assert_eq!(fast.interval, serial.interval);
        assert_eq!(fast.interval.steps, serial.interval.steps);
        assert_eq!(
            (fast.top_force, fast.bottom_force, fast.bar_shear_force),
            (
                serial.top_force,
                serial.bottom_force,
                serial.bar_shear_force
            )
        );
        assert_eq!(
            (fast.scratch.frozen_grain_steps, fast.scratch.skipped_pairs),
            (
                serial.scratch.frozen_grain_steps,
                serial.scratch.skipped_pairs
            )
        );
        assert_eq!(fast.scratch.marking.now, serial.scratch.marking.now);
    }
}

#[test]
fn every_kernel_level_gives_the_same_run_bit_for_bit() {
    use crate::dem::backend::simd::{Level, detected, level, use_at_most};
    // 203 grains: the last chunk of 32 ends in a tail of three, which the vector
    // kernels leave to the scalar code.
    let mut start = packed_pillar(203, 11, PillarParams::fast());
    start.params.bar_speed *= 20.0;
    let run = |max: Level| {
        use_at_most(max);
        // The switch really selects the version (else the comparison is vacuous).
        assert_eq!(level(), max.min(detected()));
        let mut s = start.clone();
        s.advance_with(5_000, 1);
        // A force-snapshot step too (it takes the recording path of the pair kernel).
        s.record = Some(ContactRecord::default());
        s.advance_with(1, 1);
        s
    };
    let base = run(Level::Baseline);
    // Both paths were exercised: frozen grains held, moving grains slid.
    assert!(base.scratch.frozen_grain_steps > 0);
    assert!(base.grains.vx.iter().any(|&v| v != 0.0));
    // The AVX2 kernels, and the same compiled with AVX-512 (where the processor has it;
    // elsewhere the second run repeats the first).
    for max in [Level::Avx2, Level::Avx512] {
        if detected() < max {
            // Missing hardware is a skip, said so, not a pass.
            eprintln!("SKIP: this CPU has no {max:?}: that build of the kernels is not compared");
            continue;
        }
        let fast = run(max);
        use_at_most(Level::Avx512);
        same_run_bits(&base, &fast);
    }
}

/// Every state array, force, history and total of two runs, bit for bit.
fn same_run_bits(base: &PillarSim, fast: &PillarSim) {
    assert_eq!(base.grains, fast.grains);
    assert_eq!(base.interval, fast.interval);
    assert_eq!(base.list, fast.list);
    assert_eq!(base.record, fast.record);
    let bits = |s: &PillarSim| {
        let g = &s.grains;
        [
            &s.fx,
            &s.fy,
            &s.tq,
            &s.sub_fx,
            &s.sub_fy,
            &g.x,
            &g.y,
            &g.vx,
            &g.vy,
            &g.omega,
            &g.theta,
            &g.ax,
            &g.ay,
            &s.list.shear,
            &s.top_shear,
            &s.bottom_shear,
        ]
        .map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
    };
    assert_eq!(bits(base), bits(fast));
    assert_eq!(
        (base.top_force, base.bottom_force, base.bar_shear_force),
        (fast.top_force, fast.bottom_force, fast.bar_shear_force)
    );
    assert_eq!(
        base.scratch.frozen_grain_steps,
        fast.scratch.frozen_grain_steps
    );
}

/// The pair-list skin adapts to how often the list is rebuilt, and no number depends on
/// it: each grain's partners are kept sorted and slots without contact add +0.0. A
/// thread that tested for rebuilds against a stale skin would let a list outlive its
/// skin (the overshoot check).
#[test]
fn the_skin_adapts_and_changes_no_number() {
    use crate::dem::pillar::{SKIN_MAX, SKIN_MIN};
    let mut p = PillarParams::fast();
    p.bar_speed *= 20.0;
    let start = packed_pillar(300, 9, p);
    let d = start.params.d_large;
    assert_eq!(start.list.skin, SKIN_MIN * d);
    let mut thin = start.clone();
    let mut thick = start.clone();
    // Rebuilt at the next step with the thick skin.
    thick.list.skin = SKIN_MAX * d;
    thick.list.x_ref.clear();
    let mut skins = vec![];
    for _ in 0..20 {
        thin.advance_with(200, 2);
        thick.advance_with(200, 1);
        skins.push((thin.list.skin / d, thick.list.skin / d));
    }
    // Both adapted (the fast-loaded pillar rebuilds often: the thin skin grew; the
    // thick one may not shrink, but they took different paths).
    assert!(skins.iter().any(|&(a, _)| a > SKIN_MIN), "{skins:?}");
    assert!(skins.iter().any(|&(a, b)| a != b), "{skins:?}");
    assert!(thin.list.builds != thick.list.builds);
    let bits = |s: &PillarSim| -> Vec<u64> {
        let g = &s.grains;
        [&g.x, &g.y, &g.vx, &g.vy, &g.omega, &s.fx, &s.fy, &s.tq]
            .iter()
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .chain([s.top_force.to_bits(), s.bottom_force.to_bits()])
            .collect()
    };
    assert!(bits(&thin) == bits(&thick), "the skin changed the numbers");
    // Then slowly, in one long call each: rebuilds come rarely and the skins thin
    // mid-call, where every thread must test against the list's new skin.
    for s in [&mut thin, &mut thick] {
        s.params.bar_speed /= 20.0;
        s.scratch.rebuild_overshoot = 0.0;
    }
    let before = (thin.list.skin, thick.list.skin);
    thin.advance_with(60_000, 2);
    thick.advance_with(60_000, 2);
    assert!(
        thin.list.skin < before.0 && thick.list.skin < before.1,
        "{before:?}"
    );
    assert!(bits(&thin) == bits(&thick), "the skin changed the numbers");
    for s in [&thin, &thick] {
        let o = s.scratch.rebuild_overshoot;
        // Within a step or two of travel past half the skin (1.01 here; a stale,
        // thicker skin let one run on to the next slow step: 1.12).
        assert!(o > 0.9 && o < 1.05, "a list outlived its skin: {o}");
    }
    assert!(thin.top_force > 0.0);
    // And the list holds every touching pair.
    let g = &thin.grains;
    for i in 0..g.len() {
        for j in i + 1..g.len() {
            let (dx, dy) = (g.x[i] - g.x[j], g.y[i] - g.y[j]);
            if (dx * dx + dy * dy).sqrt() < g.radius[i] + g.radius[j] {
                let (a, b) = (i.min(j), i.max(j));
                let holds = |o: usize, q: usize| {
                    let r = thin.list.start[o] as usize..thin.list.start[o + 1] as usize;
                    thin.list.j[r].contains(&(q as u32))
                };
                assert!(
                    holds(a, b) || holds(b, a),
                    "pair {a}-{b} touching, not listed"
                );
            }
        }
    }
}

/// Issue 24's fuzz: a corrupt checkpoint with one grain flung to ~1e40 m made the pair
/// list's cell grid wrap its cell count to zero and panic ("min > max") in the first
/// step. The list is now built (all pairs) and holds exactly the touching pairs.
#[test]
fn pair_list_survives_a_grain_at_an_absurd_distance() {
    use crate::dem::base::verlet::PairList;
    for far in [1e40, 1e300, 1e12] {
        // 20 grains in a row, 1 apart, radius 0.6 (each touches its neighbours), and
        // one far away.
        let mut x: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let mut y = vec![0.0; 20];
        x.push(far);
        y.push(-far);
        let r = vec![0.6; 21];
        let mut l = PairList::new(0.1);
        l.build(&x, &y, &r, Boundary::Open);
        let mut pairs = Vec::new();
        for i in 0..21 {
            for k in l.start[i] as usize..l.start[i + 1] as usize {
                pairs.push((i, l.j[k] as usize));
            }
        }
        let want: Vec<(usize, usize)> = (0..19).map(|i| (i, i + 1)).collect();
        assert_eq!(pairs, want, "far = {far}");
    }
}

/// `cross_core_lines` (what `bench dem` blames two threads' overhead on) counts what
/// crosses a split: nothing on one thread; on two, the term lines and partner state
/// of exactly the slots whose grains sit on both sides of the split, within the
/// bounds their sizes allow; more with two splits than with one.
#[test]
fn cross_core_lines_count_what_crosses_a_split() {
    use crate::dem::backend::pillar_threads::CrossLines;
    let start = packed_pillar(400, 9, PillarParams::fast());
    let run = |threads: usize| {
        let mut s = start.clone();
        s.scratch.no_fallback = true;
        s.advance_with(10, threads);
        s
    };
    assert_eq!(run(1).cross_core_lines(), CrossLines::default());
    let two = run(2);
    let lines = two.cross_core_lines();
    let split = two.scratch.buffers.bounds[1];
    let (mut slots, mut partners) = (0usize, std::collections::BTreeSet::new());
    for i in 0..split {
        for k in two.list.start[i] as usize..two.list.start[i + 1] as usize {
            let j = two.list.j[k] as usize;
            if j >= split {
                slots += 1;
                partners.insert(j);
            }
        }
    }
    assert!(
        slots > 0 && lines.marking > 0 && lines.chunk_sums > 0,
        "{lines:?}"
    );
    // One 32-byte term place per crossing slot, two to a line.
    assert!(
        (slots.div_ceil(2)..=slots).contains(&lines.terms),
        "{slots} slots, {lines:?}"
    );
    // Per partner grain a 32-byte state, a 16-byte spin and a rest flag.
    let g = partners.len();
    assert!(
        (g.div_ceil(2) + g.div_ceil(4) + 1..=3 * g).contains(&lines.partner_state),
        "{g} partners, {lines:?}"
    );
    assert!(run(3).cross_core_lines().total() > lines.total());
}
