//! The head of `run --executor slurm`: serve what is cached, attach to jobs an earlier
//! run submitted, submit the rest as job arrays, then watch them (cache entries, exit
//! status files, `squeue`) until every stage is in the cache or one has failed.

use super::SlurmOptions;
use super::batch::{self, JobRef, StageJob, State};
use super::job::{Spec, StageTask};
use crate::error::{Error, Result};
use crate::pipeline::cache::{Cache, Check, Verdict, check_dir, dir_name};
use crate::pipeline::exec::Done;
use crate::pipeline::lock::StageLock;
use crate::pipeline::options::{Keyed, RunOptions, StageEvent, Status};
use crate::pipeline::record::{place_reports, write_manifest};
use crate::pipeline::runs::{self, RunManifest, SlurmStage, StageRun};
use crate::pipeline::{Kind, Pipeline, Stage};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::{Duration, Instant};

/// How often the head looks at the cache, the status files and `squeue`.
const POLL: Duration = Duration::from_millis(500);
/// How long a job may be gone from `squeue` before its missing status file means it
/// died: the status is written just before the job ends, and a shared file system may
/// show it to the head a moment later.
const GRACE: Duration = Duration::from_secs(3);
/// Log lines quoted in a failure.
const TAIL: usize = 12;

/// Everything the local runner resolved before it handed over.
pub struct HeadRun<'a> {
    pub p: &'a Pipeline,
    pub keyed: &'a BTreeMap<String, Keyed>,
    pub force: &'a BTreeSet<String>,
    pub cache: &'a Cache,
    pub runs_dir: &'a Path,
    pub run_dir: &'a Path,
    pub run_id: &'a str,
    pub opt: &'a RunOptions,
    pub slurm: SlurmOptions,
    pub t0: Instant,
}

struct Pending {
    job: JobRef,
    /// The run that submitted the job.
    run_id: String,
    attempt: u32,
    running: bool,
    node: String,
    gone_since: Option<Instant>,
}

