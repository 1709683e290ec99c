//! `ingest`: any supported trajectory format → the canonical tracks table.

use crate::error::{Error, Result};
use crate::io::lammps::{LammpsOptions, read_lammps};
use crate::io::trackpy::{SpeciesSplit, TrackpyOptions, read_trackpy};
use crate::io::tracks_io::write_tracks_owned;
use crate::io::{read_tracks, sha256_file};
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
    /// The `ingest.toml` beside the input whose settings were used, if any.
    pub settings_file: Option<String>,
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
    let mut head = Vec::new();
    std::fs::File::open(path)
        .map_err(|e| Error::io(path, e))?
        .take(4096)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    // Only the first line decides; bytes further on are the reader's to place.
    let first = head.split(|&b| b == b'\n').next().unwrap_or(&[]);
    let first = match std::str::from_utf8(first) {
        Ok(s) => s,
        // A character cut by the 4096-byte window is not an error.
        Err(e) if e.error_len().is_none() => {
            std::str::from_utf8(&first[..e.valid_up_to()]).unwrap_or_default()
        }
        Err(e) => {
            return Err(Error::input(
                &file,
                format!(
                    "not a text file: line 1 is not UTF-8 at byte {}",
                    e.valid_up_to()
                ),
            ));
        }
    }
    .trim();
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
    // trackpy's own columns identify it; otherwise a header naming the canonical key
    // columns is read as canonical so that a missing column is reported by name.
    if has("size") || has("mass") || has("ep") || has("raw_mass") {
        return Ok(Format::Trackpy);
    }
    if has("radius") || (has("frame") && has("particle")) {
        return Ok(Format::Canonical);
    }
    Err(Error::input(
        &file,
        format!(
            "unknown format (header '{first}'); supported: {SUPPORTED}; pass --format to choose"
        ),
    ))
}

/// Ingest settings kept beside an input so that `pillar-pipe ingest FILE` needs no flags:
/// `<stem>.ingest.toml` (or `ingest.toml`) in the input's directory. Flags override it.
#[derive(Debug, Clone, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IngestSettings {
    pub format: Option<String>,
    /// Pixels per length unit (trackpy).
    pub px_per_unit: Option<f64>,
    pub unit: Option<String>,
    /// Seconds per frame.
    pub frame_time: Option<f64>,
    /// Small and large radius, length unit.
    pub radii: Option<[f64; 2]>,
    /// Canonical origin in pixels (trackpy).
    pub origin_px: Option<[f64; 2]>,
    /// Bar speed v_c, length unit per second.
    pub bar_speed: Option<f64>,
    /// Force sensor (`ingest-force`): unit of the force columns (N, mN, gf, ...).
    pub force_unit: Option<String>,
    /// Force sensor: unit of the time column (s, ms, min, ...).
    pub time_unit: Option<String>,
    /// Force sensor: initial pillar height H0, length unit.
    pub height: Option<f64>,
    /// Force sensor: pillar width W at the top edge, length unit.
    pub width: Option<f64>,
    /// Force sensor: large-grain diameter D, length unit (stress in m g μ / D).
    pub grain_size: Option<f64>,
    /// Force sensor: large-grain mass m, kg.
    pub grain_mass: Option<f64>,
    /// Force sensor: grain–substrate friction μ.
    pub mu: Option<f64>,
}

/// The settings file that applies to `input`, if any.
pub fn settings_path(input: &Path) -> Option<PathBuf> {
    let stem = input.file_stem()?.to_string_lossy().into_owned();
    let dir = input.parent().unwrap_or(Path::new("."));
    [
        dir.join(format!("{stem}.ingest.toml")),
        dir.join("ingest.toml"),
    ]
    .into_iter()
    .find(|p| p.is_file())
}

/// Parse an `ingest.toml`; an error names its line.
pub fn read_settings(path: &Path) -> Result<IngestSettings> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    toml::from_str(&text).map_err(|e| {
        let line = e
            .span()
            .map(|sp| text[..sp.start].lines().count().max(1))
            .unwrap_or(0);
        Error::input(path.display(), format!("line {line}: {}", e.message()))
    })
}

