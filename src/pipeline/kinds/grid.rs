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
        Ok(Produced {
            outputs: outputs(&[
                ("grid", stages::grid::TABLE),
                ("record", stages::grid::RECORD),
            ]),
            metrics: json!({"points": r.points, "of": r.of, "missing": r.missing.len()}),
            summary: json!({"keys": r.keys, "missing": r.missing}),
        })
    }
}
