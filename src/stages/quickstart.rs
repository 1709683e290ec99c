//! The main job on the bundled sample: ingest → kinematics → fit, into one directory,
//! with a manifest of what ran. Needs nothing outside the repository.

use crate::error::Result;
use crate::kinematics::Convention;
use crate::stages::fit::{FitOptions, FitReport};
use crate::stages::ingest::{IngestOptions, IngestReport};
use crate::stages::kinematics::{KinematicsOptions, KinematicsReport, LagSpec};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The bundled experiment sample (trackpy output) and its ingest settings, looked up
/// from the working directory first (the README runs from the repository root), then
/// beside the executable's ancestors, then where the crate was compiled — a binary built
/// in another checkout must not read that checkout's files when this one has them.
pub fn bundled_sample() -> PathBuf {
    const REL: &str = "data/sample/tracks.csv";
    let mut candidates = vec![PathBuf::from(REL)];
    if let Ok(exe) = std::env::current_exe() {
        candidates.extend(exe.ancestors().skip(1).map(|a| a.join(REL)));
    }
    candidates.push(Path::new(env!("CARGO_MANIFEST_DIR")).join(REL));
    candidates
        .iter()
        .find(|p| p.is_file())
        .cloned()
        .unwrap_or_else(|| PathBuf::from(REL))
}

#[derive(Debug, Serialize)]
pub struct QuickstartReport {
    pub out: String,
    pub ingest: IngestReport,
    pub kinematics: KinematicsReport,
    pub fit: FitReport,
    pub report: crate::stages::report::ReportOutput,
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
    let ingest = crate::stages::ingest::run(input, &tracks, &IngestOptions::default())?;
    let kin = out.join("kinematics.parquet");
    let kinematics = crate::stages::kinematics::run(
        &tracks,
        &kin,
        &KinematicsOptions {
            lag: LagSpec::Frames(vec![1]),
            rc: None,
            start: None,
            every: None,
            convention: Convention::Paper,
            columns: Default::default(),
            quiet,
        },
    )?;
    let fit = crate::stages::fit::run(
        &tracks,
        &out.join("fit.json"),
        &FitOptions {
            seed,
            bootstrap,
            quiet,
            ..Default::default()
        },
    )?;
    let report = crate::stages::report::run(
        out,
        &crate::stages::report::ReportOptions {
            title: "pillar-pipe quickstart: bundled experiment sample".into(),
            datasets: vec![crate::stages::report::DatasetInputs {
                label: "experiment".into(),
                tracks: Some(tracks.clone()),
                kinematics: Some(kin.clone()),
                fit: Some(out.join("fit.json")),
                stress: None,
                forces: None,
                ..Default::default()
            }],
            map_stages: 3,
            provenance: serde_json::json!({"input": input.display().to_string(), "seed": seed, "bootstrap": bootstrap}),
            sizes: None,
        },
    )?;
    let rep = QuickstartReport {
        out: out.display().to_string(),
        ingest,
        kinematics,
        fit,
        report,
        elapsed_s: t0.elapsed().as_secs_f64(),
    };
    crate::stages::manifest::write(
        out,
        "quickstart",
        &serde_json::json!({"input": input.display().to_string(), "seed": seed, "bootstrap": bootstrap}),
        serde_json::to_value(&rep).expect("json"),
    )?;
    Ok(rep)
}
