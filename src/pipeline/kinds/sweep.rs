//! `sweep`: a grid of sheared-disk runs; each grid point is a `shear` stage of its own
//! (the same cache entry as a hand-written one), the sweep gathers their summaries.

use super::Kind;
use super::Locate;
use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::{Error, Result};
use crate::pipeline::exec::{Ctx, Produced, outputs};
use crate::stages;
use crate::stages::shear::ShearOptions;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::collections::BTreeMap;
use std::path::Path;

/// A `sweep` stage: the grid (every combination of `phi`, `q` and `rate`) and what its
/// runs share; each grid point runs as a `shear` stage of its own (see `graph`), so
/// these are `ShearOptions` less the per-point keys and the ramp (a ramp is one run).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SweepParams {
    pub phi: Vec<f64>,
    pub q: Vec<f64>,
    pub rate: Vec<f64>,
    pub n: usize,
    pub model: crate::dem::shear::Dissipation,
    pub strain: f64,
    pub dt: Option<f64>,
    pub seed: u64,
    pub output_every: Option<u64>,
    pub sample_every: u64,
    pub transient: f64,
    pub blocks: usize,
    pub checkpoint_every: u64,
    pub checkpoint_interval: f64,
}

impl Default for SweepParams {
    fn default() -> Self {
        let d = ShearOptions::default();
        SweepParams {
            phi: Vec::new(),
            q: Vec::new(),
            rate: Vec::new(),
            n: d.n,
            model: d.model,
            strain: d.strain,
            dt: d.dt,
            seed: d.seed,
            output_every: d.output_every,
            sample_every: d.sample_every,
            transient: d.transient,
            blocks: d.blocks,
            checkpoint_every: d.checkpoint_every,
            checkpoint_interval: d.checkpoint_interval,
        }
    }
}

impl SweepParams {
    /// The grid points (φ, Q, γ̇) in table order (φ outermost), duplicates dropped.
    pub fn grid(&self) -> Vec<(f64, f64, f64)> {
        let mut g: Vec<(f64, f64, f64)> = Vec::new();
        for &phi in &self.phi {
            for &q in &self.q {
                for &rate in &self.rate {
                    if !g.contains(&(phi, q, rate)) {
                        g.push((phi, q, rate));
                    }
                }
            }
        }
        g
    }

    /// The options of the run at one grid point: exactly what a `shear` stage with the
    /// same keys would run, so both share one cache entry.
    pub fn point(&self, (phi, q, rate): (f64, f64, f64)) -> ShearOptions {
        ShearOptions {
            n: self.n,
            phi,
            q,
            rate,
            model: self.model,
            strain: self.strain,
            dt: self.dt,
            seed: self.seed,
            output_every: self.output_every,
            sample_every: self.sample_every,
            transient: self.transient,
            blocks: self.blocks,
            checkpoint_every: self.checkpoint_every,
            checkpoint_interval: self.checkpoint_interval,
            ..ShearOptions::default()
        }
    }
}

pub struct Sweep;

impl StageKind for Sweep {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<SweepParams>(given)
    }

    fn check(&self, src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        sweep_points(src, st)
    }

    fn run_only(&self) -> &'static [&'static str] {
        &stages::simulate::RUN_ONLY
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: SweepParams = typed(&s.name, &s.params)?;
        let grid = p.grid();
        let mut summaries = Vec::new();
        let mut dirs = Vec::new();
        for &point in &grid {
            let name = point_name(&s.name, point);
            let done = ctx
                .done
                .get(&name)
                .ok_or_else(|| Error::Other(format!("{name} has not run")))?;
            dirs.push((point, done.dir.clone()));
            let f = done.dir.join("summary.json");
            let text = std::fs::read_to_string(&f).map_err(|e| Error::io(&f, e))?;
            summaries.push(
                serde_json::from_str(&text)
                    .map_err(|e| Error::input(f.display(), e.to_string()))?,
            );
        }
        let points: Vec<_> = grid.iter().copied().zip(summaries).collect();
        let base = p.point(grid[0]);
        let r = stages::sweep::write_outputs(out, &grid, &points, &base)?;
        stages::sweep::write_contacts(out, &dirs)?;
        Ok(Produced {
            outputs: outputs(&[
                ("sweep", stages::sweep::TABLE),
                ("grid", stages::sweep::GRID),
                ("angles", stages::sweep::ANGLES),
                ("contacts", stages::sweep::CONTACTS),
            ]),
            metrics: json!({"points": r.runs, "model": p.model, "n": p.n}),
            summary: json!({"points": r.runs}),
        })
    }
}

/// The name of a sweep's grid point stage.
pub fn point_name(sweep: &str, (phi, q, rate): (f64, f64, f64)) -> String {
    format!("{sweep}:phi={phi},q={q},rate={rate:e}")
}

/// A sweep's grid points as `shear` stages of their own, each with exactly the
/// parameters a hand-written `shear` stage of the same run resolves to, so it has the
/// same cache key: a grown grid, or a shear stage elsewhere, reuses finished runs, and
/// under Slurm the points form one job array. The sweep stage itself only gathers their
/// summaries (its upstream `point:…` keys).
fn sweep_points(src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
    let p: SweepParams =
        serde_json::from_value(st.params.clone()).map_err(|e| src.err(&st.name, e.to_string()))?;
    for (key, v) in [("phi", &p.phi), ("q", &p.q), ("rate", &p.rate)] {
        if v.is_empty() {
            return Err(src.err(
                &format!("{}.{key}", st.name),
                "an empty list: a sweep needs at least one value of each of phi, q and rate",
            ));
        }
    }
    let mut out = Vec::new();
    for point in p.grid() {
        let o = p.point(point);
        stages::shear::params_of(&o).map_err(|m| {
            src.err(
                &st.name,
                format!(
                    "grid point φ = {}, Q = {}, γ̇ = {:e}: {m}",
                    point.0, point.1, point.2
                ),
            )
        })?;
        let given = serde_json::to_value(o).expect("json");
        let params = Kind::Shear
            .def()
            .resolve(given)
            .map_err(|m| src.err(&st.name, format!("grid point {point:?}: {m}")))?;
        let name = point_name(&st.name, point);
        st.upstream.insert(
            format!("point:phi={},q={},rate={:e}", point.0, point.1, point.2),
            name.clone(),
        );
        out.push(Stage {
            name,
            kind: Kind::Shear,
            branch: st.branch.clone(),
            line: st.line,
            params,
            upstream: BTreeMap::new(),
            datasets: Vec::new(),
            files: BTreeMap::new(),
        });
    }
    Ok(out)
}