impl HeadRun<'_> {
    fn dir_name(&self, s: &Stage) -> String {
        dir_name(s.kind.name(), &self.keyed[&s.name].key)
    }

    fn emit(
        &self,
        on_event: &mut dyn FnMut(&StageEvent),
        s: &Stage,
        status: Status,
        elapsed_s: f64,
        note: Option<String>,
    ) {
        let index = 1 + self
            .p
            .stages
            .iter()
            .position(|x| x.name == s.name)
            .unwrap_or(0);
        on_event(&StageEvent {
            index,
            total: self.p.stages.len(),
            stage: s,
            status,
            elapsed_s,
            dir: &self.cache.path(s.kind.name(), &self.keyed[&s.name].key),
            note,
        });
    }

    fn stage(&self, name: &str) -> Result<&Stage> {
        self.p
            .stage(name)
            .ok_or_else(|| Error::Other(format!("no stage '{name}'")))
    }

    fn stage_run(&self, s: &Stage, rec: Option<&Done>, slurm: Option<SlurmStage>) -> StageRun {
        let k = &self.keyed[&s.name];
        let dir = self.cache.path(s.kind.name(), &k.key);
        StageRun {
            name: s.name.clone(),
            kind: s.kind.name().into(),
            key: k.key.clone(),
            dir: dir
                .strip_prefix(self.runs_dir)
                .unwrap_or(&dir)
                .display()
                .to_string(),
            cached: slurm.is_none(),
            verified: match (&slurm, rec) {
                (None, _) => self.check().name().into(),
                (Some(_), Some(_)) => "computed".into(),
                (Some(_), None) => "submitted".into(),
            },
            recomputed_because: None,
            elapsed_s: 0.0,
            compute_s: rec.map_or(0.0, |d| d.record.elapsed_s),
            outputs: rec.map(|d| d.record.outputs.clone()).unwrap_or_default(),
            slurm,
        }
    }

    fn check(&self) -> Check {
        if self.opt.verify {
            Check::Sha256
        } else {
            Check::Sizes
        }
    }

    /// Submit `names` (stages not in the cache, none of them queued): grouped by
    /// (depth among them, kind) into job arrays, each after the tasks of the stages it
    /// reads that are still to finish.
    fn submit(
        &self,
        state: &State,
        names: &BTreeSet<String>,
        pending: &mut BTreeMap<String, Pending>,
        attempts: &BTreeMap<String, u32>,
        on_event: &mut dyn FnMut(&StageEvent),
    ) -> Result<()> {
        let mut depth: BTreeMap<&str, usize> = BTreeMap::new();
        let mut groups: BTreeMap<(usize, Kind), Vec<&Stage>> = BTreeMap::new();
        // Stages are in run order, upstream first.
        for s in self.p.stages.iter().filter(|s| names.contains(&s.name)) {
            let d = s
                .upstream
                .values()
                .filter_map(|u| depth.get(u.as_str()).map(|d| d + 1))
                .max()
                .unwrap_or(0);
            depth.insert(&s.name, d);
            groups.entry((d, s.kind)).or_default().push(s);
        }
        let pipeline = std::path::absolute(&self.p.file).map_err(|e| Error::io(&self.p.file, e))?;
        for ((_, kind), members) in groups {
            let after: BTreeSet<JobRef> = members
                .iter()
                .flat_map(|s| s.upstream.values())
                .filter_map(|u| pending.get(u).map(|p| p.job.clone()))
                .collect();
            let after: Vec<JobRef> = after.into_iter().collect();
            let id = format!("{}-{}-{}", self.run_id, kind.name(), runs::now_stamp());
            let spec = Spec::Pipeline {
                pipeline: pipeline.clone(),
                sets: self.opt.sets.clone(),
                runs_dir: self.runs_dir.to_path_buf(),
                run_id: self.run_id.to_string(),
                verify: self.opt.verify,
                quiet: self.opt.quiet,
                tasks: members
                    .iter()
                    .map(|s| StageTask {
                        stage: s.name.clone(),
                        key: self.keyed[&s.name].key.clone(),
                        force: self.force.contains(&s.name),
                    })
                    .collect(),
            };
            let spec_path = state.dir.join("jobs").join(format!("{id}.json"));
            crate::io::atomic_write_str(
                &spec_path,
                &serde_json::to_string_pretty(&spec).unwrap_or_default(),
            )?;
            let names: Vec<&str> = members.iter().map(|s| s.name.as_str()).collect();
            let script = batch::write_script(
                state,
                &id,
                &names.join(", "),
                &["slurm-job".into(), spec_path.display().to_string()],
            )?;
            let array = batch::sbatch(
                &self.slurm,
                state,
                &script,
                members.len(),
                &after,
                &format!("pp-{}", kind.name()),
            )?;
            for (t, s) in members.iter().enumerate() {
                let job = JobRef {
                    array: array.clone(),
                    task: t as u32,
                };
                let attempt = attempts.get(&s.name).copied().unwrap_or(1);
                state.set_stage_job(
                    &self.dir_name(s),
                    &StageJob {
                        job: job.clone(),
                        stage: s.name.clone(),
                        submitted: runs::now_iso(),
                        run_id: self.run_id.to_string(),
                        attempt,
                    },
                )?;
                let waits = if after.is_empty() {
                    String::new()
                } else {
                    let a: Vec<String> = after.iter().map(JobRef::to_string).collect();
                    format!(" after {}", a.join(", "))
                };
                self.emit(
                    on_event,
                    s,
                    Status::Queued,
                    0.0,
                    Some(format!("job {job}{waits}")),
                );
                pending.insert(
                    s.name.clone(),
                    Pending {
                        job,
                        run_id: self.run_id.to_string(),
                        attempt,
                        running: false,
                        node: String::new(),
                        gone_since: None,
                    },
                );
            }
        }
        Ok(())
    }

    fn failure(&self, s: &Stage, state: &State, job: &JobRef, what: &str) -> String {
        let log = state.log(job);
        format!(
            "stage '{}' ({}) failed in Slurm job {job}: {what}\n  log: {}\n  last lines of the log:\n{}",
            s.name,
            s.kind.name(),
            log.display(),
            batch::log_tail(&log, TAIL)
        )
    }

    fn ordered(&self, by_name: &BTreeMap<String, StageRun>) -> Vec<StageRun> {
        self.p
            .stages
            .iter()
            .filter_map(|s| by_name.get(&s.name).cloned())
            .collect()
    }
}

