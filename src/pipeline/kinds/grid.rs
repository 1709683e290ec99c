//! `grid`: a parameter study's points gathered (`stages::grid`). Made by `vary` on a
//! stage (`pipeline/vary.rs`), never written by hand: its upstream are the points.

use super::Locate;
use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::{Error, Result};
use crate::pipeline::exec::{Ctx, Produced, outputs};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GridParams {
    /// The kind of the points.
    pub of: String,
    /// The varied keys and their values, as given.
    pub vary: serde_json::Map<String, Json>,
}

pub struct Grid;

/// The keys of a sheared-disk sweep's grid: a study of `shear` points varying only
/// these is a sweep, and its grid also writes the sweep's tables (`stages::sweep`), so
/// the report draws it as one (one mechanism: `sweep` is the φ × Q × γ̇ product of this).
const SWEEP_KEYS: [&str; 3] = ["phi", "q", "rate"];

/// The sweep tables of a grid of `shear` points, from each point's summary and its
/// resolved (φ, Q, γ̇), in the points' order.
fn sheared_disk_tables(s: &Stage, ctx: &Ctx, out: &Path) -> Result<()> {
    let mut points = Vec::new();
    let mut dirs = Vec::new();
    let mut base = None;
    for name in s
        .upstream
        .iter()
        .filter(|(k, _)| k.starts_with("point:"))
        .map(|(_, n)| n)
    {
        let done = ctx
            .done
            .get(name)
            .ok_or_else(|| Error::Other(format!("{name} has not run")))?;
        let o: stages::shear::ShearOptions = typed(name, &done.record.params)?;
        let at = (o.phi, o.q, o.rate);
        let f = done.dir.join("summary.json");
        let text = std::fs::read_to_string(&f).map_err(|e| Error::io(&f, e))?;
        let summary: Json =
            serde_json::from_str(&text).map_err(|e| Error::input(f.display(), e.to_string()))?;
        points.push((at, summary));
        dirs.push((at, done.dir.clone()));
        base.get_or_insert(o);
    }
    let grid: Vec<(f64, f64, f64)> = points.iter().map(|p| p.0).collect();
    let base = base.ok_or_else(|| Error::Other(format!("{}: a grid without points", s.name)))?;
    stages::sweep::write_outputs(out, &grid, &points, &base)?;
    stages::sweep::write_contacts(out, &dirs)
}

impl StageKind for Grid {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<GridParams>(given)
    }

    fn check(&self, src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        if st.upstream.keys().any(|k| k.starts_with("point:")) {
            Ok(Vec::new())
        } else {
            Err(src.err(
                &st.name,
                "a grid is made by `vary` on a stage (vary = { key = [values] }), not written by hand",
            ))
        }
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: GridParams = typed(&s.name, &s.params)?;
        let keys: Vec<String> = p.vary.keys().cloned().collect();
        let mut points = Vec::new();
        // `point:0000`, `point:0001`, … in order.
        for (i, name) in s
            .upstream
            .iter()
            .filter(|(k, _)| k.starts_with("point:"))
            .map(|(_, n)| n)
            .enumerate()
        {
            let done = ctx
                .done
                .get(name)
                .ok_or_else(|| Error::Other(format!("{name} has not run")))?;
            let values = keys
                .iter()
                .map(|k| p.vary[k].get(i).cloned().unwrap_or(Json::Null))
                .collect();
            points.push(stages::grid::Point {
                values,
                metrics: done.record.metrics.clone(),
                run: (p.of == "simulate").then(|| done.dir.clone()),
            });
        }
        let r = stages::grid::run(&p.of, &keys, &points, out)?;
        let mut made = vec![
            ("grid", stages::grid::TABLE),
            ("record", stages::grid::RECORD),
        ];
        if p.of == "shear" && keys.iter().all(|k| SWEEP_KEYS.contains(&k.as_str())) {
            sheared_disk_tables(s, ctx, out)?;
            made.extend([
                ("sweep", stages::sweep::TABLE),
                ("sweep_grid", stages::sweep::GRID),
                ("angles", stages::sweep::ANGLES),
                ("contacts", stages::sweep::CONTACTS),
            ]);
        }
        Ok(Produced {
            outputs: outputs(&made),
            metrics: json!({"points": r.points, "of": r.of, "missing": r.missing.len()}),
            summary: json!({"keys": r.keys, "missing": r.missing}),
        })
    }
}
