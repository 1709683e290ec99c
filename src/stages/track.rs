//! `pillar-pipe track FRAMES…`: `locate` then `link` in one command, the frames never
//! written out as features in between; the output is trackpy's linked table (features
//! plus `particle`, px), which `pillar-pipe ingest` reads as trackpy output.

use super::locate::{LocateRun, locate_movie};
use crate::camera::{LinkOptions, LinkReport, LocateParams, link};
use crate::error::Result;
use crate::io::features::write_features;
use crate::io::write_with_sidecar;
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
        "table": "trackpy_linked",
        "columns": "y, x, mass, size, ecc, signal, raw_mass, ep, frame, particle (trackpy's; px, y down)",
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
