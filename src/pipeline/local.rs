//! The local executor: every stage whose upstream stages are done runs at once, up to
//! `jobs` at a time, each on a thread of its own; a pillar simulation, which spreads
//! over every core through threads of its own, runs alone. Stages are launched in run order; the manifest
//! lists them in run order whatever order they finish in, so a run's outputs and record
//! are those of a serial run (each stage computes the same numbers alone).
//!
//! A failure or an interruption stops new launches; the stages under way finish (an
//! interrupted simulation saves its checkpoint), then the run stops, its manifest saying
//! which stage failed and which finished.

use super::Pipeline;
use super::cache::{Cache, Check};
use super::compute::{Job, Outcome, claim_and_compute, interrupted_note, stop_interrupted};
use super::exec::Done;
use super::options::{Keyed, RunOptions, StageEvent, Status};
use super::record::{place_reports, write_manifest};
use super::runs::{RunManifest, StageRun};
use crate::error::{Error, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::sync::mpsc;
use std::time::Instant;

/// What a stage's thread tells the loop that owns the manifest and the events.
enum Msg {
    Say(usize, Status, Option<String>),
    Finished(usize, Box<Result<Outcome>>, f64),
}

/// Kinds whose stage spreads over every core on threads of its own: the pillar
/// simulation (its threads wait for each other at spinning barriers, which a second
/// stage on the same cores would stall). Such a stage runs alone, with every core;
/// single-threaded stages (the sheared disks) and those on the shared rayon pool run
/// side by side.
fn exclusive(kind: super::Kind) -> bool {
    kind.def().exclusive()
}

/// Stages at a time when `--jobs` is not given: the machine's cores.
pub fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Everything the local loop reads.
pub(crate) struct LocalRun<'a> {
    pub p: &'a Pipeline,
    pub keyed: &'a BTreeMap<String, Keyed>,
    pub force: &'a BTreeSet<String>,
    pub cache: &'a Cache,
    pub runs_dir: &'a Path,
    pub run_dir: &'a Path,
    pub run_id: &'a str,
    pub opt: &'a RunOptions,
    pub t0: Instant,
}

