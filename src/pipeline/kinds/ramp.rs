//! `ramp`: one sheared-disk strain-rate ramp (vagberg-sheared-disks Eqs. 38–41,
//! Fig. 31), from random positions or another ramp's final state.

use super::StageKind;
use crate::stages::shear::ShearOptions;

use super::Locate;
use super::Stage;
use super::typed;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// A `ramp` stage: one strain-rate ramp (vagberg-sheared-disks Eqs. 38–41), γ̇ τ_e from
/// `rate` to `rate_end` by 10^{±κ̃} every τ_e. `ShearOptions` less what only a steady
/// run reads (its strain, transient and blocks: a ramp's length is set by its rates
/// and κ̃, and it has no steady window), the ramp keys required where the command
/// line has them optional.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RampParams {
    /// `up` or `down` (the command's `--ramp`).
    pub ramp: String,
    /// Final γ̇ τ_e (`--rate-end`).
    pub rate_end: f64,
    /// κ̃ = κ τ_e / ln 10 (Eq. 39).
    pub kappa: f64,
    /// Averaging window of `ramp.parquet` (τ_e; the paper: 10³).
    pub window: f64,
    /// A `ramp` stage whose final state this ramp starts from (a cycle), else random
    /// positions.
    pub from: Option<String>,
    pub n: usize,
    pub phi: f64,
    pub q: f64,
    /// Initial γ̇ τ_e.
    pub rate: f64,
    pub model: crate::dem::shear::Dissipation,
    pub dt: Option<f64>,
    pub seed: u64,
    pub output_every: Option<u64>,
    pub sample_every: u64,
    pub checkpoint_every: u64,
    pub checkpoint_interval: f64,
}

impl Default for RampParams {
    fn default() -> Self {
        let d = ShearOptions::default();
        RampParams {
            ramp: String::new(),
            rate_end: 0.0,
            kappa: d.kappa,
            window: d.window,
            from: None,
            n: d.n,
            phi: d.phi,
            q: d.q,
            rate: d.rate,
            model: d.model,
            dt: d.dt,
            seed: d.seed,
            output_every: d.output_every,
            sample_every: d.sample_every,
            checkpoint_every: d.checkpoint_every,
            checkpoint_interval: d.checkpoint_interval,
        }
    }
}

impl RampParams {
    /// The options `simulate shear --ramp` runs with.
    pub fn options(&self) -> ShearOptions {
        ShearOptions {
            n: self.n,
            phi: self.phi,
            q: self.q,
            rate: self.rate,
            model: self.model,
            dt: self.dt,
            seed: self.seed,
            output_every: self.output_every,
            sample_every: self.sample_every,
            ramp: Some(self.ramp.clone()),
            kappa: self.kappa,
            rate_end: Some(self.rate_end),
            window: self.window,
            checkpoint_every: self.checkpoint_every,
            checkpoint_interval: self.checkpoint_interval,
            ..ShearOptions::default()
        }
    }
}

pub struct Ramp;

impl StageKind for Ramp {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<RampParams>(given)
    }

    fn check(&self, src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        check_ramp(src, st)?;
        Ok(Vec::new())
    }

    fn check_references(&self, src: &dyn Locate, st: &Stage, all: &[Stage]) -> Result<()> {
        check_source(src, st, all)
    }

    fn run_only(&self) -> &'static [&'static str] {
        &stages::simulate::RUN_ONLY
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let q = ctx.quiet;
        let p: RampParams = typed(&s.name, &s.params)?;
        let mut o = p.options();
        o.quiet = q;
        // A pipeline's sheared-disk stages run side by side (`--jobs`, a sweep's
        // points), one core each: two single-threaded runs beat one run on two
        // threads. The thread count changes no number.
        o.threads = 1;
        if p.from.is_some() {
            o.from_state = Some(ctx.input(s, "from", "state")?);
        }
        let summary = super::shear::resumable(out, ctx.dir, &mut o)?;
        Ok(Produced {
            outputs: super::shear::tables_in(out)?,
            metrics: json!({
                "n": p.n, "phi": p.phi, "q": p.q, "model": p.model, "ramp": p.ramp,
                "kappa_tilde": p.kappa, "rate_start": p.rate, "rate_end": summary.get("rate_end"),
                "windows": summary.get("windows"), "strain": summary.get("strain"),
            }),
            summary: json!({"summary": "summary.json"}),
        })
    }
}

/// A ramp's options as the run will check them, at load: the physics at the stage,
/// the ramp's own faults at the key (its direction against `rate` and `rate_end`, κ̃,
/// a `dt` that does not divide τ_e).
fn check_ramp(src: &dyn Locate, st: &Stage) -> Result<()> {
    let p: RampParams =
        serde_json::from_value(st.params.clone()).map_err(|e| src.err(&st.name, e.to_string()))?;
    let o = p.options();
    let sp = stages::shear::params_of(&o).map_err(|m| src.err(&st.name, m))?;
    match stages::shear::ramp_problem(&o, &sp) {
        Some((key, m)) => Err(src.err(&format!("{}.{key}", st.name), m)),
        None => Ok(()),
    }
}

/// A ramp that starts `from` another's final state needs the same disks: N, φ, Q, model
/// and Δt as the ramp it continues (its rate may differ: velocities are rescaled).
fn check_source(src: &dyn Locate, s: &Stage, stages: &[Stage]) -> Result<()> {
    {
        let Some(up) = s.upstream.get("from") else {
            return Ok(());
        };
        let u = stages.iter().find(|x| &x.name == up).expect("resolved");
        // dt left out means the default for the stage's Q.
        let value = |p: &Json, k: &str| match (k, p[k].as_f64(), p["q"].as_f64()) {
            ("dt", None, Some(q)) => Json::from(crate::dem::shear::ShearParams::default_dt(q)),
            _ => p[k].clone(),
        };
        let differ: Vec<String> = ["n", "phi", "q", "model", "dt"]
            .into_iter()
            .filter(|k| value(&s.params, k) != value(&u.params, k))
            .map(|k| {
                format!(
                    "{k} = {} there, {} here",
                    value(&u.params, k),
                    value(&s.params, k)
                )
            })
            .collect();
        if !differ.is_empty() {
            return Err(src.err(
                &format!("{}.from", s.name),
                format!(
                    "'{up}' ran other disks: {}; a ramp continues only the same system",
                    differ.join(", ")
                ),
            ));
        }
    }
    Ok(())
}
