//! Exact diagnostics for CSV input. The fast path reads with polars; when polars
//! rejects a file (or a column comes back as text), this slower pass finds the first
//! offending line and column so the user gets `file: line N, column 'c': ...`.

use crate::error::{Error, Result};
use std::path::Path;

/// Expected parse type of a column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Expect {
    Int,
    Float,
}

/// Header of a CSV file (first line), without reading the rest.
pub fn read_header(path: &Path) -> Result<Vec<String>> {
    let file = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_path(path)
        .map_err(|e| Error::input(&file, e.to_string()))?;
    let h = rdr
        .headers()
        .map_err(|e| Error::input(&file, e.to_string()))?
        .clone();
    if h.is_empty() || (h.len() == 1 && h[0].trim().is_empty()) {
        return Err(Error::input(&file, "empty file: no header line"));
    }
    Ok(h.iter().map(|s| s.trim().to_string()).collect())
}

/// Scan the file and return the first structural or parse problem in `columns`, as an
/// error naming the line and column. `Ok(())` when nothing is wrong.
pub fn diagnose(path: &Path, columns: &[(&str, Expect)]) -> Result<()> {
    let file = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_path(path)
        .map_err(|e| Error::input(&file, e.to_string()))?;
    let header = rdr
        .headers()
        .map_err(|e| Error::input(&file, e.to_string()))?
        .clone();
    let idx: Vec<(usize, &str, Expect)> = columns
        .iter()
        .filter_map(|(c, e)| {
            header
                .iter()
                .position(|h| h.trim() == *c)
                .map(|i| (i, *c, *e))
        })
        .collect();
    let mut rec = csv::StringRecord::new();
    loop {
        let more = rdr
            .read_record(&mut rec)
            .map_err(|e| Error::input(&file, e.to_string()))?;
        if !more {
            break;
        }
        let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
        if rec.len() != header.len() {
            return Err(Error::Value {
                file: file.clone(),
                loc: format!("line {line}"),
                column: "(row)".into(),
                msg: format!(
                    "malformed row: {} fields, expected {} (header: {})",
                    rec.len(),
                    header.len(),
                    header.iter().collect::<Vec<_>>().join(",")
                ),
            });
        }
        for &(i, name, expect) in &idx {
            let v = rec[i].trim();
            let ok = match expect {
                Expect::Int => v.parse::<i64>().is_ok(),
                Expect::Float => v.parse::<f64>().is_ok(),
            };
            if !ok {
                let what = match expect {
                    Expect::Int => "an integer",
                    Expect::Float => "a number",
                };
                let msg = if v.is_empty() {
                    format!("missing value; expected {what}")
                } else {
                    format!("malformed value '{v}'; expected {what}")
                };
                return Err(Error::Value {
                    file: file.clone(),
                    loc: format!("line {line}"),
                    column: name.to_string(),
                    msg,
                });
            }
        }
    }
    Ok(())
}

/// The columns of trackpy's output that ingest reads, with their types: here, below both
/// the trackpy reader and the fast CSV reader whose tests parse trackpy files.
pub(crate) const TRACKPY_COLUMNS: &[(&str, Expect)] = &[
    ("x", Expect::Float),
    ("y", Expect::Float),
    ("frame", Expect::Int),
    ("particle", Expect::Int),
    ("size", Expect::Float),
    ("ep", Expect::Float),
];
