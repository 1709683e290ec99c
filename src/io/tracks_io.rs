//! The canonical `tracks` table on disk: CSV or Parquet plus the `.meta.json` sidecar.

use super::atomic::{sidecar_path, write_with_sidecar};
use super::csvdiag::Expect;
use super::table::{Table, read_table, write_table};
use crate::error::{Error, Result};
use crate::schema;
use crate::tracks::{Tracks, TracksMeta, finalize};
use polars::prelude::*;
use std::path::Path;

/// Parse types of the canonical columns.
pub const TRACKS_EXPECT: &[(&str, Expect)] = &[
    ("frame", Expect::Int),
    ("particle", Expect::Int),
    ("x", Expect::Float),
    ("y", Expect::Float),
    ("radius", Expect::Float),
    ("time", Expect::Float),
    ("species", Expect::Int),
    ("theta", Expect::Float),
];

/// Read a canonical tracks table and its sidecar (if any). Columns not in the schema
/// are ignored and named in the returned warnings.
pub fn read_tracks(path: &Path) -> Result<(Tracks, Vec<String>)> {
    let table = read_table(path, TRACKS_EXPECT)?;
    let sch = schema::load("tracks");
    table.require(&sch.required())?;
    let mut warnings = Vec::new();
    let unknown: Vec<String> = table
        .columns()
        .into_iter()
        .filter(|c| sch.column(c).is_none())
        .collect();
    if !unknown.is_empty() {
        warnings.push(format!(
            "{}: ignored column(s) not in the tracks schema: {}",
            table.file,
            unknown.join(", ")
        ));
    }
    let meta = read_meta(path)?;
    if meta.is_none() {
        warnings.push(format!(
            "{}: no sidecar {} — length unit unspecified, no frame time",
            table.file,
            sidecar_path(path).display()
        ));
    }
    let t = tracks_from_table(&table, meta.unwrap_or_default())?;
    Ok((t, warnings))
}

fn tracks_from_table(table: &Table, meta: TracksMeta) -> Result<Tracks> {
    let opt_f = |c: &str| -> Result<Option<Vec<f64>>> {
        if table.has(c) {
            table.f64(c).map(Some)
        } else {
            Ok(None)
        }
    };
    let species = if table.has("species") {
        Some(
            table
                .i64("species")?
                .into_iter()
                .map(|s| s as i32)
                .collect(),
        )
    } else {
        None
    };
    let t = Tracks {
        frame: table.i64("frame")?,
        particle: table.i64("particle")?,
        x: table.f64("x")?,
        y: table.f64("y")?,
        radius: table.f64("radius")?,
        time: opt_f("time")?,
        species,
        theta: opt_f("theta")?,
        meta,
    };
    finalize(t, &table.file, table.format.locator(), None)
}

/// The sidecar of `path`, if present.
pub fn read_meta(path: &Path) -> Result<Option<TracksMeta>> {
    let p = sidecar_path(path);
    if !p.exists() {
        return Ok(None);
    }
    // Bytes, not a string: serde_json then places invalid UTF-8 at its line and column.
    let text = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
    let m: TracksMeta = serde_json::from_slice(&text)
        .map_err(|e| Error::input(p.display(), format!("malformed sidecar: {e}")))?;
    Ok(Some(m))
}

/// The tracks as a polars DataFrame with the schema's column names and types (copies).
pub fn tracks_dataframe(t: &Tracks) -> Result<DataFrame> {
    tracks_into_dataframe(t.clone())
}

/// As `tracks_dataframe`, moving the columns into polars without a copy (a 10 M-row
/// table is half a gigabyte).
pub fn tracks_into_dataframe(t: Tracks) -> Result<DataFrame> {
    let n = t.len();
    let mut cols = vec![
        Column::new("frame".into(), t.frame),
        Column::new("particle".into(), t.particle),
        Column::new("x".into(), t.x),
        Column::new("y".into(), t.y),
        Column::new("radius".into(), t.radius),
    ];
    if let Some(v) = t.time {
        cols.push(Column::new("time".into(), v));
    }
    if let Some(v) = t.species {
        cols.push(Column::new("species".into(), v));
    }
    if let Some(v) = t.theta {
        cols.push(Column::new("theta".into(), v));
    }
    DataFrame::new(n, cols).map_err(|e| Error::polars("building tracks table", e))
}

/// Write tracks (Parquet, or CSV for `.csv`) and the sidecar, the sidecar renamed into
/// place last: it never exists without its table (`write_with_sidecar`).
pub fn write_tracks(t: &Tracks, path: &Path) -> Result<()> {
    write_tracks_owned(t.clone(), path)
}

/// As `write_tracks`, consuming the tracks so that their columns are not copied.
pub fn write_tracks_owned(mut t: Tracks, path: &Path) -> Result<()> {
    let meta = serde_json::to_string_pretty(&t.meta).expect("meta serialises");
    t.meta = TracksMeta::default();
    let mut df = tracks_into_dataframe(t)?;
    write_with_sidecar(path, &meta, || write_table(&mut df, path))
}
