//! Reading a pipeline file: TOML syntax, where each key sits (so every later error can
//! name its line), the split into branches and stages, and `--set` overrides.

use super::schema::{Kind, PipelineSchema};
use crate::error::{Error, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The file's text and the line of every key, by dotted path (`experiment.fit.method`).
pub struct Source {
    pub file: PathBuf,
    pub text: String,
    lines: HashMap<String, usize>,
    /// Keys set with `--set`, by dotted path → the argument, for error locations.
    overridden: HashMap<String, String>,
}

impl Source {
    pub fn read(file: &Path) -> Result<(Source, toml::Table)> {
        let text = std::fs::read_to_string(file).map_err(|e| Error::io(file, e))?;
        // toml's own message names line and column and quotes the line.
        let doc: toml::Table = toml::from_str(&text)
            .map_err(|e| Error::input(file.display(), format!("TOML syntax: {e}")))?;
        let mut lines = HashMap::new();
        if let Ok(spanned) = toml::de::DeTable::parse(&text) {
            collect_lines(&text, spanned.get_ref(), "", &mut lines);
        }
        let src = Source {
            file: file.to_path_buf(),
            text,
            lines,
            overridden: HashMap::new(),
        };
        Ok((src, doc))
    }

    pub fn line(&self, path: &str) -> Option<usize> {
        self.lines.get(path).copied()
    }

    /// Where a key came from: "line N", "--set ARG", or the nearest enclosing table's line.
    pub fn loc(&self, path: &str) -> String {
        if let Some(arg) = self.overridden.get(path) {
            return format!("--set {arg}");
        }
        let mut p = path;
        loop {
            if let Some(n) = self.line(p) {
                return format!("line {n}");
            }
            match p.rsplit_once('.') {
                Some((head, _)) => p = head,
                None => return "file".into(),
            }
        }
    }

    /// An error about the key at `path`, naming file, line and key.
    pub fn err(&self, path: &str, msg: impl std::fmt::Display) -> Error {
        Error::input(
            self.file.display(),
            format!("{}: {path}: {msg}", self.loc(path)),
        )
    }
}

fn collect_lines(
    text: &str,
    t: &toml::de::DeTable<'_>,
    prefix: &str,
    out: &mut HashMap<String, usize>,
) {
    for (k, v) in t.iter() {
        let path = if prefix.is_empty() {
            k.get_ref().to_string()
        } else {
            format!("{prefix}.{}", k.get_ref())
        };
        let line = text[..k.span().start.min(text.len())].matches('\n').count() + 1;
        out.entry(path.clone()).or_insert(line);
        if let toml::de::DeValue::Table(sub) = v.get_ref() {
            collect_lines(text, sub, &path, out);
        }
    }
}

/// One stage table before validation.
#[derive(Debug, Clone)]
pub struct RawStage {
    /// `branch.name` or `name`.
    pub name: String,
    pub branch: Option<String>,
    pub kind: Kind,
    pub table: toml::Table,
    /// Position in the file (ties in the run order follow the file).
    pub line: usize,
}

pub struct RawPipeline {
    pub header: toml::Table,
    /// The `[executor]` table (empty when absent).
    pub executor: toml::Table,
    pub stages: Vec<RawStage>,
    pub branches: Vec<String>,
}

fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Split the document into the header, branches and stages.
pub fn structure(src: &Source, doc: toml::Table) -> Result<RawPipeline> {
    let mut header = toml::Table::new();
    let mut executor = toml::Table::new();
    let mut stages = Vec::new();
    let mut branches = Vec::new();
    for (key, value) in doc {
        if key == "pipeline" || key == "executor" {
            let t = match value {
                toml::Value::Table(t) => t,
                other => {
                    return Err(src.err(
                        &key,
                        format!("expected a table, found {}", other.type_str()),
                    ));
                }
            };
            if key == "pipeline" {
                header = t;
            } else {
                executor = t;
            }
            continue;
        }
        let toml::Value::Table(table) = value else {
            return Err(src.err(&key, "unknown top-level key; a pipeline file holds [pipeline], stage tables such as [report] and branch tables such as [experiment.ingest]"));
        };
        if !valid_name(&key) {
            return Err(src.err(
                &key,
                "stage and branch names use letters, digits, '_' and '-'",
            ));
        }
        if Kind::from_name(&key).is_some() || table.contains_key("kind") {
            stages.push(stage(src, &key, None, table)?);
            continue;
        }
        if table.is_empty() {
            return Err(src.err(&key, format!("neither a stage (name it after a kind: {}, or give kind = \"...\") nor a branch of stages", Kind::names())));
        }
        for (sub, v) in table {
            let name = format!("{key}.{sub}");
            let toml::Value::Table(t) = v else {
                return Err(src.err(&name, format!("branch '{key}' holds stage tables ([{name}]), found {}; a top-level stage is named after its kind ({}) or has a `kind` key", v.type_str(), Kind::names())));
            };
            if !valid_name(&sub) {
                return Err(src.err(&name, "stage names use letters, digits, '_' and '-'"));
            }
            stages.push(stage(src, &sub, Some(&key), t)?);
        }
        branches.push(key);
    }
    stages.sort_by_key(|s| s.line);
    Ok(RawPipeline {
        header,
        executor,
        stages,
        branches,
    })
}

fn stage(src: &Source, local: &str, branch: Option<&str>, table: toml::Table) -> Result<RawStage> {
    let name = match branch {
        Some(b) => format!("{b}.{local}"),
        None => local.to_string(),
    };
    let named = Kind::from_name(local);
    let kind = match table.get("kind") {
        None => named.ok_or_else(|| {
            src.err(&name, format!("unknown stage kind '{local}': name the stage after its kind ({}) or give kind = \"...\"", Kind::names()))
        })?,
        Some(toml::Value::String(k)) => {
            let kind = Kind::from_name(k).ok_or_else(|| {
                src.err(&format!("{name}.kind"), format!("unknown kind '{k}'; kinds: {}", Kind::names()))
            })?;
            if named.is_some_and(|n| n != kind) {
                return Err(src.err(&format!("{name}.kind"), format!("a stage named '{local}' must be of kind {local}, not {k}")));
            }
            kind
        }
        Some(other) => return Err(src.err(&format!("{name}.kind"), format!("expected a string, found {}", other.type_str()))),
    };
    Ok(RawStage {
        line: src.line(&name).unwrap_or(0),
        name,
        branch: branch.map(String::from),
        kind,
        table,
    })
}

/// Apply `--set STAGE.KEY=VALUE`: STAGE is a stage name or a kind (every stage of that
/// kind); VALUE is read as a TOML value (`1e-3`, `true`, `[1, 2]`), else as a string.
pub fn apply_overrides(
    src: &mut Source,
    stages: &mut [RawStage],
    schema: &PipelineSchema,
    sets: &[String],
) -> Result<()> {
    for arg in sets {
        let bad = |msg: String| Error::param("--set", format!("{arg}: {msg}"));
        let (lhs, value) = arg
            .split_once('=')
            .ok_or_else(|| bad("expected STAGE.KEY=VALUE".into()))?;
        let (sel, key) = lhs.trim().rsplit_once('.').ok_or_else(|| {
            bad("expected STAGE.KEY=VALUE (a stage name or kind, a dot, a key)".into())
        })?;
        let by_name: Vec<usize> = (0..stages.len())
            .filter(|&i| stages[i].name == sel)
            .collect();
        let hits = if by_name.is_empty() {
            (0..stages.len())
                .filter(|&i| stages[i].kind.name() == sel)
                .collect()
        } else {
            by_name
        };
        if hits.is_empty() {
            let names: Vec<&str> = stages.iter().map(|s| s.name.as_str()).collect();
            return Err(bad(format!(
                "'{sel}' is no stage or stage kind of this pipeline; stages: {}",
                names.join(", ")
            )));
        }
        let parsed = toml::from_str::<toml::Table>(&format!("v = {}", value.trim()))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.trim().to_string()));
        for i in hits {
            let s = &mut stages[i];
            if key == "kind" || schema.key(s.kind, key).is_none() {
                return Err(bad(format!(
                    "unknown key '{key}' for {} stage '{}'; allowed: {}",
                    s.kind.name(),
                    s.name,
                    schema
                        .stage(s.kind)
                        .keys
                        .iter()
                        .map(|k| k.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
            s.table.insert(key.to_string(), parsed.clone());
            src.overridden
                .insert(format!("{}.{key}", s.name), arg.clone());
        }
    }
    Ok(())
}

impl super::kinds::Locate for Source {
    fn locate(&self, path: &str, msg: String) -> Error {
        self.err(path, msg)
    }
}
