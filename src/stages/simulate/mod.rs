//! `simulate pillar`: the bundled DEM of li-granular-pillars Sec. II, run into a
//! directory of canonical tables (tracks, bar_forces, stress_strain, forces) and a
//! manifest. Long runs checkpoint and resume bit-exactly; the manifest is written last,
//! so a directory without one holds an unfinished run.

pub mod setup;
pub mod tables;

use crate::dem::base::codec::{Dec, Enc};
use crate::dem::base::forces::ContactRecord;
use crate::dem::pillar::params::{NormalLawName, PillarParams};
use crate::dem::pillar::{Interval, PillarSim};
use crate::error::{Error, Result};
use crate::interrupt::CheckpointClock;
use crate::io::{atomic_write_str, sidecar_path};
use crate::stages::run_dir::RunDir;
use crate::stages::simulate::tables::{Buffers, FrameStats, TABLES, merge_parts};
use crate::tracks::TracksMeta;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What a pillar run is asked to do (CLI flags and pipeline keys map onto these).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimulateOptions {
    /// Number of grains for a generated packing (ignored with `packing`).
    pub n: usize,
    pub seed: u64,
    /// A packing table (canonical tracks in cm, mm or m; first frame used) instead of
    /// generating one: `pillar-pipe pack` output or an experiment's ingested tracks.
    pub packing: Option<PathBuf>,
    /// Pipelines: the stage whose tracks are the packing (an ingest stage of the
    /// experiment's movie, a track stage), instead of a `packing` file. The runner
    /// resolves it to that stage's cached tracks; the command line takes `--packing`.
    pub packing_stage: Option<String>,
    /// `paper` or `fast` (li-granular-pillars Sec. II.C; `fast` for demos and CI).
    pub preset: String,
    /// Parameter overrides by name (SI units), e.g. `k_n = 5000.0`, `mu_g = 0.3`.
    pub set: BTreeMap<String, f64>,
    /// Grain–grain normal law (`linear`, the paper's, or `hertz`).
    pub normal_law: NormalLawName,
    /// Final engineering strain ε = ΔH/H0.
    pub strain: f64,
    /// Steps between output frames (default: the preset's, Δt_frame = R/(15 v_c)).
    pub output_every: Option<u64>,
    /// Output frames between per-grain force snapshots.
    pub forces_every: u64,
    /// Steps between checkpoints (0: none); rounded up to a multiple of output_every.
    pub checkpoint_every: u64,
    /// Wall-time seconds between checkpoints (0: none), so that a kill loses at most
    /// that much work; SIGINT and SIGTERM always save one before stopping.
    pub checkpoint_interval: f64,
    /// Continue the unfinished run in the output directory from its checkpoint.
    pub resume: bool,
    pub quiet: bool,
    /// Testing aid: stop with an error right after the first checkpoint at or past
    /// this step, as a kill would.
    #[serde(skip)]
    pub halt_after: Option<u64>,
    /// Threads (0: one per core, at most one per 256 grains). Not part of the physics:
    /// any count gives the same numbers.
    #[serde(skip)]
    pub threads: usize,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        SimulateOptions {
            n: 1000,
            seed: 1,
            packing: None,
            packing_stage: None,
            preset: "fast".into(),
            set: BTreeMap::new(),
            normal_law: NormalLawName::Linear,
            strain: 0.3,
            output_every: None,
            forces_every: 5,
            checkpoint_every: 0,
            checkpoint_interval: 60.0,
            resume: false,
            quiet: false,
            halt_after: None,
            threads: 0,
        }
    }
}

use crate::stages::resume;
pub use crate::stages::resume::RUN_ONLY;

#[cfg(test)]
mod tests {
    use super::*;

    fn physics(o: &SimulateOptions) -> serde_json::Map<String, serde_json::Value> {
        resume::physics(o.physics())
    }

