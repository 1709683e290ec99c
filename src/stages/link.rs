//! `pillar-pipe link`: located grains (a features table in trackpy's columns, px) linked
//! into trajectories (`camera::link`), written as trackpy's linked table (the features
//! plus `particle`), which `pillar-pipe ingest` reads as trackpy output.

use crate::camera::{LinkOptions, LinkReport, link};
use crate::error::{Error, Result};
use crate::io::features::{read_features, write_features};
use crate::io::{sha256_file, write_with_sidecar};
use std::path::Path;

/// What the stage did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LinkRun {
    pub input: String,
    pub output: String,
    pub options: LinkOptions,
    pub report: LinkReport,
    pub warnings: Vec<String>,
}

/// The sidecar's name for a linked table and its columns (`link` and `track` write it).
pub const LINKED_TABLE: &str = "trackpy_linked";
pub const LINKED_COLUMNS: &str =
    "y, x, mass, size, ecc, signal, raw_mass, ep, frame, particle (trackpy's; px, y down)";

/// Linked features are written as CSV in trackpy's columns: any other name is refused
/// before any work is done.
pub fn check_output(output: &Path) -> Result<()> {
    if crate::io::table::TableFormat::of(output) != crate::io::table::TableFormat::Csv {
        return Err(Error::param(
            "output",
            format!(
                "{}: linked features are written as CSV (trackpy's columns); name it .csv",
                output.display()
            ),
        ));
    }
    Ok(())
}

/// What a user should know of a linking: subnets linked greedily rather than exactly.
pub fn warnings(r: &LinkReport, opt: &LinkOptions) -> Vec<String> {
    let mut warnings = Vec::new();
    if r.subnets_greedy > 0 {
        warnings.push(format!(
            "{} subnets of more than {} particles ({} features) were linked greedily, shortest links first, not exactly; a smaller --search-range (or --subnet-limit above {}) solves them exactly",
            r.subnets_greedy, opt.subnet_limit, r.features_greedy, r.largest_subnet
        ));
    }
    warnings
}

/// Read the features at `input`, link them, write them with their particle ids to
/// `output` (CSV, trackpy's columns) with a `.meta.json` sidecar.
pub fn run(input: &Path, output: &Path, opt: &LinkOptions) -> Result<LinkRun> {
    if input == output {
        return Err(Error::param("output", "output would overwrite the input"));
    }
    check_output(output)?;
    opt.check()?;
    let features = read_features(input)?;
    let linked = link(&features, opt).map_err(|e| match e {
        // A position the reader let through cannot happen; say which file anyway.
        Error::Param { name, msg } if name == "features" => Error::input(input.display(), msg),
        e => e,
    })?;
    let r = &linked.report;
    let warnings = warnings(r, opt);
    let sidecar = serde_json::json!({
        "table": LINKED_TABLE,
        "columns": LINKED_COLUMNS,
        "report": r,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": input.display().to_string(),
            "source_sha256": sha256_file(input)?,
            "parameters": opt,
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || {
        write_features(output, &features, Some(&linked.particle))
    })?;
    Ok(LinkRun {
        input: input.display().to_string(),
        output: output.display().to_string(),
        options: opt.clone(),
        report: linked.report,
        warnings,
    })
}
