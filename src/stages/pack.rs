//! `pack`: a jammed bidisperse packing by li-granular-pillars Sec. II.A, written as a
//! one-frame canonical tracks table (cm) that `simulate pillar --packing` reads.

use crate::dem::pillar::pack::{Growth, PackOptions, Packing, pack};
use crate::dem::pillar::params::PillarParams;
use crate::error::Result;
use crate::tracks::{FrameBox, Provenance, Tracks, TracksMeta};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `pack`'s options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct PackParams {
    /// Grains (half small, half large).
    #[arg(long, default_value_t = PackParams::default().n)]
    pub n: usize,
    /// Seed of the initial random positions.
    #[arg(long, default_value_t = PackParams::default().seed)]
    pub seed: u64,
    /// How the box grows between minimisations: `halving` (default) or `secant` (half
    /// the growths, about as many CG iterations).
    #[arg(long, value_enum, default_value_t = PackParams::default().growth)]
    pub growth: Growth,
    /// A minimisation also stops once the forces balance: rms residual force at most
    /// this fraction of the mean virial per grain (the contact-force scale). 0: the
    /// paper's energy rule alone (relative energy change per CG step below 1e-12).
    #[arg(long, default_value_t = PackParams::default().f_tol)]
    pub f_tol: f64,
}

impl Default for PackParams {
    fn default() -> Self {
        PackParams {
            n: 1000,
            seed: 1,
            growth: Growth::Halving,
            f_tol: crate::dem::pillar::pack::F_TOL,
        }
    }
}

#[derive(Debug, Serialize)]
pub struct PackReport {
    pub out: String,
    pub n: usize,
    pub packing: Packing,
    pub elapsed_s: f64,
}

impl std::fmt::Display for PackReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = &self.packing;
        writeln!(
            f,
            "packing     {} grains (50:50), box {:.3} D × {:.3} D (periodic while packing)",
            self.n, p.lx, p.ly
        )?;
        writeln!(
            f,
            "jamming     φ = {:.4}, p = {:.2e} ε/D², energy/grain {:.2e} ε",
            p.phi, p.pressure, p.energy_per_grain
        )?;
        writeln!(
            f,
            "protocol    {} box growths, {} CG iterations, {} force evaluations, {} list builds, {:.1} s",
            p.growth_steps, p.cg_iterations, p.force_evaluations, p.list_builds, self.elapsed_s
        )?;
        write!(f, "wrote       {}", self.out)
    }
}

/// Generate and write the packing (lengths scaled to the paper's D = 0.635 cm).
/// `serial`: one force sum in the order drawn (the reference of `bench pack`; with
/// `f_tol` = 0, the packer before 2026-11-27 bit for bit).
pub fn run(out: &Path, params: &PackParams, serial: bool, quiet: bool) -> Result<PackReport> {
    let &PackParams {
        n,
        seed,
        growth: schedule,
        f_tol,
    } = params;
    if !(f_tol >= 0.0 && f_tol.is_finite()) {
        return Err(crate::Error::param(
            "f_tol",
            format!("need a finite tolerance ≥ 0 (0: the energy rule alone), got {f_tol}"),
        ));
    }
    if n < 2 {
        return Err(crate::Error::param(
            "n",
            format!("need at least 2 grains, got {n}"),
        ));
    }
    let t0 = std::time::Instant::now();
    let bar = crate::stages::progress(0, "packing", quiet);
    let mut opt = PackOptions {
        n,
        seed,
        schedule,
        f_tol,
        ..Default::default()
    };
    if serial {
        opt.block = usize::MAX;
    }
    let pk = pack(&opt, |step, p| {
        bar.set_message(format!("growth {step}, p = {p:.2e}"));
        bar.tick();
    })
    .map_err(stopped)?;
    bar.finish_and_clear();
    let d_cm = PillarParams::paper().d_large * 100.0;
    let r = |s: i32| {
        if s == crate::dem::base::grains::LARGE {
            0.5 * d_cm
        } else {
            0.375 * d_cm
        }
    };
    let mut meta = TracksMeta {
        length_unit: "cm".into(),
        coordinate_frame: "packing box: origin at its lower-left corner, y up; periodic while packing, open for the pillar".into(),
        provenance: Provenance {
            tool: crate::stages::TOOL.into(),
            tool_version: crate::stages::VERSION.into(),
            source: "pillar-pipe pack".into(),
            source_format: "generated".into(),
            source_sha256: String::new(),
            parameters: serde_json::json!({"n": n, "seed": seed, "protocol": opt}),
        },
        summary: serde_json::to_value(&pk).expect("json"),
        ..TracksMeta::default()
    };
    meta.boxes.push(FrameBox::from_simbox(
        0,
        &crate::geom::SimBox::periodic(pk.lx * d_cm, pk.ly * d_cm),
    ));
    let t = Tracks {
        frame: vec![0; n],
        particle: (0..n as i64).collect(),
        x: pk.x.iter().map(|v| v * d_cm).collect(),
        y: pk.y.iter().map(|v| v * d_cm).collect(),
        radius: pk.species.iter().map(|&s| r(s)).collect(),
        time: None,
        species: Some(pk.species.clone()),
        theta: None,
        meta,
    };
    crate::io::write_tracks(&t, out)?;
    Ok(PackReport {
        out: out.display().to_string(),
        n,
        packing: pk,
        elapsed_s: t0.elapsed().as_secs_f64(),
    })
}

/// A packing stopped by a signal, as the interruption `main` reports (exit 128 + signal).
/// Here rather than in `error`, whose every user would otherwise reach the simulator's
/// code (and each stage kind's cache key with it).
pub fn stopped(s: crate::dem::pillar::pack::Stopped) -> crate::error::Error {
    crate::error::Error::Interrupted {
        signal: s.signal,
        what: format!(
            "packing stopped after {} box growths, before it jammed; nothing was written (the same command starts it again)",
            s.growth_steps
        ),
    }
}