    #[test]
    fn checkpoints_of_earlier_versions_resume_when_new_options_are_default() {
        let now = SimulateOptions::default();
        let defaults = physics(&now);
        let mut then = physics(&now);
        then.remove("normal_law");
        assert!(resume::differences(&then, &physics(&now), &defaults).is_empty());
        let hertz = SimulateOptions {
            normal_law: NormalLawName::Hertz,
            ..now.clone()
        };
        let d = resume::differences(&then, &physics(&hertz), &defaults);
        assert_eq!(d.len(), 1, "a changed law must not resume: {d:?}");
        assert_eq!(d[0].to_string(), "normal_law: then not set, now \"hertz\"");
        let other = SimulateOptions {
            seed: 9,
            ..now.clone()
        };
        let d = resume::differences(&physics(&now), &physics(&other), &defaults);
        assert_eq!(d[0].to_string(), "seed: then 1, now 9");
    }

    fn with(set: &[(&str, f64)]) -> SimulateOptions {
        SimulateOptions {
            preset: "paper".into(),
            set: set.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            ..SimulateOptions::default()
        }
    }

    /// Eqs. 5–6 by hand. E = 1 MPa, ν = 0.5: 1/E* = 2 (1 − 0.25)/E, E* = 666,666.67 Pa;
    /// l = 1 cm: k_n = (π/4) E* l = 5235.9878 N/m. And E* = 4e6/π Pa at l = 1 cm gives
    /// the paper's k_n = 1e4 N/m exactly.
    #[test]
    fn k_n_follows_from_the_material_as_eqs_5_and_6_give_it() {
        let p = with(&[
            ("youngs_modulus", 1e6),
            ("poisson_ratio", 0.5),
            ("grain_height", 0.01),
        ])
        .params()
        .unwrap();
        assert!((p.k_n - 5_235.987_755_982_988).abs() < 1e-9, "{}", p.k_n);
        assert_eq!(p.preset, "paper+custom");
        let p = with(&[
            ("e_star", 4e6 / std::f64::consts::PI),
            ("grain_height", 0.01),
        ])
        .params()
        .unwrap();
        assert!((p.k_n - 1e4).abs() < 1e-9, "{}", p.k_n);
        // The bar, rigid, doubles E* and so k_n (Sec. II.B.2).
        let normal_k = |law: crate::dem::law::ContactLaw| match law.normal() {
            crate::dem::law::Normal::Linear { k_n } => k_n,
            other => panic!("{other:?}"),
        };
        assert_eq!(normal_k(p.bar_law().unwrap()), 2.0 * p.k_n);
        assert_eq!(normal_k(p.grain_law().unwrap()), p.k_n);
    }

    /// Issue 36: a `set` that only repeats the preset's values is the preset's run: the
    /// same parameters and label, and (through `resolve`) the same pipeline cache key.
    #[test]
    fn setting_a_preset_value_is_the_preset() {
        let fast = |set: &[(&str, f64)]| SimulateOptions {
            preset: "fast".into(),
            ..with(set)
        };
        let plain = fast(&[]).params().unwrap();
        let same = fast(&[("k_n", plain.k_n), ("mu_g", plain.mu_g)]);
        assert_eq!(same.params().unwrap(), plain);
        assert_eq!(same.params().unwrap().preset, "fast");
        let mut c = same.clone();
        c.canonicalise();
        assert!(c.set.is_empty(), "{:?}", c.set);
        // A different value stays, and labels the run as custom.
        let other = fast(&[("k_n", plain.k_n), ("mu_g", 0.3)]);
        let mut c = other.clone();
        c.canonicalise();
        assert_eq!(c.set.keys().collect::<Vec<_>>(), ["mu_g"]);
        assert_eq!(other.params().unwrap().preset, "fast+custom");
        use crate::pipeline::kinds::StageKind;
        let kind = crate::pipeline::kinds::simulate::Simulate;
        let resolve = |set: serde_json::Value| {
            kind.resolve(serde_json::json!({"preset": "fast", "set": set}))
                .unwrap()
        };
        assert_eq!(
            resolve(serde_json::json!({"k_n": plain.k_n})),
            resolve(serde_json::json!({}))
        );
        assert_ne!(
            resolve(serde_json::json!({"mu_g": 0.3})),
            resolve(serde_json::json!({}))
        );
    }

