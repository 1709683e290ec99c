//! `pillar-pipe locate FRAMES…`: camera frames → a features table in trackpy's columns
//! (`y, x, mass, size, ecc, signal, raw_mass, ep, frame`), with a `.meta.json` sidecar
//! recording the tool, version, parameters and every frame's SHA-256.

use crate::camera::{Feature, LocateParams, LocateReport, list_frames, locate_frames};
use crate::error::{Error, Result};
use crate::io::features::write_features;
use crate::io::write_with_sidecar;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What `locate` did.
#[derive(Debug, Clone, Serialize)]
pub struct LocateRun {
    pub output: String,
    /// The frame files, in frame order (frame k is `frame_files[k]`). Not `frames`:
    /// the report's `frames` (the count) is flattened beside it, and a second key of
    /// that name would replace this list in the sidecar.
    pub frame_files: Vec<String>,
    pub params: LocateParams,
    #[serde(flatten)]
    pub report: LocateReport,
}

/// The default output: `features.csv` beside the frames (in the folder given, or the
/// first file's folder).
pub fn default_output(inputs: &[PathBuf]) -> PathBuf {
    let first = inputs.first().cloned().unwrap_or_default();
    let dir = if first.is_dir() {
        first
    } else {
        first
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."))
    };
    dir.join("features.csv")
}

/// Locates the grains in every frame and returns them with the run's record.
pub fn locate_movie(
    inputs: &[PathBuf],
    params: &LocateParams,
    quiet: bool,
) -> Result<(Vec<Feature>, LocateRun)> {
    let set = list_frames(inputs)?;
    let bar = super::progress(set.paths.len() as u64, "locate", quiet);
    let (features, report) = locate_frames(&set.paths, params, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let run = LocateRun {
        output: String::new(),
        frame_files: set.paths.iter().map(|p| p.display().to_string()).collect(),
        params: params.clone(),
        report,
    };
    Ok((features, run))
}

/// Features are written as CSV in trackpy's columns: any other name (`.parquet`, which
/// `link` would read as Parquet) is refused before any work is done.
pub fn check_output(output: &Path) -> Result<()> {
    if crate::io::table::TableFormat::of(output) != crate::io::table::TableFormat::Csv {
        return Err(Error::param(
            "output",
            format!(
                "{}: features are written as CSV (trackpy's columns); name it .csv",
                output.display()
            ),
        ));
    }
    Ok(())
}

/// `pillar-pipe locate`: locate and write `output` with its sidecar.
pub fn run(
    inputs: &[PathBuf],
    output: &Path,
    params: &LocateParams,
    quiet: bool,
) -> Result<LocateRun> {
    check_output(output)?;
    let (features, mut run) = locate_movie(inputs, params, quiet)?;
    run.output = output.display().to_string();
    let sidecar = serde_json::json!({
        "tool": super::TOOL,
        "tool_version": super::VERSION,
        "command": "locate",
        "locate": &run,
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || write_features(output, &features, None))?;
    Ok(run)
}
