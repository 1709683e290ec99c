//! DEM throughput: particle-steps per second of a loaded pillar, with the pair-list
//! distance pass (the floor any implementation pays) timed in the same run, and an
//! export of the loaded state for `bench/lammps_pillar.py` (LAMMPS on the same grains).

use crate::dem::backend::pillar_threads::CrossLines;
use crate::dem::pillar::PillarSim;
use crate::dem::pillar::pack::{PackOptions, pack};
use crate::dem::pillar::params::PillarParams;
use crate::error::{Error, Result};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

#[derive(Debug, Clone, Serialize)]
pub struct PillarBench {
    pub n: usize,
    pub steps: u64,
    /// Grain–grain contacts per grain, Z = 2 contacts / N, over the timed steps' start.
    pub z: f64,
    pub seconds: f64,
    pub ns_per_particle_step: f64,
    /// Same run: one pass over the pair list computing distances only, per particle.
    pub floor_ns_per_particle: f64,
    pub list_builds: u64,
    /// Whether a timed run finished on one thread because its waits kept being long
    /// (a machine busy with other work): its figure is then not the threads'.
    pub fell_back: bool,
    /// Same steps, same state, with the frozen-grain skip off (same run; the timed run has it on).
    pub ns_per_particle_step_no_skip: f64,
    /// Fraction of grain-steps frozen (skipped).
    pub reused_fraction: f64,
    /// Threads of the timed run, and the same steps on one thread (same run, skip on):
    /// medians of `rounds` rounds, one thread and the threads alternating.
    pub threads: usize,
    pub rounds: usize,
    /// Each round's figures (ns per particle-step), one thread and the threads, in
    /// the order they ran.
    pub one_thread_rounds: Vec<f64>,
    pub threads_rounds: Vec<f64>,
    pub ns_per_particle_step_one_thread: f64,
    /// Several threads: the cache lines that cross between cores every step at the
    /// run's split, what one exchange of that many lines (written on one core, read on
    /// the other, and back) costs on this machine (ns, measured in the same run), and
    /// the step's overhead over the one-thread step divided by the threads (ns).
    pub cross_lines: CrossLines,
    pub line_exchange_ns: f64,
    /// The same for the partners' state alone: what any split with one exchange a step
    /// pays, however its arrays are laid out.
    pub state_exchange_ns: f64,
    pub overhead_ns_per_step: f64,
}

/// A jammed periodic packing of 1000 grains tiled k × k (N = 1000 k²; the packing is
/// periodic, so the copies join without gaps or overlaps), in metres.
pub fn tiled_packing(k: usize, seed: u64, d: f64) -> Result<(Vec<f64>, Vec<f64>, Vec<i32>)> {
    let pk = pack(
        &PackOptions {
            n: 1000,
            seed,
            ..Default::default()
        },
        |_, _| {},
    )
    .map_err(crate::stages::pack::stopped)?;
    let (mut x, mut y, mut s) = (Vec::new(), Vec::new(), Vec::new());
    for a in 0..k {
        for b in 0..k {
            for i in 0..pk.x.len() {
                x.push((pk.x[i] + a as f64 * pk.lx) * d);
                y.push((pk.y[i] + b as f64 * pk.ly) * d);
                s.push(pk.species[i]);
            }
        }
    }
    Ok((x, y, s))
}

/// Load a pillar of 1000 k² grains to strain `preload` (fast preset, bar 10× faster
/// still, to get there quickly), then time `steps` steps at the `preset`'s δt and bar
/// speed.
pub fn bench_pillar(
    k: usize,
    steps: u64,
    preset: &str,
    preload: f64,
    export: Option<&Path>,
) -> Result<PillarBench> {
    let p = PillarParams::preset(preset)
        .ok_or_else(|| Error::param("preset", format!("unknown preset '{preset}'")))?;
    let (x, y, s) = tiled_packing(k, 1, p.d_large)?;
    let ids: Vec<i64> = (0..x.len() as i64).collect();
    let mut load = PillarParams::fast();
    load.bar_speed *= 10.0;
    let mut sim = PillarSim::new(load, &x, &y, &s, &ids);
    while sim.strain() < preload {
        sim.advance(100);
    }
    // Continue at the benchmarked preset from the loaded state (bar where it is now).
    let top = sim.top_y();
    sim.top_y0 = top;
    sim.step = 0;
    sim.params = p;
    sim.refresh_forces();
    let z = 2.0 * sim.contacts() as f64 / sim.grains.len() as f64;
    if let Some(dir) = export {
        export_state(&sim, dir)?;
    }
    time_pillar(sim, steps, z)
}