    #[test]
    fn k_n_and_the_material_together_or_half_a_material_are_refused_by_name() {
        let err = |set: &[(&str, f64)]| with(set).params().unwrap_err().to_string();
        let e = err(&[("k_n", 1e4), ("e_star", 1e6), ("grain_height", 0.01)]);
        assert!(
            e.contains("k_n is set and so is the material") && e.contains("e_star, grain_height"),
            "{e}"
        );
        let e = err(&[("youngs_modulus", 1e6), ("grain_height", 0.01)]);
        assert!(e.contains("needs youngs_modulus and poisson_ratio"), "{e}");
        let e = err(&[("e_star", 1e6)]);
        assert!(e.contains("needs grain_height"), "{e}");
        let e = err(&[
            ("youngs_modulus", 1e6),
            ("poisson_ratio", 0.7),
            ("grain_height", 0.01),
        ]);
        assert!(e.contains("poisson_ratio = 0.7"), "{e}");
        let e = err(&[("e_star", -1.0), ("grain_height", 0.01)]);
        assert!(e.contains("must be > 0"), "{e}");
    }
}

impl SimulateOptions {
    /// The options that determine the numbers (a resume must match these).
    fn physics(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(self).expect("options serialise");
        for k in RUN_ONLY {
            v.as_object_mut().expect("object").remove(k);
        }
        v
    }

    /// The preset with overrides applied, validated.
    /// Drops the `set` entries equal to the preset's own value (material keys, which
    /// stand for a k_n together, are kept, and so is k_n beside them), so that a run asking for the default is the
    /// default run: the same parameters, label and pipeline cache entry. An unknown
    /// preset is left for [`Self::params`] to refuse.
    pub fn canonicalise(&mut self) {
        let Some(base) = PillarParams::preset(&self.preset) else {
            return;
        };
        let v = serde_json::to_value(&base).expect("params serialise");
        // k_n beside a material is a conflict `params` names; it is not a default then.
        let material = MATERIAL_KEYS.iter().any(|m| self.set.contains_key(*m));
        self.set.retain(|k, x| {
            MATERIAL_KEYS.contains(&k.as_str())
                || (material && k == "k_n")
                || v.get(k).and_then(|d| d.as_f64()) != Some(*x)
        });
    }

    pub fn params(&self) -> Result<PillarParams> {
        let base = PillarParams::preset(&self.preset).ok_or_else(|| {
            Error::param(
                "preset",
                format!(
                    "unknown preset '{}'; expected one of: paper, fast",
                    self.preset
                ),
            )
        })?;
        let mut v = serde_json::to_value(&base).expect("params serialise");
        v["normal_law"] = serde_json::json!(self.normal_law);
        let mut canonical = self.clone();
        canonical.canonicalise();
        let set = with_k_n_from_material(&canonical.set)?;
        for (k, x) in &set {
            if k == "preset" || k == "normal_law" || v.get(k).is_none() {
                let known: Vec<&String> = v
                    .as_object()
                    .expect("object")
                    .keys()
                    .filter(|k| *k != "preset" && *k != "normal_law")
                    .collect();
                return Err(Error::param(
                    "set",
                    format!("unknown parameter '{k}'; known: {known:?}"),
                ));
            }
            v[k] = serde_json::json!(x);
        }
        if !set.is_empty() {
            v["preset"] = serde_json::json!(format!("{}+custom", self.preset));
        }
        let p: PillarParams =
            serde_json::from_value(v).map_err(|e| Error::param("set", e.to_string()))?;
        p.validate().map_err(|e| Error::param("set", e))?;
        Ok(p)
    }
}

/// The material names `set` also takes instead of `k_n` (SI units): the grains'
/// Young's modulus E (Pa) and Poisson ratio ν, or their contact modulus E* (Pa)
/// directly, and the cylinders' height l (m).
pub const MATERIAL_KEYS: [&str; 4] = ["youngs_modulus", "poisson_ratio", "e_star", "grain_height"];

