//! `pillar-pipe bench gofr`: g(r) by species (li-granular-pillars Fig. 2,
//! `structure::pair_distribution`) of N grains in a periodic box against freud's
//! `density.RDF` on the same points (`bench/freud_gofr.py`), both timed in-process on
//! the compute alone, alternating rounds, medians. Ours fills three histograms (all,
//! small-centred, large-centred); freud's one.

use crate::bench::whole::{median, write_npy};
use crate::error::{Error, Result};
use crate::geom::Vec2;
use crate::structure::pair_distribution;
use crate::synth::bidisperse_packing;
use crate::tracks::SMALL;
use serde::Serialize;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The freud side, carried in the binary so the bench needs no checkout.
const FREUD_SCRIPT: &str = include_str!("../../bench/freud_gofr.py");

#[derive(Debug, Clone, Serialize)]
pub struct GofrBench {
    pub n: usize,
    pub r_max_over_d: f64,
    pub bins: usize,
    pub ours_s: Vec<f64>,
    pub freud_s: Vec<f64>,
    /// freud's version, or why it could not run.
    pub freud: std::result::Result<String, String>,
    /// The highest g(r) of each, as a check that both saw the same packing.
    pub g_peak_ours: f64,
    pub g_peak_freud: f64,
}

impl GofrBench {
    pub fn ours_median(&self) -> f64 {
        median(&self.ours_s)
    }
    pub fn freud_median(&self) -> Option<f64> {
        (!self.freud_s.is_empty()).then(|| median(&self.freud_s))
    }
}

/// `rounds` alternating rounds of `reps` computes each on a jittered bidisperse packing
/// of about `n` grains (D = 1) in its periodic box; files under `dir`.
pub fn bench_gofr(
    n: usize,
    reps: usize,
    rounds: usize,
    dir: &Path,
    python: &str,
) -> Result<GofrBench> {
    let (r_max, bins) = (4.0, 100);
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let p = bidisperse_packing(n, 1.0, 0.3, 11);
    let b = p.simbox;
    // Positions in [0, L) for freud; ours takes the box as it is.
    let wrapped: Vec<Vec2> = p.pos.iter().map(|&r| b.wrap(r)).collect();
    let col = |f: fn(&Vec2) -> f64, b0: f64| {
        wrapped
            .iter()
            .map(move |v| (f(v) - b0).to_le_bytes())
            .collect::<Vec<_>>()
    };
    let m = wrapped.len();
    write_npy(
        &dir.join("x.npy"),
        "<f8",
        col(|v| v.x, b.x_lo).into_iter(),
        m,
    )?;
    write_npy(
        &dir.join("y.npy"),
        "<f8",
        col(|v| v.y, b.y_lo).into_iter(),
        m,
    )?;
    write_npy(
        &dir.join("box.npy"),
        "<f8",
        [b.lx, b.ly].iter().map(|v| v.to_le_bytes()),
        2,
    )?;
    let script = dir.join("freud_gofr.py");
    std::fs::write(&script, FREUD_SCRIPT).map_err(|e| Error::io(&script, e))?;
    let small: Vec<bool> = p.species.iter().map(|&s| s == SMALL).collect();
    let (mut ours_s, mut freud_s) = (Vec::new(), Vec::new());
    let (mut g_peak_ours, mut g_peak_freud) = (f64::NAN, f64::NAN);
    let mut freud: std::result::Result<String, String> = Err("not run".into());
    for _ in 0..rounds.max(1) {
        for _ in 0..reps.max(1) {
            let t = Instant::now();
            let g = pair_distribution(&wrapped, &small, r_max, bins, Some(b))?;
            ours_s.push(t.elapsed().as_secs_f64());
            g_peak_ours = g.g_all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        }
        if matches!(&freud, Err(e) if e != "not run") {
            continue; // freud failed once: do not retry every round
        }
        let o = Command::new(python)
            .arg(&script)
            .arg(dir)
            .args([r_max.to_string(), bins.to_string(), reps.max(1).to_string()])
            .output();
        match o {
            Ok(o) if o.status.success() => {
                let v: serde_json::Value = serde_json::from_slice(&o.stdout)
                    .map_err(|e| Error::Other(format!("freud_gofr.py output: {e}")))?;
                freud_s.extend(
                    v["seconds"]
                        .as_array()
                        .into_iter()
                        .flatten()
                        .filter_map(|s| s.as_f64()),
                );
                g_peak_freud = v["g_peak"].as_f64().unwrap_or(f64::NAN);
                freud = Ok(v["freud"].as_str().unwrap_or("?").to_string());
            }
            Ok(o) => {
                freud = Err(format!(
                    "{python} bench/freud_gofr.py failed (pip install freud-analysis): {}",
                    String::from_utf8_lossy(&o.stderr)
                        .lines()
                        .last()
                        .unwrap_or("")
                ))
            }
            Err(e) => freud = Err(format!("{python} not runnable: {e}")),
        }
    }
    Ok(GofrBench {
        n: m,
        r_max_over_d: r_max,
        bins,
        ours_s,
        freud_s,
        freud,
        g_peak_ours,
        g_peak_freud,
    })
}