/// A pillar from a `simulate pillar` checkpoint (the state of a real run, mid-way),
/// timed for `steps` steps as [`bench_pillar`] does.
pub fn bench_checkpoint(path: &Path, steps: u64) -> Result<PillarBench> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let (mut sim, _) = PillarSim::load(&bytes).map_err(|e| Error::input(path.display(), e))?;
    // Same state, nothing advanced: the recorded forces are the ones the run would use.
    let z = 2.0 * sim.contacts() as f64 / sim.grains.len() as f64;
    sim.record = None;
    time_pillar(sim, steps, z)
}

/// Time `steps` steps from `sim`: without the frozen-grain skip on one thread, then
/// with it on one thread and on `threads_for_run()` threads (the headline number),
/// alternating for `THREAD_ROUNDS` rounds (medians: the machine may be shared, and a
/// ratio of two timings taken minutes apart followed the host's moods more than the
/// code); check every run gives the same grains; time the pair-list distance pass.
fn time_pillar(mut sim: PillarSim, steps: u64, z: f64) -> Result<PillarBench> {
    sim.scratch.skip_frozen = true;
    sim.scratch.frozen_grain_steps = 0;
    let mut plain = sim.clone();
    plain.scratch.skip_frozen = false;
    let t = Instant::now();
    plain.advance_with(steps, 1);
    let seconds_plain = t.elapsed().as_secs_f64();
    let threads = sim.threads_for_run();
    let builds0 = sim.list.builds;
    let (mut one, mut many) = (Vec::new(), Vec::new());
    let mut fell_back = false;
    let mut last = None;
    for _ in 0..THREAD_ROUNDS {
        let mut single = sim.clone();
        let t = Instant::now();
        single.advance_with(steps, 1);
        one.push(t.elapsed().as_secs_f64());
        let mut split = sim.clone();
        let fallbacks0 = split.scratch.fallbacks;
        let t = Instant::now();
        split.advance_with(steps, threads);
        many.push(t.elapsed().as_secs_f64());
        fell_back |= split.scratch.fallbacks > fallbacks0;
        if plain.grains != single.grains || single.grains != split.grains {
            return Err(Error::Other(
                "the frozen-grain skip or the thread count changed the results".into(),
            ));
        }
        last = Some(split);
    }
    let sim = last.ok_or_else(|| Error::Other("no timed round".into()))?;
    let n = sim.grains.len();
    let per = |v: &[f64]| -> Vec<f64> {
        v.iter()
            .map(|s| s / (n as f64 * steps as f64) * 1e9)
            .collect()
    };
    let (one_thread_rounds, threads_rounds) = (per(&one), per(&many));
    // Each count's own median (the one-thread run goes first in every round).
    let median = crate::bench::whole::median;
    let (seconds, seconds_single) = (median(&many), median(&one));
    let reused_fraction =
        sim.scratch.frozen_grain_steps as f64 / (steps as f64 * sim.grains.len() as f64);
    let cross_lines = sim.cross_core_lines();
    let (line_exchange_ns, state_exchange_ns) = if threads > 1 {
        (
            line_exchange_ns(cross_lines.total().max(1), 20_000),
            line_exchange_ns(cross_lines.partner_state.max(1), 20_000),
        )
    } else {
        (0.0, 0.0)
    };
    let overhead_ns_per_step =
        (seconds - seconds_single / threads as f64) / steps.max(1) as f64 * 1e9;
    let floor = {
        let g = &sim.grains;
        let reps = 200;
        let t = Instant::now();
        let mut c = 0usize;
        for _ in 0..reps {
            for i in 0..n {
                for kk in sim.list.start[i] as usize..sim.list.start[i + 1] as usize {
                    let j = sim.list.j[kk] as usize;
                    let (dx, dy) = (g.x[i] - g.x[j], g.y[i] - g.y[j]);
                    let rs = g.radius[i] + g.radius[j];
                    c += (dx * dx + dy * dy < rs * rs) as usize;
                }
            }
        }
        std::hint::black_box(c);
        t.elapsed().as_secs_f64() / (reps * n) as f64 * 1e9
    };
    Ok(PillarBench {
        n,
        steps,
        z,
        seconds,
        ns_per_particle_step: seconds / (n as f64 * steps as f64) * 1e9,
        floor_ns_per_particle: floor,
        list_builds: sim.list.builds - builds0,
        fell_back,
        rounds: THREAD_ROUNDS,
        one_thread_rounds,
        threads_rounds,
        ns_per_particle_step_no_skip: seconds_plain / (n as f64 * steps as f64) * 1e9,
        reused_fraction,
        threads,
        ns_per_particle_step_one_thread: seconds_single / (n as f64 * steps as f64) * 1e9,
        cross_lines,
        line_exchange_ns,
        state_exchange_ns,
        overhead_ns_per_step,
    })
}

