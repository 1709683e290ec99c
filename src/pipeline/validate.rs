//! Checking each table against the schema: unknown keys (with the allowed ones), types,
//! ranges, required and conflicting keys; then filling defaults through the typed
//! parameter structs.

use super::params;
use super::parse::{RawStage, Source};
use super::schema::{self, PipelineSchema};
use crate::error::Result;
use serde_json::Value as Json;
use std::path::{Path, PathBuf};

/// The `[pipeline]` table, resolved.
#[derive(Debug, Clone)]
pub struct Header {
    pub name: String,
    pub title: String,
    pub description: Option<String>,
    /// Absolute directory that relative paths are resolved against.
    pub root: PathBuf,
}

pub fn header(src: &Source, schema: &PipelineSchema, t: &toml::Table) -> Result<Header> {
    let mut get = std::collections::BTreeMap::new();
    for (k, v) in t {
        let path = format!("pipeline.{k}");
        let spec = schema
            .pipeline
            .keys
            .iter()
            .find(|s| &s.name == k)
            .ok_or_else(|| {
                let allowed: Vec<&str> = schema
                    .pipeline
                    .keys
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect();
                src.err(
                    &path,
                    format!("unknown key; allowed in [pipeline]: {}", allowed.join(", ")),
                )
            })?;
        let v = schema::check(spec, v).map_err(|m| src.err(&path, m))?;
        get.insert(k.as_str(), v.as_str().unwrap_or_default().to_string());
    }
    let stem = src
        .file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "pipeline".into());
    let name = get.get("name").cloned().unwrap_or(stem);
    let dir = src.file.parent().unwrap_or(Path::new("."));
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let root = dir.join(get.get("root").map_or(".", |s| s.as_str()));
    let root = root.canonicalize().map_err(|e| {
        src.err(
            "pipeline.root",
            format!("root directory {}: {e}", root.display()),
        )
    })?;
    Ok(Header {
        title: get.get("title").cloned().unwrap_or_else(|| name.clone()),
        description: get.get("description").cloned(),
        name,
        root,
    })
}

/// The `[executor]` table, checked against the schema.
pub fn executor(
    src: &Source,
    schema: &PipelineSchema,
    t: &toml::Table,
) -> Result<super::slurm::ExecutorSpec> {
    let mut out = super::slurm::ExecutorSpec::default();
    for (k, v) in t {
        let path = format!("executor.{k}");
        let spec = schema
            .executor
            .keys
            .iter()
            .find(|s| &s.name == k)
            .ok_or_else(|| {
                let allowed: Vec<&str> = schema
                    .executor
                    .keys
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect();
                src.err(
                    &path,
                    format!("unknown key; allowed in [executor]: {}", allowed.join(", ")),
                )
            })?;
        let v = schema::check(spec, v).map_err(|m| src.err(&path, m))?;
        let text = || v.as_str().map(str::to_string);
        let count = || v.as_integer().and_then(|i| u32::try_from(i).ok());
        let o = &mut out.slurm;
        match k.as_str() {
            "name" => out.name = text(),
            "partition" => o.partition = text(),
            "account" => o.account = text(),
            "time" => o.time = text(),
            "mem" => o.mem = text(),
            "cpus_per_task" => o.cpus_per_task = count(),
            "retry" => o.retry = count(),
            "detach" => o.detach = v.as_bool().unwrap_or(false),
            "sbatch_args" => {
                o.sbatch_args = v
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(|x| x.as_str().map(str::to_string))
                    .collect()
            }
            _ => return Err(src.err(&path, "not handled (schema and code disagree)")),
        }
    }
    Ok(out)
}

/// Validate one stage table and fill its defaults: the resolved parameters.
pub fn stage_params(src: &Source, schema: &PipelineSchema, s: &RawStage) -> Result<Json> {
    let spec = schema.stage(s.kind);
    let mut given = serde_json::Map::new();
    for (k, v) in &s.table {
        let path = format!("{}.{k}", s.name);
        let Some(ks) = schema.key(s.kind, k) else {
            let allowed: Vec<&str> = spec.keys.iter().map(|k| k.name.as_str()).collect();
            let hint = s.kind.def().unknown_key_hint(k).unwrap_or("");
            return Err(src.err(
                &path,
                format!(
                    "unknown key for a {} stage; allowed: {}{hint}",
                    s.kind.name(),
                    allowed.join(", ")
                ),
            ));
        };
        let v = schema::check(ks, v).map_err(|m| src.err(&path, m))?;
        // `vary` makes points of the stage (`vary.rs`); it is no parameter of the kind.
        if k != "kind" && k != "vary" {
            given.insert(k.clone(), schema::to_json(&v));
        }
    }
    for ks in &spec.keys {
        if ks.required && !s.table.contains_key(&ks.name) {
            return Err(src.err(
                &s.name,
                format!("missing required key '{}': {}", ks.name, ks.description),
            ));
        }
        if s.table.contains_key(&ks.name) {
            for c in ks.conflicts.iter().flatten() {
                if s.table.contains_key(c) {
                    return Err(src.err(
                        &format!("{}.{}", s.name, ks.name),
                        format!("give '{}' or '{c}', not both", ks.name),
                    ));
                }
            }
        }
    }
    params::resolve(s.kind, Json::Object(given)).map_err(|m| src.err(&s.name, m))
}
