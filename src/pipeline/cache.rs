//! Content-addressed stage outputs: `runs/cache/<kind>-<hash>/`. A stage is computed in a
//! temporary sibling directory, its record (`stage.json`) and then the completion marker
//! are written last, and the directory is renamed into place; so a directory under the
//! final name is complete, and anything interrupted is a `.tmp-*` directory that is never
//! read. The record lists every output file's size and SHA-256: a hit is served only if
//! the sizes match (and the hashes, when asked), and a damaged entry is moved aside to
//! `.damaged-<name>-<time>/` and recomputed. Computing takes the stage's lock
//! (`super::lock`), so concurrent runs compute each stage once, and the stage's
//! temporary directories are swept only by the lock's holder: nobody else, on any
//! machine, can be writing them then.

use super::lock::{LockEvent, StageLock, hostname};
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
    /// SHA-256 of the canonical JSON of (tool, version, source hash, kind, params,
    /// upstream, files).
    pub key: String,
    pub tool: String,
    pub tool_version: String,
    /// The build's source hash for this kind (`source_key`), which the key covers.
    #[serde(default)]
    pub source_sha256: Option<String>,
    /// SHA-256 of the executable that computed the stage (provenance; not in the key).
    #[serde(default)]
    pub executable_sha256: Option<String>,
    /// The Slurm job that computed the stage, with its node, if one did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slurm_job: Option<String>,
    /// Parameters that entered the key (references and paths enter as hashes instead).
    pub params: Json,
    /// Upstream stage keys, by the key that refers to them.
    pub upstream: BTreeMap<String, String>,
    /// SHA-256 of input files, by key.
    pub files: BTreeMap<String, String>,
    /// Output files, by name, relative to the stage directory.
    pub outputs: BTreeMap<String, String>,
    /// Every file in the stage directory but `stage.json` and `.complete`, by path
    /// relative to it ('/'-separated), as written (after paths were relocated). `None`
    /// in records of older builds: such an entry cannot be verified and is recomputed.
    #[serde(default)]
    pub output_files: Option<BTreeMap<String, FileSum>>,
    /// Key numbers for run manifests (Θ, η_c, N, frames, ...).
    pub metrics: Json,
    /// The stage function's own report.
    pub summary: Json,
    pub elapsed_s: f64,
    pub created: String,
    pub computed_in_run: String,
}

/// Size (bytes) and SHA-256 (hex) of one output file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileSum {
    pub size: u64,
    pub sha256: String,
}

/// How thoroughly a cache entry is checked before it is served.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// Every listed file present with its recorded size: a truncated or partly
    /// written file, a deleted one. Costs a `stat` per file.
    Sizes,
    /// Sizes, then every file's SHA-256: also a same-size corruption.
    Sha256,
}

impl Check {
    pub fn name(self) -> &'static str {
        match self {
            Check::Sizes => "sizes",
            Check::Sha256 => "sha256",
        }
    }
}

/// What checking one cache directory found.
#[derive(Debug)]
pub enum Verdict {
    Ok(Box<StageRecord>),
    /// No complete entry (absent, or without its completion marker).
    Missing,
    /// A complete entry whose record lists no sizes or hashes.
    Unverifiable(String),
    /// What is wrong, naming the files with expected and found size or hash.
    Damaged(String),
}

/// Check the entry in `dir` (a complete stage directory) against its record; `key`,
/// when given, must be the record's. Every problem is listed, not just the first.
pub fn check_dir(dir: &Path, key: Option<&str>, how: Check) -> Verdict {
    if !dir.join(MARKER).is_file() {
        return Verdict::Missing;
    }
    let text = match std::fs::read_to_string(dir.join(RECORD)) {
        Ok(t) => t,
        Err(e) => return Verdict::Damaged(format!("{RECORD}: unreadable ({e})")),
    };
    let r: StageRecord = match serde_json::from_str(&text) {
        Ok(r) => r,
        Err(e) => return Verdict::Damaged(format!("{RECORD}: not a stage record ({e})")),
    };
    let name = dir
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let expected = key.map_or_else(|| name.clone(), |k| dir_name(&r.kind, k));
    if key.is_some_and(|k| k != r.key) || dir_name(&r.kind, &r.key) != expected {
        return Verdict::Damaged(format!(
            "{RECORD}: record of {} {}, expected {expected}",
            r.kind,
            short(&r.key)
        ));
    }
    let Some(files) = &r.output_files else {
        return Verdict::Unverifiable(format!(
            "{RECORD} lists no output sizes or hashes (written by an older build)"
        ));
    };
    let mut bad = Vec::new();
    for (rel, sum) in files {
        match std::fs::metadata(dir.join(rel)) {
            Ok(m) if m.len() == sum.size => {}
            Ok(m) => bad.push(format!("{rel}: {} bytes, expected {}", m.len(), sum.size)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                bad.push(format!("{rel}: missing, expected {} bytes", sum.size));
            }
            Err(e) => bad.push(format!("{rel}: unreadable ({e})")),
        }
    }
    if bad.is_empty() && how == Check::Sha256 {
        for (rel, sum) in files {
            match crate::io::sha256_file(&dir.join(rel)) {
                Ok(h) if h == sum.sha256 => {}
                Ok(h) => bad.push(format!(
                    "{rel}: sha256 {}, expected {}",
                    short(&h),
                    short(&sum.sha256)
                )),
                Err(e) => bad.push(format!("{rel}: unreadable ({e})")),
            }
        }
    }
    if bad.is_empty() {
        Verdict::Ok(Box::new(r))
    } else {
        Verdict::Damaged(bad.join("; "))
    }
}

