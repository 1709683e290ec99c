//! Strain-rate ramps of the sheared disks (vagberg-sheared-disks Eqs. 38–41): the
//! schedule and the windowed ramp table.

use crate::dem::shear::{ShearParams, ShearSim};
use crate::error::{Error, Result};
use crate::io::atomic_write_str;
use crate::io::table::write_table;
use crate::stages::run_dir::RunDir;
use crate::stages::shear::{SERIES, ShearOptions, ShearReport};
use polars::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A ramp's schedule: `intervals` changes of γ̇ by `factor`, one every τ_e.
pub(crate) struct Ramp {
    pub factor: f64,
    pub intervals: u64,
    pub steps_per_tau: u64,
}

pub(crate) fn ramp_plan(opt: &ShearOptions, p: &ShearParams) -> Result<Option<Ramp>> {
    match &opt.ramp {
        None => Ok(None),
        Some(_) => check_ramp(opt, p)
            .map(Some)
            .map_err(|(key, msg)| Error::param(key, msg)),
    }
}

/// A ramp's schedule, or the option at fault and why (the pipeline names the key, the
/// command line the flag).
pub(crate) fn check_ramp(
    opt: &ShearOptions,
    p: &ShearParams,
) -> std::result::Result<Ramp, (&'static str, String)> {
    let dir = opt.ramp.as_deref().unwrap_or_default();
    let up = match dir {
        "up" => true,
        "down" => false,
        d => return Err(("ramp", format!("expected up or down, got '{d}'"))),
    };
    let end = opt
        .rate_end
        .ok_or(("rate_end", "a ramp needs --rate-end".to_string()))?;
    if !(opt.kappa > 0.0 && opt.kappa < 1.0) {
        return Err(("kappa", format!("κ̃ must be in (0, 1), got {}", opt.kappa)));
    }
    if up != (end > p.rate) || !(end > 0.0 && end <= 1.0) {
        return Err((
            "rate_end",
            format!("ramping {dir} from γ̇ = {:e} cannot end at {end:e}", p.rate),
        ));
    }
    let steps_per_tau = (1.0 / p.dt).round() as u64;
    if ((steps_per_tau as f64) * p.dt - 1.0).abs() > 1e-9 {
        return Err((
            "dt",
            "a ramp changes γ̇ every τ_e: dt must divide 1".to_string(),
        ));
    }
    let intervals = ((end / p.rate).log10().abs() / opt.kappa).round() as u64;
    if intervals == 0 {
        return Err((
            "kappa",
            format!(
                "κ̃ = {} is more than the ramp's span of {:.3} decades: no change of γ̇",
                opt.kappa,
                (end / p.rate).log10().abs()
            ),
        ));
    }
    let factor = 10f64.powf(if up { opt.kappa } else { -opt.kappa });
    Ok(Ramp {
        factor,
        intervals,
        steps_per_tau,
    })
}

/// The state a finished ramp leaves (positions, velocities, spins, contact history at
/// its last step), which the next ramp of a cycle starts from.
pub const STATE: &str = "state.bin";

/// The run in `state` (a ramp's `STATE`) as the start of a ramp with parameters `p`: the
/// same disks, φ, Q, model and Δt, its velocities and spins rescaled to `p.rate` (Eqs.
/// 40–41), so that a ramp down continues where the ramp up ended, as in the paper's
/// cycles (Fig. 31). Its step and time go on from there.
pub(crate) fn start_from(state: &Path, p: &ShearParams) -> Result<ShearSim> {
    let bytes = std::fs::read(state).map_err(|e| Error::input(state.display(), e.to_string()))?;
    let (mut sim, _) = ShearSim::load(&bytes).map_err(|e| Error::input(state.display(), e))?;
    let q = &sim.p;
    let same = q.n == p.n
        && q.phi == p.phi
        && q.q == p.q
        && q.model == p.model
        && q.alpha == p.alpha
        && q.dt == p.dt;
    if !same {
        return Err(Error::param(
            "from",
            format!(
                "{} holds N = {}, φ = {}, Q = {}, {:?}, dt = {}; this ramp has N = {}, φ = {}, Q = {}, {:?}, dt = {}",
                state.display(),
                q.n,
                q.phi,
                q.q,
                q.model,
                q.dt,
                p.n,
                p.phi,
                p.q,
                p.model,
                p.dt
            ),
        ));
    }
    sim.set_rate(p.rate);
    sim.p.seed = p.seed;
    Ok(sim)
}

/// A ramp's outputs: `ramp.parquet` (means over windows of `window` τ_e, as in Fig. 31)
/// and summary.json describing the ramp, then the manifest.
#[allow(clippy::too_many_arguments)]
pub(crate) fn finish_ramp(
    dir: &RunDir,
    opt: &ShearOptions,
    p: &ShearParams,
    r: &Ramp,
    cols: &[Vec<f64>],
    sim: &ShearSim,
    frames: i64,
    series: PathBuf,
    tracks: PathBuf,
    t0: std::time::Instant,
    (step0, strain0): (u64, f64),
) -> Result<ShearReport> {
    let out = dir.out.as_path();
    let col = |name: &str| {
        &cols[SERIES
            .iter()
            .position(|s| *s == name)
            .expect("series column")]
    };
    let time = col("time");
    let keys = ["rate", "p", "sigma", "p_el", "sigma_el", "z"];
    let mut win: Vec<Vec<f64>> = vec![Vec::new(); keys.len() + 1];
    let mut start = 0;
    while start < time.len() {
        let end = (start..time.len())
            .find(|&k| time[k] >= time[start] + opt.window)
            .unwrap_or(time.len());
        if end == time.len() && start > 0 && time[end - 1] - time[start] < 0.5 * opt.window {
            break; // a trailing scrap shorter than half a window would only add noise
        }
        win[0].push(0.5 * (time[start] + time[end - 1]));
        for (w, k) in win[1..].iter_mut().zip(keys) {
            let c = &col(k)[start..end];
            w.push(c.iter().sum::<f64>() / c.len() as f64);
        }
        start = end;
    }
    let names = std::iter::once("time").chain(keys);
    let mut df = DataFrame::new(
        win[0].len(),
        names
            .zip(&win)
            .map(|(n, c)| Column::new(n.into(), c))
            .collect(),
    )
    .map_err(|e| Error::polars("building the ramp table", e))?;
    let table = out.join("ramp.parquet");
    write_table(&mut df, &table)?;
    crate::io::atomic_write_bytes(&out.join(STATE), &sim.save(&[]))?;
    let elapsed = t0.elapsed().as_secs_f64();
    let summary = serde_json::json!({
        "ramp": opt.ramp, "kappa_tilde": opt.kappa, "rate_start": p.rate, "rate_end": sim.p.rate,
        "rate_changes": r.intervals, "window_tau_e": opt.window, "windows": win[0].len(),
        "strain": sim.strain() - strain0, "steps": sim.step - step0, "params": p,
        "started_from": opt.from_state.as_ref().map(|f| f.display().to_string()),
    });
    atomic_write_str(
        &out.join("summary.json"),
        &serde_json::to_string_pretty(&summary).expect("json"),
    )?;
    let body = serde_json::json!({
        "params": p, "tables": {"series": series, "ramp": table, "tracks": tracks, "state": out.join(STATE)},
        "elapsed_s": elapsed,
    });
    crate::stages::manifest::write(out, "simulate shear --ramp", opt, body)?;
    dir.finished();
    Ok(ShearReport {
        out: out.to_path_buf(),
        steps: sim.step - step0,
        frames: frames as usize,
        summary: BTreeMap::new(),
        elapsed_s: elapsed,
    })
}
