//! `sweep … --executor slurm`: the grid points still to run as one job array (each task
//! one sheared-disk run into its directory under the sweep's output, resuming its
//! checkpoint after a requeue), then the summary table written by the head from the
//! runs' summaries, by the same code as a local sweep. State in `OUT/.slurm/`.

use super::SlurmOptions;
use super::batch::{self, JobRef, StageJob, State};
use super::spec::Spec;
use crate::error::{Error, Result};
use crate::pipeline::runs;
use crate::stages::shear::ShearOptions;
use crate::stages::sweep::{SweepOptions, SweepReport, grid, run_dir, run_point as run_local};

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

const POLL: Duration = Duration::from_millis(500);
const GRACE: Duration = Duration::from_secs(3);

pub use super::spec::{SweepSpec, state_dir};

/// A grid point's directory name (its runs's directory under the sweep's output).
pub fn point_name(&(phi, q, rate): &(f64, f64, f64)) -> String {
    run_dir(Path::new(""), phi, q, rate).display().to_string()
}

/// Array task `i`: run grid point `i` of the spec.
pub fn run_point(spec: &SweepSpec, i: usize) -> Result<()> {
    let p = spec.points[i];
    println!(
        "pillar-pipe {}: sweep point {} as Slurm job {} on {}",
        crate::stages::VERSION,
        point_name(&p),
        batch::this_job().map_or_else(|| "?".into(), |j| j.to_string()),
        crate::pipeline::lock::hostname()
    );
    run_local(&spec.out, &spec.base, p).map(|_| ())
}

/// A point still to finish: (point, job, attempt, gone from squeue since, seen running).
type Pending = ((f64, f64, f64), JobRef, u32, Option<Instant>, bool);

/// The sweep's jobs: how many points were submitted, and the summary table.
pub struct SlurmSweep {
    pub submitted: usize,
    pub attached: usize,
    pub report: SweepReport,
}

