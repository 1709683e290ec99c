//! `pillar-pipe bar-pressure`: the contact pressure along the compressing bar of a
//! `simulate pillar` run (li-granular-pillars Fig. 10c), averaged over the force
//! snapshots whose strain lies in a window of the plastic regime, in the paper's units:
//! p in m g μ/D against x/W (see `structure::pressure` for the construction).

use crate::error::{Error, Result};
use crate::geom::Vec2;
use crate::io::csvdiag::Expect;
use crate::io::table::{read_table, write_table};
use crate::io::{sha256_file, write_with_sidecar};
use crate::structure::pressure::{PressureProfile, bar_pressure, mean_profile};
use polars::prelude::{Column, DataFrame};
use std::collections::HashMap;
use std::path::Path;

/// The default strain window: plastic flow at every size (li-granular-pillars Fig. 4:
/// the stress has levelled off by ε ≈ 0.05; the paper's ⟨σ⟩ window ends at 0.2).
pub const WINDOW: (f64, f64) = (0.1, 0.2);

/// Bins across the interface.
pub const BINS: usize = 10;

/// One force snapshot of a run: the grains' centres and radii in D and one column of
/// the forces table, by grain.
pub struct Snapshot {
    pub frame: i64,
    pub pos: Vec<Vec2>,
    pub radius: Vec<f64>,
    pub value: Vec<f64>,
}

/// The force snapshots of the run in `dir` whose strain lies in `window`, with the
/// forces table's `column` (a float column of `data_schema/forces.schema.json`), and
/// the largest strain the run reached (for the caller's "none in the window" error).
pub fn snapshots(dir: &Path, window: (f64, f64), column: &str) -> Result<(Vec<Snapshot>, f64)> {
    let ss_path = dir.join("stress_strain.parquet");
    let ss = read_table(
        &ss_path,
        &[("frame", Expect::Int), ("strain", Expect::Float)],
    )?;
    let strain_of: HashMap<i64, f64> = ss
        .i64("frame")?
        .into_iter()
        .zip(ss.f64("strain")?)
        .collect();
    let reached = strain_of
        .values()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let f_path = dir.join("forces.parquet");
    let forces = read_table(
        &f_path,
        &[
            ("frame", Expect::Int),
            ("particle", Expect::Int),
            (column, Expect::Float),
        ],
    )
    .map_err(|e| match e {
        Error::Io { .. } => e,
        other => Error::input(
            f_path.display(),
            format!(
                "{other} (runs made before the forces table had {column} lack it: simulate again)"
            ),
        ),
    })?;
    let (ff, fp, fv) = (
        forces.i64("frame")?,
        forces.i64("particle")?,
        forces.f64(column)?,
    );
    let (tracks, _) = crate::io::read_tracks(&dir.join("tracks.parquet"))?;
    let d = tracks
        .large_diameter()
        .ok_or_else(|| Error::input(dir.join("tracks.parquet").display(), "no grain radii"))?;
    let ranges: HashMap<i64, std::ops::Range<usize>> = tracks.frame_ranges().into_iter().collect();
    let mut out = Vec::new();
    let mut s = 0;
    while s < ff.len() {
        let frame = ff[s];
        let e = s + ff[s..].iter().take_while(|&&v| v == frame).count();
        let in_window = strain_of
            .get(&frame)
            .is_some_and(|&eps| eps >= window.0 && eps <= window.1);
        if let (true, Some(r)) = (in_window, ranges.get(&frame)) {
            let at: HashMap<i64, usize> = r.clone().map(|i| (tracks.particle[i], i)).collect();
            let mut snap = Snapshot {
                frame,
                pos: Vec::new(),
                radius: Vec::new(),
                value: Vec::new(),
            };
            for k in s..e {
                if let Some(&i) = at.get(&fp[k]) {
                    snap.pos.push(Vec2::new(tracks.x[i] / d, tracks.y[i] / d));
                    snap.radius.push(tracks.radius[i] / d);
                    snap.value.push(fv[k]);
                }
            }
            out.push(snap);
        }
        s = e;
    }
    Ok((out, reached))
}

/// The run tables [`snapshots`] reads, each with its SHA-256, for an output's sidecar.
pub fn snapshot_sources(dir: &Path) -> Result<Vec<serde_json::Value>> {
    ["stress_strain.parquet", "forces.parquet", "tracks.parquet"]
        .iter()
        .map(|name| {
            let f = dir.join(name);
            Ok(serde_json::json!({
                "source": f.display().to_string(), "source_sha256": sha256_file(&f)?,
            }))
        })
        .collect()
}

/// A run's mean profile over its snapshots in `window`, p in m g μ/D, and how many
/// snapshots it averages.
pub fn run_profile(
    dir: &Path,
    window: (f64, f64),
    bins: usize,
) -> Result<(PressureProfile, usize)> {
    let (snaps, reached) = snapshots(dir, window, "f_bar_reduced")?;
    let profiles: Vec<PressureProfile> = snaps
        .iter()
        .filter_map(|s| {
            let x: Vec<f64> = s.pos.iter().map(|p| p.x).collect();
            bar_pressure(&x, &s.radius, &s.value, bins)
        })
        .collect();
    let n = profiles.len();
    let mean = mean_profile(&profiles).ok_or_else(|| {
        Error::input(
            dir.join("forces.parquet").display(),
            format!(
                "no force snapshot with the bar in contact at {} ≤ ε ≤ {} (the run reached ε = {reached:.3}; snapshots every --forces-every frames)",
                window.0, window.1
            ),
        )
    })?;
    Ok((mean, n))
}

/// [`run_profile`], written to `output` as an (x_over_w, p) table with its `.meta.json`
/// sidecar (the run's three tables it read, each with its SHA-256).
pub fn run(
    dir: &Path,
    window: (f64, f64),
    bins: usize,
    output: &Path,
) -> Result<(PressureProfile, usize)> {
    if bins == 0 {
        return Err(Error::param("bins", "must be at least 1"));
    }
    let (p, n) = run_profile(dir, window, bins)?;
    let mut df = DataFrame::new(
        p.p.len(),
        vec![
            Column::new("x_over_w".into(), p.x_over_w.clone()),
            Column::new("p".into(), p.p.clone()),
        ],
    )
    .map_err(|e| Error::polars("the bar pressure table", e))?;
    let sources = snapshot_sources(dir)?;
    let sidecar = serde_json::json!({
        "table": "bar_pressure",
        "snapshots": n,
        "w_over_d": p.width,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "run": dir.display().to_string(),
            "sources": sources,
            "parameters": {"strain_window": [window.0, window.1], "bins": bins},
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || write_table(&mut df, output))?;
    Ok((p, n))
}
