//! The main job on the bundled sample: ingest → kinematics → fit, into one directory,
//! with a manifest of what ran. Needs nothing outside the repository.

use super::fit::{FitOptions, FitReport};
use super::ingest::{IngestOptions, IngestReport};
use super::kinematics::{KinematicsOptions, KinematicsReport, LagSpec};
use crate::error::Result;
use crate::io::atomic_write_str;
use crate::kinematics::Convention;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The bundled experiment sample (trackpy output) and its ingest settings.
pub fn bundled_sample() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/sample/tracks.csv")
}

#[derive(Debug, Serialize)]
pub struct QuickstartReport {
    pub out: String,
    pub ingest: IngestReport,
    pub kinematics: KinematicsReport,
    pub fit: FitReport,
    pub elapsed_s: f64,
}

pub fn run(
    input: &Path,
    out: &Path,
    seed: u64,
    bootstrap: usize,
    quiet: bool,
) -> Result<QuickstartReport> {
    let t0 = std::time::Instant::now();
    std::fs::create_dir_all(out).map_err(|e| crate::Error::io(out, e))?;
    let tracks = out.join("tracks.parquet");
    let ingest = super::ingest::run(input, &tracks, &IngestOptions::default())?;
    let kin = out.join("kinematics.parquet");
    let kinematics = super::kinematics::run(
        &tracks,
        &kin,
        &KinematicsOptions {
            lag: LagSpec::Frames(vec![1]),
            rc: None,
            start: None,
            every: None,
            convention: Convention::Paper,
            quiet,
        },
    )?;
    let fit = super::fit::run(
        &tracks,
        &out.join("fit.json"),
        &FitOptions {
            seed,
            bootstrap,
            quiet,
            ..Default::default()
        },
    )?;
    let rep = QuickstartReport {
        out: out.display().to_string(),
        ingest,
        kinematics,
        fit,
        elapsed_s: t0.elapsed().as_secs_f64(),
    };
    atomic_write_str(
        &out.join("manifest.json"),
        &serde_json::to_string_pretty(&rep).expect("json"),
    )?;
    Ok(rep)
}
