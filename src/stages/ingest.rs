//! `ingest`: any supported trajectory format → the canonical tracks table.

use crate::error::{Error, Result};
use crate::io::lammps::{LammpsOptions, read_lammps};
use crate::io::trackpy::{SpeciesSplit, TrackpyOptions, read_trackpy};
use crate::io::{read_tracks, sha256_file, write_tracks};
use crate::tracks::{
    Provenance, TracksSummary, detached_trajectories, drop_trajectories, summarize,
};
use serde::Serialize;
use std::io::Read;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    Auto,
    Trackpy,
    Lammps,
    Canonical,
}

pub const SUPPORTED: &str =
    "trackpy (CSV from trackpy batch+link), lammps (text dump), canonical (tracks CSV or Parquet)";

#[derive(Debug, Clone, Default)]
pub struct IngestOptions {
    pub format: Option<Format>,
    pub px_per_unit: Option<f64>,
    pub unit: Option<String>,
    pub frame_time: Option<f64>,
    pub radii: Option<(f64, f64)>,
    pub origin_px: Option<(f64, f64)>,
    pub bar_speed: Option<f64>,
    /// Keep trackpy trajectories that are detached from the packing.
    pub keep_detached: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct IngestReport {
    pub input: String,
    pub output: String,
    pub format: Format,
    pub summary: TracksSummary,
    pub species_split: Option<SpeciesSplit>,
    pub warnings: Vec<String>,
}

/// Default output beside the input: `name.csv` → `name.tracks.parquet`.
pub fn default_output(input: &Path) -> PathBuf {
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "tracks".into());
    let stem = stem.strip_suffix(".tracks").unwrap_or(&stem).to_string();
    input.with_file_name(format!("{stem}.tracks.parquet"))
}

/// Decide the format from the extension and the first line.
pub fn detect(path: &Path) -> Result<Format> {
    let file = path.display().to_string();
    if crate::io::table::TableFormat::of(path) == crate::io::table::TableFormat::Parquet {
        return Ok(Format::Canonical);
    }
    let mut head = String::new();
    std::fs::File::open(path)
        .map_err(|e| Error::io(path, e))?
        .take(4096)
        .read_to_string(&mut head)
        .map_err(|e| Error::input(&file, format!("not a text file: {e}")))?;
    let first = head.lines().next().unwrap_or("").trim();
    if first.is_empty() {
        return Err(Error::input(&file, "empty file"));
    }
    if first.starts_with("ITEM:") {
        return Ok(Format::Lammps);
    }
    let cols: Vec<&str> = first
        .split(',')
        .map(|c| c.trim().trim_matches('"'))
        .collect();
    let has = |c: &str| cols.contains(&c);
    if has("frame") && has("particle") && has("x") && has("y") {
        if has("radius") {
            return Ok(Format::Canonical);
        }
        if has("size") || has("mass") || has("ep") {
            return Ok(Format::Trackpy);
        }
    }
    Err(Error::input(
        &file,
        format!(
            "unknown format (header '{first}'); supported: {SUPPORTED}; pass --format to choose"
        ),
    ))
}

/// Run the stage: read `input`, validate, write `output` (+ sidecar), summarise.
pub fn run(input: &Path, output: &Path, opt: &IngestOptions) -> Result<IngestReport> {
    if !input.exists() {
        return Err(Error::io(
            input,
            std::io::Error::new(std::io::ErrorKind::NotFound, "input file not found"),
        ));
    }
    if input == output {
        return Err(Error::param("output", "output would overwrite the input"));
    }
    let format = match opt.format.unwrap_or(Format::Auto) {
        Format::Auto => detect(input)?,
        f => f,
    };
    let mut warnings = Vec::new();
    let mut split = None;
    let mut tracks = match format {
        Format::Trackpy => {
            let keep_px = opt.px_per_unit.is_none() && opt.unit.as_deref() == Some("px");
            let o = TrackpyOptions {
                px_per_unit: if keep_px { Some(1.0) } else { opt.px_per_unit },
                unit: opt.unit.clone(),
                frame_time: opt.frame_time,
                radii: opt.radii,
                origin_px: opt.origin_px,
            };
            let (mut t, s) = read_trackpy(input, &o)?;
            split = Some(s);
            if !opt.keep_detached {
                let ids = detached_trajectories(&t);
                if !ids.is_empty() {
                    warnings.push(format!(
                        "dropped {} detached trajectories (fewer than 2 detections within 1.25 D in most of their frames; tracker artefacts such as bar corners): particles {:?}; --keep-detached keeps them",
                        ids.len(),
                        ids
                    ));
                    drop_trajectories(&mut t, &ids);
                }
            }
            t
        }
        Format::Lammps => read_lammps(
            input,
            &LammpsOptions {
                unit: opt.unit.clone(),
                frame_time: opt.frame_time,
                radii: opt.radii,
            },
        )?,
        Format::Canonical => {
            let (mut t, w) = read_tracks(input)?;
            warnings.extend(w);
            if let Some(u) = &opt.unit {
                t.meta.length_unit = u.clone();
            }
            if let Some(dt) = opt.frame_time {
                t.meta.frame_time = Some(dt);
                t.meta.time_unit = "s".into();
            }
            t
        }
        Format::Auto => unreachable!("resolved above"),
    };
    if tracks.meta.frame_time.is_none() {
        warnings.push("no frame time given (--fps or --frame-time): times are in frames".into());
    }
    if let Some(v) = opt.bar_speed {
        tracks.meta.bar_speed = Some(v);
    }
    let summary = summarize(&tracks);
    tracks.meta.provenance = Provenance {
        tool: super::TOOL.into(),
        tool_version: super::VERSION.into(),
        source: input.display().to_string(),
        source_format: format!("{format:?}").to_lowercase(),
        source_sha256: sha256_file(input)?,
        parameters: serde_json::json!({
            "px_per_unit": opt.px_per_unit, "unit": opt.unit, "frame_time": opt.frame_time,
            "radii": opt.radii, "origin_px": opt.origin_px, "bar_speed": opt.bar_speed,
            "keep_detached": opt.keep_detached,
        }),
    };
    tracks.meta.summary = serde_json::to_value(&summary).expect("summary serialises");
    write_tracks(&tracks, output)?;
    Ok(IngestReport {
        input: input.display().to_string(),
        output: output.display().to_string(),
        format,
        summary,
        species_split: split,
        warnings,
    })
}
