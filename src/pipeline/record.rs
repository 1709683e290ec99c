//! What a run leaves under `runs/<id>/`: the manifest and a copy of the report.

use super::exec::Done;
use super::options::{Keyed, RunOptions};
use super::runs::{self, InputFile, PipelineInfo, RunManifest};
use super::{Pipeline, Stage};
use crate::error::{Error, Result};
use crate::io::atomic_write_str;
use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub fn manifest(p: &Pipeline, opt: &RunOptions, keyed: &BTreeMap<String, Keyed>) -> RunManifest {
    let mut inputs = BTreeMap::new();
    let mut seeds = BTreeMap::new();
    for s in &p.stages {
        for (k, f) in &s.files {
            inputs.insert(
                format!("{}.{k}", s.name),
                InputFile {
                    path: f.display().to_string(),
                    sha256: keyed[&s.name].files[k].clone(),
                },
            );
        }
        if let Some(seed) = s.params.get("seed").and_then(Json::as_u64) {
            seeds.insert(s.name.clone(), seed);
        }
    }
    RunManifest {
        run_id: String::new(),
        status: "ok".into(),
        executor: None,
        failed_stage: None,
        error: None,
        started: runs::now_iso(),
        elapsed_s: 0.0,
        tool: crate::stages::TOOL.into(),
        tool_version: crate::stages::VERSION.into(),
        pipeline: PipelineInfo {
            name: p.name.clone(),
            title: p.title.clone(),
            description: p.description.clone(),
            file: p.file.display().to_string(),
            sha256: p.sha256.clone(),
            root: p.root.display().to_string(),
        },
        overrides: opt.sets.clone(),
        forced: opt.force.clone(),
        parameters: p
            .stages
            .iter()
            .map(|s| (s.name.clone(), s.params.clone()))
            .collect(),
        seeds,
        inputs,
        stages: Vec::new(),
        metrics: BTreeMap::new(),
        report: None,
    }
}

pub fn write_manifest(run_dir: &Path, m: &RunManifest) -> Result<()> {
    atomic_write_str(
        &run_dir.join(runs::MANIFEST),
        &serde_json::to_string_pretty(m).expect("json"),
    )
}

/// Copy report outputs into the run directory (one report: `report.html` and
/// `figures/` at the top; several: one sub-directory per report stage). Copies, not
/// links, so a run directory stays whole when the cache is cleared.
pub fn place_reports(
    p: &Pipeline,
    done: &BTreeMap<String, Done>,
    run_dir: &Path,
) -> Result<Option<String>> {
    let reports: Vec<&Stage> = p
        .stages
        .iter()
        .filter(|s| s.kind.def().is_report())
        .collect();
    let mut first = None;
    for s in &reports {
        let d = &done[&s.name];
        let sub = if reports.len() == 1 {
            PathBuf::new()
        } else {
            PathBuf::from(&s.name)
        };
        for name in d.record.outputs.values() {
            copy_tree(&d.dir.join(name), &run_dir.join(&sub).join(name))?;
        }
        first.get_or_insert_with(|| sub.join("report.html").display().to_string());
    }
    Ok(first)
}

fn copy_tree(from: &Path, to: &Path) -> Result<()> {
    if from.is_dir() {
        std::fs::create_dir_all(to).map_err(|e| Error::io(to, e))?;
        for e in std::fs::read_dir(from)
            .map_err(|e| Error::io(from, e))?
            .flatten()
        {
            copy_tree(&e.path(), &to.join(e.file_name()))?;
        }
        Ok(())
    } else {
        if let Some(parent) = to.parent() {
            std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
        }
        std::fs::copy(from, to)
            .map(|_| ())
            .map_err(|e| Error::io(to, e))
    }
}
