//! `report`: the branches' data sets side by side (`report.html`, figures), with the
//! provenance of every stage it depends on.

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

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReportParams {
    pub datasets: Vec<String>,
    pub title: Option<String>,
    pub map_stages: usize,
}

impl Default for ReportParams {
    fn default() -> Self {
        ReportParams {
            datasets: Vec::new(),
            title: None,
            map_stages: 3,
        }
    }
}

pub struct Report;

impl StageKind for Report {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<ReportParams>(given)
    }

    /// The report's title defaults to the pipeline's.
    fn complete(&self, params: &mut Json, title: &str) {
        if params["title"].is_null() {
            params["title"] = Json::String(title.to_string());
        }
    }

    /// Two or more pillar runs: their size scan, a stage of its own the report reads.
    fn check(&self, _src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        Ok(super::sizes::for_report(st)?.into_iter().collect())
    }

    fn is_report(&self) -> bool {
        true
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: ReportParams = typed(&s.name, &s.params)?;
        let datasets = s
            .datasets
            .iter()
            .map(|d| super::sizes::dataset_inputs(d, ctx))
            .collect();
        let opt = stages::report::ReportOptions {
            title: p.title.unwrap_or_else(|| ctx.pipeline.title.clone()),
            datasets,
            map_stages: p.map_stages,
            provenance: provenance(s, ctx),
            sizes: ctx.input(s, "sizes", "analysis").ok(),
        };
        let r = stages::report::run(out, &opt)?;
        let mut outs = outputs(&[("html", "report.html"), ("figures", "figures")]);
        // The sweeps' classification tables and the size scan's tables, copied into
        // the run beside the report.
        for e in std::fs::read_dir(out)
            .map_err(|e| Error::io(out, e))?
            .flatten()
        {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with("classification_") || name.starts_with("size_scan") {
                outs.insert(name.replace('.', "_"), name);
            }
        }
        Ok(Produced {
            outputs: outs,
            metrics: json!({"figures": r.figures.len()}),
            summary: json!({"sections": r.sections}),
        })
    }
}

/// What the report prints under "Provenance": the stages it depends on with their
/// parameters, cache keys and input hashes, the pipeline file and the run that made it.
fn provenance(s: &Stage, ctx: &Ctx) -> Json {
    let mut todo: Vec<&str> = s.upstream.values().map(String::as_str).collect();
    let mut stages = serde_json::Map::new();
    while let Some(n) = todo.pop() {
        let (Some(st), Some(d)) = (ctx.pipeline.stage(n), ctx.done.get(n)) else {
            continue;
        };
        if stages.contains_key(n) {
            continue;
        }
        todo.extend(st.upstream.values().map(String::as_str));
        stages.insert(
            n.to_string(),
            json!({"kind": d.record.kind, "cache_key": d.record.key, "parameters": st.params, "input_sha256": d.record.files}),
        );
    }
    json!({
        "pipeline": ctx.pipeline.name,
        "pipeline_file": ctx.pipeline.file.display().to_string(),
        "pipeline_sha256": ctx.pipeline.sha256,
        "computed_in_run": ctx.run_id,
        "tool": format!("{} {}", stages::TOOL, stages::VERSION),
        "stages": stages,
    })
}
