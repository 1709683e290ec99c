//! Content-addressed stage outputs: `runs/cache/<kind>-<hash>/`. A stage is computed in a
//! temporary sibling directory, its record (`stage.json`) and then the completion marker
//! are written last, and the directory is renamed into place; so a directory under the
//! final name is complete, and anything interrupted is a `.tmp-*` directory that is never
//! read (and is swept once the process that made it is gone).

use crate::error::{Error, Result};
use crate::io::atomic_write_str;
use crate::io::hash::sha256_bytes;
use serde::{Deserialize, Serialize};
use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const MARKER: &str = ".complete";
pub const RECORD: &str = "stage.json";

/// What a cached stage directory holds besides its outputs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StageRecord {
    pub kind: String,
    /// SHA-256 of the canonical JSON of (tool, version, kind, params, upstream, files).
    pub key: String,
    pub tool: String,
    pub tool_version: String,
    /// Parameters that entered the key (references and paths enter as hashes instead).
    pub params: Json,
    /// Upstream stage keys, by the key that refers to them.
    pub upstream: BTreeMap<String, String>,
    /// SHA-256 of input files, by key.
    pub files: BTreeMap<String, String>,
    /// Output files, by name, relative to the stage directory.
    pub outputs: BTreeMap<String, String>,
    /// Key numbers for run manifests (Θ, η_c, N, frames, ...).
    pub metrics: Json,
    /// The stage function's own report.
    pub summary: Json,
    pub elapsed_s: f64,
    pub created: String,
    pub computed_in_run: String,
}

/// JSON with object keys sorted at every level, no whitespace: the hashed form.
pub fn canonical(v: &Json) -> String {
    match v {
        Json::Object(m) => {
            let sorted: BTreeMap<&String, &Json> = m.iter().collect();
            let body: Vec<String> = sorted
                .iter()
                .map(|(k, v)| format!("{}:{}", Json::String((*k).clone()), canonical(v)))
                .collect();
            format!("{{{}}}", body.join(","))
        }
        Json::Array(a) => format!(
            "[{}]",
            a.iter().map(canonical).collect::<Vec<_>>().join(",")
        ),
        other => other.to_string(),
    }
}

pub fn stage_key(
    kind: &str,
    params: &Json,
    upstream: &BTreeMap<String, String>,
    files: &BTreeMap<String, String>,
) -> String {
    let v = serde_json::json!({
        "tool": crate::stages::TOOL,
        "tool_version": crate::stages::VERSION,
        "build": build_id(),
        "kind": kind,
        "params": params,
        "upstream": upstream,
        "files": files,
    });
    sha256_bytes(canonical(&v).as_bytes())
}

/// SHA-256 of the running executable: a rebuilt tool (new code, same version number)
/// must not reuse outputs the old code computed. Hashed once per process.
pub fn build_id() -> &'static str {
    static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ID.get_or_init(|| {
        std::env::current_exe()
            .ok()
            .and_then(|p| crate::io::sha256_file(&p).ok())
            .unwrap_or_else(|| "unknown".into())
    })
}

pub fn dir_name(kind: &str, key: &str) -> String {
    format!("{kind}-{}", &key[..16.min(key.len())])
}

pub struct Cache {
    pub dir: PathBuf,
}

impl Cache {
    pub fn path(&self, kind: &str, key: &str) -> PathBuf {
        self.dir.join(dir_name(kind, key))
    }

    /// The record of a complete cached stage with this key, if any.
    pub fn lookup(&self, kind: &str, key: &str) -> Option<StageRecord> {
        let d = self.path(kind, key);
        if !d.join(MARKER).is_file() {
            return None;
        }
        let text = std::fs::read_to_string(d.join(RECORD)).ok()?;
        let r: StageRecord = serde_json::from_str(&text).ok()?;
        // An output deleted by hand makes the entry stale rather than a broken input.
        let whole = r.outputs.values().all(|o| d.join(o).exists());
        (r.key == key && whole).then_some(r)
    }

