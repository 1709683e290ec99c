//! `pillar-pipe edge-stress`: the local stress of a `simulate pillar` run's grains
//! against their distance from the nearer lateral edge (li-granular-pillars Sec. V),
//! pooled over the force snapshots in a strain window; p in m g μ/D, d in D. The
//! construction is `structure::edge_stress`'.

use crate::error::{Error, Result};
use crate::io::table::write_table;
use crate::io::write_with_sidecar;
use crate::structure::edge_stress::{EdgeProfile, EdgeStress};
use polars::prelude::{Column, DataFrame};
use std::path::Path;

/// The run's profile over its snapshots in `window` (the bar pressure's by default).
pub fn run_profile(dir: &Path, window: (f64, f64)) -> Result<EdgeProfile> {
    let (snaps, reached) = super::bar_pressure::snapshots(dir, window, "f_n_reduced")?;
    let mut acc = EdgeStress::default();
    for s in &snaps {
        acc.add(&s.pos, &s.radius, &s.value);
    }
    if acc.snapshots == 0 {
        return Err(Error::input(
            dir.join("forces.parquet").display(),
            format!(
                "no force snapshot at {} ≤ ε ≤ {} (the run reached ε = {reached:.3}; snapshots every --forces-every frames)",
                window.0, window.1
            ),
        ));
    }
    Ok(acc.profile())
}

/// [`run_profile`] written to `output` as a (d_over_d, p, grains) table with its
/// `.meta.json` sidecar (the run's tables read, each with its SHA-256, and the rate).
pub fn run(dir: &Path, window: (f64, f64), output: &Path) -> Result<EdgeProfile> {
    if !(window.0 <= window.1) {
        return Err(Error::param(
            "strain",
            format!("{},{}: LO must not exceed HI", window.0, window.1),
        ));
    }
    let p = run_profile(dir, window)?;
    let mut df = DataFrame::new(
        p.p.len(),
        vec![
            Column::new("d_over_d".into(), p.d_over_d.clone()),
            Column::new("p".into(), p.p.clone()),
            Column::new(
                "grains".into(),
                p.grains.iter().map(|&g| g as i64).collect::<Vec<i64>>(),
            ),
        ],
    )
    .map_err(|e| Error::polars("the edge stress table", e))?;
    let sources = super::bar_pressure::snapshot_sources(dir)?;
    let sidecar = serde_json::json!({
        "table": "edge_stress",
        "units": {"d_over_d": "D", "p": "m g mu / D", "rate": "m g mu / D per D"},
        "snapshots": p.snapshots,
        "rate": p.rate,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "run": dir.display().to_string(),
            "sources": sources,
            "parameters": {"strain_window": [window.0, window.1],
                "bar_layer_d": crate::structure::edge_stress::BAR_LAYER_D,
                "fit_d": crate::structure::edge_stress::FIT_D},
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || write_table(&mut df, output))?;
    Ok(p)
}