/// Run the pipeline's uncached stages as Slurm jobs; `m` is the run's manifest, already
/// written once as "incomplete".
pub fn run(h: &HeadRun, m: &mut RunManifest, on_event: &mut dyn FnMut(&StageEvent)) -> Result<()> {
    let state = State::new(h.runs_dir.join("slurm"))?;
    m.executor = Some("slurm".into());
    let mut done: BTreeMap<String, Done> = BTreeMap::new();
    let mut by_name: BTreeMap<String, StageRun> = BTreeMap::new();
    for s in &h.p.stages {
        let k = &h.keyed[&s.name];
        let dir = h.cache.path(s.kind.name(), &k.key);
        if !h.force.contains(&s.name)
            && let Verdict::Ok(r) = check_dir(&dir, Some(&k.key), h.check())
        {
            h.emit(on_event, s, Status::Cached, 0.0, None);
            let d = Done { record: *r, dir };
            by_name.insert(s.name.clone(), h.stage_run(s, Some(&d), None));
            if let Some(mt) = d.record.metrics.as_object().filter(|o| !o.is_empty()) {
                m.metrics
                    .insert(s.name.clone(), serde_json::Value::Object(mt.clone()));
            }
            done.insert(s.name.clone(), d);
        }
    }
    let mut pending: BTreeMap<String, Pending> = BTreeMap::new();
    {
        // Two heads starting at once must not both submit a stage.
        let _lock = StageLock::take(&state.dir.join(".submit-lock"), &mut |_| {})?;
        let queue = batch::squeue()?;
        let mut fresh = BTreeSet::new();
        let mut stale = Vec::new();
        for s in h.p.stages.iter().filter(|s| !done.contains_key(&s.name)) {
            let mut earlier = state
                .stage_job(&h.dir_name(s))
                .filter(|j| queue.get(&j.job.to_string()).is_some_and(|q| q.alive()));
            // A job queued after jobs that are not the ones its stages now wait for (an
            // upstream stage is submitted anew) would wait for the wrong ones: replace it.
            if let Some(j) = &earlier
                && s.upstream
                    .values()
                    .any(|u| !done.contains_key(u) && !pending.contains_key(u))
            {
                stale.push(j.job.clone());
                earlier = None;
            }
            match earlier {
                Some(j) => {
                    h.emit(
                        on_event,
                        s,
                        Status::Queued,
                        0.0,
                        Some(format!(
                            "job {} (submitted by run {}; attached)",
                            j.job, j.run_id
                        )),
                    );
                    pending.insert(
                        s.name.clone(),
                        Pending {
                            job: j.job,
                            run_id: j.run_id,
                            attempt: j.attempt,
                            running: false,
                            node: String::new(),
                            gone_since: None,
                        },
                    );
                }
                None => {
                    fresh.insert(s.name.clone());
                }
            }
        }
        batch::scancel(&stale)?;
        h.submit(&state, &fresh, &mut pending, &BTreeMap::new(), on_event)?;
    }
    let slurm_info = |h: &HeadRun, p: &Pending, st: &str, wall: Option<f64>| SlurmStage {
        job: p.job.to_string(),
        node: p.node.clone(),
        wall_s: wall,
        log: state
            .log(&p.job)
            .strip_prefix(h.runs_dir)
            .map_or_else(|_| state.log(&p.job), |r| r.to_path_buf())
            .display()
            .to_string(),
        state: st.into(),
        attempts: p.attempt,
    };
    if h.slurm.detach && !pending.is_empty() {
        for (name, p) in &pending {
            let s = h.stage(name)?;
            by_name.insert(
                name.clone(),
                h.stage_run(s, None, Some(slurm_info(h, p, "queued", None))),
            );
        }
        m.stages = h.ordered(&by_name);
        m.status = "submitted".into();
        m.elapsed_s = h.t0.elapsed().as_secs_f64();
        write_manifest(h.run_dir, m)?;
        return Ok(());
    }
    let retry = h.slurm.retry.unwrap_or(0);
    let mut squeue_ok = Instant::now();
    while !pending.is_empty() {
        if let Some(signal) = crate::interrupt::requested() {
            m.stages = h.ordered(&by_name);
            m.status = "interrupted".into();
            let what = format!(
                "stopped watching {} Slurm job(s); they go on on the cluster, and the same \
                 command attaches to them again",
                pending.len()
            );
            m.error = Some(what.clone());
            m.elapsed_s = h.t0.elapsed().as_secs_f64();
            write_manifest(h.run_dir, m)?;
            return Err(Error::Interrupted { signal, what });
        }
        // A busy controller may not answer every poll; give up after a minute of silence.
        let queue = match batch::squeue() {
            Ok(q) => {
                squeue_ok = Instant::now();
                q
            }
            Err(_) if squeue_ok.elapsed() < Duration::from_secs(60) => {
                std::thread::sleep(POLL);
                continue;
            }
            Err(e) => return Err(e),
        };
        let mut failed: Vec<(String, String)> = Vec::new();
        let names: Vec<String> = pending.keys().cloned().collect();
        for name in names {
            let s = h.stage(&name)?;
            let k = &h.keyed[&name];
            let dir = h.cache.path(s.kind.name(), &k.key);
            let upstream_pending = s.upstream.values().any(|u| pending.contains_key(u));
            let Some(p) = pending.get_mut(&name) else {
                continue;
            };
            let verdict = check_dir(&dir, Some(&k.key), Check::Sizes);
            // A forced stage's old entry stays in place until its job replaces it.
            let verdict = match verdict {
                Verdict::Ok(r) if h.force.contains(&name) && r.computed_in_run != p.run_id => {
                    Verdict::Missing
                }
                v => v,
            };
            if let Verdict::Ok(r) = verdict {
                let st = state.status(&p.job);
                let q = queue.get(&p.job.to_string());
                // The job writes its status (node, wall time) just after the entry.
                if st.is_none() && q.is_some_and(|q| q.alive()) {
                    continue;
                }
                if let Some(q) = q.filter(|q| !q.node.is_empty()) {
                    p.node = q.node.clone();
                }
                if let Some(host) = st
                    .as_ref()
                    .map(|x| x.host.clone())
                    .filter(|x| !x.is_empty())
                {
                    p.node = host;
                }
                let wall = st.as_ref().and_then(|x| x.wall_s);
                h.emit(
                    on_event,
                    s,
                    Status::Computed,
                    wall.unwrap_or(r.elapsed_s),
                    Some(format!("job {} on {}", p.job, p.node)),
                );
                let d = Done { record: *r, dir };
                let info = slurm_info(h, p, "done", wall);
                by_name.insert(name.clone(), h.stage_run(s, Some(&d), Some(info)));
                if let Some(mt) = d.record.metrics.as_object().filter(|o| !o.is_empty()) {
                    m.metrics
                        .insert(name.clone(), serde_json::Value::Object(mt.clone()));
                }
                done.insert(name.clone(), d);
                pending.remove(&name);
                m.stages = h.ordered(&by_name);
                m.elapsed_s = h.t0.elapsed().as_secs_f64();
                write_manifest(h.run_dir, m)?;
                continue;
            }
            match queue.get(&p.job.to_string()) {
                Some(q) if q.alive() => {
                    p.gone_since = None;
                    if q.running() && !p.running {
                        p.running = true;
                        p.node = q.node.clone();
                        h.emit(
                            on_event,
                            s,
                            Status::Running,
                            0.0,
                            Some(format!("job {} on {}", p.job, p.node)),
                        );
                    }
                }
                q => {
                    // Read only once Slurm no longer runs the job: a job requeued after
                    // its first run wrote a status runs again under the same id.
                    if let Some(st) = state.status(&p.job) {
                        if !st.host.is_empty() {
                            p.node = st.host.clone();
                        }
                        let what = match (st.exit_code, &st.error) {
                            (0, _) => {
                                "the job ended without error but left no complete cache entry"
                                    .into()
                            }
                            (c, Some(e)) => format!("exit status {c} on {}: {e}", st.host),
                            (c, None) => format!("exit status {c} on {}", st.host),
                        };
                        failed.push((name.clone(), h.failure(s, &state, &p.job, &what)));
                        continue;
                    }
                    let since = *p.gone_since.get_or_insert_with(Instant::now);
                    if since.elapsed() < GRACE {
                        continue;
                    }
                    // Cancelled by Slurm because a stage it reads failed: that stage's
                    // failure is the one to report (or to retry, resubmitting this one).
                    let dependency = q.is_some_and(|q| q.reason == "DependencyNeverSatisfied");
                    if dependency && upstream_pending {
                        continue;
                    }
                    let how = q.map_or_else(
                        || "no longer listed by squeue".to_string(),
                        |q| format!("{}, reason {}", q.state, q.reason),
                    );
                    let what = if dependency {
                        format!("Slurm cancelled the job ({how}): a job it waited for failed")
                    } else {
                        format!(
                            "the job ended ({how}) without writing its exit status: cancelled, \
                             killed at its time limit or for memory, or its node failed"
                        )
                    };
                    failed.push((name.clone(), h.failure(s, &state, &p.job, &what)));
                }
            }
        }
        if let Some((name, msg)) = failed.first() {
            let attempt = pending.get(name).map_or(1, |p| p.attempt);
            if attempt <= retry {
                // This stage and everything still to run downstream of it, anew.
                let mut again: BTreeSet<String> = BTreeSet::new();
                again.insert(name.clone());
                for s in &h.p.stages {
                    if pending.contains_key(&s.name)
                        && s.upstream.values().any(|u| again.contains(u))
                    {
                        again.insert(s.name.clone());
                    }
                }
                let cancel: Vec<JobRef> = again
                    .iter()
                    .filter_map(|n| pending.get(n).map(|p| p.job.clone()))
                    .collect();
                batch::scancel(&cancel)?;
                let mut attempts = BTreeMap::new();
                attempts.insert(name.clone(), attempt + 1);
                for n in &again {
                    if n != name {
                        attempts.insert(n.clone(), pending.get(n).map_or(1, |p| p.attempt));
                    }
                    pending.remove(n);
                }
                let s = h.stage(name)?;
                h.emit(
                    on_event,
                    s,
                    Status::Retrying,
                    0.0,
                    Some(format!(
                        "attempt {} of {}; {}",
                        attempt + 1,
                        retry + 1,
                        msg.lines().next().unwrap_or("")
                    )),
                );
                h.submit(&state, &again, &mut pending, &attempts, on_event)?;
                continue;
            }
            let s = h.stage(name)?;
            if let Some(p) = pending.get(name) {
                let st = state.status(&p.job);
                let info = slurm_info(h, p, "failed", st.and_then(|x| x.wall_s));
                by_name.insert(name.clone(), h.stage_run(s, None, Some(info)));
            }
            m.stages = h.ordered(&by_name);
            m.status = "failed".into();
            m.failed_stage = Some(name.clone());
            m.error = Some(msg.clone());
            m.elapsed_s = h.t0.elapsed().as_secs_f64();
            write_manifest(h.run_dir, m)?;
            return Err(Error::Other(msg.clone()));
        }
        std::thread::sleep(POLL);
    }
    m.stages = h.ordered(&by_name);
    m.report = place_reports(h.p, &done, h.run_dir)?;
    m.status = "ok".into();
    m.elapsed_s = h.t0.elapsed().as_secs_f64();
    write_manifest(h.run_dir, m)
}

