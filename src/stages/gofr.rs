//! `pillar-pipe gofr`: g(r) by the species at the centre for one frame of tracks
//! (li-granular-pillars Fig. 2), r in units of the large-grain diameter D; the open-edge
//! rule and normalisation are `structure::pair_distribution`'s.

use crate::error::{Error, Result};
use crate::geom::Vec2;
use crate::io::table::write_table;
use crate::io::{read_tracks, sha256_file, write_with_sidecar};
use crate::structure::{PairDistribution, pair_distribution};
use crate::tracks::{SMALL, Tracks};
use polars::prelude::*;
use std::path::Path;

/// g(r) of frame `frame` (default: the first) of the tracks at `input`, up to
/// `r_max_over_d` D in `bins` bins, written to `output` (Parquet or CSV by extension)
/// with its `.meta.json` sidecar.
pub fn run(
    input: &Path,
    output: &Path,
    frame: Option<i64>,
    r_max_over_d: f64,
    bins: usize,
) -> Result<(PairDistribution, i64, f64)> {
    let (t, _) = read_tracks(input)?;
    let (g, f, d) = of_tracks(&t, &input.display().to_string(), frame, r_max_over_d, bins)?;
    let mut df = DataFrame::new(
        bins,
        vec![
            Column::new(
                "r_over_d".into(),
                g.r.iter().map(|r| r / d).collect::<Vec<f64>>(),
            ),
            Column::new("g_all".into(), &g.g_all),
            Column::new("g_small".into(), &g.g_small),
            Column::new("g_large".into(), &g.g_large),
        ],
    )
    .map_err(|e| Error::polars("the g(r) table", e))?;
    let sidecar = serde_json::json!({
        "table": "gofr",
        "frame": f,
        "d_large": d,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": input.display().to_string(), "source_sha256": sha256_file(input)?,
            "parameters": {"frame": frame, "r_max_over_d": r_max_over_d, "bins": bins},
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || write_table(&mut df, output))?;
    Ok((g, f, d))
}

/// g(r) of frame `frame` (default: the first) of tracks `t` read from `source` (named
/// in errors): the distribution (r in the tracks' length unit), the frame, and D.
pub fn of_tracks(
    t: &Tracks,
    source: &str,
    frame: Option<i64>,
    r_max_over_d: f64,
    bins: usize,
) -> Result<(PairDistribution, i64, f64)> {
    let ranges = t.frame_ranges();
    let (f, rows) = match frame {
        None => ranges
            .first()
            .cloned()
            .ok_or_else(|| Error::input(source, "no rows"))?,
        Some(f) => ranges
            .iter()
            .find(|(k, _)| *k == f)
            .cloned()
            .ok_or_else(|| Error::param("frame", format!("{}: no frame {f}", source)))?,
    };
    let d = t
        .large_diameter()
        .ok_or_else(|| Error::input(source, "no radii to take D from"))?;
    let pos: Vec<Vec2> = rows.clone().map(|i| Vec2::new(t.x[i], t.y[i])).collect();
    let small: Vec<bool> = match &t.species {
        Some(s) => rows.clone().map(|i| s[i] == SMALL).collect(),
        None => rows
            .clone()
            .map(|i| t.radius[i] < 0.5 * d * 0.999)
            .collect(),
    };
    let g = pair_distribution(&pos, &small, r_max_over_d * d, bins, t.meta.box_at(f))?;
    Ok((g, f, d))
}