/// Run every stage locally into the cache, recording each in `m` as it finishes.
pub(crate) fn run(
    r: &LocalRun,
    m: &mut RunManifest,
    on_event: &mut dyn FnMut(&StageEvent),
) -> Result<()> {
    let (p, total) = (r.p, r.p.stages.len());
    let jobs = r.opt.jobs.unwrap_or_else(default_jobs).max(1);
    let how = if r.opt.verify {
        Check::Sha256
    } else {
        Check::Sizes
    };
    let mut done: BTreeMap<String, Done> = BTreeMap::new();
    let mut runs: Vec<Option<StageRun>> = vec![None; total];
    let mut started = vec![false; total];
    let (mut running, mut finished) = (0usize, 0usize);
    let mut exclusive_running = false;
    // The first failure, and the stage it names.
    let mut failure: Option<(String, String)> = None;
    let mut stopped: Option<(i32, String)> = None;
    let (tx, rx) = mpsc::channel::<Msg>();
    std::thread::scope(|scope| -> Result<()> {
        loop {
            let halt =
                failure.is_some() || stopped.is_some() || crate::interrupt::requested().is_some();
            // A stage that spreads over every core itself runs alone (see `exclusive`).
            if !halt && !exclusive_running {
                let mut ready: Vec<usize> = (0..total)
                    .filter(|&i| {
                        !started[i] && p.stages[i].upstream.values().all(|u| done.contains_key(u))
                    })
                    .take(jobs.saturating_sub(running))
                    .collect();
                if let Some(k) = ready.iter().position(|&i| exclusive(p.stages[i].kind)) {
                    // The first exclusive stage waits for an empty machine, and nothing
                    // after it starts meanwhile, so run order is kept.
                    ready.truncate(if k == 0 && running == 0 { 1 } else { k });
                }
                exclusive_running = ready.iter().any(|&i| exclusive(p.stages[i].kind));
                // A stage's own progress bar only when it runs alone: bars of stages
                // side by side would overwrite each other.
                let alone = running == 0 && ready.len() == 1;
                for i in ready {
                    let s = &p.stages[i];
                    started[i] = true;
                    running += 1;
                    let k = &r.keyed[&s.name];
                    let snapshot = done.clone();
                    let force = r.force.contains(&s.name);
                    // The run's --quiet, as a Slurm job gets it (some stages record it).
                    let quiet = r.opt.quiet;
                    let (tx, cache, run_id) = (tx.clone(), r.cache, r.run_id);
                    scope.spawn(move || {
                        if !alone {
                            crate::stages::hide_progress_on_this_thread();
                        }
                        let t = Instant::now();
                        let job = Job {
                            quiet,
                            run_id,
                            slurm_job: None,
                        };
                        let say_tx = tx.clone();
                        let out = claim_and_compute(
                            p,
                            s,
                            k,
                            cache,
                            &snapshot,
                            force,
                            how,
                            &job,
                            &mut |status, note| {
                                let _ = say_tx.send(Msg::Say(i, status, note));
                            },
                        );
                        let _ = tx.send(Msg::Finished(i, Box::new(out), t.elapsed().as_secs_f64()));
                    });
                }
            }
            if running == 0 {
                break;
            }
            let msg = rx
                .recv()
                .map_err(|_| Error::Other("the local executor lost its stage threads".into()))?;
            let (i, outcome, elapsed_s) = match msg {
                Msg::Say(i, status, note) => {
                    let s = &p.stages[i];
                    let dir = r.cache.path(s.kind.name(), &r.keyed[&s.name].key);
                    on_event(&StageEvent {
                        index: i + 1,
                        total,
                        stage: s,
                        status,
                        elapsed_s: 0.0,
                        dir: &dir,
                        note,
                    });
                    continue;
                }
                Msg::Finished(i, outcome, elapsed_s) => (i, *outcome, elapsed_s),
            };
            running -= 1;
            let s = &p.stages[i];
            if exclusive(s.kind) {
                exclusive_running = false;
            }
            let (k, kind) = (&r.keyed[&s.name], s.kind.name());
            let dir = r.cache.path(kind, &k.key);
            let o = match outcome {
                Ok(o) => o,
                Err(Error::Interrupted { signal, what }) => {
                    stopped.get_or_insert((signal, format!("stage '{}' ({kind}): {what}", s.name)));
                    continue;
                }
                Err(e) => {
                    failure.get_or_insert((
                        s.name.clone(),
                        format!("stage '{}' ({kind}) failed: {e}", s.name),
                    ));
                    continue;
                }
            };
            finished += 1;
            on_event(&StageEvent {
                index: i + 1,
                total,
                stage: s,
                status: if o.cached {
                    Status::Cached
                } else {
                    Status::Computed
                },
                elapsed_s,
                dir: &dir,
                note: None,
            });
            let record = o.record;
            if !record.metrics.as_object().is_none_or(|o| o.is_empty()) {
                m.metrics.insert(s.name.clone(), record.metrics.clone());
            }
            runs[i] = Some(StageRun {
                name: s.name.clone(),
                kind: kind.into(),
                key: k.key.clone(),
                dir: dir
                    .strip_prefix(r.runs_dir)
                    .unwrap_or(&dir)
                    .display()
                    .to_string(),
                cached: o.cached,
                verified: if o.cached { how.name() } else { "computed" }.into(),
                recomputed_because: o.because,
                elapsed_s,
                compute_s: record.elapsed_s,
                outputs: record.outputs.clone(),
                slurm: None,
            });
            done.insert(s.name.clone(), Done { record, dir });
            // In run order, whatever order the stages finish in.
            m.stages = runs.iter().flatten().cloned().collect();
            m.elapsed_s = r.t0.elapsed().as_secs_f64();
            write_manifest(r.run_dir, m)?;
        }
        Ok(())
    })?;
    if let Some((stage, msg)) = failure {
        m.status = "failed".into();
        m.failed_stage = Some(stage);
        m.error = Some(msg.clone());
        m.elapsed_s = r.t0.elapsed().as_secs_f64();
        write_manifest(r.run_dir, m)?;
        return Err(Error::Other(msg));
    }
    let signal = stopped
        .as_ref()
        .map(|(s, _)| *s)
        .or_else(crate::interrupt::requested);
    if let Some(signal) = signal
        && finished < total
    {
        let what = match stopped {
            Some((_, what)) => format!("{what}; {}", interrupted_note(finished, total)),
            None => interrupted_note(finished, total),
        };
        return Err(stop_interrupted(m, r.run_dir, r.t0, signal, what));
    }
    m.report = place_reports(p, &done, r.run_dir)?;
    m.status = "ok".into();
    m.elapsed_s = r.t0.elapsed().as_secs_f64();
    write_manifest(r.run_dir, m)?;
    Ok(())
}