/// `set` with the material keys replaced by the `k_n` they give (li-granular-pillars
/// Eqs. 5–6): two grains of one material have 1/E* = 2(1 − ν²)/E, and two cylinders of
/// height l in contact k_n = (π/4) E* l. (The bar, rigid, doubles E* and so k_n: Sec.
/// II.B.2, which `PillarParams::bar_law` applies to whatever k_n is.)
pub fn with_k_n_from_material(set: &BTreeMap<String, f64>) -> Result<BTreeMap<String, f64>> {
    let get = |k: &str| set.get(k).copied();
    let given: Vec<&str> = MATERIAL_KEYS
        .into_iter()
        .filter(|k| set.contains_key(*k))
        .collect();
    if given.is_empty() {
        return Ok(set.clone());
    }
    let bad = |msg: String| Err(Error::param("set", msg));
    if set.contains_key("k_n") {
        return bad(format!(
            "k_n is set and so is the material it would follow from ({}; Eqs. 5–6): give one of them",
            given.join(", ")
        ));
    }
    let e_star = match (get("e_star"), get("youngs_modulus"), get("poisson_ratio")) {
        (Some(es), None, None) => es,
        (None, Some(e), Some(nu)) => {
            if !(nu > -1.0 && nu < 0.5 + 1e-12) {
                return bad(format!("poisson_ratio = {nu}: expected −1 < ν ≤ 0.5"));
            }
            e / (2.0 * (1.0 - nu * nu))
        }
        (Some(_), _, _) => {
            return bad(
                "e_star is E* itself: give it alone, or youngs_modulus and poisson_ratio instead"
                    .into(),
            );
        }
        _ => {
            return bad(format!(
                "{} set: k_n from the material needs youngs_modulus and poisson_ratio (or e_star) and grain_height",
                given.join(", ")
            ));
        }
    };
    let Some(l) = get("grain_height") else {
        return bad(
            "k_n from the material needs grain_height, the cylinders' height l (m), Eq. 5".into(),
        );
    };
    if !(e_star > 0.0 && e_star.is_finite() && l > 0.0 && l.is_finite()) {
        return bad(format!(
            "E* = {e_star} Pa and l = {l} m must be > 0 and finite"
        ));
    }
    let mut out: BTreeMap<String, f64> = set
        .iter()
        .filter(|(k, _)| !MATERIAL_KEYS.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), *v))
        .collect();
    out.insert("k_n".into(), std::f64::consts::FRAC_PI_4 * e_star * l);
    Ok(out)
}

/// What a finished run reports; also written as `DIR/manifest.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SimulateReport {
    pub out: PathBuf,
    /// Files written into `out`, by table name (tracks, bar_forces, stress_strain, forces).
    pub tables: BTreeMap<String, PathBuf>,
    pub n: usize,
    pub frames: usize,
    pub steps: u64,
    /// Mean flow stress ⟨σ⟩ for 0.05 ≤ ε ≤ 0.2 (N/m), when the run reached ε = 0.2.
    pub mean_flow_stress: Option<f64>,
    /// Wall time of this session (s).
    pub elapsed_s: f64,
    /// Wall time of the whole run, earlier sessions of a resumed run included, up to
    /// their last checkpoint (s).
    #[serde(default)]
    pub elapsed_total_s: f64,
}

/// Output bookkeeping saved with each checkpoint.
pub struct Progress {
    frames: u64,
    parts: u64,
    prev_x: Vec<f64>,
    prev_y: Vec<f64>,
    physics: String,
    setup: String,
    /// Wall time (s) of the earlier sessions of this run.
    elapsed_before: f64,
}

