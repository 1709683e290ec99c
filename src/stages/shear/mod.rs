//! `simulate shear`: vagberg-sheared-disks runs into a directory — the time series of
//! the pressure tensor parts, Z and spins (`series.parquet`), the trajectories in the
//! canonical tracks schema with the Lees–Edwards box per frame, and `summary.json` of
//! steady-state means with block-average errors. `manifest.json` is written last.

mod ramp;
mod stats;
mod steady;
mod tracks;

use crate::dem::base::codec::{Dec, Enc};
use crate::dem::shear::{Dissipation, ShearParams, ShearSim};
use crate::error::{Error, Result};
use crate::io::table::write_f64_columns;
use crate::io::{atomic_write_str, sidecar_path};
use crate::stages::resume;
use crate::stages::run_dir::RunDir;
pub use crate::stages::shear::ramp::STATE;
use crate::stages::shear::ramp::{finish_ramp, ramp_plan, start_from};
pub use crate::stages::shear::stats::MeanErr;
pub(crate) use crate::stages::shear::stats::block_stats;
use crate::stages::shear::stats::summarize;
use crate::stages::shear::steady::Steady;
pub use crate::stages::shear::steady::{FIELD_RADIUS, FIELD_SNAPSHOTS};
use crate::stages::shear::tracks::{empty_tracks, flush_tracks, frame_box, push_frame};
use crate::stages::simulate::tables::merge_parts;
use crate::tracks::{Provenance, TracksMeta};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ShearOptions {
    pub n: usize,
    pub phi: f64,
    pub q: f64,
    /// γ̇ τ_e.
    pub rate: f64,
    pub model: Dissipation,
    /// Total strain γ.
    pub strain: f64,
    /// Δt/τ_e (default 0.05, or 0.01 for Q < 0.5).
    pub dt: Option<f64>,
    pub seed: u64,
    /// Steps between trajectory frames (default: every 0.05 strain).
    pub output_every: Option<u64>,
    /// Steps between samples of the series.
    pub sample_every: u64,
    /// Fraction of the run discarded as transient before averaging.
    pub transient: f64,
    /// Blocks for the error bars.
    pub blocks: usize,
    /// Strain-rate ramp `up` or `down` (Eqs. 38–41): γ̇ changes by 10^{±κ̃} every τ_e,
    /// velocities and spins rescaled, from `rate` to `rate_end`.
    pub ramp: Option<String>,
    /// κ̃ = κ τ_e / ln 10 (Eq. 39).
    pub kappa: f64,
    /// Final strain rate of a ramp.
    pub rate_end: Option<f64>,
    /// Averaging window of the ramp table (τ_e; the paper uses 10³).
    pub window: f64,
    /// Steps between checkpoints (0: none).
    pub checkpoint_every: u64,
    /// Wall-time seconds between checkpoints (0: none), so that a kill loses at most
    /// that much work; SIGINT and SIGTERM always save one before stopping.
    pub checkpoint_interval: f64,
    /// Continue the unfinished run in the output directory.
    pub resume: bool,
    pub quiet: bool,
    /// Testing aid: fail right after the first checkpoint at or past this step.
    #[serde(skip)]
    pub halt_after: Option<u64>,
    /// A ramp's start: the `state.bin` another ramp left (a pipeline's `from` key, whose
    /// stage key enters this one's), instead of random positions.
    #[serde(skip)]
    pub from_state: Option<PathBuf>,
    /// Threads (0: one per core, at most one per 4096 disks). Not part of the physics:
    /// any count gives the same numbers, so it is neither recorded nor keyed.
    #[serde(skip)]
    pub threads: usize,
}

/// The default steps between samples of the series (`--sample-every`).
pub const SAMPLE_EVERY: u64 = 10;

