//! What a pipeline run is asked to do and what it reports as it goes: the options of
//! `pillar-pipe run`, each stage's key material, and the events the command line prints.
//! Plain types, so that the executors (local, Slurm) and the run record share them
//! without importing each other.

use super::Stage;
use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    /// `local` or `slurm`; `None`: the pipeline file's `[executor]`, else local.
    pub executor: Option<String>,
    /// Slurm settings given on the command line (they override the file's).
    pub slurm: super::slurm::SlurmOptions,
    /// Stages run at once by the local executor; `None`: the machine's cores.
    pub jobs: Option<usize>,
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
    /// Submitted to Slurm (or found submitted by an earlier run); `note` names the job.
    Queued,
    /// A Slurm job's attempt failed and the stage was submitted again; `note` says why.
    Retrying,
}

/// One line of progress for the caller to print.
pub struct StageEvent<'a> {
    pub index: usize,
    pub total: usize,
    pub stage: &'a Stage,
    pub status: Status,
    pub elapsed_s: f64,
    pub dir: &'a Path,
    /// Details for `Waiting`, `BrokeLock`, `Damaged`, `Unverifiable`, `Queued`,
    /// `Retrying`; the job (and node) for `Running` and `Computed` under Slurm.
    pub note: Option<String>,
}

/// Keys of every stage, in run order, with the parameters and file hashes they cover.
pub struct Keyed {
    pub key: String,
    pub params: Json,
    pub upstream: BTreeMap<String, String>,
    pub files: BTreeMap<String, String>,
}