impl Progress {
    fn encode(&self) -> Vec<u8> {
        let mut e = Enc::default();
        e.u64(self.frames);
        e.u64(self.parts);
        e.f64s(&self.prev_x);
        e.f64s(&self.prev_y);
        e.bytes(self.physics.as_bytes());
        e.bytes(self.setup.as_bytes());
        e.f64(self.elapsed_before);
        e.0
    }
    fn decode(b: &[u8]) -> std::result::Result<Self, String> {
        let mut d = Dec::new(b);
        let p = Progress {
            frames: d.u64()?,
            parts: d.u64()?,
            prev_x: d.f64s()?,
            prev_y: d.f64s()?,
            physics: String::from_utf8(d.bytes()?).map_err(|e| e.to_string())?,
            setup: String::from_utf8(d.bytes()?).map_err(|e| e.to_string())?,
            // Checkpoints from before this field existed: unknown, counted as 0.
            elapsed_before: if d.done() { 0.0 } else { d.f64()? },
        };
        Ok(p)
    }
}

/// Read a pillar run's checkpoint for `--resume`: the state and the output bookkeeping,
/// checked against each other. Errors name the file (and the byte, for a truncated or
/// corrupt one).
pub fn read_checkpoint(ckpt: &Path) -> Result<(PillarSim, Progress)> {
    let bytes = crate::stages::read_checkpoint_bytes(ckpt)?;
    let bad = |e: String| Error::input(ckpt.display(), e);
    let (sim, extra) = PillarSim::load(&bytes).map_err(bad)?;
    let prog = Progress::decode(&extra).map_err(|e| bad(format!("output bookkeeping: {e}")))?;
    // The frame's velocities (Eq. 13) take the previous frame's positions grain by grain.
    let n = sim.grains.len();
    if prog.prev_x.len() != n || prog.prev_y.len() != n {
        return Err(bad(format!(
            "output bookkeeping: {} and {} previous positions for {n} grains",
            prog.prev_x.len(),
            prog.prev_y.len()
        )));
    }
    Ok((sim, prog))
}

/// The options `--resume DIR` runs with when the command line gave only the keys in
/// `given`: the others are the interrupted run's. Also returns the options so taken whose
/// value differs from `opt`'s.
pub fn options_for_resume(
    dir: &Path,
    opt: &SimulateOptions,
    given: &std::collections::BTreeSet<String>,
) -> Result<(SimulateOptions, Vec<(String, serde_json::Value)>)> {
    let ckpt = dir.join(crate::stages::run_dir::CHECKPOINT);
    let (_, prog) = read_checkpoint(&ckpt)?;
    let then = resume::recorded(&ckpt, &prog.physics)?;
    let (mut o, taken) = resume::adopt(opt, &then, given)?;
    // Not serialised, so not recorded: they stay as given.
    o.halt_after = opt.halt_after;
    o.threads = opt.threads;
    Ok((o, taken))
}

pub use crate::stages::manifest::MANIFEST;

