//! What the head writes for a job array and its tasks read back (`jobs/<id>.json`): a
//! pipeline's stages or a sweep's grid points. Plain data, below both the job runner and
//! the sweep submitter.

use crate::stages::shear::ShearOptions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One pipeline stage to compute.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StageTask {
    pub stage: String,
    /// The key the head computed; the job refuses to run under another.
    pub key: String,
    pub force: bool,
}

/// A job array's tasks, written by the head to `jobs/<id>.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "what", rename_all = "snake_case")]
pub enum Spec {
    Pipeline {
        pipeline: PathBuf,
        sets: Vec<String>,
        runs_dir: PathBuf,
        run_id: String,
        verify: bool,
        /// The head's `--quiet`: some stages record it, so jobs take it over.
        quiet: bool,
        tasks: Vec<StageTask>,
    },
    Sweep(SweepSpec),
}

impl Spec {
    pub fn state_dir(&self) -> PathBuf {
        match self {
            Spec::Pipeline { runs_dir, .. } => runs_dir.join("slurm"),
            Spec::Sweep(s) => state_dir(&s.out),
        }
    }
}

/// What an array task needs: where, the options every run shares, the grid points.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SweepSpec {
    pub out: PathBuf,
    pub base: ShearOptions,
    pub points: Vec<(f64, f64, f64)>,
}

pub fn state_dir(out: &Path) -> PathBuf {
    out.join(".slurm")
}
