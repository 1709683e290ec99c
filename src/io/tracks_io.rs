//! The canonical `tracks` table on disk: CSV or Parquet plus the `.meta.json` sidecar.

use super::atomic::{sidecar_path, write_with_sidecar};
use super::csvdiag::Expect;
use super::table::{ParquetColumns, Table, TableFormat, read_table, write_table};
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
    // Parquet one column at a time (never polars' copy of every column beside ours).
    let source = match TableFormat::of(path) {
        TableFormat::Parquet => Source::Columns(ParquetColumns::open(path)?),
        TableFormat::Csv => Source::Whole(read_table(path, TRACKS_EXPECT)?),
    };
    let table = source.table();
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
    let t = tracks_from_source(&source, meta.unwrap_or_default())?;
    Ok((t, warnings))
}

/// Where the tracks' columns come from: a table read whole (CSV), or a Parquet file
/// read a column at a time.
enum Source {
    Whole(Table),
    Columns(ParquetColumns),
}

impl Source {
    /// The table's columns (for a Parquet file, without their values).
    fn table(&self) -> &Table {
        match self {
            Source::Whole(t) => t,
            Source::Columns(c) => &c.schema,
        }
    }
    fn f64(&self, c: &str) -> Result<Vec<f64>> {
        match self {
            Source::Whole(t) => t.f64(c),
            Source::Columns(p) => p.column(c)?.f64(c),
        }
    }
    fn i64(&self, c: &str) -> Result<Vec<i64>> {
        match self {
            Source::Whole(t) => t.i64(c),
            Source::Columns(p) => p.column(c)?.i64(c),
        }
    }
}

fn tracks_from_source(source: &Source, meta: TracksMeta) -> Result<Tracks> {
    let table = source.table();
    let f64s = |c: &str| source.f64(c);
    let i64s = |c: &str| source.i64(c);
    let opt_f = |c: &str| -> Result<Option<Vec<f64>>> {
        if table.has(c) {
            f64s(c).map(Some)
        } else {
            Ok(None)
        }
    };
    let species = if table.has("species") {
        Some(i64s("species")?.into_iter().map(|s| s as i32).collect())
    } else {
        None
    };
    let t = Tracks {
        frame: i64s("frame")?,
        particle: i64s("particle")?,
        x: f64s("x")?,
        y: f64s("y")?,
        radius: f64s("radius")?,
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Parquet tracks are read one column at a time: a file of several row groups reads
    /// as the same rows through CSV, an unknown column is still named, and a missing
    /// value is still placed at its row and column.
    #[test]
    fn parquet_read_a_column_at_a_time_keeps_every_check() {
        let dir = std::env::temp_dir().join(format!("pp-tracks-cols-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let n = 300_000usize;
        let table = |y: Vec<Option<f64>>| {
            df!(
                "frame" => (0..n).map(|i| (i % 2) as i64).collect::<Vec<_>>(),
                "particle" => (0..n).map(|i| (i / 2) as i64).collect::<Vec<_>>(),
                "x" => (0..n).map(|i| (i / 2) as f64 * 1.5 + (i % 2) as f64 * 0.01).collect::<Vec<_>>(),
                "y" => y,
                "radius" => vec![0.5; n],
                "brightness" => vec![1.0; n],
            )
            .unwrap()
        };
        let ys: Vec<Option<f64>> = (0..n).map(|i| Some((i % 7) as f64)).collect();
        for (name, format) in [("t.parquet", "parquet"), ("t.csv", "csv")] {
            let mut df = table(ys.clone());
            let path = dir.join(name);
            super::super::table::write_table(&mut df, &path).unwrap();
            let (t, warnings) = read_tracks(&path).unwrap();
            assert_eq!(t.len(), n, "{format}");
            let want_x = |r: usize| t.particle[r] as f64 * 1.5 + t.frame[r] as f64 * 0.01;
            assert!((0..n).all(|r| t.x[r] == want_x(r)), "{format}");
            assert!(
                warnings.iter().any(|w| w.contains("brightness")),
                "{format}: {warnings:?}"
            );
        }
        // Several row groups, so each column is read across them.
        let f = std::fs::File::open(dir.join("t.parquet")).unwrap();
        let groups = ParquetReader::new(f)
            .get_metadata()
            .unwrap()
            .row_groups
            .len();
        assert!(groups >= 2, "{groups} row groups");
        let (a, _) = read_tracks(&dir.join("t.parquet")).unwrap();
        let (b, _) = read_tracks(&dir.join("t.csv")).unwrap();
        assert_eq!(
            (&a.frame, &a.particle, &a.x, &a.y),
            (&b.frame, &b.particle, &b.x, &b.y)
        );

        let mut holed = ys;
        holed[299_990] = None;
        let mut df = table(holed);
        let path = dir.join("holed.parquet");
        super::super::table::write_table(&mut df, &path).unwrap();
        let e = read_tracks(&path).unwrap_err().to_string();
        assert!(
            e.contains("row 299990") && e.contains("'y'") && e.contains("missing value"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