/// Nanoseconds to move `lines` cache lines from one core to another and back: one
/// thread writes them, the other reads them, in turn (a flag says whose turn it is),
/// the median of `reps` turns, each line on its own 128 bytes as the pillar's arrays
/// are spread. What two threads pay at least each step for the lines they share.
pub fn line_exchange_ns(lines: usize, reps: u64) -> f64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    #[repr(align(128))]
    struct Line(AtomicU64);
    let buf: Vec<Line> = (0..lines).map(|_| Line(AtomicU64::new(0))).collect();
    let turn = Line(AtomicU64::new(0));
    let mut times = Vec::with_capacity(reps as usize);
    std::thread::scope(|s| {
        s.spawn(|| {
            for r in 0..reps {
                while turn.0.load(Ordering::Acquire) != 2 * r {
                    std::hint::spin_loop();
                }
                for l in &buf {
                    l.0.store(r, Ordering::Relaxed);
                }
                turn.0.store(2 * r + 1, Ordering::Release);
            }
        });
        let mut sum = 0u64;
        for r in 0..reps {
            let t = Instant::now();
            while turn.0.load(Ordering::Acquire) != 2 * r + 1 {
                std::hint::spin_loop();
            }
            for l in &buf {
                sum = sum.wrapping_add(l.0.load(Ordering::Relaxed));
            }
            turn.0.store(2 * r + 2, Ordering::Release);
            times.push(t.elapsed().as_secs_f64() * 1e9);
        }
        std::hint::black_box(sum);
    });
    crate::bench::whole::median(&times)
}

/// The loaded state for LAMMPS: `grains.csv` (id, type, diameter, density, x, y, vx,
/// vy, omega in SI) and `setup.json` (bars, model parameters).
fn export_state(sim: &PillarSim, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let g = &sim.grains;
    let mut csv = String::from("id,type,diameter,mass,x,y,vx,vy,omega\n");
    for i in 0..g.len() {
        csv += &format!(
            "{},{},{:e},{:e},{:e},{:e},{:e},{:e},{:e}\n",
            g.id[i] + 1,
            g.species[i] + 1,
            2.0 * g.radius[i],
            g.mass[i],
            g.x[i],
            g.y[i],
            g.vx[i],
            g.vy[i],
            g.omega[i]
        );
    }
    crate::io::atomic_write_str(&dir.join("grains.csv"), &csv)?;
    let setup = serde_json::json!({"bottom_y": sim.bottom_y, "top_y": sim.top_y(), "params": sim.params,
        "z": 2.0 * sim.contacts() as f64 / g.len() as f64});
    crate::io::atomic_write_str(
        &dir.join("setup.json"),
        &serde_json::to_string_pretty(&setup).expect("json"),
    )
}

#[derive(Debug, Clone, Serialize)]
pub struct PresetComparison {
    pub n: usize,
    pub strain: f64,
    /// Strain bin centres and the mean σ (units m g μ / D) of each preset in the bin.
    pub bins: Vec<(f64, f64, f64)>,
    pub mean_stress_fast: f64,
    pub mean_stress_paper: f64,
    /// Mean |σ_fast − σ_paper| over bins, relative to the paper preset's mean σ.
    pub mean_abs_difference_rel: f64,
    pub seconds_fast: f64,
    pub seconds_paper: f64,
}

