//! The Slurm executor against a real Slurm: a one-node cluster on this machine
//! (`scripts/slurm-cluster.sh up`, which `.ci/run` calls; the tests call it too when no
//! cluster answers). Where none can be started the tests say so, and fail under CI=true.
//!
//! "The same outputs" below: every table and figure (Parquet, PNG, SVG) byte for byte;
//! JSON and HTML byte for byte once the runs directory's path, run ids, timings
//! (`elapsed_s`, per-second rates, `created`, `computed_in_run`) and the SHA-256 of files
//! holding timings are masked. Two local runs differ in exactly those. A resumed
//! simulation's manifest also says so (`resume`, the `*_this_session` statistics of the
//! last session), as it does after a local resume.

use crate::common::*;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

/// One test at a time: the cluster has the machine's cores only.
static SERIAL: Mutex<()> = Mutex::new(());

fn cluster_answers() -> bool {
    Command::new("sinfo")
        .args(["-h", "-o", "%T"])
        .output()
        .is_ok_and(|o| {
            let t = String::from_utf8_lossy(&o.stdout);
            o.status.success() && ["idle", "mixed", "allocated"].iter().any(|s| t.contains(s))
        })
}

/// A running cluster (started with the repository's script if none answers), or the
/// reason there is none.
fn cluster() -> Result<(), String> {
    static UP: OnceLock<Result<(), String>> = OnceLock::new();
    UP.get_or_init(|| {
        if cluster_answers() {
            return Ok(());
        }
        let script = Path::new(ROOT).join("scripts/slurm-cluster.sh");
        let out = Command::new(&script)
            .arg("up")
            .output()
            .map_err(|e| format!("cannot run {}: {e}", script.display()))?;
        if cluster_answers() {
            Ok(())
        } else {
            Err(format!(
                "no Slurm cluster answers and `scripts/slurm-cluster.sh up` could not start one: {}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            ))
        }
    })
    .clone()
}

fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// The guard of the cluster, or None (skip, or fail under CI=true).
fn need_cluster(test: &str) -> Option<MutexGuard<'static, ()>> {
    let g = serial();
    match cluster() {
        Ok(()) => Some(g),
        Err(why) => {
            cannot_check(&format!("{test}: {why}"));
            None
        }
    }
}

const VOLATILE: &[&str] = &["created", "computed_in_run", "started", "finished"];

fn volatile(key: &str) -> bool {
    VOLATILE.contains(&key)
        || key.contains("elapsed")
        || key.contains("per_s")
        || key.starts_with("ns_per")
        || key.ends_with("_this_session")
        || key == "resume"
}

fn strip(v: &mut Value) {
    match v {
        Value::Object(m) => {
            m.retain(|k, _| !volatile(k));
            m.values_mut().for_each(strip);
        }
        Value::Array(a) => a.iter_mut().for_each(strip),
        _ => {}
    }
}

/// Run ids (`YYYYmmdd-HHMMSS-mmm-xxxxxx`) and 64-hex digests masked.
fn mask(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let hex = |c: u8| c.is_ascii_digit() || (b'a'..=b'f').contains(&c);
    while i < b.len() {
        let run = b[i..].iter().take_while(|c| hex(**c)).count();
        if run == 64 && (i == 0 || !hex(b[i - 1])) {
            out.push_str("HASH");
            i += 64;
            continue;
        }
        let id = b.len() >= i + 26
            && b[i..i + 8].iter().all(u8::is_ascii_digit)
            && b[i + 8] == b'-'
            && b[i + 9..i + 15].iter().all(u8::is_ascii_digit)
            && b[i + 15] == b'-'
            && b[i + 16..i + 19].iter().all(u8::is_ascii_digit)
            && b[i + 19] == b'-'
            && b[i + 20..i + 26].iter().all(|c| hex(*c));
        if id {
            out.push_str("RUNID");
            i += 26;
            continue;
        }
        let ch = text[i..].chars().next().unwrap_or(' ');
        out.push(ch);
        i += ch.len_utf8();
    }
    out
}

/// A file's comparable form (see the module comment).
fn normal(path: &Path, root: &Path) -> Vec<u8> {
    let bytes = std::fs::read(path).unwrap();
    let ext = path
        .extension()
        .map_or(String::new(), |e| e.to_string_lossy().into_owned());
    if ext != "json" && ext != "html" {
        return bytes;
    }
    let text = String::from_utf8_lossy(&bytes).replace(&root.display().to_string(), "ROOT");
    if ext == "json"
        && let Ok(mut v) = serde_json::from_str::<Value>(&text)
    {
        strip(&mut v);
        return serde_json::to_string_pretty(&v).unwrap().into_bytes();
    }
    mask(&text).into_bytes()
}

/// Every file below `dir` but the executor's state, the cache's bookkeeping
/// (`stage.json`, `.complete`, locks) and run directories: relative path → content.
fn outputs(dir: &Path, root: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        let n = e.file_name().to_string_lossy().into_owned();
        if n.starts_with('.') || n == "stage.json" || n == "slurm" {
            continue;
        }
        if p.is_dir() {
            outputs(&p, root, out);
        } else {
            let rel = p.strip_prefix(root).unwrap().display().to_string();
            out.insert(rel, normal(&p, root));
        }
    }
}

