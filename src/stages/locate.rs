//! `pillar-pipe locate FRAMES…`: camera frames → a features table in trackpy's columns
//! (`y, x, mass, size, ecc, signal, raw_mass, ep, frame`), with a `.meta.json` sidecar
//! recording the tool, version, parameters and every frame's SHA-256.

use crate::camera::{Feature, LocateParams, LocateReport, list_frames, locate_frames};
use crate::error::{Error, Result};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// trackpy's column order; `particle` last when the features are linked.
pub const FEATURE_COLUMNS: [&str; 9] = [
    "y", "x", "mass", "size", "ecc", "signal", "raw_mass", "ep", "frame",
];

/// What `locate` did.
#[derive(Debug, Clone, Serialize)]
pub struct LocateRun {
    pub output: String,
    pub frames: Vec<String>,
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
        frames: set.paths.iter().map(|p| p.display().to_string()).collect(),
        params: params.clone(),
        report,
    };
    Ok((features, run))
}

/// `pillar-pipe locate`: locate and write `output` with its sidecar.
pub fn run(
    inputs: &[PathBuf],
    output: &Path,
    params: &LocateParams,
    quiet: bool,
) -> Result<LocateRun> {
    let (features, mut run) = locate_movie(inputs, params, quiet)?;
    run.output = output.display().to_string();
    let sidecar = serde_json::json!({
        "tool": super::TOOL,
        "tool_version": super::VERSION,
        "command": "locate",
        "locate": &run,
    });
    write_features(output, &features, None, &sidecar)?;
    Ok(run)
}

fn num(v: f64) -> String {
    if v.is_finite() {
        // Shortest text that reads back to the same f64.
        format!("{v}")
    } else {
        // pandas reads an empty field as NaN.
        String::new()
    }
}

/// Writes features as CSV in trackpy's column order (with `particle` when given), and
/// the sidecar, atomically.
pub fn write_features(
    path: &Path,
    features: &[Feature],
    particle: Option<&[i64]>,
    sidecar: &serde_json::Value,
) -> Result<()> {
    if let Some(p) = particle
        && p.len() != features.len()
    {
        return Err(Error::Other(format!(
            "{} particle ids for {} features",
            p.len(),
            features.len()
        )));
    }
    let side = serde_json::to_string_pretty(sidecar).expect("json");
    crate::io::write_with_sidecar(path, &side, || {
        crate::io::atomic_write(path, |f| {
            let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
            let io = |e| Error::io(path, e);
            let mut head = FEATURE_COLUMNS.join(",");
            if particle.is_some() {
                head.push_str(",particle");
            }
            writeln!(w, "{head}").map_err(io)?;
            for (i, g) in features.iter().enumerate() {
                write!(
                    w,
                    "{},{},{},{},{},{},{},{},{}",
                    num(g.y),
                    num(g.x),
                    num(g.mass),
                    num(g.size),
                    num(g.ecc),
                    num(g.signal),
                    num(g.raw_mass),
                    num(g.ep),
                    g.frame
                )
                .map_err(io)?;
                if let Some(p) = particle {
                    write!(w, ",{}", p[i]).map_err(io)?;
                }
                writeln!(w).map_err(io)?;
            }
            w.flush().map_err(io)
        })
    })
}