    /// Compute a stage into a temporary directory with `f(tmp, final)` and move it into
    /// place; replaces an existing directory (forced or incomplete).
    pub fn compute<F>(&self, kind: &str, key: &str, f: F) -> Result<StageRecord>
    where
        F: FnOnce(&Path, &Path) -> Result<StageRecord>,
    {
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        let name = dir_name(kind, key);
        let fin = self.dir.join(&name);
        self.sweep(&name);
        let nonce = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let tmp = self
            .dir
            .join(format!(".tmp-{name}-{}-{nonce}", std::process::id()));
        std::fs::create_dir_all(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let result = f(&tmp, &fin).and_then(|rec| {
            let text = serde_json::to_string_pretty(&rec).expect("json");
            atomic_write_str(&tmp.join(RECORD), &text)?;
            relocate_json(&tmp, &tmp, &fin)?;
            let text = std::fs::read_to_string(tmp.join(RECORD)).map_err(|e| Error::io(&tmp, e))?;
            let rec: StageRecord = serde_json::from_str(&text).expect("just written");
            // Last: the marker that makes the directory count as complete.
            atomic_write_str(&tmp.join(MARKER), key)?;
            Ok(rec)
        });
        let rec = match result {
            Ok(r) => r,
            Err(e) => {
                let _ = std::fs::remove_dir_all(&tmp);
                return Err(e);
            }
        };
        if fin.exists() {
            // Move the old one aside first: the final name only ever holds a whole output.
            let old = self.dir.join(format!(".old-{name}-{}", std::process::id()));
            std::fs::rename(&fin, &old).map_err(|e| Error::io(&fin, e))?;
            let _ = std::fs::remove_dir_all(&old);
        }
        if let Err(e) = std::fs::rename(&tmp, &fin) {
            let _ = std::fs::remove_dir_all(&tmp);
            // Another run finished the same stage first: its output is as good as ours.
            return self.lookup(kind, key).ok_or_else(|| Error::io(&fin, e));
        }
        Ok(rec)
    }

    /// Remove temporary (and replaced) directories of this stage left by processes that
    /// no longer run.
    fn sweep(&self, name: &str) {
        let Ok(rd) = std::fs::read_dir(&self.dir) else {
            return;
        };
        let prefixes = [format!(".tmp-{name}-"), format!(".old-{name}-")];
        for e in rd.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            let Some(pid) = prefixes
                .iter()
                .find_map(|p| n.strip_prefix(p.as_str()))
                .and_then(|r| r.split('-').next())
            else {
                continue;
            };
            if !process_alive(pid) {
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
    }
}

/// Without /proc (not Linux) every process counts as alive and nothing is swept.
fn process_alive(pid: &str) -> bool {
    !Path::new("/proc/self").exists() || Path::new("/proc").join(pid).exists()
}

/// Stage functions record their output paths (fit.json names its scatter table); those
/// point into the temporary directory until it is renamed, so rewrite them now.
fn relocate_json(dir: &Path, tmp: &Path, fin: &Path) -> Result<()> {
    let (from, to) = (tmp.display().to_string(), fin.display().to_string());
    for e in std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .flatten()
    {
        let p = e.path();
        if p.is_dir() {
            relocate_json(&p, tmp, fin)?;
        } else if p.extension().is_some_and(|x| x == "json") {
            let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&p, e))?;
            if text.contains(&from) {
                atomic_write_str(&p, &text.replace(&from, &to))?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn canonical_json_ignores_key_order() {
        let a = serde_json::json!({"b": 1, "a": {"y": [1.5, "x"], "x": null}});
        let b: serde_json::Value =
            serde_json::from_str(r#"{"a": {"x": null, "y": [1.5, "x"]}, "b": 1}"#).unwrap();
        assert_eq!(super::canonical(&a), super::canonical(&b));
        assert_eq!(
            super::canonical(&a),
            r#"{"a":{"x":null,"y":[1.5,"x"]},"b":1}"#
        );
    }
}