/// A detached run's stages as they stand now (`runs show`): finished ones from the
/// cache, failed ones from their exit status, the others from `squeue` (when it can
/// be asked). The manifest on disk is left as it was.
pub fn refresh(m: &mut RunManifest, runs_dir: &Path) {
    let state = State {
        dir: runs_dir.join("slurm"),
    };
    let queue = batch::squeue().unwrap_or_default();
    let mut all_done = true;
    for st in &mut m.stages {
        let Some(sl) = st.slurm.as_mut() else {
            continue;
        };
        let Some((array, task)) = sl.job.split_once('_') else {
            continue;
        };
        let job = JobRef {
            array: array.into(),
            task: task.parse().unwrap_or(0),
        };
        if let Verdict::Ok(_) = check_dir(&runs_dir.join(&st.dir), Some(&st.key), Check::Sizes) {
            sl.state = "done".into();
            if let Some(x) = state.status(&job) {
                sl.node = x.host;
                sl.wall_s = x.wall_s;
            }
            continue;
        }
        all_done = false;
        if let Some(x) = state.status(&job) {
            sl.state = format!("failed (exit status {})", x.exit_code);
            sl.node = x.host;
        } else if let Some(q) = queue.get(&sl.job) {
            sl.state = q.state.to_lowercase();
            sl.node = q.node.clone();
        }
    }
    if m.status == "submitted" && all_done {
        m.status =
            "submitted; every stage has finished (run the pipeline again for the report)".into();
    }
}
