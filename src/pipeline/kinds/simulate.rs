//! `simulate`: the pillar DEM (li-granular-pillars Sec. II), resumable: a killed
//! pipeline continues from the run's last checkpoint.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::{Error, Result};
use crate::pipeline::exec::{Ctx, Produced, sum};
use crate::pipeline::exec::{move_files, work_dir};
use crate::stages;
use serde_json::{Value as Json, json};
use std::collections::BTreeMap;
use std::path::Path;

/// How a run behaves, not what it computes: `--quiet`, and resuming (a pipeline stage
/// always starts in a fresh directory).
pub(crate) const SIMULATE_RUN_ONLY: [&str; 2] = ["quiet", "resume"];

/// Remove `keys` from resolved parameters.
pub(crate) fn drop_keys(v: &mut Json, keys: &[&str]) {
    if let Some(o) = v.as_object_mut() {
        for k in keys {
            o.remove(*k);
        }
    }
}

pub struct Simulate;

impl StageKind for Simulate {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        let mut o: stages::simulate::SimulateOptions =
            serde_json::from_value(given).map_err(|e| e.to_string())?;
        o.canonicalise();
        let mut v = serde_json::to_value(o).expect("json");
        drop_keys(&mut v, &SIMULATE_RUN_ONLY);
        Ok(v)
    }

    fn run_only(&self) -> &'static [&'static str] {
        &stages::simulate::RUN_ONLY
    }

    /// The pillar's threads wait for each other at spinning barriers.
    fn exclusive(&self) -> bool {
        true
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let q = ctx.quiet;
        let mut o: stages::simulate::SimulateOptions = typed(&s.name, &s.params)?;
        o.packing = match &o.packing_stage {
            Some(_) => Some(ctx.input(s, "packing_stage", "tracks")?),
            None => s.files.get("packing").cloned(),
        };
        o.quiet = q;
        let r = simulate_resumable(out, ctx.dir, &mut o)?;
        let rel: BTreeMap<String, String> = r
            .tables
            .iter()
            .map(|(k, p)| {
                let p = p
                    .file_name()
                    .map(std::path::PathBuf::from)
                    .unwrap_or_else(|| p.clone());
                (k.clone(), p.display().to_string())
            })
            .collect();
        if !rel.contains_key("tracks") {
            return Err(Error::Other(format!(
                "simulate reported no tracks table (tables: {:?})",
                rel.keys().collect::<Vec<_>>()
            )));
        }
        Ok(Produced {
            outputs: rel,
            metrics: json!({"n": r.n, "frames": r.frames, "steps": r.steps, "mean_flow_stress": r.mean_flow_stress}),
            summary: sum(&r),
        })
    }
}

/// Run a simulation so that a killed pipeline resumes it: the work happens in a
/// directory beside the cache named after the stage's (`.work-simulate-<hash>` for
/// `simulate-<hash>`, so the stage's key, which covers its options, the packing and
/// the tool build, names it, and the stage's lock covers it; not swept with the stage's
/// temporary directory), with checkpoints; a rerun continues from the last one, and the
/// finished tables are then moved into the stage's `out`.
fn simulate_resumable(
    out: &Path,
    stage_dir: &Path,
    o: &mut stages::simulate::SimulateOptions,
) -> Result<stages::simulate::SimulateReport> {
    let work = work_dir(stage_dir);
    let finished = work.join(stages::simulate::MANIFEST).exists();
    o.resume = !finished && work.join("checkpoint.bin").exists();
    if !finished && !o.resume && work.exists() {
        std::fs::remove_dir_all(&work).map_err(|e| Error::io(&work, e))?;
    }
    let report = if finished {
        let text = std::fs::read_to_string(work.join(stages::simulate::MANIFEST))
            .map_err(|e| Error::io(&work, e))?;
        let m: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| Error::input(work.display(), e.to_string()))?;
        serde_json::from_value(m["report"].clone())
            .map_err(|e| Error::input(work.display(), e.to_string()))?
    } else {
        stages::simulate::run(&work, o)?
    };
    move_files(&work, out)?;
    let _ = std::fs::remove_dir_all(&work);
    let mut report = report;
    report.out = out.to_path_buf();
    for p in report.tables.values_mut() {
        if let Some(name) = p.file_name() {
            *p = out.join(name);
        }
    }
    Ok(report)
}
