//! Declarative pipelines (`pipelines/*.toml`, format in `data_schema/pipeline.schema.json`):
//! stages of kind ingest, simulate, kinematics, fit, compare and report, wired by
//! references to each other's outputs, run in dependency order with every stage's output
//! cached under the hash of its parameters, inputs and the tool version, and every run
//! tracked under `runs/<id>/`.
//!
//! `parse` reads the file and `--set` overrides, `validate` checks keys against the
//! schema, `graph` resolves references; `cache`, `exec` and `runner` run it, `record`
//! writes `runs/<id>/`; `runs` and `views` list, show and compare tracked runs.

pub mod cache;
pub mod compute;
pub mod exec;
pub mod graph;
#[cfg(test)]
mod import_graph;
pub mod kinds;
pub mod local;
pub mod lock;
pub mod options;
pub mod params;
pub mod parse;
pub mod record;
pub mod runner;
pub mod runs;
pub mod schema;
pub mod slurm;
pub mod source_key;
pub mod validate;
pub mod vary;
pub mod views;

pub use graph::{Dataset, Stage};
pub use runner::{RunOptions, StageEvent, run};
pub use schema::Kind;

use crate::error::Result;
use std::path::{Path, PathBuf};

/// A validated pipeline: stages in run order.
#[derive(Debug, Clone)]
pub struct Pipeline {
    pub file: PathBuf,
    pub sha256: String,
    pub name: String,
    pub title: String,
    pub description: Option<String>,
    pub root: PathBuf,
    pub overrides: Vec<String>,
    pub stages: Vec<Stage>,
    /// The `[executor]` table (where the stages run).
    pub executor: slurm::ExecutorSpec,
}

impl Pipeline {
    pub fn stage(&self, name: &str) -> Option<&Stage> {
        self.stages.iter().find(|s| s.name == name)
    }
}

/// Read, override (`--set`), validate and order a pipeline file.
pub fn load(file: &Path, sets: &[String]) -> Result<Pipeline> {
    let schema = schema::load();
    let (mut src, doc) = parse::Source::read(file)?;
    let mut raw = parse::structure(&src, doc)?;
    parse::apply_overrides(&mut src, &mut raw.stages, &schema, sets)?;
    let header = validate::header(&src, &schema, &raw.header)?;
    let executor = validate::executor(&src, &schema, &raw.executor)?;
    let mut params = Vec::new();
    for s in &raw.stages {
        let mut p = validate::stage_params(&src, &schema, s)?;
        s.kind.def().complete(&mut p, &header.title);
        params.push(p);
    }
    if raw.stages.is_empty() {
        return Err(crate::Error::input(
            file.display(),
            "no stages; see data_schema/pipeline.schema.json",
        ));
    }
    let stages = graph::build(
        &src,
        &schema,
        &raw.stages,
        params,
        &raw.branches,
        &header.root,
    )?;
    Ok(Pipeline {
        file: file.to_path_buf(),
        sha256: crate::io::hash::sha256_bytes(src.text.as_bytes()),
        name: header.name,
        title: header.title,
        description: header.description,
        root: header.root,
        overrides: sets.to_vec(),
        stages,
        executor,
    })
}
