//! Running one stage into a directory: its parameters become the stage function's
//! options, its references become the upstream stages' output files, and what it wrote
//! is described by output names and key metrics.

use super::cache::StageRecord;
use super::{Pipeline, Stage};
use crate::error::{Error, Result};
use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A finished stage: its record and where it lies.
#[derive(Debug, Clone)]
pub struct Done {
    pub record: StageRecord,
    pub dir: PathBuf,
}

impl Done {
    pub fn output(&self, name: &str) -> Option<PathBuf> {
        self.record.outputs.get(name).map(|r| self.dir.join(r))
    }
}

pub struct Ctx<'a> {
    pub pipeline: &'a Pipeline,
    pub done: &'a BTreeMap<String, Done>,
    pub quiet: bool,
    pub run_id: &'a str,
    /// The stage's cache directory (its final name; the stage writes elsewhere).
    pub dir: &'a Path,
}

/// What the stage produced: output files (relative), metrics, its report.
pub struct Produced {
    pub outputs: BTreeMap<String, String>,
    pub metrics: Json,
    pub summary: Json,
}

pub(crate) fn outputs(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

impl Ctx<'_> {
    pub(crate) fn upstream(&self, s: &Stage, key: &str) -> Result<&Done> {
        let name = s
            .upstream
            .get(key)
            .ok_or_else(|| Error::param(format!("{}.{key}", s.name), "no upstream stage"))?;
        self.done
            .get(name)
            .ok_or_else(|| Error::Other(format!("{name} has not run")))
    }

    /// The named output of the stage `key` refers to.
    pub(crate) fn input(&self, s: &Stage, key: &str, output: &str) -> Result<PathBuf> {
        self.upstream(s, key)?.output(output).ok_or_else(|| {
            Error::Other(format!(
                "{}: upstream stage {} has no '{output}' output",
                s.name, s.upstream[key]
            ))
        })
    }

    pub(crate) fn optional(&self, name: &Option<String>, output: &str) -> Option<PathBuf> {
        name.as_ref()
            .and_then(|n| self.done.get(n))
            .and_then(|d| d.output(output))
    }
}

/// Run stage `s` into `out` as its kind does (`kinds/<kind>.rs`).
pub fn execute(s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
    s.kind.def().execute(s, ctx, out)
}

pub(crate) fn sum<T: serde::Serialize>(r: &T) -> Json {
    serde_json::to_value(r).unwrap_or(Json::Null)
}

/// `.work-<name>` beside the stage's cache directory `<name>`: named by the stage's
/// key, so only the holder of the stage's lock uses it, and not swept with the
/// stage's temporary directory.
pub(crate) fn work_dir(stage_dir: &Path) -> PathBuf {
    let cache = stage_dir.parent().unwrap_or(stage_dir);
    let name = stage_dir
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    cache.join(format!(".work-{name}"))
}

/// Move every plain file (tables, sidecars, manifest) of `from` into `to`.
pub(crate) fn move_files(from: &Path, to: &Path) -> Result<()> {
    for e in std::fs::read_dir(from)
        .map_err(|e| Error::io(from, e))?
        .flatten()
    {
        if e.path().is_file() {
            let dest = to.join(e.file_name());
            std::fs::rename(e.path(), &dest).map_err(|err| Error::io(&dest, err))?;
        }
    }
    Ok(())
}