impl Default for ShearOptions {
    fn default() -> Self {
        ShearOptions {
            n: 1024,
            phi: 0.82,
            q: 1.0,
            rate: 1e-4,
            model: Dissipation::Cdrot,
            strain: 10.0,
            dt: None,
            seed: 1,
            output_every: None,
            sample_every: SAMPLE_EVERY,
            transient: 0.25,
            blocks: 10,
            ramp: None,
            kappa: 1e-5,
            rate_end: None,
            window: 1000.0,
            checkpoint_every: 0,
            checkpoint_interval: 60.0,
            resume: false,
            quiet: false,
            halt_after: None,
            from_state: None,
            threads: 0,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct ShearReport {
    pub out: PathBuf,
    pub steps: u64,
    pub frames: usize,
    pub summary: BTreeMap<String, MeanErr>,
    pub elapsed_s: f64,
}

pub(crate) const SERIES: [&str; 19] = [
    "time",
    "strain",
    "p",
    "sigma",
    "p_el",
    "sigma_el",
    "p_dis",
    "sigma_dis",
    "p_kin",
    "sigma_kin",
    "z",
    "theta_dot_over_gamma_dot",
    "theta_dot_over_gamma_dot_var",
    "collisions_begun",
    "contact_time_ended",
    "collisions_ended",
    "rate",
    "dvx2",
    "vy2",
];

/// A sheared-disk run's checkpoint as `--resume` reads it.
pub struct Resumed {
    pub sim: ShearSim,
    /// The options of the interrupted run (JSON), which the resumed one must match.
    pub physics: String,
    frame: i64,
    parts: u64,
    cols: Vec<Vec<f64>>,
    steady: Steady,
    /// (frame, Lees–Edwards offset) of every frame written so far.
    boxes: Vec<(i64, f64)>,
}

/// Read a sheared-disk checkpoint: the state and the output bookkeeping. Errors name the
/// file (and the byte, for a truncated or corrupt one).
pub fn read_checkpoint(ckpt: &Path) -> Result<Resumed> {
    let bytes = crate::stages::read_checkpoint_bytes(ckpt)?;
    let bad = |e: String| Error::input(ckpt.display(), e);
    let (sim, extra) = ShearSim::load(&bytes).map_err(bad)?;
    let mut d = Dec::new(&extra);
    let book = |e: String| bad(format!("output bookkeeping: {e}"));
    let physics = String::from_utf8(d.bytes().map_err(book)?).map_err(|e| book(e.to_string()))?;
    let frame = d.u64().map_err(book)? as i64;
    let parts = d.u64().map_err(book)?;
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); SERIES.len()];
    for c in cols.iter_mut() {
        *c = d.f64s().map_err(book)?;
    }
    // The series becomes one table: every column one row per sample.
    if cols.iter().any(|c| c.len() != cols[0].len()) {
        return Err(book("series columns of different lengths".into()));
    }
    let steady = Steady::decode(&mut d).map_err(book)?;
    let (bf, bx) = (d.i64s().map_err(book)?, d.f64s().map_err(book)?);
    if bf.len() != bx.len() {
        return Err(book(format!(
            "{} frames but {} box offsets",
            bf.len(),
            bx.len()
        )));
    }
    Ok(Resumed {
        sim,
        physics,
        frame,
        parts,
        cols,
        steady,
        boxes: bf.into_iter().zip(bx).collect(),
    })
}

/// The default options as a checkpoint records them: what an option recorded on one side
/// only must hold for a resume.
fn default_physics() -> serde_json::Map<String, serde_json::Value> {
    resume::physics(serde_json::to_value(ShearOptions::default()).expect("json"))
}

/// The options `--resume DIR` runs with when the command line gave only the keys in
/// `given`: the others are the interrupted run's. Also returns the options so taken whose
/// value differs from `opt`'s.
pub fn options_for_resume(
    dir: &Path,
    opt: &ShearOptions,
    given: &std::collections::BTreeSet<String>,
) -> Result<(ShearOptions, Vec<(String, serde_json::Value)>)> {
    let ckpt = dir.join(crate::stages::run_dir::CHECKPOINT);
    let r = read_checkpoint(&ckpt)?;
    let then = resume::recorded(&ckpt, &r.physics)?;
    let (mut o, taken) = resume::adopt(opt, &then, given)?;
    // Not serialised, so not recorded: they stay as given.
    o.halt_after = opt.halt_after;
    o.from_state.clone_from(&opt.from_state);
    o.threads = opt.threads;
    Ok((o, taken))
}

/// The run's physical parameters, or what is wrong with the options (checked before a
/// run starts, and by a pipeline before any stage runs).
pub fn params_of(opt: &ShearOptions) -> std::result::Result<ShearParams, String> {
    let p = ShearParams {
        n: opt.n,
        phi: opt.phi,
        q: opt.q,
        rate: opt.rate,
        model: opt.model,
        alpha: 2.0,
        dt: opt.dt.unwrap_or_else(|| ShearParams::default_dt(opt.q)),
        seed: opt.seed,
    };
    p.validate()?;
    if !(opt.strain > 0.0
        && opt.transient >= 0.0
        && opt.transient < 0.9
        && opt.blocks >= 2
        && opt.sample_every >= 1)
    {
        return Err("need strain > 0, 0 ≤ transient < 0.9, blocks ≥ 2, sample_every ≥ 1".into());
    }
    Ok(p)
}

/// A ramp's options (with `p` from `params_of`) checked as `run` would check them: the
/// key at fault and why, or None. For pipelines, which check every stage before any runs.
pub fn ramp_problem(opt: &ShearOptions, p: &ShearParams) -> Option<(&'static str, String)> {
    crate::stages::shear::ramp::check_ramp(opt, p).err()
}

pub fn run(out: &Path, opt: &ShearOptions) -> Result<ShearReport> {
    let t0 = std::time::Instant::now();
    let p = params_of(opt).map_err(|e| Error::param("shear", e))?;
    let dir = RunDir::create(out)?;
    let origin = match &opt.from_state {
        Some(_) if opt.ramp.is_none() => {
            return Err(Error::param(
                "from",
                "only a ramp starts from another run's state",
            ));
        }
        Some(f) => Some(start_from(f, &p)?),
        None => None,
    };
    // Steps and strain are counted on from a state's; the ramp's schedule starts at it.
    let (step0, strain0) = origin.as_ref().map_or((0, 0.0), |s| (s.step, s.strain()));
    let physics = {
        let mut v = resume::physics(serde_json::to_value(opt).expect("json"));
        // A continued ramp's schedule counts from the state's step: a resume must
        // start from the same one (a run from random positions records nothing, so
        // its older checkpoints still resume).
        if opt.from_state.is_some() {
            v.insert("from_step".into(), serde_json::json!(step0));
        }
        v
    };
    let physics_json = serde_json::Value::Object(physics.clone()).to_string();
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); SERIES.len()];
    let mut tracks = empty_tracks();
    let (mut frame, mut parts) = (0i64, 0u64);
    let mut steady = Steady::default();
    let mut sim = if opt.resume {
        let r = read_checkpoint(&dir.checkpoint)?;
        let then = resume::recorded(&dir.checkpoint, &r.physics)?;
        let diffs = resume::differences(&then, &physics, &default_physics());
        let note = if diffs.iter().any(|d| d.key == "from_step") {
            " (from_step: the ramp continued another run's state; give its --ramp and --from DIR again)"
        } else {
            ""
        };
        resume::refuse_differences(&diffs, note)?;
        let sim = r.sim;
        (frame, parts, cols, steady) = (r.frame, r.parts, r.cols, r.steady);
        for (f, xy) in r.boxes {
            tracks.meta.boxes.push(frame_box(f, sim.l, xy));
        }
        dir.resume(parts)?;
        sim
    } else {
        dir.start()?;
        origin.unwrap_or_else(|| ShearSim::new(p.clone()))
    };
    sim.threads = opt.threads;
    let ramp = ramp_plan(opt, &p)?;
    let total = step0
        + match &ramp {
            Some(r) => r.intervals * r.steps_per_tau,
            None => (opt.strain / (p.rate * p.dt)).ceil() as u64,
        };
    let out_every = opt.output_every.unwrap_or(match &ramp {
        Some(_) => ((opt.window / p.dt).round() as u64).max(1),
        None => ((0.05 / (p.rate * p.dt)).round() as u64).max(1),
    });
    // Contact-velocity draws per steady sample, so that CONTACT_SAMPLES spread over the window.
    let steady_samples = ((1.0 - opt.transient) * total as f64 / opt.sample_every as f64).max(1.0);
    let per_sample =
        (crate::stages::shear::steady::CONTACT_SAMPLES as f64 / steady_samples).ceil() as usize;
    let field_every = ((steady_samples / crate::stages::shear::steady::FIELD_SNAPSHOTS as f64)
        .floor() as u64)
        .max(1);
    let bar = crate::stages::progress(total - step0, "shear", opt.quiet);
    let mut clock =
        crate::interrupt::CheckpointClock::new(opt.checkpoint_every, opt.checkpoint_interval);
    // A resumed run's current step was recorded and checkpointed before the stop.
    let mut fresh = !opt.resume;
    loop {
        let rel = sim.step - step0;
        if fresh && rel.is_multiple_of(opt.sample_every) {
            if ramp.is_none() && sim.strain() >= opt.transient * opt.strain {
                if sim.coll.window_start.is_infinite() {
                    // The duration cohort: contacts begun from here on.
                    sim.coll.window_start = sim.time;
                }
                steady.sample(&sim, per_sample, field_every, opt.seed);
            }
            let vir = sim.virial();
            let (el, dis, kin) = sim.pressure_tensor_of(&vir);
            let pr = |t: [f64; 4]| 0.5 * (t[0] + t[3]);
            let sg = |t: [f64; 4]| -t[1];
            let tot: [f64; 4] = std::array::from_fn(|k| el[k] + dis[k] + kin[k]);
            let n = sim.g.len() as f64;
            let spins: Vec<f64> = sim.g.omega.iter().map(|w| w / sim.p.rate).collect();
            let sm = spins.iter().sum::<f64>() / n;
            let sv = spins.iter().map(|s| (s - sm).powi(2)).sum::<f64>() / n;
            let row = [
                sim.time,
                sim.strain(),
                pr(tot),
                sg(tot),
                pr(el),
                sg(el),
                pr(dis),
                sg(dis),
                pr(kin),
                sg(kin),
                2.0 * vir.contacts as f64 / n,
                sm,
                sv,
                sim.coll.begun as f64,
                sim.coll.duration_sum,
                sim.coll.ended as f64,
                sim.p.rate,
                kin[0] * sim.l * sim.l / n,
                kin[3] * sim.l * sim.l / n,
            ];
            for (c, v) in cols.iter_mut().zip(row) {
                c.push(v);
            }
        }
        if fresh && (rel.is_multiple_of(out_every) || sim.step == total) {
            push_frame(&mut tracks, &sim, frame);
            frame += 1;
            bar.set_position(rel);
        }
        // The clock and the signal flag are read every 64 steps (a step is ~20 µs).
        if fresh
            && sim.step > step0
            && sim.step < total
            && (clock.due_by_steps(sim.step) || (sim.step.is_multiple_of(64) && clock.due_now()))
        {
            flush_tracks(&mut tracks, &dir.parts, parts)?;
            parts += 1;
            let mut e = Enc::default();
            e.bytes(physics_json.as_bytes());
            e.u64(frame as u64);
            e.u64(parts);
            for c in &cols {
                e.f64s(c);
            }
            steady.encode(&mut e);
            e.i64s(
                &tracks
                    .meta
                    .boxes
                    .iter()
                    .map(|b| b.frame)
                    .collect::<Vec<_>>(),
            );
            e.f64s(&tracks.meta.boxes.iter().map(|b| b.xy).collect::<Vec<_>>());
            dir.save(&sim.save(&e.0), sim.step, total, opt.halt_after, &mut clock)?;
        }
        fresh = true;
        if sim.step >= total {
            break;
        }
        // Up to the next step at which the loop's head has something to do (a
        // sample, a frame, a look at the checkpoint clock, the ramp's next rate, the
        // end), in one call: the steps of one call predict each next step ahead.
        let rel = sim.step - step0;
        let to_next = |every: u64| every - rel % every;
        let mut k = (total - sim.step)
            .min(to_next(opt.sample_every))
            .min(64 - sim.step % 64);
        if out_every > 0 {
            // (`--output-every 0`: frames at the start and the end only.)
            k = k.min(to_next(out_every));
        }
        if let Some(due) = clock.steps_to_due(sim.step) {
            k = k.min(due);
        }
        if let Some(r) = &ramp {
            k = k.min(to_next(r.steps_per_tau));
        }
        sim.steps(k);
        if let Some(r) = &ramp
            && (sim.step - step0).is_multiple_of(r.steps_per_tau)
        {
            // Eq. 38 in steps of τ_e; the initial rate times an integer power, so a
            // resumed ramp lands on the same rates.
            let k = ((sim.step - step0) / r.steps_per_tau) as f64;
            sim.set_rate(p.rate * r.factor.powf(k));
        }
    }
    bar.finish_and_clear();
    let series = out.join("series.parquet");
    write_f64_columns(&SERIES, &cols, &series, "the series")?;
    tracks.meta = TracksMeta {
        length_unit: "d_s".into(),
        time_unit: "tau_e".into(),
        frame_time: Some(out_every as f64 * p.dt),
        coordinate_frame: "Lees–Edwards box [0, L)²: positions in the primary cell; the image above is shifted by boxes[].xy = γ L along x (unwrapped γ)".into(),
        boxes: tracks.meta.boxes.clone(),
        provenance: Provenance {
            tool: crate::stages::TOOL.into(),
            tool_version: crate::stages::VERSION.into(),
            source: "pillar-pipe simulate shear".into(),
            source_format: "simulation".into(),
            source_sha256: String::new(),
            parameters: serde_json::to_value(&p).expect("json"),
        },
        ..TracksMeta::default()
    };
    let tracks_path = out.join("tracks.parquet");
    flush_tracks(&mut tracks, &dir.parts, parts)?;
    parts += 1;
    merge_parts(&dir.parts, "tracks", parts, &tracks_path)?;
    atomic_write_str(
        &sidecar_path(&tracks_path),
        &serde_json::to_string_pretty(&tracks.meta).expect("json"),
    )?;
    if let Some(r) = &ramp {
        return finish_ramp(
            &dir,
            opt,
            &p,
            r,
            &cols,
            &sim,
            frame,
            series,
            tracks_path,
            t0,
            (step0, strain0),
        );
    }
    let cohort = crate::stages::shear::stats::Cohort::of(&sim);
    let mut summary = summarize(&cols, &p, sim.g.len(), opt, &cohort)?;
    steady.write(&sim, out)?;
    let (making, breaking) = steady.angle_counts(&sim);
    summary.extend(crate::stages::shear::stats::collision_angle_stats(
        &making, &breaking,
    ));
    let summary_json = serde_json::json!({
        "params": p, "options": opt, "steps": sim.step, "strain": sim.strain(),
        "box_side": sim.l, "averaged_from_strain": opt.transient * opt.strain, "blocks": opt.blocks,
        // Eq. 27's ϑ over the steady window: bin k covers (−180° + 3.6° k, −180° + 3.6° (k + 1)].
        "collision_angle_making": making, "collision_angle_breaking": breaking,
        "quantities": summary.iter().map(|(k, v)| (k.clone(), serde_json::json!({"mean": v.mean, "err": v.err}))).collect::<serde_json::Map<_, _>>(),
    });
    let mut flat = summary_json["quantities"].clone();
    for (k, v) in summary_json.as_object().expect("object") {
        if k != "quantities" {
            flat[k] = v.clone();
        }
    }
    atomic_write_str(
        &out.join("summary.json"),
        &serde_json::to_string_pretty(&flat).expect("json"),
    )?;
    let rep = ShearReport {
        out: out.to_path_buf(),
        steps: sim.step,
        frames: frame as usize,
        summary,
        elapsed_s: t0.elapsed().as_secs_f64(),
    };
    let body = serde_json::json!({
        "params": p, "tables": {"series": series, "tracks": tracks_path, "tracks_meta": sidecar_path(&tracks_path), "collision_angles": out.join("collision_angles.parquet"), "profile": out.join("profile.parquet"), "contact_velocities": out.join("contact_velocities.parquet"), "fields": out.join("fields.parquet")},
        "elapsed_s": rep.elapsed_s,
        "ns_per_particle_step": rep.elapsed_s * 1e9 / (sim.g.len() as f64 * sim.step.max(1) as f64),
        "force_kernel": sim.kernel_name(),
        "threads_this_session": sim.step_threads_used(),
        "decisions": [
            "units d_s = m = tau_e = 1: k_e = 1, k_d = 1/Q",
            "positions unwrapped; minimum image with the Lees–Edwards offset gamma L, the image's velocity shifted by n gamma_dot L",
            "kinetic stress from fluctuations about v_x = gamma_dot y",
            "Z counts every contact (rattlers included); nu_coll = contacts begun per particle per tau_e in the window; tau_dur = mean duration of the contacts begun in the window, those still open at its end censored (Kaplan-Meier on 20 log bins per decade, each bin's mass at its mean; error from two halves of the cohort); tau_dur_ended_only = the biased mean over contacts that ended in the window, for comparison",
            "initial state: random positions at phi with the affine flow v_x = gamma_dot y",
        ],
    });
    crate::stages::manifest::write(out, "simulate shear", opt, body)?;
    dir.finished();
    Ok(rep)
}

