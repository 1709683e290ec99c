//! `pillar-pipe run`: load the pipeline, compute every stage's cache key, reuse or
//! compute each stage (locally, several at once: `local`; or as Slurm jobs), then record
//! the run under `runs/<id>/`.

use super::Pipeline;
use super::cache::Cache;
use super::record::{manifest, write_manifest};
use super::runs::{self, RunManifest};
use crate::error::{Error, Result};
use std::time::Instant;

pub(crate) use super::compute::forced;
pub use super::compute::{Job, Outcome, claim_and_compute, keys};
pub use super::options::{Keyed, RunOptions, StageEvent, Status};

pub fn run(opt: &RunOptions, on_event: &mut dyn FnMut(&StageEvent)) -> Result<RunManifest> {
    let t0 = Instant::now();
    let p = super::load(&opt.pipeline, &opt.sets)?;
    let force = forced(&p, &opt.force)?;
    let runs_dir = std::path::absolute(&opt.runs_dir).map_err(|e| Error::io(&opt.runs_dir, e))?;
    let cache = Cache {
        dir: runs_dir.join("cache"),
    };
    let keyed = keys(&p)?;
    let all_keys: Vec<&str> = p
        .stages
        .iter()
        .map(|s| keyed[&s.name].key.as_str())
        .collect();
    let config = crate::io::hash::sha256_bytes(all_keys.join(",").as_bytes());
    let total = p.stages.len();
    let mut m = manifest(&p, opt, &keyed);
    if opt.dry_run {
        for (i, s) in p.stages.iter().enumerate() {
            let k = &keyed[&s.name];
            let hit = !force.contains(&s.name) && cache.lookup(s.kind.name(), &k.key).is_some();
            let status = if hit {
                Status::Cached
            } else {
                Status::WouldRun
            };
            on_event(&StageEvent {
                index: i + 1,
                total,
                stage: s,
                status,
                elapsed_s: 0.0,
                dir: &cache.path(s.kind.name(), &k.key),
                note: None,
            });
        }
        return Ok(m);
    }
    let slurm = executor(&p, opt)?;
    let (id, run_dir) = runs::new_run_dir(&runs_dir, &config)?;
    m.run_id = id.clone();
    // Rewritten after every stage: a run that is killed stays listed as "incomplete",
    // with the stages it finished.
    m.status = "incomplete".into();
    write_manifest(&run_dir, &m)?;
    if let Some(slurm) = slurm {
        let h = super::slurm::head::HeadRun {
            p: &p,
            keyed: &keyed,
            force: &force,
            cache: &cache,
            runs_dir: &runs_dir,
            run_dir: &run_dir,
            run_id: &id,
            opt,
            slurm,
            t0,
        };
        super::slurm::head::run(&h, &mut m, on_event)?;
        return Ok(m);
    }
    let local = super::local::LocalRun {
        p: &p,
        keyed: &keyed,
        force: &force,
        cache: &cache,
        runs_dir: &runs_dir,
        run_dir: &run_dir,
        run_id: &id,
        opt,
        t0,
    };
    super::local::run(&local, &mut m, on_event)?;
    Ok(m)
}

/// The Slurm settings when the stages run as Slurm jobs (`--executor slurm` or the
/// file's `[executor]`), `None` for a local run.
fn executor(p: &Pipeline, opt: &RunOptions) -> Result<Option<super::slurm::SlurmOptions>> {
    let name = opt
        .executor
        .clone()
        .or_else(|| p.executor.name.clone())
        .unwrap_or_else(|| "local".into());
    match name.as_str() {
        "slurm" => Ok(Some(opt.slurm.over(&p.executor.slurm))),
        "local" if opt.slurm != super::slurm::SlurmOptions::default() => Err(Error::param(
            "--executor",
            "--partition, --account, --time, --mem, --cpus-per-task, --sbatch-arg, --retry \
             and --detach apply to --executor slurm",
        )),
        "local" => Ok(None),
        other => Err(Error::param(
            "--executor",
            format!("'{other}' is not an executor: local or slurm"),
        )),
    }
}
