//! The Slurm executor: `run … --executor slurm` and `sweep … --executor slurm`.
//!
//! The head process (the command the user types) resolves the stage graph and the cache
//! keys exactly as a local run does, then submits every stage that is not cached with
//! `sbatch`: stages of one kind at the same depth of the graph as one job array,
//! downstream arrays with `--dependency=afterok:` on the array tasks they read. Each
//! task runs `pillar-pipe slurm-job SPEC` (`job`), which loads the same pipeline,
//! refuses to run if its build gives the stage another key, and computes the stage
//! into the shared cache through the same code as a local run (lock, temporary
//! directory, record, completion marker, rename). The job writes its exit status to a
//! file the head reads (`batch::ExitStatus`); nothing depends on Slurm's accounting
//! database. The head watches cache, status files and `squeue` (`head`).
//!
//! State lives beside the cache, in `RUNS_DIR/slurm/`: `jobs/` (batch scripts and task
//! specs), `logs/<array>_<task>.out`, `status/<array>_<task>.json`, and
//! `stages/<kind>-<hash>.json` (the job last submitted for a stage, so that a second
//! `run` attaches to it instead of submitting it again).

pub mod batch;
pub mod head;
pub mod job;
pub mod spec;
pub mod sweep;

use serde::{Deserialize, Serialize};

/// Slurm settings: from `--partition` etc. on the command line, or the pipeline file's
/// `[executor]` table (the command line wins, key by key).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct SlurmOptions {
    pub partition: Option<String>,
    pub account: Option<String>,
    /// `--time` (e.g. `02:00:00`, `1-00:00:00`).
    pub time: Option<String>,
    /// `--mem` (e.g. `4G`).
    pub mem: Option<String>,
    pub cpus_per_task: Option<u32>,
    /// Further `sbatch` arguments, passed as they are (`--qos=short`, `--constraint=x`).
    #[serde(default)]
    pub sbatch_args: Vec<String>,
    /// Submit a failed stage again up to this many times.
    pub retry: Option<u32>,
    /// Submit and return without waiting.
    #[serde(default)]
    pub detach: bool,
}

impl SlurmOptions {
    /// `self` (the command line) over `file` (the pipeline's `[executor]` table).
    pub fn over(&self, file: &SlurmOptions) -> SlurmOptions {
        SlurmOptions {
            partition: self.partition.clone().or_else(|| file.partition.clone()),
            account: self.account.clone().or_else(|| file.account.clone()),
            time: self.time.clone().or_else(|| file.time.clone()),
            mem: self.mem.clone().or_else(|| file.mem.clone()),
            cpus_per_task: self.cpus_per_task.or(file.cpus_per_task),
            sbatch_args: if self.sbatch_args.is_empty() {
                file.sbatch_args.clone()
            } else {
                self.sbatch_args.clone()
            },
            retry: self.retry.or(file.retry),
            detach: self.detach || file.detach,
        }
    }

    /// The `sbatch` options these settings stand for.
    pub fn sbatch_options(&self) -> Vec<String> {
        let mut v = Vec::new();
        let mut opt = |name: &str, val: &Option<String>| {
            if let Some(x) = val {
                v.push(format!("--{name}={x}"));
            }
        };
        opt("partition", &self.partition);
        opt("account", &self.account);
        opt("time", &self.time);
        opt("mem", &self.mem);
        opt("cpus-per-task", &self.cpus_per_task.map(|c| c.to_string()));
        v.extend(self.sbatch_args.iter().cloned());
        v
    }
}

/// The `[executor]` table of a pipeline file, validated.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExecutorSpec {
    /// `local` or `slurm`; `None` when the file does not say.
    pub name: Option<String>,
    pub slurm: SlurmOptions,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn command_line_overrides_file_key_by_key() {
        let file = SlurmOptions {
            partition: Some("debug".into()),
            time: Some("01:00:00".into()),
            sbatch_args: vec!["--qos=low".into()],
            retry: Some(2),
            ..Default::default()
        };
        let cli = SlurmOptions {
            time: Some("00:10:00".into()),
            cpus_per_task: Some(4),
            ..Default::default()
        };
        let o = cli.over(&file);
        assert_eq!(
            o.sbatch_options(),
            [
                "--partition=debug",
                "--time=00:10:00",
                "--cpus-per-task=4",
                "--qos=low"
            ]
        );
        assert_eq!(o.retry, Some(2));
    }
}