/// Run a pillar simulation into `out`.
pub fn run(out: &Path, opt: &SimulateOptions) -> Result<SimulateReport> {
    let t0 = std::time::Instant::now();
    let params = opt.params()?;
    if !(opt.strain > 0.0 && opt.strain < 0.9) {
        return Err(Error::param(
            "strain",
            format!("must be in (0, 0.9), got {}", opt.strain),
        ));
    }
    if opt.forces_every == 0 {
        return Err(Error::param("forces_every", "must be ≥ 1"));
    }
    let dir = RunDir::create(out)?;
    let physics = serde_json::to_string(&opt.physics()).expect("json");
    let (mut sim, mut prog) = if opt.resume {
        let (sim, prog) = read_checkpoint(&dir.checkpoint)?;
        let then = resume::recorded(&dir.checkpoint, &prog.physics)?;
        let defaults = resume::physics(SimulateOptions::default().physics());
        let now = resume::physics(opt.physics());
        resume::refuse_differences(&resume::differences(&then, &now, &defaults), "")?;
        dir.resume(prog.parts)?;
        (sim, prog)
    } else {
        dir.start()?;
        let (sim, setup) = crate::stages::simulate::setup::initial_pillar(opt, params.clone())?;
        let prog = Progress {
            frames: 0,
            parts: 0,
            prev_x: sim.grains.x.clone(),
            prev_y: sim.grains.y.clone(),
            physics,
            setup: serde_json::to_string(&setup).expect("json"),
            elapsed_before: 0.0,
        };
        (sim, prog)
    };
    sim.scratch.threads = opt.threads;
    let p = sim.params.clone();
    let step0 = sim.step;
    let h0 = sim.top_y0 - sim.bottom_y;
    let total = (opt.strain * h0 / (p.bar_speed * p.dt)).ceil() as u64;
    let out_every = opt
        .output_every
        .unwrap_or_else(|| ((0.5 * p.d_large / (15.0 * p.bar_speed) / p.dt).round() as u64).max(1));
    let ck_every = if opt.checkpoint_every == 0 {
        0
    } else {
        opt.checkpoint_every.div_ceil(out_every) * out_every
    };
    let mut buf = Buffers::new();
    let bar = crate::stages::progress(total, "simulate", opt.quiet);
    bar.set_position(sim.step);
    let record_frame = |sim: &PillarSim, buf: &mut Buffers, prog: &mut Progress| {
        // Eq. 21 with Eq. 13's mean velocity over the output interval.
        let dt_frame = out_every as f64 * p.dt;
        let g = &sim.grains;
        let p_gs = if sim.step == 0 {
            0.0
        } else {
            (0..g.len())
                .map(|i| {
                    g.mass[i]
                        * p.g
                        * p.mu
                        * (g.x[i] - prog.prev_x[i]).hypot(g.y[i] - prog.prev_y[i])
                        / dt_frame
                })
                .sum()
        };
        let frame = prog.frames as i64;
        buf.record(sim, &FrameStats { frame, p_gs });
        if sim.record.is_some() {
            buf.record_forces(sim, frame);
        }
        prog.prev_x.clone_from(&g.x);
        prog.prev_y.clone_from(&g.y);
        prog.frames += 1;
    };
    if sim.step == 0 {
        // Re-evaluate on a copy (a second evaluation would advance contact history) so
        // the step-0 snapshot has its per-grain record.
        let mut c = sim.clone();
        c.record = Some(ContactRecord::default());
        c.refresh_forces();
        record_frame(&c, &mut buf, &mut prog);
    }
    let mut clock = CheckpointClock::new(ck_every, opt.checkpoint_interval);
    // Steps per call of `advance` between looks at the clock and the signal flag, kept
    // near a quarter of a second; where the calls split a frame changes no number.
    let mut chunk: u64 = 64;
    let checkpoint =
        |sim: &PillarSim, buf: &mut Buffers, prog: &mut Progress, clock: &mut CheckpointClock| {
            buf.flush(&dir.parts, prog.parts)?;
            prog.parts += 1;
            let saved = prog.elapsed_before;
            prog.elapsed_before += t0.elapsed().as_secs_f64();
            let bytes = sim.save(&prog.encode());
            prog.elapsed_before = saved;
            dir.save(&bytes, sim.step, total, opt.halt_after, clock)
        };
    while sim.step < total {
        // Run to the next output frame (or the end) in chunks, so the threads of
        // `advance` live for many steps; the last step records forces when due.
        let stop = ((sim.step / out_every + 1) * out_every).min(total);
        while sim.step + 1 < stop {
            let n = (stop - 1 - sim.step).min(chunk);
            let t = std::time::Instant::now();
            sim.advance(n);
            let took = t.elapsed().as_secs_f64();
            if n == chunk && took < 0.1 {
                chunk = chunk.saturating_mul(2);
            } else if took > 0.4 {
                chunk = (chunk / 2).max(1);
            }
            if sim.step + 1 < stop && clock.due_now() {
                checkpoint(&sim, &mut buf, &mut prog, &mut clock)?;
                bar.set_position(sim.step);
            }
        }
        if stop.is_multiple_of(out_every) && prog.frames.is_multiple_of(opt.forces_every) {
            sim.record = Some(ContactRecord::default());
        }
        sim.advance(1);
        record_frame(&sim, &mut buf, &mut prog);
        sim.record = None;
        sim.interval = Interval::default();
        bar.set_position(sim.step);
        if (clock.due_by_steps(sim.step) || clock.due_now()) && sim.step < total {
            checkpoint(&sim, &mut buf, &mut prog, &mut clock)?;
        }
    }
    bar.finish_and_clear();
    buf.flush(&dir.parts, prog.parts)?;
    prog.parts += 1;
    let mut tables = BTreeMap::new();
    let mut rows = BTreeMap::new();
    for name in TABLES {
        let path = out.join(format!("{name}.parquet"));
        rows.insert(name, merge_parts(&dir.parts, name, prog.parts, &path)?);
        tables.insert(name.to_string(), path);
    }
    let setup: serde_json::Value = serde_json::from_str(&prog.setup).expect("own json");
    let meta = tracks_meta(&sim, opt, out_every, &setup);
    atomic_write_str(
        &sidecar_path(&tables["tracks"]),
        &serde_json::to_string_pretty(&meta).expect("json"),
    )?;
    let mean_flow_stress =
        crate::stages::simulate::setup::mean_flow_stress(&tables["stress_strain"])?;
    let elapsed = t0.elapsed().as_secs_f64();
    let report = SimulateReport {
        out: out.to_path_buf(),
        tables,
        n: sim.grains.len(),
        frames: prog.frames as usize,
        steps: sim.step,
        mean_flow_stress,
        elapsed_s: elapsed,
        elapsed_total_s: prog.elapsed_before + elapsed,
    };
    let body = serde_json::json!({
        "params": p,
        "checks": {
            "eq12_ratio_2kn_vc_dt_over_m_g_mu": p.quasistatic_ratio(),
            "dt_over_sqrt_m_over_2kn": p.stiffness_ratio(),
        },
        "setup": setup,
        "output_every_steps": out_every,
        "frame_time_s": out_every as f64 * p.dt,
        "h0_cm": h0 * 100.0,
        "rows": rows,
        "pair_list_builds": sim.list.builds,
        "report": &report,
        "steps_this_session": sim.step - step0,
        "threads_this_session": sim.threads_for_run(),
        "pair_kernel_this_session": sim.pair_kernel(),
        "thread_fallbacks_this_session": sim.scratch.fallbacks,
        // How much the exact skip of substrate-held grains saved (docs/performance.md,
        // "Pillar DEM"): grain-steps skipped over grain-steps run, this session.
        "frozen_grain_step_fraction_this_session": sim.scratch.frozen_grain_steps as f64
            / (sim.grains.len() as f64 * (sim.step - step0).max(1) as f64),
        "particle_steps_per_s_this_session": (sim.grains.len() as f64 * (sim.step - step0) as f64) / elapsed,
        "decisions": crate::stages::simulate::setup::DECISIONS,
    });
    crate::stages::manifest::write(out, "simulate pillar", opt, body)?;
    dir.finished();
    Ok(report)
}

fn tracks_meta(
    sim: &PillarSim,
    opt: &SimulateOptions,
    out_every: u64,
    setup: &serde_json::Value,
) -> TracksMeta {
    let p = &sim.params;
    TracksMeta {
        length_unit: "cm".into(),
        time_unit: "s".into(),
        frame_time: Some(out_every as f64 * p.dt),
        bar_speed: Some(p.bar_speed * 100.0),
        coordinate_frame: "simulation: y up along the compression axis (top bar on top), bottom bar face at y = 0, x = 0 at the initial pillar centre".into(),
        provenance: crate::tracks::Provenance {
            tool: crate::stages::TOOL.into(),
            tool_version: crate::stages::VERSION.into(),
            source: "pillar-pipe simulate pillar".into(),
            source_format: "simulation".into(),
            source_sha256: setup["packing_sha256"].as_str().unwrap_or("").into(),
            parameters: serde_json::json!({"options": opt, "params": p}),
        },
        ..TracksMeta::default()
    }
}