/// The first 16 hex digits of a hash, enough to tell two apart in a message.
fn short(h: &str) -> String {
    format!("{}…", &h[..16.min(h.len())])
}

/// Size and SHA-256 of every file below `dir` but the record and the marker at its top.
fn sum_files(dir: &Path) -> Result<BTreeMap<String, FileSum>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, FileSum>) -> Result<()> {
        for e in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
            let p = e.map_err(|e| Error::io(dir, e))?.path();
            if p.is_dir() {
                walk(root, &p, out)?;
                continue;
            }
            let rel: Vec<String> = p
                .strip_prefix(root)
                .unwrap_or(&p)
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            let rel = rel.join("/");
            if rel == RECORD || rel == MARKER {
                continue;
            }
            let size = std::fs::metadata(&p).map_err(|e| Error::io(&p, e))?.len();
            let sha256 = crate::io::sha256_file(&p)?;
            out.insert(rel, FileSum { size, sha256 });
        }
        Ok(())
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out)?;
    Ok(out)
}

/// Heard while claiming a stage, for the caller to print.
pub enum CacheEvent<'a> {
    Lock(LockEvent<'a>),
    /// A damaged entry, what is wrong with it, and where it was moved.
    Damaged(&'a str, &'a Path),
    Unverifiable(&'a str),
}

/// A stage to serve from the cache, or to compute under its lock.
pub enum Claim {
    Cached(Box<StageRecord>),
    Compute {
        lock: StageLock,
        /// Why an existing entry was not served (damaged, unverifiable).
        because: Option<String>,
    },
}

/// One cache entry as `runs verify` found it.
pub struct EntryCheck {
    pub name: String,
    pub verdict: Verdict,
    /// Where a damaged entry was moved, or why it was left in place.
    pub moved: std::result::Result<PathBuf, String>,
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
    kind: super::Kind,
    params: &Json,
    upstream: &BTreeMap<String, String>,
    files: &BTreeMap<String, String>,
) -> String {
    stage_key_with(
        kind,
        super::source_key::source_hash(kind),
        params,
        upstream,
        files,
    )
}

/// The key with a given source hash (another build's, in tests).
pub fn stage_key_with(
    kind: super::Kind,
    source: &str,
    params: &Json,
    upstream: &BTreeMap<String, String>,
    files: &BTreeMap<String, String>,
) -> String {
    let v = serde_json::json!({
        "tool": crate::stages::TOOL,
        "tool_version": crate::stages::VERSION,
        "source": source,
        "kind": kind.name(),
        "params": params,
        "upstream": upstream,
        "files": files,
    });
    sha256_bytes(canonical(&v).as_bytes())
}

/// SHA-256 of the running executable, recorded with each stage it computes (which
/// binary made this), but no longer part of the key: any relink would change it.
/// Hashed once per process.
pub fn executable_sha256() -> &'static str {
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

    fn lock_path(&self, name: &str) -> PathBuf {
        self.dir.join(format!(".lock-{name}"))
    }

    /// The record of a complete cached stage with this key whose files have their
    /// recorded sizes, if any.
    pub fn lookup(&self, kind: &str, key: &str) -> Option<StageRecord> {
        match check_dir(&self.path(kind, key), Some(key), Check::Sizes) {
            Verdict::Ok(r) => Some(*r),
            _ => None,
        }
    }

    /// Serve the stage from the cache if a whole entry passes `how`, else take its lock
    /// (waiting while another process computes it, then looking again) for the caller
    /// to compute it. A damaged entry is moved aside first; `force` skips the cache.
    pub fn claim(
        &self,
        kind: &str,
        key: &str,
        force: bool,
        how: Check,
        events: &mut dyn FnMut(CacheEvent),
    ) -> Result<Claim> {
        let dir = self.path(kind, key);
        if !force && let Verdict::Ok(r) = check_dir(&dir, Some(key), how) {
            return Ok(Claim::Cached(r));
        }
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        let name = dir_name(kind, key);
        let lock = StageLock::take(&self.lock_path(&name), &mut |e| events(CacheEvent::Lock(e)))?;
        if force {
            return Ok(Claim::Compute {
                lock,
                because: None,
            });
        }
        // Looked up again under the lock: the process we waited for has usually
        // finished the stage, and a damaged entry is moved only by the lock's holder.
        let because = match check_dir(&dir, Some(key), how) {
            Verdict::Ok(r) => return Ok(Claim::Cached(r)),
            Verdict::Missing => None,
            Verdict::Unverifiable(why) => {
                events(CacheEvent::Unverifiable(&why));
                Some(format!("unverifiable: {why}"))
            }
            Verdict::Damaged(what) => {
                let to = self.move_aside(&name)?;
                events(CacheEvent::Damaged(&what, &to));
                Some(format!("damaged: {what}"))
            }
        };
        Ok(Claim::Compute { lock, because })
    }

    /// Move the entry `name` to `.damaged-<name>-<UTC time>/`, kept for inspection.
    fn move_aside(&self, name: &str) -> Result<PathBuf> {
        let from = self.dir.join(name);
        let to = self
            .dir
            .join(format!(".damaged-{name}-{}", super::runs::now_stamp()));
        std::fs::rename(&from, &to).map_err(|e| Error::io(&from, e))?;
        Ok(to)
    }

    /// Hash-check one entry (`runs verify`); a damaged one is moved aside unless another
    /// process holds its lock (it is recomputing it). Entries whose record predates
    /// output hashes are reported, not moved: a run never serves them.
    pub fn verify_entry(&self, name: &str, key: Option<&str>) -> Result<EntryCheck> {
        let verdict = check_dir(&self.dir.join(name), key, Check::Sha256);
        let mut moved = Err(String::new());
        if matches!(verdict, Verdict::Damaged(_)) {
            moved = match StageLock::try_take(&self.lock_path(name))? {
                super::lock::Attempt::Taken(_lock) => Ok(self.move_aside(name)?),
                super::lock::Attempt::Held(info, _) => Err(format!(
                    "left in place: being recomputed by {}",
                    info.map_or_else(|| "another process".into(), |i| i.holder())
                )),
            };
        }
        Ok(EntryCheck {
            name: name.to_string(),
            verdict,
            moved,
        })
    }

    /// Names of the cache's entries (sorted) and of the damaged entries kept aside.
    pub fn entries(&self) -> Result<(Vec<String>, Vec<String>)> {
        let (mut live, mut aside) = (Vec::new(), Vec::new());
        let rd = match std::fs::read_dir(&self.dir) {
            Ok(rd) => rd,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok((live, aside)),
            Err(e) => return Err(Error::io(&self.dir, e)),
        };
        for e in rd.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if !e.path().is_dir() {
                continue;
            }
            if n.starts_with(".damaged-") {
                aside.push(n);
            } else if !n.starts_with('.') {
                live.push(n);
            }
        }
        live.sort();
        aside.sort();
        Ok((live, aside))
    }

    /// Compute a stage into a temporary directory with `f(tmp, final)` and move it into
    /// place; replaces an existing directory (forced or incomplete). `_lock`, the
    /// stage's lock from `claim`, must be held for the whole of it.
    pub fn compute<F>(&self, kind: &str, key: &str, _lock: &StageLock, f: F) -> Result<StageRecord>
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
        let me = format!("{}-{}", hostname(), std::process::id());
        let tmp = self.dir.join(format!(".tmp-{name}-{me}-{nonce}"));
        std::fs::create_dir_all(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let result = f(&tmp, &fin).and_then(|rec| {
            let text = serde_json::to_string_pretty(&rec).expect("json");
            atomic_write_str(&tmp.join(RECORD), &text)?;
            relocate_json(&tmp, &tmp, &fin)?;
            let text = std::fs::read_to_string(tmp.join(RECORD)).map_err(|e| Error::io(&tmp, e))?;
            let mut rec: StageRecord = serde_json::from_str(&text).expect("just written");
            // Summed as they will be served: after the paths in them were relocated.
            rec.output_files = Some(sum_files(&tmp)?);
            let text = serde_json::to_string_pretty(&rec).expect("json");
            atomic_write_str(&tmp.join(RECORD), &text)?;
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
            let old = self.dir.join(format!(".old-{name}-{me}-{nonce}"));
            std::fs::rename(&fin, &old).map_err(|e| Error::io(&fin, e))?;
            let _ = std::fs::remove_dir_all(&old);
        }
        if let Err(e) = std::fs::rename(&tmp, &fin) {
            let _ = std::fs::remove_dir_all(&tmp);
            // Only after our lock was broken as stale can another run have finished
            // the same stage meanwhile: its output is as good as ours.
            return self.lookup(kind, key).ok_or_else(|| Error::io(&fin, e));
        }
        Ok(rec)
    }

    /// Remove this stage's temporary and replaced directories and lock leftovers. Only
    /// the lock's holder calls it, so whatever it finds was left by a process that died
    /// (or whose lock was broken as stale), on whichever machine.
    fn sweep(&self, name: &str) {
        let Ok(rd) = std::fs::read_dir(&self.dir) else {
            return;
        };
        let prefixes = [
            format!(".tmp-{name}-"),
            format!(".old-{name}-"),
            format!(".lock-{name}."),
        ];
        for e in rd.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            if !prefixes.iter().any(|p| n.starts_with(p.as_str())) {
                continue;
            }
            let p = e.path();
            let _ = if p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else {
                std::fs::remove_file(&p)
            };
        }
    }
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
