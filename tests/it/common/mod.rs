//! Helpers shared by the integration tests: scratch directories, the CLI (alone or
//! against a runs directory), manifests, the cache.

#![allow(dead_code)]

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

pub const BIN: &str = env!("CARGO_BIN_EXE_pillar-pipe");
pub const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// A fresh scratch directory, removed when the test that made it passes (kept when it
/// fails, to look at; a test run used to leave a hundred directories behind).
pub fn tmpdir(name: &str) -> TmpDir {
    let d = std::env::temp_dir().join(format!("pp-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TmpDir(d)
}

/// See [`tmpdir`]; derefs to its path.
#[derive(Debug)]
pub struct TmpDir(PathBuf);

impl std::ops::Deref for TmpDir {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl AsRef<Path> for TmpDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TmpDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Run the CLI: (success, stdout followed by stderr).
pub fn cli(args: &[&str]) -> (bool, String) {
    let out = Command::new(BIN).args(args).output().expect("binary runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

pub fn bundled(name: &str) -> String {
    Path::new(ROOT)
        .join("pipelines")
        .join(format!("{name}.toml"))
        .display()
        .to_string()
}

/// Run the CLI with `--runs-dir runs`: (success, stdout, stderr).
pub fn pp(args: &[&str], runs: &Path) -> (bool, String, String) {
    let o = Command::new(BIN)
        .args(args)
        .arg("--runs-dir")
        .arg(runs)
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

pub fn run_ok(args: &[&str], runs: &Path) -> String {
    let (ok, out, err) = pp(args, runs);
    assert!(ok, "pillar-pipe {args:?} failed:\n{out}\n{err}");
    out
}

/// The newest run's manifest.
pub fn latest(runs: &Path) -> Value {
    let mut ids: Vec<String> = std::fs::read_dir(runs)
        .unwrap()
        .flatten()
        .filter(|e| e.path().join("manifest.json").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    ids.sort();
    let text = std::fs::read_to_string(runs.join(ids.last().unwrap()).join("manifest.json"));
    serde_json::from_str(&text.unwrap()).unwrap()
}

/// The cache folder of stage `name` in the run manifest `m` under `runs`.
pub fn stage_dir(m: &Value, runs: &Path, name: &str) -> PathBuf {
    let st = m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == name)
        .unwrap_or_else(|| panic!("no stage {name}: {m}"));
    runs.join(st["dir"].as_str().unwrap())
}

/// Names of the stages a run computed (not taken from the cache).
pub fn computed(m: &Value) -> Vec<String> {
    m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["cached"] == Value::Bool(false))
        .map(|s| s["name"].as_str().unwrap().to_string())
        .collect()
}

/// Every file under the cache with its modification time.
pub fn cache_files(dir: &Path, out: &mut BTreeMap<PathBuf, SystemTime>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            cache_files(&p, out);
        } else {
            out.insert(p.clone(), e.metadata().unwrap().modified().unwrap());
        }
    }
}

/// Stage directories under their final name, each of which must be complete.
pub fn final_dirs(runs: &Path) -> Vec<PathBuf> {
    let Ok(rd) = std::fs::read_dir(runs.join("cache")) else {
        return Vec::new();
    };
    let dirs: Vec<PathBuf> = rd
        .flatten()
        .map(|e| e.path())
        .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .collect();
    for d in &dirs {
        assert!(
            d.join(".complete").is_file() && d.join("stage.json").is_file(),
            "{} looks like a stage output but is incomplete",
            d.display()
        );
    }
    dirs
}

/// A pipeline with the bundled sample's ingest stage, then `body`.
pub fn with_ingest(body: &str) -> String {
    format!(
        "[pipeline]\nroot = '{ROOT}'\n\n[experiment.ingest]\ninput = \"data/sample/tracks.csv\"\n\n{body}"
    )
}

pub fn line_of(text: &str, needle: &str) -> usize {
    1 + text.lines().position(|l| l.starts_with(needle)).unwrap()
}

/// Run the CLI under a file-size limit of `blocks` (`ulimit -f`, 512-byte blocks in
/// dash): (success, stdout followed by stderr).
pub fn cli_file_limit(blocks: u32, args: &[&str]) -> (bool, String) {
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -f {blocks}; exec \"$0\" \"$@\""))
        .arg(BIN)
        .args(args)
        .output()
        .expect("sh runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// Names of the files in `dir`, sorted.
pub fn file_names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Whether a pipeline's simulate stage has written a checkpoint in its work directory
/// (`runs/cache/.work-simulate-*/checkpoint.bin`): the run is provably under way.
pub fn simulation_checkpointed(cache: &Path) -> bool {
    std::fs::read_dir(cache)
        .into_iter()
        .flatten()
        .flatten()
        .any(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with(".work-simulate-")
                && e.path().join("checkpoint.bin").exists()
        })
}

/// A check this machine cannot make: under `CI=true` (where CI provides the thing) that is
/// a failure; elsewhere it is reported as a skip on stderr, never silently passed.
pub fn cannot_check(what: &str) {
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{what}, but CI=true: CI must provide it");
    }
    eprintln!("SKIP: {what}");
}

/// Write `text` to the pipeline file `file` and run it: the run must be refused before
/// anything runs, its error naming the file and containing every one of `needles`.
pub fn refused(file: &Path, runs: &Path, text: &str, needles: &[&str]) {
    std::fs::write(file, text).unwrap();
    let (ok, out, err) = pp(&["run", file.to_str().unwrap(), "--quiet"], runs);
    assert!(!ok, "{out}");
    for n in needles {
        assert!(err.contains(n), "missing '{n}' in: {err}");
    }
    let name = file.file_name().unwrap().to_string_lossy();
    assert!(err.contains(name.as_ref()), "{err}");
}
