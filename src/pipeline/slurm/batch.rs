//! Talking to Slurm (`sbatch`, `squeue`, `scancel`) and the files a job and its head
//! exchange: batch scripts, exit status files, the job last submitted per stage.

use super::SlurmOptions;
use crate::error::{Error, Result};
use crate::io::atomic_write_str;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One task of a job array, `ARRAY_TASK` as Slurm writes it.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct JobRef {
    pub array: String,
    pub task: u32,
}

impl std::fmt::Display for JobRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}_{}", self.array, self.task)
    }
}

/// The executor's directories under `RUNS_DIR/slurm` (or a sweep's `OUT/.slurm`).
#[derive(Debug, Clone)]
pub struct State {
    pub dir: PathBuf,
}

impl State {
    pub fn new(dir: PathBuf) -> Result<State> {
        for sub in ["jobs", "logs", "status", "stages"] {
            let d = dir.join(sub);
            std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
        }
        Ok(State { dir })
    }
    pub fn log(&self, j: &JobRef) -> PathBuf {
        self.dir.join("logs").join(format!("{j}.out"))
    }
    pub fn status_path(&self, j: &JobRef) -> PathBuf {
        self.dir.join("status").join(format!("{j}.json"))
    }
    pub fn stage_path(&self, name: &str) -> PathBuf {
        self.dir.join("stages").join(format!("{name}.json"))
    }
    pub fn status(&self, j: &JobRef) -> Option<ExitStatus> {
        let text = std::fs::read_to_string(self.status_path(j)).ok()?;
        serde_json::from_str(&text).ok()
    }
    pub fn stage_job(&self, name: &str) -> Option<StageJob> {
        let text = std::fs::read_to_string(self.stage_path(name)).ok()?;
        serde_json::from_str(&text).ok()
    }
    pub fn set_stage_job(&self, name: &str, j: &StageJob) -> Result<()> {
        atomic_write_str(
            &self.stage_path(name),
            &serde_json::to_string_pretty(j).unwrap_or_default(),
        )
    }
}

/// What a job leaves in `status/<array>_<task>.json` when it ends: written by
/// `pillar-pipe slurm-job`, or, if that process died without writing it, by the batch
/// script with the exit status alone.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ExitStatus {
    pub exit_code: i32,
    #[serde(default)]
    pub host: String,
    #[serde(default)]
    pub stage: Option<String>,
    #[serde(default)]
    pub started: Option<String>,
    #[serde(default)]
    pub finished: Option<String>,
    #[serde(default)]
    pub wall_s: Option<f64>,
    #[serde(default)]
    pub error: Option<String>,
}

/// The job last submitted for a stage (`stages/<kind>-<hash>.json`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StageJob {
    pub job: JobRef,
    pub stage: String,
    pub submitted: String,
    pub run_id: String,
    pub attempt: u32,
}

/// One line of `squeue`.
#[derive(Debug, Clone)]
pub struct Queued {
    pub state: String,
    pub node: String,
    pub reason: String,
}

impl Queued {
    /// Still to run or running (not ended).
    pub fn alive(&self) -> bool {
        matches!(
            self.state.as_str(),
            "PENDING"
                | "CONFIGURING"
                | "RUNNING"
                | "COMPLETING"
                | "SUSPENDED"
                | "REQUEUED"
                | "REQUEUE_HOLD"
                | "REQUEUE_FED"
                | "RESIZING"
                | "SIGNALING"
                | "STAGE_OUT"
        )
    }
    pub fn running(&self) -> bool {
        matches!(
            self.state.as_str(),
            "RUNNING" | "COMPLETING" | "CONFIGURING"
        )
    }
}

