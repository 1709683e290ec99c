//! `pillar-pipe track FRAMES…`: `locate` then `link` in one command, the frames never
//! written out as features in between; the output is trackpy's linked table (features
//! plus `particle`, px), which `pillar-pipe ingest` reads as trackpy output.

use super::locate::{LocateRun, locate_movie};
use crate::camera::{LinkOptions, LinkReport, LocateParams, link};
use crate::error::{Error, Result};
use crate::io::features::write_features;
use crate::io::write_with_sidecar;
use crate::stages::ingest::{Format, IngestOptions};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What `track` did.
#[derive(Debug, Clone, Serialize)]
pub struct TrackRun {
    pub output: String,
    pub locate: LocateRun,
    pub link_options: LinkOptions,
    pub link: LinkReport,
    pub warnings: Vec<String>,
}

/// Locate every frame, link, and write `output` (CSV) with its `.meta.json` sidecar
/// (parameters of both steps, every frame's SHA-256, the tool's version).
pub fn run(
    inputs: &[PathBuf],
    output: &Path,
    locate: &LocateParams,
    link_options: &LinkOptions,
    quiet: bool,
) -> Result<TrackRun> {
    super::link::check_output(output)?;
    link_options.check()?;
    let (features, mut located) = locate_movie(inputs, locate, quiet)?;
    located.output = output.display().to_string();
    let linked = link(&features, link_options)?;
    let run = TrackRun {
        output: output.display().to_string(),
        warnings: super::link::warnings(&linked.report, link_options),
        locate: located,
        link_options: link_options.clone(),
        link: linked.report,
    };
    let sidecar = serde_json::json!({
        "table": super::link::LINKED_TABLE,
        "columns": super::link::LINKED_COLUMNS,
        "tool": super::TOOL,
        "tool_version": super::VERSION,
        "command": "track",
        "track": &run,
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || {
        write_features(output, &features, Some(&linked.particle))
    })?;
    Ok(run)
}

/// The `ingest` options that turn a `render` folder's tracked pixels back into the
/// rendered tracks' length unit and time: the pixel mapping of its `camera.json`
/// (`x_px = (x − x0)·s`, `y_px = (y0 − y)·s`, so trackpy's origin is (−x0·s, y0·s)),
/// its length unit, frame interval and bar speed, and the two grain radii of its
/// `ground_truth.csv` (the sizes of the grains, as an experimenter knows them).
pub fn camera_ingest_options(frames: &Path) -> Result<IngestOptions> {
    let path = frames.join("camera.json");
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::input(path.display(), e.to_string()))?;
    let num = |k: &str| {
        v["pixel_map"][k].as_f64().ok_or_else(|| {
            Error::input(path.display(), format!("pixel_map.{k}: expected a number"))
        })
    };
    let (s, x0, y0) = (num("px_per_unit")?, num("x0")?, num("y0")?);
    let unit = v["length_unit"]
        .as_str()
        .ok_or_else(|| Error::input(path.display(), "length_unit: expected a string"))?;
    // Times in seconds only where the rendered tracks had them.
    let frame_time = (v["time_unit"].as_str() == Some("s"))
        .then(|| v["frame_interval"].as_f64())
        .flatten();
    Ok(IngestOptions {
        format: Some(Format::Trackpy),
        px_per_unit: Some(s),
        unit: Some(unit.to_string()),
        frame_time,
        radii: truth_radii(&frames.join("ground_truth.csv"))?,
        origin_px: Some((-x0 * s, y0 * s)),
        bar_speed: v["bar_speed"].as_f64(),
        ..IngestOptions::default()
    })
}

/// The smallest and largest grain radius of a render's `ground_truth.csv` (length
/// unit), or `None` when it has no rows.
fn truth_radii(path: &Path) -> Result<Option<(f64, f64)>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default();
    let col = header
        .split(',')
        .position(|c| c == "radius")
        .ok_or_else(|| Error::input(path.display(), "no `radius` column"))?;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, line) in lines.enumerate() {
        let r: f64 = line
            .split(',')
            .nth(col)
            .and_then(|x| x.parse().ok())
            .ok_or_else(|| Error::input(path.display(), format!("line {}: no radius", i + 2)))?;
        lo = lo.min(r);
        hi = hi.max(r);
    }
    Ok((lo <= hi).then_some((lo, hi)))
}