/// Fill the options the user did not give from the settings file beside the input.
/// Returns the file used.
pub fn apply_settings(input: &Path, opt: &mut IngestOptions) -> Result<Option<PathBuf>> {
    let Some(path) = settings_path(input) else {
        return Ok(None);
    };
    let s = read_settings(&path)?;
    if (opt.format.is_none() || opt.format == Some(Format::Auto))
        && let Some(f) = &s.format
    {
        opt.format = Some(match f.as_str() {
            "trackpy" => Format::Trackpy,
            "lammps" => Format::Lammps,
            "canonical" => Format::Canonical,
            "auto" => Format::Auto,
            other => {
                return Err(Error::input(
                    path.display(),
                    format!("format '{other}' unknown; supported: {SUPPORTED}"),
                ));
            }
        });
    }
    opt.px_per_unit = opt.px_per_unit.or(s.px_per_unit);
    opt.unit = opt.unit.take().or(s.unit);
    opt.frame_time = opt.frame_time.or(s.frame_time);
    opt.radii = opt.radii.or(s.radii.map(|r| (r[0], r[1])));
    opt.origin_px = opt.origin_px.or(s.origin_px.map(|r| (r[0], r[1])));
    opt.bar_speed = opt.bar_speed.or(s.bar_speed);
    Ok(Some(path))
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
    let mut opt = opt.clone();
    let settings_file = apply_settings(input, &mut opt)?;
    let opt = &opt;
    let format = match opt.format.unwrap_or(Format::Auto) {
        Format::Auto => detect(input)?,
        f => f,
    };
    let mut warnings = Vec::new();
    // Hash the input on a low-priority thread: it takes the cycles the parse leaves
    // idle (the single-threaded steps after it) instead of half the parse's cores.
    let hasher = {
        let input = input.to_path_buf();
        std::thread::spawn(move || {
            crate::io::hash::lower_this_thread_priority();
            sha256_file(&input)
        })
    };
    let read = read_input(input, format, opt);
    let (mut tracks, w, s) = read?;
    warnings.extend(w);
    warnings.extend(tracks.meta.warnings.iter().cloned());
    let split = s;
    if tracks.meta.frame_time.is_none() {
        warnings.push("no frame time given (--fps or --frame-time): times are in frames".into());
    }
    if let Some(v) = opt.bar_speed {
        tracks.meta.bar_speed = Some(v);
    }
    let summary = summarize(&tracks);
    tracks.meta.provenance = Provenance {
        tool: crate::stages::TOOL.into(),
        tool_version: crate::stages::VERSION.into(),
        source: input.display().to_string(),
        source_format: format!("{format:?}").to_lowercase(),
        source_sha256: hasher
            .join()
            .map_err(|_| Error::Other("the hashing thread panicked".into()))??,
        parameters: serde_json::json!({
            "px_per_unit": opt.px_per_unit, "unit": opt.unit, "frame_time": opt.frame_time,
            "radii": opt.radii, "origin_px": opt.origin_px, "bar_speed": opt.bar_speed,
            "keep_detached": opt.keep_detached,
        }),
    };
    // The reader's own facts (a LAMMPS dump's timesteps) stay beside the summary.
    let mut merged = serde_json::to_value(&summary).expect("summary serialises");
    if let (Some(m), Some(reader)) = (merged.as_object_mut(), tracks.meta.summary.as_object()) {
        for (k, v) in reader {
            m.entry(k.clone()).or_insert_with(|| v.clone());
        }
    }
    tracks.meta.summary = merged;
    write_tracks_owned(tracks, output)?;
    Ok(IngestReport {
        input: input.display().to_string(),
        output: output.display().to_string(),
        format,
        summary,
        species_split: split,
        settings_file: settings_file.map(|p| p.display().to_string()),
        warnings,
    })
}

/// Read `input` in `format` into validated tracks, with warnings and (trackpy) the
/// species split: everything `run` does short of hashing and writing (the fuzz tests
/// call it directly).
pub fn read_input(
    input: &Path,
    format: Format,
    opt: &IngestOptions,
) -> Result<(crate::tracks::Tracks, Vec<String>, Option<SpeciesSplit>)> {
    let mut warnings = Vec::new();
    let mut split = None;
    let tracks = match format {
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
                let all: std::collections::BTreeSet<i64> = t.particle.iter().copied().collect();
                if !ids.is_empty() && ids.len() >= all.len() {
                    // Every trajectory "detached" means the grains are not a packing at
                    // the radii in use (a loose lattice, wrong --radii or scale), not
                    // that every one is a tracker artefact: an empty table would be a
                    // silent wrong answer.
                    return Err(Error::input(
                        input.display(),
                        format!(
                            "all {} trajectories would be dropped as detached from the packing (fewer than 2 neighbours within 1.25 D, D the large diameter from --radii or estimated); check --px-per-unit and --radii, or pass --keep-detached",
                            all.len()
                        ),
                    ));
                }
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
    Ok((tracks, warnings, split))
}