/// The same packing run with the `fast` and `paper` presets: how far apart the
/// stress–strain curves sit (binned in ε to average out the stick–slip noise).
pub fn compare_presets(n: usize, strain: f64, seed: u64, bin: f64) -> Result<PresetComparison> {
    use crate::io::table::read_table;
    use crate::stages::simulate::{SimulateOptions, run};
    let dir = std::env::temp_dir().join(format!("pp-presets-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut curves = Vec::new();
    let mut secs = Vec::new();
    for preset in ["fast", "paper"] {
        let out = dir.join(preset);
        let opt = SimulateOptions {
            n,
            seed,
            preset: preset.into(),
            strain,
            quiet: true,
            ..Default::default()
        };
        let rep = run(&out, &opt)?;
        secs.push(rep.elapsed_s);
        let t = read_table(&out.join("stress_strain.parquet"), &[])?;
        curves.push((t.f64("strain")?, t.f64("stress_reduced")?));
    }
    let _ = std::fs::remove_dir_all(&dir);
    let nb = (strain / bin).floor() as usize;
    let mean_in = |c: &(Vec<f64>, Vec<f64>), lo: f64, hi: f64| {
        let v: Vec<f64> =
            c.0.iter()
                .zip(&c.1)
                .filter(|(e, _)| **e > lo && **e <= hi)
                .map(|(_, s)| *s)
                .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let bins: Vec<(f64, f64, f64)> = (0..nb)
        .map(|b| {
            let (lo, hi) = (b as f64 * bin, (b + 1) as f64 * bin);
            (
                0.5 * (lo + hi),
                mean_in(&curves[0], lo, hi),
                mean_in(&curves[1], lo, hi),
            )
        })
        .collect();
    let mf = mean_in(&curves[0], 0.0, strain);
    let mp = mean_in(&curves[1], 0.0, strain);
    let mad = bins.iter().map(|b| (b.1 - b.2).abs()).sum::<f64>() / nb.max(1) as f64;
    Ok(PresetComparison {
        n,
        strain,
        bins,
        mean_stress_fast: mf,
        mean_stress_paper: mp,
        mean_abs_difference_rel: mad / mp,
        seconds_fast: secs[0],
        seconds_paper: secs[1],
    })
}

#[derive(Debug, Clone, Serialize)]
pub struct ShearBench {
    pub n: usize,
    pub steps: u64,
    pub z: f64,
    pub seconds: f64,
    /// Per step of Eqs. 21–24 (two force evaluations).
    pub ns_per_particle_step: f64,
    pub list_builds: u64,
    /// Re-selections of the near list (`shear_near`) in the timed steps.
    pub near_selections: u64,
    /// Same steps from the same state without re-sorting into cell order (same run).
    pub ns_per_particle_step_unsorted: f64,
    /// The timed steps again from the same state on one thread and on two, alternating
    /// (medians of `THREAD_ROUNDS` rounds each, same run), their ratio, and whether the
    /// two runs ended in the same state bit for bit.
    pub ns_per_particle_step_one_thread: f64,
    pub ns_per_particle_step_two_threads: f64,
    pub two_thread_speedup: f64,
    pub two_threads_same_bits: bool,
    /// Steps of the two-thread runs (all rounds) that ran on one thread because the
    /// team's waits were long (a busy machine; see `shear::threads`): when not 0, the
    /// two-thread figure is partly a one-thread one.
    pub two_thread_solo_steps: u64,
}

/// Rounds of the one- and two-thread timings (alternating, medians: the machine may be
/// shared).
const THREAD_ROUNDS: usize = 3;

/// Sheared disks at φ = 0.82, Q = 1, γ̇ = 1e-4, CDrot: `warmup` steps, then `steps` timed.
pub fn bench_shear(n: usize, steps: u64, warmup: u64) -> ShearBench {
    use crate::dem::shear::{Dissipation, ShearParams, ShearSim};
    let p = ShearParams {
        n,
        phi: 0.82,
        q: 1.0,
        rate: 1e-4,
        model: Dissipation::Cdrot,
        alpha: 2.0,
        dt: 0.05,
        seed: 1,
    };
    let mut s = ShearSim::new(p);
    // The headline figures on one thread.
    s.threads = 1;
    shear_steps(&mut s, warmup);
    let mut unsorted = s.clone();
    unsorted.resort_every = 0;
    let t = Instant::now();
    shear_steps(&mut unsorted, steps);
    let seconds_unsorted = t.elapsed().as_secs_f64();
    // Time from the first re-sort on, as a long run sees it.
    s.resort();
    let (b0, s0) = (s.list.builds, s.slots.selections);
    let t = Instant::now();
    shear_steps(&mut s, steps);
    let seconds = t.elapsed().as_secs_f64();
    let (one, two, same, solo) = time_shear_threads(&s, steps);
    let per = |secs: f64| secs / (n as f64 * steps as f64) * 1e9;
    ShearBench {
        n,
        steps,
        z: 2.0 * s.virial().contacts as f64 / n as f64,
        seconds,
        ns_per_particle_step: seconds / (n as f64 * steps as f64) * 1e9,
        list_builds: s.list.builds - b0,
        near_selections: s.slots.selections - s0,
        ns_per_particle_step_unsorted: seconds_unsorted / (n as f64 * steps as f64) * 1e9,
        ns_per_particle_step_one_thread: per(one),
        ns_per_particle_step_two_threads: per(two),
        two_thread_speedup: one / two,
        two_threads_same_bits: same,
        two_thread_solo_steps: solo,
    }
}

/// `steps` steps of `s` in calls of `simulate shear`'s default sample interval: the
/// stage makes the steps between two samples in one `ShearSim::steps` call (or fewer,
/// cut at frames and every 64 steps for its checkpoint clock), each but the last
/// predicting the next ahead. (Before 2026-11-29 the figures timed single `step`s.)
fn shear_steps(s: &mut crate::dem::shear::ShearSim, steps: u64) {
    let every = crate::stages::shear::SAMPLE_EVERY;
    for _ in 0..steps / every {
        s.steps(every);
    }
    s.steps(steps % every);
}

/// `steps` steps from `start` on one thread and on two, alternating for
/// `THREAD_ROUNDS` rounds: the median seconds of each, and whether every run ended in
/// the same grains, forces and contact counts bit for bit; and the steps of the
/// two-thread runs that fell back to one thread.
fn time_shear_threads(start: &crate::dem::shear::ShearSim, steps: u64) -> (f64, f64, bool, u64) {
    let mut times = [Vec::new(), Vec::new()];
    let mut ends = Vec::new();
    let mut solo = 0;
    for _ in 0..THREAD_ROUNDS {
        for (k, threads) in [1, 2].into_iter().enumerate() {
            let mut s = start.clone();
            s.threads = threads;
            let t = Instant::now();
            shear_steps(&mut s, steps);
            times[k].push(t.elapsed().as_secs_f64());
            solo += s.solo_steps();
            // Its team's threads end here, not sleep on through the later rounds.
            s.end_threads();
            ends.push(s);
        }
    }
    let median = crate::bench::whole::median;
    let bits = |s: &crate::dem::shear::ShearSim| {
        let g = &s.g;
        [
            &g.x, &g.y, &g.vx, &g.vy, &g.omega, &g.theta, &s.fx, &s.fy, &s.tq,
        ]
        .iter()
        .flat_map(|v| v.iter().map(|x| x.to_bits()))
        .collect::<Vec<u64>>()
    };
    let first = bits(&ends[0]);
    let same = ends
        .iter()
        .all(|e| bits(e) == first && e.coll == ends[0].coll && e.list.shear == ends[0].list.shear);
    (median(&times[0]), median(&times[1]), same, solo)
}

#[cfg(test)]
mod tests {
    /// The exchange finishes (each side waits for the other's turn) and takes a
    /// positive, finite time (its size is a measurement, not checked here).
    #[test]
    fn a_line_exchange_takes_time_and_returns() {
        let one = super::line_exchange_ns(1, 200);
        let many = super::line_exchange_ns(256, 200);
        assert!(one.is_finite() && one > 0.0, "{one}");
        assert!(many.is_finite() && many > 0.0, "{many}");
    }
}
