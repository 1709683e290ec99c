//! `shear`: one steady sheared-disk run (vagberg-sheared-disks), resumable like a
//! simulate stage.

use super::Locate;
use super::Stage;
use super::StageKind;
use super::simulate::{SIMULATE_RUN_ONLY, drop_keys};
use super::typed;
use crate::error::{Error, Result};
use crate::pipeline::exec::{Ctx, Produced};
use crate::pipeline::exec::{move_files, work_dir};
use crate::stages;
use serde_json::{Value as Json, json};
use std::collections::BTreeMap;
use std::path::Path;

/// Options of `ShearOptions` that only a ramp reads: a `shear` stage is a steady run,
/// a ramp is a `ramp` stage.
pub const RAMP_ONLY: [&str; 4] = ["ramp", "kappa", "rate_end", "window"];

pub struct Shear;

impl StageKind for Shear {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        let mut v = super::round_trip::<stages::shear::ShearOptions>(given)?;
        drop_keys(&mut v, &RAMP_ONLY);
        drop_keys(&mut v, &SIMULATE_RUN_ONLY);
        Ok(v)
    }

    fn check(&self, src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        let o: stages::shear::ShearOptions = super::typed_at(src, st)?;
        stages::shear::params_of(&o).map_err(|m| src.err(&st.name, m))?;
        Ok(Vec::new())
    }

    fn unknown_key_hint(&self, key: &str) -> Option<&'static str> {
        RAMP_ONLY
            .contains(&key)
            .then_some(" (a strain-rate ramp is a stage of its own: kind = \"ramp\")")
    }

    fn run_only(&self) -> &'static [&'static str] {
        &stages::simulate::RUN_ONLY
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let q = ctx.quiet;
        let mut o: stages::shear::ShearOptions = typed(&s.name, &s.params)?;
        o.quiet = q;
        // A pipeline's sheared-disk stages run side by side (`--jobs`, a sweep's
        // points), one core each: two single-threaded runs beat one run on two
        // threads. The thread count changes no number.
        o.threads = 1;
        let summary = resumable(out, ctx.dir, &mut o)?;
        let mean = |k: &str| summary.get(k).and_then(|v| v.get("mean")).cloned();
        Ok(Produced {
            outputs: tables_in(out)?,
            metrics: json!({
                "n": o.n, "phi": o.phi, "q": o.q, "rate": o.rate, "model": o.model,
                "p": mean("p"), "z": mean("z"), "mu": mean("mu"),
            }),
            summary: json!({"summary": "summary.json"}),
        })
    }
}

/// A sheared-disk run's outputs by name: each table (`series`, `ramp`, `tracks`, …),
/// each JSON record (`summary`, `manifest`) in `out`, and a ramp's final `state`;
/// sidecars (`x.meta.json`) go with their tables.
pub(crate) fn tables_in(out: &Path) -> Result<BTreeMap<String, String>> {
    let mut outs = BTreeMap::new();
    for e in std::fs::read_dir(out)
        .map_err(|e| Error::io(out, e))?
        .flatten()
    {
        let name = e.file_name().to_string_lossy().into_owned();
        let key = name
            .strip_suffix(".parquet")
            .or_else(|| name.strip_suffix(".json").filter(|n| !n.contains('.')))
            .or_else(|| (name == stages::shear::STATE).then_some("state"));
        if let Some(k) = key {
            outs.insert(k.to_string(), name.clone());
        }
    }
    Ok(outs)
}

/// A `shear` or `ramp` stage's run, resumable like a simulate stage's
/// (`simulate_resumable`): it works in `.work-shear-<hash>/` (`.work-ramp-<hash>/`)
/// beside the cache, from its checkpoint when one is there; the files then move into
/// `out`. Returns `summary.json`'s top level (a ramp's: its rates, windows, strain).
pub(crate) fn resumable(
    out: &Path,
    stage_dir: &Path,
    o: &mut stages::shear::ShearOptions,
) -> Result<serde_json::Map<String, Json>> {
    let work = work_dir(stage_dir);
    let finished = work.join(stages::manifest::MANIFEST).exists();
    o.resume = !finished && work.join("checkpoint.bin").exists();
    if !finished && !o.resume && work.exists() {
        std::fs::remove_dir_all(&work).map_err(|e| Error::io(&work, e))?;
    }
    if !finished {
        stages::shear::run(&work, o)?;
    }
    move_files(&work, out)?;
    let _ = std::fs::remove_dir_all(&work);
    stages::shear::relocate_records(out)?;
    let f = out.join("summary.json");
    if !f.exists() {
        return Ok(Default::default());
    }
    let text = std::fs::read_to_string(&f).map_err(|e| Error::io(&f, e))?;
    let v: Json =
        serde_json::from_str(&text).map_err(|e| Error::input(f.display(), e.to_string()))?;
    Ok(v.as_object().cloned().unwrap_or_default())
}