fn command_output(cmd: &mut Command, what: &str) -> Result<String> {
    let out = cmd.output().map_err(|e| {
        Error::Other(format!(
            "cannot run {what} ({e}): is this a Slurm cluster's login node, with Slurm's commands on PATH?"
        ))
    })?;
    if !out.status.success() {
        return Err(Error::Other(format!(
            "{what} failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Every job array task Slurm still lists (pending, running, and recently ended ones
/// with their final state), by `ARRAY_TASK`.
pub fn squeue() -> Result<BTreeMap<String, Queued>> {
    let text = command_output(
        Command::new("squeue").args(["-h", "-r", "--states=all", "-o", "%F|%K|%T|%N|%r"]),
        "squeue",
    )?;
    Ok(parse_squeue(&text))
}

fn parse_squeue(text: &str) -> BTreeMap<String, Queued> {
    let mut out = BTreeMap::new();
    for line in text.lines() {
        let f: Vec<&str> = line.trim().split('|').collect();
        if f.len() < 5 || f[1] == "N/A" {
            continue;
        }
        out.insert(
            format!("{}_{}", f[0], f[1]),
            Queued {
                state: f[2].to_string(),
                node: f[3].to_string(),
                reason: f[4].to_string(),
            },
        );
    }
    out
}

/// Submit `script` as an array of `tasks` tasks after the tasks in `after` succeeded;
/// its output goes to `logs/<array>_<task>.out`. Returns the array's job id.
pub fn sbatch(
    opt: &SlurmOptions,
    state: &State,
    script: &Path,
    tasks: usize,
    after: &[JobRef],
    name: &str,
) -> Result<String> {
    let mut cmd = Command::new("sbatch");
    cmd.arg("--parsable")
        .arg(format!("--array=0-{}", tasks.saturating_sub(1)))
        .arg(format!("--job-name={name}"))
        .arg(format!(
            "--output={}",
            state.dir.join("logs").join("%A_%a.out").display()
        ))
        // A job whose upstream failed is cancelled (and seen as such), not left pending.
        .arg("--kill-on-invalid-dep=yes");
    if let Ok(cwd) = std::env::current_dir() {
        cmd.arg(format!("--chdir={}", cwd.display()));
    }
    if !after.is_empty() {
        let deps: Vec<String> = after.iter().map(JobRef::to_string).collect();
        cmd.arg(format!("--dependency=afterok:{}", deps.join(":")));
    }
    cmd.args(opt.sbatch_options()).arg(script);
    let out = command_output(&mut cmd, "sbatch")?;
    // `--parsable` prints `ID` or `ID;CLUSTER`.
    let id = out
        .trim()
        .split(';')
        .next()
        .unwrap_or("")
        .trim()
        .to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(Error::Other(format!(
            "sbatch printed no job id: '{}'",
            out.trim()
        )));
    }
    Ok(id)
}

pub fn scancel(jobs: &[JobRef]) -> Result<()> {
    if jobs.is_empty() {
        return Ok(());
    }
    let ids: Vec<String> = jobs.iter().map(JobRef::to_string).collect();
    command_output(Command::new("scancel").args(&ids), "scancel").map(|_| ())
}

fn sh_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// A batch script that runs `pillar-pipe ARGS…` with the head's own executable (on a
/// cluster it must lie on the shared file system) and, if that process ended without
/// writing its exit status (killed, crashed), writes one with the exit code alone.
pub fn write_script(state: &State, id: &str, title: &str, args: &[String]) -> Result<PathBuf> {
    let exe = std::env::current_exe().map_err(|e| Error::Other(format!("own executable: {e}")))?;
    let status_dir = state.dir.join("status");
    let cmd: Vec<String> = std::iter::once(exe.display().to_string())
        .chain(args.iter().cloned())
        .map(|a| sh_quote(&a))
        .collect();
    let text = format!(
        "#!/bin/sh\n# pillar-pipe: {title}\n{}\nrc=$?\n\
         st={}/\"${{SLURM_ARRAY_JOB_ID}}_${{SLURM_ARRAY_TASK_ID}}.json\"\n\
         if [ ! -f \"$st\" ]; then\n  \
         printf '{{\"exit_code\": %d, \"host\": \"%s\", \"error\": \"the stage process ended without writing its status (exit %d: killed or crashed)\"}}\\n' \
         \"$rc\" \"$(hostname)\" \"$rc\" > \"$st.tmp.$$\" && mv \"$st.tmp.$$\" \"$st\"\n\
         fi\nexit $rc\n",
        cmd.join(" "),
        sh_quote(&status_dir.display().to_string()),
    );
    let path = state.dir.join("jobs").join(format!("{id}.sh"));
    atomic_write_str(&path, &text)?;
    Ok(path)
}

/// The last `n` lines of a log file, indented, or why there are none.
pub fn log_tail(path: &Path, n: usize) -> String {
    match std::fs::read_to_string(path) {
        Ok(t) => {
            let lines: Vec<&str> = t.lines().collect();
            let from = lines.len().saturating_sub(n);
            if lines.is_empty() {
                "    (the log is empty)".into()
            } else {
                lines[from..]
                    .iter()
                    .map(|l| format!("    | {l}"))
                    .collect::<Vec<_>>()
                    .join("\n")
            }
        }
        Err(e) => format!("    (no log: {e})"),
    }
}

/// This job's `ARRAY_TASK` from Slurm's environment (`None` outside a job).
pub fn this_job() -> Option<JobRef> {
    let array = std::env::var("SLURM_ARRAY_JOB_ID")
        .or_else(|_| std::env::var("SLURM_JOB_ID"))
        .ok()?;
    let task = std::env::var("SLURM_ARRAY_TASK_ID")
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or(0);
    Some(JobRef { array, task })
}

#[cfg(test)]
mod tests {
    #[test]
    fn squeue_lines() {
        let q = super::parse_squeue(
            "12|0|RUNNING|vm|None\n12|1|PENDING||Resources\n13|N/A|PENDING||Dependency\n\
             14|0|CANCELLED||DependencyNeverSatisfied\n",
        );
        assert_eq!(q.len(), 3);
        assert!(q["12_0"].running() && q["12_0"].alive() && q["12_0"].node == "vm");
        assert!(q["12_1"].alive() && !q["12_1"].running());
        assert!(!q["14_0"].alive());
        assert_eq!(q["14_0"].reason, "DependencyNeverSatisfied");
    }
}
