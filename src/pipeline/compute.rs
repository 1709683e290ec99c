//! Stage keys and computing one stage into the cache: what the local executor, the
//! Slurm head and the Slurm jobs all go through, so a stage computed anywhere is the same
//! cache entry with the same guarantees.

use super::cache::{Cache, CacheEvent, Check, Claim, StageRecord, stage_key};
use super::exec::{Ctx, Done, execute};
use super::lock::LockEvent;
use super::options::{Keyed, Status};
use super::record::write_manifest;
use super::runs::{self, RunManifest};
use super::{Pipeline, Stage};
use crate::error::{Error, Result};
use crate::io::sha256_file;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::Instant;

/// Stages matching `--force` and everything downstream of them.
pub(crate) fn forced(p: &Pipeline, force: &[String]) -> Result<BTreeSet<String>> {
    let mut set = BTreeSet::new();
    for f in force {
        let hits: Vec<&Stage> = p
            .stages
            .iter()
            // A sweep's name also stands for its grid points' runs.
            .filter(|s| {
                f == "all"
                    || &s.name == f
                    || s.kind.name() == f
                    || s.name
                        .strip_prefix(f.as_str())
                        .is_some_and(|r| r.starts_with(':'))
            })
            .collect();
        if hits.is_empty() {
            let names: Vec<&str> = p.stages.iter().map(|s| s.name.as_str()).collect();
            return Err(Error::param(
                "--force",
                format!(
                    "'{f}' is no stage or stage kind of this pipeline; stages: {}",
                    names.join(", ")
                ),
            ));
        }
        set.extend(hits.iter().map(|s| s.name.clone()));
    }
    for s in &p.stages {
        if s.upstream.values().any(|u| set.contains(u)) {
            set.insert(s.name.clone());
        }
    }
    Ok(set)
}

pub fn keys(p: &Pipeline) -> Result<BTreeMap<String, Keyed>> {
    let mut out: BTreeMap<String, Keyed> = BTreeMap::new();
    for s in &p.stages {
        let mut params = s.params.clone();
        if let Some(o) = params.as_object_mut() {
            // References and paths enter as upstream keys and content hashes.
            for k in s.upstream.keys().chain(s.files.keys()) {
                o.remove(k);
            }
            // How often a simulation checkpoints changes none of its numbers.
            for k in s.kind.def().run_only() {
                o.remove(*k);
            }
        }
        let upstream = s
            .upstream
            .iter()
            .map(|(k, u)| (k.clone(), out[u].key.clone()))
            .collect();
        let mut files = BTreeMap::new();
        for (k, f) in &s.files {
            // A folder (a track stage's frames) by its files' names and contents.
            let sum = if f.is_dir() {
                crate::io::hash::sha256_folder(f)?
            } else {
                sha256_file(f)?
            };
            files.insert(k.clone(), sum);
        }
        let key = stage_key(s.kind, &params, &upstream, &files);
        out.insert(
            s.name.clone(),
            Keyed {
                key,
                params,
                upstream,
                files,
            },
        );
    }
    Ok(out)
}

/// Who computes a stage: the run's id, and the Slurm job when a job does.
pub struct Job<'a> {
    pub quiet: bool,
    pub run_id: &'a str,
    /// `JOB_TASK on HOST`, recorded in the stage's record.
    pub slurm_job: Option<String>,
}

/// A stage served or computed.
pub struct Outcome {
    pub record: StageRecord,
    pub cached: bool,
    /// Why an existing entry was recomputed (damaged, unverifiable).
    pub because: Option<String>,
}

/// Serve a stage from the cache, or take its lock and compute it into the cache (a
/// temporary directory, the record and the completion marker last, renamed into
/// place). The local runner and Slurm jobs both go through here, so a stage computed
/// on a cluster is the same entry, with the same guarantees, as one computed locally.
/// `say` hears lock waits, broken locks, damaged entries, and `Running`.
#[allow(clippy::too_many_arguments)]
pub fn claim_and_compute(
    p: &Pipeline,
    s: &Stage,
    k: &Keyed,
    cache: &Cache,
    done: &BTreeMap<String, Done>,
    force: bool,
    how: Check,
    job: &Job,
    say: &mut dyn FnMut(Status, Option<String>),
) -> Result<Outcome> {
    let kind = s.kind.name();
    let dir = cache.path(kind, &k.key);
    let t = Instant::now();
    let claim = cache.claim(kind, &k.key, force, how, &mut |e| match e {
        CacheEvent::Lock(LockEvent::Waiting(h)) => say(Status::Waiting, Some(h.holder())),
        CacheEvent::Lock(LockEvent::BrokeStale(h, why)) => say(
            Status::BrokeLock,
            Some(format!(
                "{} ({why})",
                h.map_or_else(|| "unreadable lock".into(), |h| h.holder())
            )),
        ),
        CacheEvent::Damaged(what, to) => say(
            Status::Damaged,
            Some(format!("{what}; moved to {}", to.display())),
        ),
        CacheEvent::Unverifiable(why) => say(Status::Unverifiable, Some(why.to_string())),
    })?;
    let (lock, because) = match claim {
        Claim::Cached(r) => {
            return Ok(Outcome {
                record: *r,
                cached: true,
                because: None,
            });
        }
        Claim::Compute { lock, because } => (lock, because),
    };
    say(Status::Running, None);
    let ctx = Ctx {
        pipeline: p,
        done,
        quiet: job.quiet,
        run_id: job.run_id,
        dir: &dir,
    };
    let record = cache.compute(kind, &k.key, &lock, |tmp, _| {
        let pr = execute(s, &ctx, tmp)?;
        Ok(StageRecord {
            kind: kind.into(),
            key: k.key.clone(),
            tool: crate::stages::TOOL.into(),
            tool_version: crate::stages::VERSION.into(),
            source_sha256: Some(super::source_key::source_hash(s.kind).to_string()),
            executable_sha256: Some(super::cache::executable_sha256().to_string()),
            slurm_job: job.slurm_job.clone(),
            params: k.params.clone(),
            upstream: k.upstream.clone(),
            files: k.files.clone(),
            outputs: pr.outputs,
            output_files: None,
            metrics: pr.metrics,
            summary: pr.summary,
            elapsed_s: t.elapsed().as_secs_f64(),
            created: runs::now_iso(),
            computed_in_run: job.run_id.to_string(),
        })
    })?;
    Ok(Outcome {
        record,
        cached: false,
        because,
    })
}

pub(crate) fn interrupted_note(finished: usize, total: usize) -> String {
    format!(
        "{finished} of {total} stages finished and cached; running the pipeline again continues \
         (a simulation from its last checkpoint)"
    )
}

/// Record a run stopped by a signal in its manifest and make the error that says so.
pub(crate) fn stop_interrupted(
    m: &mut RunManifest,
    run_dir: &Path,
    t0: Instant,
    signal: i32,
    what: String,
) -> Error {
    m.status = "interrupted".into();
    m.error = Some(format!(
        "stopped by {}: {what}",
        crate::interrupt::name(signal)
    ));
    m.elapsed_s = t0.elapsed().as_secs_f64();
    if let Err(e) = write_manifest(run_dir, m) {
        return e;
    }
    Error::Interrupted { signal, what }
}
