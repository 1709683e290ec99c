//! `pillar-pipe run`: load the pipeline, compute every stage's cache key, reuse or
//! compute each stage in order, then record the run under `runs/<id>/`.

use super::cache::{Cache, CacheEvent, Check, Claim, StageRecord, stage_key};
use super::exec::{Ctx, Done, execute};
use super::lock::LockEvent;
use super::record::{manifest, place_reports, write_manifest};
use super::runs::{self, RunManifest, StageRun};
use super::{Pipeline, Stage};
use crate::error::{Error, Result};
use crate::io::sha256_file;
use serde_json::Value as Json;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, Clone)]
pub struct RunOptions {
    pub pipeline: PathBuf,
    /// `STAGE.KEY=VALUE` overrides.
    pub sets: Vec<String>,
    /// Stage names, kinds, or `all`: recomputed with everything downstream of them.
    pub force: Vec<String>,
    pub quiet: bool,
    pub runs_dir: PathBuf,
    /// Validate and show what would run; write nothing.
    pub dry_run: bool,
    /// Check cached outputs' SHA-256, not only their sizes, before serving them.
    pub verify: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    Running,
    Cached,
    Computed,
    WouldRun,
    /// Another process computes the stage; `note` names it.
    Waiting,
    /// A stale lock was broken; `note` says whose and why.
    BrokeLock,
    /// The cached entry failed its check and was moved aside; `note` says what and where.
    Damaged,
    /// The cached entry's record has no sizes or hashes; it is recomputed.
    Unverifiable,
}

/// One line of progress for the caller to print.
pub struct StageEvent<'a> {
    pub index: usize,
    pub total: usize,
    pub stage: &'a Stage,
    pub status: Status,
    pub elapsed_s: f64,
    pub dir: &'a Path,
    /// Details for `Waiting`, `BrokeLock`, `Damaged`, `Unverifiable`.
    pub note: Option<String>,
}