/// A shear run's `manifest.json` and `summary.json` as a pipeline stage keeps them
/// (here, not in the pipeline's dispatch, so the stage's source key covers it): its tables
/// named relative to the stage directory (they were written in the work directory and
/// moved), and `quiet` left out of the options (how the run was watched, which a local
/// run and a Slurm job choose differently, is no part of what it computed).
pub fn relocate_records(out: &Path) -> Result<()> {
    for name in [crate::stages::manifest::MANIFEST, "summary.json"] {
        let f = out.join(name);
        let Ok(text) = std::fs::read_to_string(&f) else {
            continue;
        };
        let mut v: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| Error::input(f.display(), e.to_string()))?;
        if let Some(o) = v
            .get_mut("options")
            .and_then(serde_json::Value::as_object_mut)
        {
            o.remove("quiet");
        }
        if let Some(t) = v
            .get_mut("tables")
            .and_then(serde_json::Value::as_object_mut)
        {
            for p in t.values_mut() {
                let rel = p
                    .as_str()
                    .and_then(|s| Path::new(s).file_name())
                    .map(|n| n.to_string_lossy().into_owned());
                if let Some(rel) = rel {
                    *p = serde_json::Value::String(rel);
                }
            }
        }
        atomic_write_str(&f, &serde_json::to_string_pretty(&v).expect("json"))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every new `ShearOptions` field is absent from the checkpoints written before it;
    /// they resume while it holds its default.
    #[test]
    fn checkpoints_without_a_new_option_resume_while_it_is_default() {
        let now = default_physics();
        let mut then = now.clone();
        then.remove("window");
        assert!(resume::differences(&then, &now, &default_physics()).is_empty());
        let mut wider = now.clone();
        wider.insert("window".into(), serde_json::json!(500.0));
        let d = resume::differences(&then, &wider, &default_physics());
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].to_string(), "window: then not set, now 500.0");
        // A run-only option may differ.
        let mut quiet = serde_json::to_value(ShearOptions::default()).unwrap();
        quiet["quiet"] = serde_json::json!(true);
        quiet["checkpoint_every"] = serde_json::json!(100);
        let quiet = resume::physics(quiet);
        assert!(resume::differences(&then, &quiet, &default_physics()).is_empty());
    }
}