/// Submit the unfinished grid points, wait for them, write the table. `say` hears one
/// line per event (submitted, running, done, failed).
pub fn run_sweep(
    out: &Path,
    opt: &SweepOptions,
    slurm: &SlurmOptions,
    say: &mut dyn FnMut(&str),
) -> Result<SlurmSweep> {
    if opt.phi.is_empty() || opt.q.is_empty() || opt.rate.is_empty() {
        return Err(Error::param(
            "sweep",
            "give at least one value each of --phi, --q and --rate",
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let out = std::path::absolute(out).map_err(|e| Error::io(out, e))?;
    let state = State::new(state_dir(&out))?;
    let points = grid(opt);
    let unfinished: Vec<(f64, f64, f64)> = points
        .iter()
        .copied()
        .filter(|&(phi, q, rate)| !run_dir(&out, phi, q, rate).join("manifest.json").exists())
        .collect();
    // Two sweep commands starting at once on one output must not both submit a point.
    let submit_lock =
        crate::pipeline::lock::StageLock::take(&state.dir.join(".submit-lock"), &mut |_| {})?;
    let queue = if unfinished.is_empty() {
        BTreeMap::new()
    } else {
        batch::squeue()?
    };
    let mut pending: Vec<Pending> = Vec::new();
    let mut fresh = Vec::new();
    for p in &unfinished {
        match state
            .stage_job(&point_name(p))
            .filter(|j| queue.get(&j.job.to_string()).is_some_and(|q| q.alive()))
        {
            Some(j) => {
                say(&format!(
                    "{}  queued   job {} (attached)",
                    point_name(p),
                    j.job
                ));
                pending.push((*p, j.job, j.attempt, None, false));
            }
            None => fresh.push(*p),
        }
    }
    let (attached, submitted) = (pending.len(), fresh.len());
    let base = ShearOptions {
        quiet: true,
        ..opt.base.clone()
    };
    let submit = |points: Vec<(f64, f64, f64)>,
                  attempt: u32,
                  pending: &mut Vec<_>,
                  say: &mut dyn FnMut(&str)|
     -> Result<()> {
        if points.is_empty() {
            return Ok(());
        }
        let id = format!("sweep-{}", runs::now_stamp());
        let spec = Spec::Sweep(SweepSpec {
            out: out.clone(),
            base: base.clone(),
            points: points.clone(),
        });
        let spec_path = state.dir.join("jobs").join(format!("{id}.json"));
        crate::io::atomic_write_str(
            &spec_path,
            &serde_json::to_string_pretty(&spec).unwrap_or_default(),
        )?;
        let script = batch::write_script(
            &state,
            &id,
            &format!("sweep of {} points", points.len()),
            &["slurm-job".into(), spec_path.display().to_string()],
        )?;
        let array = batch::sbatch(slurm, &state, &script, points.len(), &[], "pp-sweep")?;
        for (t, p) in points.iter().enumerate() {
            let job = JobRef {
                array: array.clone(),
                task: t as u32,
            };
            state.set_stage_job(
                &point_name(p),
                &StageJob {
                    job: job.clone(),
                    stage: point_name(p),
                    submitted: runs::now_iso(),
                    run_id: id.clone(),
                    attempt,
                },
            )?;
            say(&format!("{}  queued   job {job}", point_name(p)));
            pending.push((*p, job, attempt, None, false));
        }
        Ok(())
    };
    submit(fresh, 1, &mut pending, say)?;
    drop(submit_lock);
    let retry = slurm.retry.unwrap_or(0);
    while !pending.is_empty() {
        if let Some(signal) = crate::interrupt::requested() {
            return Err(Error::Interrupted {
                signal,
                what: format!(
                    "stopped watching {} Slurm job(s); they go on on the cluster, and the \
                     same sweep command attaches to them again",
                    pending.len()
                ),
            });
        }
        let queue = batch::squeue()?;
        let mut again = Vec::new();
        let mut still = Vec::new();
        for (p, job, attempt, mut gone, mut running) in pending.drain(..) {
            let (phi, q, rate) = p;
            let name = point_name(&p);
            if run_dir(&out, phi, q, rate).join("manifest.json").exists() {
                let st = state.status(&job);
                say(&format!(
                    "{name}  done     job {job} on {} ({:.1} s)",
                    st.as_ref().map_or("?", |s| s.host.as_str()),
                    st.as_ref().and_then(|s| s.wall_s).unwrap_or(0.0)
                ));
                continue;
            }
            // The status is read only once Slurm no longer runs the job: a requeued job
            // runs again under the same id.
            let failure = match queue.get(&job.to_string()) {
                Some(qe) if qe.alive() => {
                    gone = None;
                    if qe.running() && !running {
                        running = true;
                        say(&format!("{name}  running  job {job} on {}", qe.node));
                    }
                    None
                }
                qe => {
                    if let Some(st) = state.status(&job) {
                        Some(format!(
                            "exit status {} on {}: {}",
                            st.exit_code,
                            st.host,
                            st.error.unwrap_or_default()
                        ))
                    } else {
                        let since = *gone.get_or_insert_with(Instant::now);
                        (since.elapsed() >= GRACE).then(|| {
                            format!(
                                "the job ended ({}) without writing its exit status: cancelled, \
                                 killed at its time limit or for memory, or its node failed",
                                qe.map_or("no longer listed by squeue".into(), |q| q.state.clone())
                            )
                        })
                    }
                }
            };
            match failure {
                Some(what) if attempt <= retry => {
                    say(&format!("{name}  retry    job {job} failed: {what}"));
                    again.push((p, attempt + 1));
                }
                Some(what) => {
                    let log = state.log(&job);
                    return Err(Error::Other(format!(
                        "sweep point {name} failed in Slurm job {job}: {what}\n  log: {}\n  last lines of the log:\n{}",
                        log.display(),
                        batch::log_tail(&log, 12)
                    )));
                }
                None => still.push((p, job, attempt, gone, running)),
            }
        }
        pending = still;
        for (p, attempt) in again {
            submit(vec![p], attempt, &mut pending, say)?;
        }
        if !pending.is_empty() {
            std::thread::sleep(POLL);
        }
    }
    // Every run has finished: the local code reads them back and writes the table.
    let report = crate::stages::sweep::run_sweep(&out, opt)?;
    Ok(SlurmSweep {
        submitted,
        attached,
        report,
    })
}