fn assert_same(local: &Path, slurm: &Path) {
    let (mut a, mut b) = (BTreeMap::new(), BTreeMap::new());
    outputs(local, local, &mut a);
    outputs(slurm, slurm, &mut b);
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    assert!(!a.is_empty());
    let mut tables = 0;
    for (k, v) in &a {
        assert!(
            b[k] == *v,
            "{k} differs between the local and the Slurm run"
        );
        tables += usize::from(k.ends_with(".parquet") || k.ends_with(".png"));
    }
    eprintln!("{} files the same ({tables} tables and figures)", a.len());
}

/// The job id printed for a stage's "queued" line (`job 12_0`).
fn queued_job(out: &str, stage: &str) -> Option<String> {
    out.lines()
        .find(|l| l.contains(&format!(" {stage} ")) && l.contains(" queued "))
        .and_then(|l| l.split("job ").nth(1))
        .and_then(|r| r.split_whitespace().next())
        .map(str::to_string)
}

fn wait_for(what: &str, limit_s: u64, mut f: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !f() {
        assert!(
            t0.elapsed() < Duration::from_secs(limit_s),
            "timed out after {limit_s} s waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The bundled quickstart: every stage a job, one array per (depth, kind), outputs the
/// same as the local run's, the manifest tells job, node, wall time and log; running
/// it again submits nothing.
#[test]
fn quickstart_under_slurm_is_the_local_run() {
    let Some(_g) = need_cluster("quickstart under Slurm") else {
        return;
    };
    let d = tmpdir("slurm-qs");
    let (local, slurm) = (d.join("local"), d.join("slurm"));
    let qs = bundled("quickstart");
    run_ok(&["run", &qs], &local);
    let t0 = Instant::now();
    let out = run_ok(&["run", &qs, "--executor", "slurm"], &slurm);
    eprintln!(
        "{out}quickstart under Slurm: {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(out.matches(" queued ").count(), 8, "{out}");
    let (ek, sk) = (
        queued_job(&out, "experiment.kinematics").unwrap(),
        queued_job(&out, "simulation.kinematics").unwrap(),
    );
    assert_eq!(
        ek.split('_').next(),
        sk.split('_').next(),
        "independent stages of one kind are one job array: {out}"
    );
    assert_ne!(ek, sk);
    assert!(
        out.lines()
            .any(|l| l.contains(" compare ") && l.contains(" after ")),
        "compare waits for the fits: {out}"
    );
    assert_same(&local.join("cache"), &slurm.join("cache"));
    let m = latest(&slurm);
    assert_eq!(m["status"], "ok");
    assert_eq!(m["executor"], "slurm");
    for s in m["stages"].as_array().unwrap() {
        let j = &s["slurm"];
        assert_eq!(j["state"], "done", "{s}");
        assert!(!j["node"].as_str().unwrap().is_empty(), "{s}");
        assert!(j["wall_s"].as_f64().is_some(), "{s}");
        assert!(slurm.join(j["log"].as_str().unwrap()).is_file(), "{s}");
    }
    let run_dir = slurm.join(m["run_id"].as_str().unwrap());
    assert!(run_dir.join("report.html").is_file());

    let scripts = file_names(&slurm.join("slurm/jobs")).len();
    let again = run_ok(&["run", &qs, "--executor", "slurm"], &slurm);
    assert!(
        !again.contains(" queued "),
        "a re-run submits nothing: {again}"
    );
    assert_eq!(again.matches(" cached ").count(), 8, "{again}");
    assert_eq!(file_names(&slurm.join("slurm/jobs")).len(), scripts);

    // --force: the report is submitted again, and the run waits for its new entry.
    let forced = run_ok(
        &["run", &qs, "--executor", "slurm", "--force", "report"],
        &slurm,
    );
    assert_eq!(forced.matches(" queued ").count(), 1, "{forced}");
    let m = latest(&slurm);
    let report = m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "report")
        .unwrap();
    let rec: Value = serde_json::from_str(
        &std::fs::read_to_string(
            slurm
                .join(report["dir"].as_str().unwrap())
                .join("stage.json"),
        )
        .unwrap(),
    )
    .unwrap();
    assert_eq!(
        rec["computed_in_run"], m["run_id"],
        "recomputed by this run"
    );
}

const SWEEP: &[&str] = &[
    "sweep",
    "--phi",
    "0.80,0.84",
    "--q",
    "1",
    "--rate",
    "1e-3,1e-2",
    "--n",
    "256",
    "--strain",
    "0.5",
];

/// A 4-point sweep: one job array of 4 tasks, the same runs and table as locally.
#[test]
fn sweep_under_slurm_is_the_local_sweep() {
    let Some(_g) = need_cluster("sweep under Slurm") else {
        return;
    };
    let d = tmpdir("slurm-sweep");
    let (local, slurm) = (d.join("local"), d.join("slurm"));
    let with = |out: &Path, more: &[&str]| {
        let mut a: Vec<String> = SWEEP.iter().map(|s| s.to_string()).collect();
        a.extend(["-o".into(), out.display().to_string()]);
        a.extend(more.iter().map(|s| s.to_string()));
        a
    };
    let t = Instant::now();
    let (ok, text) = cli(&with(&local, &["--quiet"])
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>());
    assert!(ok, "{text}");
    let local_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let args = with(&slurm, &["--executor", "slurm"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (ok, text) = cli(&args);
    assert!(ok, "{text}");
    let slurm_s = t.elapsed().as_secs_f64();
    eprintln!("{text}4-point sweep: local {local_s:.1} s, Slurm {slurm_s:.1} s");
    let arrays: std::collections::BTreeSet<&str> = text
        .lines()
        .filter(|l| l.contains(" queued "))
        .filter_map(|l| l.split("job ").nth(1)?.split('_').next())
        .collect();
    assert_eq!(text.matches(" queued ").count(), 4, "{text}");
    assert_eq!(arrays.len(), 1, "the grid points are one job array: {text}");
    assert_same(&local, &slurm);
    let (ok, again) = cli(&args);
    assert!(
        ok && again.contains("0 submitted") && !again.contains(" queued "),
        "{again}"
    );
}

/// A pipeline's sweep stage under Slurm: its grid points are one job array of `shear`
/// stages, the sweep and the report follow, and every output is the local run's.
#[test]
fn sweep_stage_under_slurm_is_the_local_run() {
    let Some(_g) = need_cluster("sweep stage under Slurm") else {
        return;
    };
    let d = tmpdir("slurm-sweep-stage");
    let (local, slurm) = (d.join("local"), d.join("slurm"));
    let file = d.join("sweep.toml");
    std::fs::write(
        &file,
        "[flow.sweep]\nphi = [0.80, 0.84]\nq = [1]\nrate = [1e-2, 3e-2]\nn = 32\nstrain = 0.3\nsample_every = 2\n\n\
         [report]\ndatasets = [\"flow\"]\n",
    )
    .unwrap();
    let f = file.to_str().unwrap();
    run_ok(&["run", f, "--quiet"], &local);
    let out = run_ok(&["run", f, "--executor", "slurm"], &slurm);
    assert_eq!(out.matches(" queued ").count(), 6, "{out}");
    let arrays: std::collections::BTreeSet<String> = [
        "0.8,q=1,rate=1e-2",
        "0.8,q=1,rate=3e-2",
        "0.84,q=1,rate=1e-2",
        "0.84,q=1,rate=3e-2",
    ]
    .iter()
    .map(|p| {
        queued_job(&out, &format!("flow.sweep:phi={p}"))
            .unwrap_or_else(|| panic!("{p} not queued: {out}"))
            .split('_')
            .next()
            .unwrap()
            .to_string()
    })
    .collect();
    assert_eq!(arrays.len(), 1, "the grid points are one job array: {out}");
    assert_same(&local.join("cache"), &slurm.join("cache"));
    let again = run_ok(&["run", f, "--executor", "slurm"], &slurm);
    assert!(!again.contains(" queued "), "{again}");
}

/// A simulation cancelled mid-run (`scancel`): the next `run` submits only what is not
/// in the cache, the simulation continues from its checkpoint, and, requeued by Slurm
/// while it runs again (`scontrol requeue`), continues from its checkpoint once more;
/// the outputs are those of an uninterrupted local run.
#[test]
fn cancelled_job_is_resubmitted_alone_and_resumes() {
    let Some(_g) = need_cluster("scancel under Slurm") else {
        return;
    };
    let d = tmpdir("slurm-cancel");
    let file = d.join("p.toml");
    std::fs::write(
        &file,
        format!(
            "[pipeline]\nroot = '{ROOT}'\n\n[experiment.ingest]\ninput = \"data/sample/tracks.csv\"\n\n\
             [simulation.simulate]\npreset = \"fast\"\nn = 300\nstrain = 0.3\nseed = 2\ncheckpoint_every = 20000\n\n\
             [simulation.fit]\ninput = \"simulation.simulate\"\nbootstrap = 50\n"
        ),
    )
    .unwrap();
    let file = file.to_str().unwrap();
    let (local, slurm) = (d.join("local"), d.join("slurm"));
    run_ok(&["run", file], &local);
    let out = run_ok(&["run", file, "--executor", "slurm", "--detach"], &slurm);
    assert!(out.contains("submitted to Slurm"), "{out}");
    let sim = queued_job(&out, "simulation.simulate").unwrap();
    // A second head while the jobs are queued or running attaches to them.
    let twice = run_ok(&["run", file, "--executor", "slurm", "--detach"], &slurm);
    assert_eq!(
        queued_job(&twice, "simulation.simulate").as_deref(),
        Some(sim.as_str()),
        "not submitted twice: {twice}"
    );
    assert_eq!(
        queued_job(&twice, "simulation.fit"),
        queued_job(&out, "simulation.fit"),
        "{twice}"
    );
    assert!(twice.contains("attached"), "{twice}");
    let cache = slurm.join("cache");
    let ingested = || {
        final_dirs(&slurm).iter().any(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("ingest-")
        })
    };
    wait_for(
        "the simulation's first checkpoint and the ingest",
        120,
        || simulation_checkpointed(&cache) && ingested(),
    );
    let st = Command::new("scancel").arg(&sim).status().unwrap();
    assert!(st.success());
    let status = slurm.join(format!("slurm/status/{sim}.json"));
    wait_for("the cancelled job's exit status", 60, || status.is_file());
    let exit: Value = serde_json::from_str(&std::fs::read_to_string(&status).unwrap()).unwrap();
    assert_ne!(exit["exit_code"], 0, "{exit}");
    assert!(
        !final_dirs(&slurm).iter().any(|p| p
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("simulate-")),
        "the simulation was cancelled before it finished (make it longer if this fails)"
    );
    assert!(simulation_checkpointed(&cache), "its checkpoint is kept");
    // `runs show` of the detached run tells the failed stage.
    let show = run_ok(&["runs", "show", "latest"], &slurm);
    assert!(show.contains("submitted"), "{show}");

    let head = Command::new(BIN)
        .args(["run", file, "--executor", "slurm", "--runs-dir"])
        .arg(&slurm)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Slurm's own path for a node failure or a preemption: the running job is requeued
    // (SIGTERM, then it runs again under the same id). The head goes on waiting.
    let running_sim = || {
        let o = Command::new("squeue")
            .args([
                "-h",
                "-r",
                "-n",
                "pp-simulate",
                "-t",
                "RUNNING",
                "-o",
                "%F_%K",
            ])
            .output()
            .unwrap();
        let t = String::from_utf8_lossy(&o.stdout).trim().to_string();
        (!t.is_empty()).then_some(t)
    };
    wait_for("the resubmitted simulation to run", 60, || {
        running_sim().is_some()
    });
    let sim2 = running_sim().unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let rq = Command::new("scontrol")
        .args(["requeue", &sim2])
        .status()
        .unwrap();
    assert!(rq.success(), "scontrol requeue {sim2}");
    // Slurm holds a requeued job back for about two minutes; release it now.
    wait_for("the requeued job to be pending", 30, || {
        let o = Command::new("squeue")
            .args(["-h", "-r", "-j", &sim2, "-o", "%T"])
            .output()
            .unwrap();
        String::from_utf8_lossy(&o.stdout).contains("PENDING")
    });
    let up = Command::new("scontrol")
        .args(["update", &format!("jobid={sim2}"), "StartTime=now"])
        .status()
        .unwrap();
    assert!(up.success());
    let o = head.wait_with_output().unwrap();
    let again = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{again}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let restarted: Value = serde_json::from_str(
        &std::fs::read_to_string(slurm.join(format!("slurm/status/{sim2}.json"))).unwrap(),
    )
    .unwrap();
    assert_eq!(
        restarted["exit_code"], 0,
        "the requeued run's own status: {restarted}"
    );
    let queued: Vec<&str> = ["experiment.ingest", "simulation.simulate", "simulation.fit"]
        .into_iter()
        .filter(|s| queued_job(&again, s).is_some())
        .collect();
    assert_eq!(
        queued,
        ["simulation.simulate", "simulation.fit"],
        "only what is missing is submitted: {again}"
    );
    assert!(
        again
            .lines()
            .any(|l| l.contains(" experiment.ingest ") && l.contains(" cached ")),
        "{again}"
    );
    let sim2 = queued_job(&again, "simulation.simulate").unwrap();
    let log = std::fs::read_to_string(slurm.join(format!("slurm/logs/{sim2}.out"))).unwrap();
    assert!(
        log.contains("continues from it"),
        "resumed from the checkpoint: {log}"
    );
    assert_same(&local.join("cache"), &slurm.join("cache"));
}

/// A stage whose job fails: the run fails naming the stage, the job, its log and the
/// log's last lines (which hold the error), after `retry = 1` (the file's `[executor]`)
/// submitted it once more; nothing of it enters the cache.
#[test]
fn failed_job_fails_its_stage_with_job_log_and_tail() {
    let Some(_g) = need_cluster("a failing job under Slurm") else {
        return;
    };
    let d = tmpdir("slurm-fail");
    let runs = d.join("runs");
    std::fs::write(
        d.join("bad.csv"),
        "frame,particle,x,y,radius\n0,0,1.0,2.0,0.5\n0,1,abc,2.0,0.5\n",
    )
    .unwrap();
    let file = d.join("p.toml");
    std::fs::write(
        &file,
        "[executor]\nname = \"slurm\"\nretry = 1\n\n\
         [experiment.ingest]\ninput = \"bad.csv\"\n\n[experiment.fit]\ninput = \"ingest\"\nbootstrap = 20\n",
    )
    .unwrap();
    // The executor and --retry 1 come from the file's [executor] table.
    let (ok, out, err) = pp(&["run", file.to_str().unwrap()], &runs);
    assert!(!ok, "{out}");
    assert!(
        out.contains("retrying"),
        "--retry 1 submitted it again: {out}"
    );
    let first = queued_job(&out, "experiment.ingest").unwrap();
    let last = out
        .lines()
        .rfind(|l| l.contains(" experiment.ingest ") && l.contains(" queued "))
        .and_then(|l| l.split("job ").nth(1)?.split_whitespace().next())
        .unwrap()
        .to_string();
    assert_ne!(first, last, "a second job: {out}");
    assert!(
        err.contains(&format!(
            "stage 'experiment.ingest' (ingest) failed in Slurm job {last}: exit status 1"
        )),
        "{err}"
    );
    let log = runs.join(format!("slurm/logs/{last}.out"));
    assert!(err.contains(&format!("log: {}", log.display())), "{err}");
    assert!(log.is_file());
    let tail = err.split("last lines of the log:").nth(1).unwrap_or("");
    assert!(
        tail.contains("line 3"),
        "the log's tail holds the error: {err}"
    );
    assert!(final_dirs(&runs).is_empty(), "nothing entered the cache");
    let m = latest(&runs);
    assert_eq!(m["status"], "failed");
    assert_eq!(m["failed_stage"], "experiment.ingest");
    assert!(m["error"].as_str().unwrap().contains(&last));
}

/// A job refuses a stage whose key its own build (and the inputs it sees) would not
/// give: it never computes something else under the head's key. No cluster needed:
/// the job command is run as Slurm would run it.
#[test]
fn job_refuses_a_key_its_build_does_not_give() {
    let _g = serial();
    let d = tmpdir("slurm-key");
    let runs = d.join("runs");
    for sub in ["status", "logs", "jobs", "stages"] {
        std::fs::create_dir_all(runs.join("slurm").join(sub)).unwrap();
    }
    let spec = serde_json::json!({
        "what": "pipeline",
        "pipeline": bundled("experiment-only"),
        "sets": [],
        "runs_dir": runs,
        "run_id": "test",
        "verify": false,
        "quiet": true,
        "tasks": [{"stage": "experiment.ingest", "key": "0".repeat(64), "force": false}],
    });
    let spec_file = d.join("spec.json");
    std::fs::write(&spec_file, spec.to_string()).unwrap();
    let o = Command::new(BIN)
        .arg("slurm-job")
        .arg(&spec_file)
        .env("SLURM_ARRAY_JOB_ID", "77")
        .env("SLURM_ARRAY_TASK_ID", "0")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let status: Value = serde_json::from_str(
        &std::fs::read_to_string(runs.join("slurm/status/77_0.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(status["exit_code"], 1);
    let e = status["error"].as_str().unwrap();
    assert!(
        e.contains("refusing to compute stage 'experiment.ingest'"),
        "{e}"
    );
    assert!(final_dirs(&runs).is_empty());
    let _: PathBuf = runs;
}

/// The `[executor]` table is checked like the rest of the file, and Slurm's options
/// are refused for a local run. No cluster needed.
#[test]
fn executor_settings_are_checked() {
    let d = tmpdir("slurm-exec");
    let runs = d.join("runs");
    let file = d.join("p.toml");
    std::fs::write(
        &file,
        with_ingest("").replace("[pipeline]", "[executor]\nname = \"pbs\"\n\n[pipeline]"),
    )
    .unwrap();
    let (ok, _, err) = pp(&["run", file.to_str().unwrap()], &runs);
    assert!(!ok);
    assert!(
        err.contains("line 2: executor.name: 'pbs' is not one of: local, slurm"),
        "{err}"
    );
    std::fs::write(
        &file,
        with_ingest("").replace("[pipeline]", "[executor]\nqueue = \"x\"\n\n[pipeline]"),
    )
    .unwrap();
    let (ok, _, err) = pp(&["run", file.to_str().unwrap()], &runs);
    assert!(
        !ok && err.contains("unknown key; allowed in [executor]"),
        "{err}"
    );
    let (ok, _, err) = pp(
        &["run", &bundled("quickstart"), "--partition", "debug"],
        &runs,
    );
    assert!(!ok && err.contains("apply to --executor slurm"), "{err}");
    assert!(!runs.join("cache").exists(), "nothing ran");
}
