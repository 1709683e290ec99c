//! `pillar-pipe slurm-job SPEC`: what one array task runs. It picks its task from
//! `SLURM_ARRAY_TASK_ID`, does it, and writes its exit status file last.

use super::batch::{ExitStatus, JobRef, State, this_job};
use crate::error::{Error, Result};
use crate::io::atomic_write_str;
use crate::pipeline::cache::{Cache, Check};
use crate::pipeline::compute::{Job, claim_and_compute, keys};
use crate::pipeline::exec::Done;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

pub use super::spec::{Spec, StageTask};

/// Run task `SLURM_ARRAY_TASK_ID` of the spec in `spec_file`; returns the exit code.
/// The status file is written in every case this process survives, panics included.
pub fn main(spec_file: &Path) -> i32 {
    let t0 = Instant::now();
    let started = crate::pipeline::runs::now_iso();
    let job = this_job().unwrap_or(JobRef {
        array: "local".into(),
        task: 0,
    });
    let spec: Result<Spec> = std::fs::read_to_string(spec_file)
        .map_err(|e| Error::io(spec_file, e))
        .and_then(|t| {
            serde_json::from_str(&t).map_err(|e| Error::input(spec_file.display(), e.to_string()))
        });
    let spec = match spec {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return 1;
        }
    };
    let state = State {
        dir: spec.state_dir(),
    };
    // Left by this job's previous run if Slurm requeued it: this run's outcome counts.
    let _ = std::fs::remove_file(state.status_path(&job));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_task(&spec, &job)));
    let (code, stage, error) = match result {
        Ok((stage, Ok(()))) => (0, stage, None),
        Ok((stage, Err(e))) => {
            let code = match &e {
                Error::Interrupted { signal, .. } => crate::interrupt::exit_code(*signal),
                _ => 1,
            };
            (code, stage, Some(e.to_string()))
        }
        Err(_) => (
            101,
            None,
            Some("the stage process panicked (see the log)".into()),
        ),
    };
    if let Some(e) = &error {
        eprintln!("error: {e}");
    }
    let status = ExitStatus {
        exit_code: code,
        host: crate::pipeline::lock::hostname().to_string(),
        stage,
        started: Some(started),
        finished: Some(crate::pipeline::runs::now_iso()),
        wall_s: Some(t0.elapsed().as_secs_f64()),
        error,
    };
    let path = state.status_path(&job);
    if let Err(e) = atomic_write_str(
        &path,
        &serde_json::to_string_pretty(&status).unwrap_or_default(),
    ) {
        eprintln!("error: cannot write the exit status: {e}");
    }
    code
}

fn task_index(job: &JobRef, n: usize) -> Result<usize> {
    let i = job.task as usize;
    if i >= n {
        return Err(Error::Other(format!(
            "array task {i}, but the spec has {n} tasks"
        )));
    }
    Ok(i)
}

/// (the stage's name, the outcome).
fn run_task(spec: &Spec, job: &JobRef) -> (Option<String>, Result<()>) {
    match spec {
        Spec::Pipeline {
            pipeline,
            sets,
            runs_dir,
            run_id,
            verify,
            quiet,
            tasks,
        } => {
            let t = match task_index(job, tasks.len()) {
                Ok(i) => &tasks[i],
                Err(e) => return (None, Err(e)),
            };
            let r = stage_task(pipeline, sets, runs_dir, run_id, (*verify, *quiet), t, job);
            (Some(t.stage.clone()), r)
        }
        Spec::Sweep(s) => match task_index(job, s.points.len()) {
            Ok(i) => (
                Some(super::sweep::point_name(&s.points[i])),
                super::sweep::run_point(s, i),
            ),
            Err(e) => (None, Err(e)),
        },
    }
}

fn stage_task(
    pipeline: &Path,
    sets: &[String],
    runs_dir: &Path,
    run_id: &str,
    (verify, quiet): (bool, bool),
    t: &StageTask,
    job: &JobRef,
) -> Result<()> {
    let p = crate::pipeline::load(pipeline, sets)?;
    let keyed = keys(&p)?;
    let s = p
        .stage(&t.stage)
        .ok_or_else(|| Error::Other(format!("the pipeline has no stage '{}' now", t.stage)))?;
    let k = &keyed[&s.name];
    if k.key != t.key {
        return Err(Error::Other(format!(
            "refusing to compute stage '{}': this job's build and inputs give it the key {}, \
             the head submitted it under {} (the job runs another build of pillar-pipe than \
             the head, or the pipeline file or an input changed since it was submitted)",
            s.name, k.key, t.key
        )));
    }
    let cache = Cache {
        dir: runs_dir.join("cache"),
    };
    // Every finished stage this one may read; the head submitted it after them.
    let mut done = BTreeMap::new();
    for u in &p.stages {
        let ku = &keyed[&u.name];
        if let Some(r) = cache.lookup(u.kind.name(), &ku.key) {
            let dir = cache.path(u.kind.name(), &ku.key);
            done.insert(u.name.clone(), Done { record: r, dir });
        }
    }
    for u in s.upstream.values() {
        if !done.contains_key(u) {
            return Err(Error::Other(format!(
                "stage '{}' reads stage '{u}', which is not in the cache",
                s.name
            )));
        }
    }
    let host = crate::pipeline::lock::hostname();
    println!(
        "pillar-pipe {}: stage '{}' ({}) key {} as Slurm job {job} on {host}",
        crate::stages::VERSION,
        s.name,
        s.kind.name(),
        &k.key[..16]
    );
    // A simulation stopped earlier (time limit, scancel, requeue) left its checkpoint here.
    let work = runs_dir.join("cache").join(format!(
        ".work-{}",
        crate::pipeline::cache::dir_name(s.kind.name(), &k.key)
    ));
    if work.join("checkpoint.bin").is_file() {
        println!(
            "a checkpoint of this stage exists ({}): the simulation continues from it",
            work.display()
        );
    }
    let how = if verify { Check::Sha256 } else { Check::Sizes };
    let o = claim_and_compute(
        &p,
        s,
        k,
        &cache,
        &done,
        t.force,
        how,
        &Job {
            quiet,
            run_id,
            slurm_job: Some(format!("{job} on {host}")),
        },
        &mut |status, note| match note {
            Some(n) => println!("{status:?}: {n}"),
            None => println!("{status:?}"),
        },
    )?;
    println!(
        "{} stage '{}' -> {}",
        if o.cached { "cached" } else { "computed" },
        s.name,
        cache.path(s.kind.name(), &k.key).display()
    );
    Ok(())
}
