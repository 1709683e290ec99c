//! The cache trusts nothing blindly and loses nothing: a damaged entry (truncated, or
//! one byte flipped) is found, named, moved aside and recomputed, never served; two runs
//! of one pipeline at once compute each stage once; stage locks of dead processes, or
//! without a heartbeat, are broken, and live ones are waited for.

use crate::common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The only entry of this kind in the cache.
fn entry(runs: &Path, kind: &str) -> PathBuf {
    let dirs: Vec<PathBuf> = final_dirs(runs)
        .into_iter()
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with(&format!("{kind}-"))
        })
        .collect();
    assert_eq!(dirs.len(), 1, "{dirs:?}");
    dirs[0].clone()
}

fn stage<'a>(m: &'a Value, name: &str) -> &'a Value {
    m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == name)
        .unwrap_or_else(|| panic!("no stage {name} in {m}"))
}

fn dot_entries(runs: &Path, prefix: &str) -> Vec<String> {
    std::fs::read_dir(runs.join("cache"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix))
        .collect()
}

fn flip_byte(file: &Path, at: usize) {
    let mut b = std::fs::read(file).unwrap();
    b[at] ^= 0xff;
    std::fs::write(file, b).unwrap();
}

#[test]
fn damaged_cache_entries_are_found_moved_aside_and_recomputed() {
    let d = tmpdir("damaged");
    let runs = d.join("runs");
    let file = d.join("p.toml");
    std::fs::write(
        &file,
        with_ingest("[experiment.kinematics]\ninput = \"ingest\"\nlags = [1]\n"),
    )
    .unwrap();
    let p = file.to_str().unwrap();
    run_ok(&["run", p, "--quiet"], &runs);
    let tracks = entry(&runs, "ingest").join("tracks.parquet");
    let original = std::fs::read(&tracks).unwrap();
    assert!(original.len() > 1000);

    // Truncated: found by the size check of a plain run, named, moved aside, recomputed.
    std::fs::OpenOptions::new()
        .write(true)
        .open(&tracks)
        .unwrap()
        .set_len(1000)
        .unwrap();
    let (ok, out, err) = pp(&["run", p], &runs);
    assert!(ok, "{out}\n{err}");
    let expect = format!(
        "cached stage 'experiment.ingest' is damaged, recomputing: tracks.parquet: 1000 bytes, expected {}",
        original.len()
    );
    assert!(err.contains(&expect), "no '{expect}' in:\n{err}");
    let m = latest(&runs);
    assert_eq!(
        computed(&m),
        ["experiment.ingest"],
        "kinematics' key is unchanged"
    );
    let ingest = stage(&m, "experiment.ingest");
    assert_eq!(ingest["verified"], "computed");
    assert!(
        ingest["recomputed_because"]
            .as_str()
            .unwrap()
            .starts_with("damaged: tracks.parquet: 1000 bytes"),
        "{ingest}"
    );
    assert_eq!(stage(&m, "experiment.kinematics")["verified"], "sizes");
    assert_eq!(
        std::fs::read(&tracks).unwrap(),
        original,
        "recomputed alike"
    );
    let aside = dot_entries(&runs, ".damaged-ingest-");
    assert_eq!(aside.len(), 1, "kept for inspection");
    let kept = runs.join("cache").join(&aside[0]).join("tracks.parquet");
    assert_eq!(std::fs::metadata(kept).unwrap().len(), 1000);

    // Same size, one byte flipped: `runs verify --all` hashes, finds and moves it.
    flip_byte(&tracks, original.len() / 2);
    let (ok, out, err) = pp(&["runs", "verify", "--all"], &runs);
    assert!(!ok, "a damaged entry fails verify:\n{out}");
    assert!(err.contains("1 damaged cache entry"), "{err}");
    let line = out
        .lines()
        .find(|l| l.starts_with("ingest-"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        line.contains("DAMAGED") && line.contains("tracks.parquet: sha256 "),
        "{line}"
    );
    let line = out.lines().find(|l| l.starts_with("kinematics-")).unwrap();
    assert!(line.contains("OK"), "{line}");
    assert_eq!(out.matches("kept aside").count(), 2, "{out}");
    assert!(!tracks.exists(), "moved aside, so no run serves it");
    run_ok(&["run", p, "--quiet"], &runs);
    assert_eq!(computed(&latest(&runs)), ["experiment.ingest"]);
    assert_eq!(std::fs::read(&tracks).unwrap(), original);

    // Flipped again: `run --verify` hashes what it serves.
    flip_byte(&tracks, 100);
    let (ok, out, err) = pp(&["run", p, "--verify", "--quiet"], &runs);
    assert!(ok, "{out}\n{err}");
    assert!(
        err.contains("cached stage 'experiment.ingest' is damaged")
            && err.contains("tracks.parquet: sha256 "),
        "{err}"
    );
    assert_eq!(computed(&latest(&runs)), ["experiment.ingest"]);
    assert_eq!(std::fs::read(&tracks).unwrap(), original);
    run_ok(&["run", p, "--verify", "--quiet"], &runs);
    let m = latest(&runs);
    assert!(computed(&m).is_empty());
    for s in m["stages"].as_array().unwrap() {
        assert_eq!(s["verified"], "sha256", "{s}");
    }
    // The latest run's stages, whole again.
    let out = run_ok(&["runs", "verify"], &runs);
    assert_eq!(out.matches(" OK ").count(), 2, "{out}");
    assert_eq!(dot_entries(&runs, ".damaged-").len(), 3);
}

/// Two runs of one pipeline started together: the second waits for each stage the
/// first computes instead of computing it again.
#[test]
fn concurrent_runs_compute_each_stage_once() {
    let d = tmpdir("concurrent");
    let runs = d.join("runs");
    let file = d.join("sim.toml");
    // A few seconds of simulation, so that the two runs overlap.
    std::fs::write(
        &file,
        "[simulation.simulate]\npreset = \"fast\"\nn = 200\nstrain = 0.25\nseed = 3\n\n\
         [simulation.kinematics]\ninput = \"simulation.simulate\"\nlags = [1]\n",
    )
    .unwrap();
    let spawn = || {
        Command::new(BIN)
            .args(["run", file.to_str().unwrap(), "--runs-dir"])
            .arg(&runs)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (spawn(), spawn());
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    let text = |o: &std::process::Output| {
        format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )
    };
    let (ta, tb) = (text(&a), text(&b));
    assert!(a.status.success() && b.status.success(), "{ta}\n{tb}");
    let mut ms: Vec<Value> = std::fs::read_dir(&runs)
        .unwrap()
        .flatten()
        .filter_map(|e| std::fs::read_to_string(e.path().join("manifest.json")).ok())
        .map(|t| serde_json::from_str(&t).unwrap())
        .collect();
    assert_eq!(ms.len(), 2);
    ms.sort_by_key(|m| m["run_id"].as_str().unwrap().to_string());
    for name in ["simulation.simulate", "simulation.kinematics"] {
        let times = ms
            .iter()
            .filter(|m| stage(m, name)["cached"] == false)
            .count();
        assert_eq!(times, 1, "{name} computed {times} times:\n{ta}\n{tb}");
        assert_eq!(stage(&ms[0], name)["dir"], stage(&ms[1], name)["dir"]);
    }
    assert_eq!(ms[0]["metrics"], ms[1]["metrics"], "identical outputs");
    let waits = format!("{ta}{tb}")
        .matches("waiting for stage 'simulation.simulate' (computed by ")
        .count();
    assert_eq!(waits, 1, "{ta}\n{tb}");
    // Locks released, temporary directories gone.
    let cache = runs.join("cache");
    let left: Vec<String> = std::fs::read_dir(&cache)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    assert_eq!(final_dirs(&runs).len(), 2);
}

fn lock_json(host: &str, pid: u32, beat: u64) -> String {
    serde_json::json!({
        "host": host, "pid": pid, "slurm_job_id": null,
        "started": "2020-01-01T00:00:00.000Z",
        "heartbeat": format!("beat {beat}"),
        "token": format!("{host}-{pid}-test"),
    })
    .to_string()
}

/// Write the lock as a holder does (aside, then renamed over it).
fn write_lock(path: &Path, text: &str) {
    let tmp = path.with_extension("writing");
    std::fs::write(&tmp, text).unwrap();
    std::fs::rename(&tmp, path).unwrap();
}

#[test]
fn stale_locks_are_broken_and_live_ones_waited_for() {
    let d = tmpdir("locks");
    let runs = d.join("runs");
    let file = d.join("p.toml");
    std::fs::write(&file, with_ingest("")).unwrap();
    let p = file.to_str().unwrap();
    run_ok(&["run", p, "--quiet"], &runs);
    let dir = entry(&runs, "ingest");
    let lock = runs.join("cache").join(format!(
        ".lock-{}",
        dir.file_name().unwrap().to_string_lossy()
    ));
    let run = |stale_s: Option<&str>| {
        let mut c = Command::new(BIN);
        c.args(["run", p, "--quiet", "--runs-dir"]).arg(&runs);
        match stale_s {
            Some(s) => c.env("PILLAR_PIPE_LOCK_STALE_S", s),
            None => c.env_remove("PILLAR_PIPE_LOCK_STALE_S"),
        };
        let t = Instant::now();
        let o = c.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        assert_eq!(computed(&latest(&runs)), ["experiment.ingest"], "{err}");
        assert!(!lock.exists(), "lock released");
        (t.elapsed(), err)
    };

    // A dead process on this host: broken at once, without waiting out the 60 s limit.
    let mut child = Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let host = pillar_pipe::pipeline::lock::hostname();
    write_lock(&lock, &lock_json(host, dead, 0));
    let (t, err) = run(None);
    assert!(
        err.contains("broke the stale lock of stage 'experiment.ingest'")
            && err.contains(&format!("{host}:{dead}"))
            && err.contains("no longer running on this host"),
        "{err}"
    );
    assert!(t < Duration::from_secs(20), "{t:?}");

    // Another host's lock whose heartbeat stopped: waited for, broken after the limit
    // (PID 1 is alive here, which must not matter for a lock of another host).
    std::fs::remove_dir_all(&dir).unwrap();
    write_lock(&lock, &lock_json("other-host.example", 1, 0));
    let (t, err) = run(Some("1.5"));
    assert!(
        err.contains("waiting for stage 'experiment.ingest' (computed by other-host.example:1")
            && err.contains("broke the stale lock")
            && err.contains("no heartbeat for"),
        "{err}"
    );
    assert!(t >= Duration::from_millis(1500), "{t:?}");

    // A live holder elsewhere (heartbeat kept fresh, then released after 3 s): waited
    // for, never broken, although 3 s is twice the stale limit.
    std::fs::remove_dir_all(&dir).unwrap();
    write_lock(&lock, &lock_json("other-host.example", 1, 0));
    let holder = {
        let lock = lock.clone();
        std::thread::spawn(move || {
            let t = Instant::now();
            let mut beat = 0;
            while t.elapsed() < Duration::from_secs(3) {
                beat += 1;
                write_lock(&lock, &lock_json("other-host.example", 1, beat));
                std::thread::sleep(Duration::from_millis(200));
            }
            std::fs::remove_file(&lock).unwrap();
        })
    };
    let (t, err) = run(Some("1.5"));
    holder.join().unwrap();
    assert!(
        err.contains("waiting for stage 'experiment.ingest'"),
        "{err}"
    );
    assert!(!err.contains("broke"), "a live lock was broken: {err}");
    assert!(t >= Duration::from_millis(2500), "{t:?}");
}
