//! Tracked runs: `runs/<id>/manifest.json` (what ran, with which parameters and inputs,
//! what was cached, key metrics) and the `runs list | show | compare` views of them.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const MANIFEST: &str = "manifest.json";

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PipelineInfo {
    pub name: String,
    pub title: String,
    pub description: Option<String>,
    pub file: String,
    pub sha256: String,
    pub root: String,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct InputFile {
    pub path: String,
    pub sha256: String,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StageRun {
    pub name: String,
    pub kind: String,
    pub key: String,
    /// Output directory, relative to the runs directory.
    pub dir: String,
    pub cached: bool,
    /// How the output was checked: "sizes" or "sha256" (a cache hit), "computed".
    /// Empty in manifests written before outputs were verified.
    #[serde(default)]
    pub verified: String,
    /// Why a cached entry was not used (damaged, unverifiable); it was recomputed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recomputed_because: Option<String>,
    /// Time spent in this run (near zero when cached).
    pub elapsed_s: f64,
    /// Time the computation took when it ran.
    pub compute_s: f64,
    pub outputs: BTreeMap<String, String>,
    /// The Slurm job that computed the stage in this run (`--executor slurm`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slurm: Option<SlurmStage>,
}

/// A stage's Slurm job as the run saw it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SlurmStage {
    /// `ARRAY_TASK`.
    pub job: String,
    /// Where it ran (empty while queued).
    pub node: String,
    /// Wall time of the job's stage process, seconds.
    pub wall_s: Option<f64>,
    pub log: String,
    /// queued, running, done, failed, cancelled (an upstream stage failed).
    pub state: String,
    /// How many times the stage was submitted in this run.
    pub attempts: u32,
}

/// `runs/<id>/manifest.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunManifest {
    pub run_id: String,
    /// "ok", "failed", "incomplete" (running, or killed), or "submitted" (Slurm,
    /// `--detach`: `runs show` looks the stages up).
    pub status: String,
    /// "slurm" when the stages ran as Slurm jobs; absent for local runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub executor: Option<String>,
    pub failed_stage: Option<String>,
    pub error: Option<String>,
    pub started: String,
    pub elapsed_s: f64,
    pub tool: String,
    pub tool_version: String,
    pub pipeline: PipelineInfo,
    pub overrides: Vec<String>,
    pub forced: Vec<String>,
    /// Resolved parameters of every stage (defaults filled).
    pub parameters: BTreeMap<String, Json>,
    pub seeds: BTreeMap<String, u64>,
    /// Input files by `stage.key`.
    pub inputs: BTreeMap<String, InputFile>,
    pub stages: Vec<StageRun>,
    /// Key metrics by stage: Θ, η_c with intervals (fit), N and frames (ingest,
    /// simulate), mean flow stress (simulate), agreement (compare).
    pub metrics: BTreeMap<String, Json>,
    /// The report, relative to the run directory.
    pub report: Option<String>,
}

/// Broken-down UTC time (no time-zone database needed): (y, m, d, H, M, S).
fn utc(secs: i64) -> (i64, u32, u32, u32, u32, u32) {
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    let (h, mi, s) = (rem / 3600, rem % 3600 / 60, rem % 60);
    (y, m, d, h as u32, mi as u32, s as u32)
}

fn now() -> (i64, u32) {
    let d = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    (d.as_secs() as i64, d.subsec_millis())
}

/// Now as ISO 8601 UTC.
pub fn now_iso() -> String {
    let (s, ms) = now();
    let (y, m, d, h, mi, sec) = utc(s);
    format!("{y:04}-{m:02}-{d:02}T{h:02}:{mi:02}:{sec:02}.{ms:03}Z")
}

/// Now as a compact UTC stamp for file names, `YYYYmmddTHHMMSS.mmmZ`.
pub fn now_stamp() -> String {
    let (s, ms) = now();
    let (y, m, d, h, mi, sec) = utc(s);
    format!("{y:04}{m:02}{d:02}T{h:02}{mi:02}{sec:02}.{ms:03}Z")
}

/// A new run directory `YYYYmmdd-HHMMSS-mmm-<config>`: sorts by start time (UTC, to the
/// millisecond), and runs of the same resolved pipeline share the suffix (the first six
/// hex digits of the hash of its stage keys). Created exclusively, so ids are unique.
pub fn new_run_dir(runs: &Path, config_hash: &str) -> Result<(String, PathBuf)> {
    std::fs::create_dir_all(runs).map_err(|e| Error::io(runs, e))?;
    loop {
        let (s, ms) = now();
        let (y, m, d, h, mi, sec) = utc(s);
        let id = format!(
            "{y:04}{m:02}{d:02}-{h:02}{mi:02}{sec:02}-{ms:03}-{}",
            &config_hash[..6.min(config_hash.len())]
        );
        let dir = runs.join(&id);
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok((id, dir)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            Err(e) => return Err(Error::io(&dir, e)),
        }
    }
}

/// Every tracked run under `runs`, oldest first (directories without a run manifest,
/// such as `cache/` or the `quickstart` command's output, are skipped).
pub fn list(runs: &Path) -> Result<Vec<RunManifest>> {
    let mut out = Vec::new();
    let rd = match std::fs::read_dir(runs) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(out),
        Err(e) => return Err(Error::io(runs, e)),
    };
    for e in rd.flatten() {
        let m = e.path().join(MANIFEST);
        if let Ok(text) = std::fs::read_to_string(&m)
            && let Ok(r) = serde_json::from_str::<RunManifest>(&text)
        {
            out.push(r);
        }
    }
    out.sort_by(|a, b| a.run_id.cmp(&b.run_id));
    Ok(out)
}

/// A run by id, unique id prefix, or `latest`.
pub fn find(runs: &Path, id: &str) -> Result<RunManifest> {
    let all = list(runs)?;
    let hits: Vec<&RunManifest> = if id == "latest" {
        all.last().into_iter().collect()
    } else if let Some(r) = all.iter().find(|r| r.run_id == id) {
        vec![r]
    } else {
        all.iter().filter(|r| r.run_id.starts_with(id)).collect()
    };
    match hits.as_slice() {
        [one] => Ok((*one).clone()),
        [] => Err(Error::param(
            "run",
            format!(
                "no run '{id}' in {} ({} runs; see `pillar-pipe runs list`)",
                runs.display(),
                all.len()
            ),
        )),
        many => Err(Error::param(
            "run",
            format!(
                "'{id}' matches {} runs: {}",
                many.len(),
                many.iter()
                    .map(|r| r.run_id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn utc_dates() {
        assert_eq!(super::utc(0), (1970, 1, 1, 0, 0, 0));
        // A leap day, and the last second of a century year.
        assert_eq!(super::utc(951_782_400 + 3661), (2000, 2, 29, 1, 1, 1));
        assert_eq!(super::utc(4_102_444_799), (2099, 12, 31, 23, 59, 59));
    }
}
