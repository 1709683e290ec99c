//! A parameter study's results (li-granular-pillars Sec. II.C): each point's varied
//! values and metrics in one table, `grid.csv`, and for `simulate` points also the
//! size scan's measures of its run — ⟨σ⟩ and κ over 0.05 ≤ ε ≤ 0.2 and the yield point
//! ε_y, σ_y with their 95 % intervals (`sizes::row`) — so a report can draw them against
//! the varied key. `grid.json` names the varied keys and what a point could not give.

use crate::error::Result;
use crate::io::write_with_sidecar;
use serde::{Deserialize, Serialize};
use serde_json::Value as Json;
use std::path::{Path, PathBuf};

pub const TABLE: &str = "grid.csv";
pub const RECORD: &str = "grid.json";

/// One point: its varied values (in the study's key order), its stage's metrics, and
/// for a pillar run its folder.
pub struct Point {
    pub values: Vec<Json>,
    pub metrics: Json,
    pub run: Option<PathBuf>,
}

/// What `grid.json` holds.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GridRecord {
    /// The kind of the points.
    pub of: String,
    /// The varied keys (`set.k_n`), the table's first columns.
    pub keys: Vec<String>,
    pub points: usize,
    /// The columns after the keys, in order.
    pub columns: Vec<String>,
    /// (point, why a measure is missing), e.g. a run that stopped before ε = 0.2.
    pub missing: Vec<(usize, String)>,
    /// Units of the pillar measures (the varied keys and metrics keep their stage's).
    #[serde(default)]
    pub units: std::collections::BTreeMap<String, String>,
}

/// The measures of a pillar run the report draws (li-granular-pillars Secs. III, V).
pub const PILLAR_COLUMNS: [&str; 9] = [
    "sigma_mean",
    "sigma_err",
    "kappa_mean",
    "eps_y",
    "eps_y_lo",
    "eps_y_hi",
    "sigma_y",
    "sigma_y_lo",
    "sigma_y_hi",
];

/// Write the study's table and record into `out`.
pub fn run(of: &str, keys: &[String], points: &[Point], out: &Path) -> Result<GridRecord> {
    let mut metric_names: Vec<String> = Vec::new();
    for p in points {
        for (k, v) in p.metrics.as_object().into_iter().flatten() {
            // A metric named as a varied key (a shear stage's `phi`) is that key's value.
            if v.is_number() && !metric_names.contains(k) && !keys.contains(k) {
                metric_names.push(k.clone());
            }
        }
    }
    metric_names.sort();
    let pillar = points.iter().any(|p| p.run.is_some());
    let mut names: Vec<String> = vec!["point".into()];
    names.extend(keys.iter().cloned());
    names.extend(metric_names.iter().cloned());
    if pillar {
        names.extend(PILLAR_COLUMNS.iter().map(|s| s.to_string()));
    }
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut missing = Vec::new();
    for (i, p) in points.iter().enumerate() {
        let mut row = vec![i as f64];
        row.extend(p.values.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)));
        row.extend(
            metric_names
                .iter()
                .map(|m| p.metrics[m].as_f64().unwrap_or(f64::NAN)),
        );
        if pillar {
            match p.run.as_deref().map(crate::stages::sizes::row) {
                Some(Ok(r)) => {
                    let y = r.yield_columns();
                    row.extend([r.sigma, r.sigma_err, r.kappa]);
                    row.extend(y);
                }
                Some(Err(e)) => {
                    missing.push((i, e.to_string()));
                    row.extend([f64::NAN; 9]);
                }
                None => row.extend([f64::NAN; 9]),
            }
        }
        for (c, v) in cols.iter_mut().zip(row) {
            c.push(v);
        }
    }
    let record = GridRecord {
        of: of.to_string(),
        keys: keys.to_vec(),
        points: points.len(),
        columns: names[1 + keys.len()..].to_vec(),
        missing,
        units: if pillar {
            PILLAR_COLUMNS
                .iter()
                .map(|c| {
                    let u = match *c {
                        "kappa_mean" => "1 (P_g-s / P_in)",
                        c if c.starts_with("eps_y") => "strain",
                        _ => "m g mu / D",
                    };
                    (c.to_string(), u.to_string())
                })
                .collect()
        } else {
            Default::default()
        },
    };
    let text = serde_json::to_string_pretty(&record).expect("json");
    let table = out.join(TABLE);
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    write_with_sidecar(&table, &text, || {
        crate::io::table::write_f64_columns(&refs, &cols, &table, "the grid table")
    })?;
    crate::io::atomic_write_str(&out.join(RECORD), &text)?;
    Ok(record)
}

/// A study's record beside its table.
pub fn read_record(dir: &Path) -> Result<GridRecord> {
    let f = dir.join(RECORD);
    let text = std::fs::read_to_string(&f).map_err(|e| crate::Error::io(&f, e))?;
    serde_json::from_str(&text).map_err(|e| crate::Error::input(f.display(), e.to_string()))
}