/// Stages matching `--force` and everything downstream of them.
fn forced(p: &Pipeline, force: &[String]) -> Result<BTreeSet<String>> {
    let mut set = BTreeSet::new();
    for f in force {
        let hits: Vec<&Stage> = p
            .stages
            .iter()
            .filter(|s| f == "all" || &s.name == f || s.kind.name() == f)
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

/// Keys of every stage, in run order, with the parameters and file hashes they cover.
pub struct Keyed {
    pub key: String,
    pub params: Json,
    pub upstream: BTreeMap<String, String>,
    pub files: BTreeMap<String, String>,
}

fn keys(p: &Pipeline) -> Result<BTreeMap<String, Keyed>> {
    let mut out: BTreeMap<String, Keyed> = BTreeMap::new();
    for s in &p.stages {
        let mut params = s.params.clone();
        if let Some(o) = params.as_object_mut() {
            // References and paths enter as upstream keys and content hashes.
            for k in s.upstream.keys().chain(s.files.keys()) {
                o.remove(k);
            }
            // How often a simulation checkpoints changes none of its numbers.
            if s.kind == super::Kind::Simulate {
                for k in crate::stages::simulate::RUN_ONLY {
                    o.remove(k);
                }
            }
        }
        let upstream = s
            .upstream
            .iter()
            .map(|(k, u)| (k.clone(), out[u].key.clone()))
            .collect();
        let mut files = BTreeMap::new();
        for (k, f) in &s.files {
            files.insert(k.clone(), sha256_file(f)?);
        }
        let key = stage_key(s.kind.name(), &params, &upstream, &files);
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
    let (id, run_dir) = runs::new_run_dir(&runs_dir, &config)?;
    m.run_id = id.clone();
    // Rewritten after every stage: a run that is killed stays listed as "incomplete",
    // with the stages it finished.
    m.status = "incomplete".into();
    write_manifest(&run_dir, &m)?;
    let mut done: BTreeMap<String, Done> = BTreeMap::new();
    for (i, s) in p.stages.iter().enumerate() {
        let k = &keyed[&s.name];
        let kind = s.kind.name();
        let dir = cache.path(kind, &k.key);
        let t = Instant::now();
        let how = if opt.verify {
            Check::Sha256
        } else {
            Check::Sizes
        };
        let mut say = |status, note: String| {
            on_event(&StageEvent {
                index: i + 1,
                total,
                stage: s,
                status,
                elapsed_s: 0.0,
                dir: &dir,
                note: Some(note),
            });
        };
        let claim = cache.claim(
            kind,
            &k.key,
            force.contains(&s.name),
            how,
            &mut |e| match e {
                CacheEvent::Lock(LockEvent::Waiting(h)) => say(Status::Waiting, h.holder()),
                CacheEvent::Lock(LockEvent::BrokeStale(h, why)) => say(
                    Status::BrokeLock,
                    format!(
                        "{} ({why})",
                        h.map_or_else(|| "unreadable lock".into(), |h| h.holder())
                    ),
                ),
                CacheEvent::Damaged(what, to) => say(
                    Status::Damaged,
                    format!("{what}; moved to {}", to.display()),
                ),
                CacheEvent::Unverifiable(why) => say(Status::Unverifiable, why.to_string()),
            },
        );
        let (record, cached, because) = match claim {
            Ok(Claim::Cached(r)) => (Ok(*r), true, None),
            Ok(Claim::Compute { lock, because }) => {
                on_event(&StageEvent {
                    index: i + 1,
                    total,
                    stage: s,
                    status: Status::Running,
                    elapsed_s: 0.0,
                    dir: &dir,
                    note: None,
                });
                let ctx = Ctx {
                    pipeline: &p,
                    done: &done,
                    quiet: opt.quiet,
                    run_id: &id,
                    dir: &dir,
                };
                let computed = cache.compute(kind, &k.key, &lock, |tmp, _| {
                    let pr = execute(s, &ctx, tmp)?;
                    Ok(StageRecord {
                        kind: kind.into(),
                        key: k.key.clone(),
                        tool: crate::stages::TOOL.into(),
                        tool_version: crate::stages::VERSION.into(),
                        params: k.params.clone(),
                        upstream: k.upstream.clone(),
                        files: k.files.clone(),
                        outputs: pr.outputs,
                        output_files: None,
                        metrics: pr.metrics,
                        summary: pr.summary,
                        elapsed_s: t.elapsed().as_secs_f64(),
                        created: runs::now_iso(),
                        computed_in_run: id.clone(),
                    })
                });
                (computed, false, because)
            }
            Err(e) => (Err(e), false, None),
        };
        let record = match record {
            Ok(r) => r,
            Err(Error::Interrupted { signal, what }) => {
                let what = format!(
                    "stage '{}' ({kind}): {what}; {}",
                    s.name,
                    interrupted_note(i, total)
                );
                return Err(stop_interrupted(&mut m, &run_dir, t0, signal, what));
            }
            Err(e) => {
                let msg = format!("stage '{}' ({kind}) failed: {e}", s.name);
                m.status = "failed".into();
                m.failed_stage = Some(s.name.clone());
                m.error = Some(msg.clone());
                m.elapsed_s = t0.elapsed().as_secs_f64();
                write_manifest(&run_dir, &m)?;
                return Err(Error::Other(msg));
            }
        };
        let elapsed_s = t.elapsed().as_secs_f64();
        on_event(&StageEvent {
            index: i + 1,
            total,
            stage: s,
            status: if cached {
                Status::Cached
            } else {
                Status::Computed
            },
            elapsed_s,
            dir: &dir,
            note: None,
        });
        if !record.metrics.as_object().is_none_or(|o| o.is_empty()) {
            m.metrics.insert(s.name.clone(), record.metrics.clone());
        }
        m.stages.push(StageRun {
            name: s.name.clone(),
            kind: kind.into(),
            key: k.key.clone(),
            dir: dir
                .strip_prefix(&runs_dir)
                .unwrap_or(&dir)
                .display()
                .to_string(),
            cached,
            verified: if cached { how.name() } else { "computed" }.into(),
            recomputed_because: because,
            elapsed_s,
            compute_s: record.elapsed_s,
            outputs: record.outputs.clone(),
        });
        done.insert(s.name.clone(), Done { record, dir });
        m.elapsed_s = t0.elapsed().as_secs_f64();
        write_manifest(&run_dir, &m)?;
        if let Some(signal) = crate::interrupt::requested()
            && i + 1 < total
        {
            let what = format!(
                "after stage '{}'; {}",
                s.name,
                interrupted_note(i + 1, total)
            );
            return Err(stop_interrupted(&mut m, &run_dir, t0, signal, what));
        }
    }
    m.report = place_reports(&p, &done, &run_dir)?;
    m.status = "ok".into();
    m.elapsed_s = t0.elapsed().as_secs_f64();
    write_manifest(&run_dir, &m)?;
    Ok(m)
}

fn interrupted_note(finished: usize, total: usize) -> String {
    format!(
        "{finished} of {total} stages finished and cached; running the pipeline again continues \
         (a simulation from its last checkpoint)"
    )
}

/// Record a run stopped by a signal in its manifest and make the error that says so.
fn stop_interrupted(
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
