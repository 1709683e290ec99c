//! Real signals sent to real runs (issue 24): SIGTERM and SIGINT make `simulate pillar`,
//! `simulate shear`, `sweep` and `run` save a checkpoint at the next step boundary, exit
//! with 128 + signal and print the command that continues; that command ends with the
//! tables of an uninterrupted run. SIGKILL loses at most the wall-time checkpoint
//! interval. Every test first waits until the run is provably under way (a checkpoint
//! file exists), and checks afterwards that the signal landed before the end.

use crate::common;
use crate::common::{BIN, tmpdir};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Wait (at most a minute) until `ready()` holds.
fn wait_for(what: &str, ready: impl Fn() -> bool) {
    let t0 = Instant::now();
    while !ready() {
        assert!(t0.elapsed() < Duration::from_secs(60), "timed out: {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

pub(crate) fn signal(child: &Child, sig: i32) {
    // SAFETY: kill(2) on our own child's pid; no memory is touched.
    let r = unsafe { libc::kill(child.id() as libc::pid_t, sig) };
    assert_eq!(r, 0, "kill failed");
}

/// Wait for the child; (exit code, stdout + stderr).
pub(crate) fn finish(child: Child) -> (Option<i32>, String) {
    let o = child.wait_with_output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.code(), text)
}

pub(crate) fn spawn(args: &[&str]) -> Child {
    Command::new(BIN)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn run_ok(args: &[&str]) -> String {
    let o = Command::new(BIN).args(args).output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "pillar-pipe {args:?} failed:\n{text}");
    text
}

/// The command the CLI printed after "continue with:", as arguments (test paths hold no
/// spaces or quotes).
fn continue_command(text: &str) -> Vec<String> {
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("continue with: "))
        .unwrap_or_else(|| panic!("no 'continue with:' line in:\n{text}"));
    let mut words: Vec<String> = line.split_whitespace().map(str::to_string).collect();
    assert_eq!(words.remove(0), "pillar-pipe", "{line}");
    words
}

/// The step the interruption's checkpoint was saved at.
fn saved_step(text: &str) -> u64 {
    let rest = text
        .split("checkpoint saved at step ")
        .nth(1)
        .unwrap_or_else(|| panic!("no checkpoint step in:\n{text}"));
    rest.split_whitespace().next().unwrap().parse().unwrap()
}

fn bytes_of(dir: &Path, names: &[&str]) -> Vec<(String, Vec<u8>)> {
    names
        .iter()
        .map(|n| (n.to_string(), std::fs::read(dir.join(n)).unwrap()))
        .collect()
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

const PILLAR: [&str; 10] = [
    "simulate", "pillar", "--n", "200", "--preset", "fast", "--strain", "0.2", "--seed", "4",
];
const PILLAR_TABLES: [&str; 4] = [
    "tracks.parquet",
    "bar_forces.parquet",
    "stress_strain.parquet",
    "forces.parquet",
];

#[test]
fn sigterm_checkpoints_a_pillar_run_and_the_printed_command_resumes_it() {
    // The fast preset, and a short run of the paper's (Sec. II.C: δt = 1e-5 s, ~6e5 steps).
    sigterm_pillar("sig-pillar", &PILLAR, "2000");
    let mut paper = PILLAR.to_vec();
    paper[5] = "paper";
    paper[7] = "0.01";
    sigterm_pillar("sig-pillar-paper", &paper, "20000");
}

fn sigterm_pillar(name: &str, run: &[&str], every: &str) {
    let d = tmpdir(name);
    let (a, b) = (d.join("a"), d.join("b"));
    let mut args = run.to_vec();
    args.extend(["--quiet", "-o", a.to_str().unwrap()]);
    run_ok(&args);
    // The first step-count checkpoint shows the run is under way; the wall-time one is off
    // so that the only other checkpoint is the signal's.
    let mut args = run.to_vec();
    args.extend(["--quiet", "--checkpoint-every", every]);
    args.extend(["--checkpoint-interval", "0", "-o", b.to_str().unwrap()]);
    let child = spawn(&args);
    wait_for("first checkpoint", || b.join("checkpoint.bin").exists());
    signal(&child, libc::SIGTERM);
    let (code, text) = finish(child);
    assert_eq!(code, Some(143), "exit 128 + SIGTERM:\n{text}");
    assert!(text.contains("stopped by SIGTERM"), "{text}");
    assert!(!b.join("manifest.json").exists(), "stopped before the end");
    let step = saved_step(&text);
    let resume = continue_command(&text);
    assert!(
        resume.contains(&"--resume".to_string()) && !resume.contains(&"-o".to_string()),
        "{resume:?}"
    );
    let resume: Vec<&str> = resume.iter().map(String::as_str).collect();
    run_ok(&resume);
    assert_eq!(
        bytes_of(&a, &PILLAR_TABLES),
        bytes_of(&b, &PILLAR_TABLES),
        "resumed tables equal the uninterrupted run's"
    );
    let m = json(&b.join("manifest.json"));
    assert_eq!(
        m["steps_this_session"].as_u64().unwrap() + step,
        m["report"]["steps"].as_u64().unwrap(),
        "the resumed session started from the signal's checkpoint"
    );
}

#[test]
fn sigkill_loses_at_most_the_wall_time_interval() {
    let d = tmpdir("sig-kill");
    let (a, b) = (d.join("a"), d.join("b"));
    let mut args = PILLAR.to_vec();
    args.extend(["--quiet", "-o", a.to_str().unwrap()]);
    run_ok(&args);
    // No step-count checkpoints: only the wall clock makes them.
    let mut args = PILLAR.to_vec();
    args.extend(["--quiet", "--checkpoint-interval", "0.05"]);
    args.extend(["-o", b.to_str().unwrap()]);
    let mut child = spawn(&args);
    wait_for("a wall-time checkpoint", || {
        b.join("checkpoint.bin").exists()
    });
    child.kill().unwrap(); // SIGKILL: no handler runs
    let (code, _) = finish(child);
    assert_eq!(code, None, "killed by the signal, not exited");
    assert!(!b.join("manifest.json").exists(), "killed before the end");
    let mut args = PILLAR.to_vec();
    args.extend(["--quiet", "--resume", b.to_str().unwrap()]);
    run_ok(&args);
    assert_eq!(bytes_of(&a, &PILLAR_TABLES), bytes_of(&b, &PILLAR_TABLES));
    let m = json(&b.join("manifest.json"));
    assert!(
        m["steps_this_session"].as_u64() < m["report"]["steps"].as_u64(),
        "resumed from the checkpoint, not from the start"
    );
}

#[test]
fn sigint_checkpoints_a_sheared_run_and_resume_gives_the_same_tables() {
    let d = tmpdir("sig-shear");
    let (a, b) = (d.join("a"), d.join("b"));
    let base = [
        "simulate", "shear", "--n", "1024", "--phi", "0.8", "--rate", "1e-4", "--strain", "0.4",
        "--quiet",
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter()
            .chain(extra)
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
    };
    let args = with(&["-o", a.to_str().unwrap()]);
    run_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let args = with(&[
        "--checkpoint-every",
        "2000",
        "--checkpoint-interval",
        "0",
        "-o",
        b.to_str().unwrap(),
    ]);
    let child = spawn(&args.iter().map(String::as_str).collect::<Vec<_>>());
    wait_for("first checkpoint", || b.join("checkpoint.bin").exists());
    signal(&child, libc::SIGINT);
    let (code, text) = finish(child);
    assert_eq!(code, Some(130), "exit 128 + SIGINT:\n{text}");
    assert!(!b.join("manifest.json").exists(), "stopped before the end");
    assert!(saved_step(&text) > 0, "{text}");
    let resume = continue_command(&text);
    run_ok(&resume.iter().map(String::as_str).collect::<Vec<_>>());
    let tables = [
        "series.parquet",
        "tracks.parquet",
        "collision_angles.parquet",
        "profile.parquet",
        "fields.parquet",
        "contact_velocities.parquet",
    ];
    assert_eq!(bytes_of(&a, &tables), bytes_of(&b, &tables));
    let (sa, sb) = (json(&a.join("summary.json")), json(&b.join("summary.json")));
    assert_eq!(sa["p"], sb["p"]);
    assert_eq!(sa["tau_dur"], sb["tau_dur"]);
}

#[test]
fn sigterm_stops_a_sweep_and_the_same_command_finishes_it() {
    let d = tmpdir("sig-sweep");
    let (a, b) = (d.join("a"), d.join("b"));
    let grid = [
        "sweep",
        "--phi",
        "0.8",
        "--q",
        "1",
        "--rate",
        "1e-4,2e-4",
        "--n",
        "512",
        "--strain",
        "0.3",
        "--jobs",
        "2",
        "--quiet",
    ];
    let with = |out: &PathBuf, extra: &[&str]| -> Vec<String> {
        grid.iter()
            .chain(extra)
            .map(|s| s.to_string())
            .chain(["-o".to_string(), out.display().to_string()])
            .collect()
    };
    let args = with(&a, &[]);
    run_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let args = with(
        &b,
        &["--checkpoint-every", "2000", "--checkpoint-interval", "0"],
    );
    let child = spawn(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let any_checkpoint = || {
        std::fs::read_dir(&b)
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| e.path().join("checkpoint.bin").exists())
    };
    wait_for("a run's first checkpoint", any_checkpoint);
    signal(&child, libc::SIGTERM);
    let (code, text) = finish(child);
    assert_eq!(code, Some(143), "{text}");
    assert!(text.contains("saved checkpoints"), "{text}");
    assert!(!b.join("sweep.parquet").exists(), "stopped before the end");
    let resume = continue_command(&text);
    assert_eq!(resume, args, "the same command");
    run_ok(&resume.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(
        bytes_of(&a, &["sweep.parquet"]),
        bytes_of(&b, &["sweep.parquet"])
    );
}

#[test]
fn sigterm_stops_a_pipeline_which_records_it_and_continues_when_run_again() {
    let d = tmpdir("sig-run");
    let pipeline = d.join("sim.toml");
    std::fs::write(
        &pipeline,
        "[simulation.simulate]\npreset = \"fast\"\nn = 200\nstrain = 0.2\nseed = 4\ncheckpoint_every = 2000\ncheckpoint_interval = 0\n",
    )
    .unwrap();
    let file = pipeline.to_str().unwrap();
    let (a, b) = (d.join("runs-a"), d.join("runs-b"));
    run_ok(&["run", file, "--quiet", "--runs-dir", a.to_str().unwrap()]);
    let child = spawn(&["run", file, "--quiet", "--runs-dir", b.to_str().unwrap()]);
    let cache = b.join("cache");
    let checkpointed = || common::simulation_checkpointed(&cache);
    wait_for("the simulation's first checkpoint", checkpointed);
    signal(&child, libc::SIGTERM);
    let (code, text) = finish(child);
    assert_eq!(code, Some(143), "{text}");
    assert!(text.contains("0 of 1 stages finished"), "{text}");
    let manifests: Vec<serde_json::Value> = std::fs::read_dir(&b)
        .unwrap()
        .flatten()
        .filter(|e| e.path().join("manifest.json").exists())
        .map(|e| json(&e.path().join("manifest.json")))
        .collect();
    assert_eq!(manifests.len(), 1);
    assert_eq!(manifests[0]["status"], "interrupted", "{:?}", manifests[0]);
    assert!(checkpointed(), "the checkpoint survives for the next run");
    let resume = continue_command(&text);
    assert_eq!(resume[..2], ["run".to_string(), file.to_string()]);
    run_ok(&resume.iter().map(String::as_str).collect::<Vec<_>>());
    let tracks = |runs: &Path| {
        let dir = std::fs::read_dir(runs.join("cache"))
            .unwrap()
            .flatten()
            .find(|e| e.file_name().to_string_lossy().starts_with("simulate-"))
            .unwrap()
            .path();
        std::fs::read(dir.join("tracks.parquet")).unwrap()
    };
    assert_eq!(tracks(&a), tracks(&b), "same trajectories after the resume");
}

/// A pipeline's `ramp` stage (Eqs. 38–41), here the ramp down of a cycle that starts
/// where a short ramp up ended, stopped by SIGTERM resumes from its checkpoint in
/// `runs/cache/.work-ramp-<hash>/` when the pipeline runs again, and ends with the
/// tables of an uninterrupted run: the rates the ramp lands on after the resume are the
/// same integer powers of 10^κ̃, counted from the step it started at.
#[test]
fn sigterm_stops_a_ramp_stage_which_resumes_from_its_work_dir() {
    let d = tmpdir("sig-ramp");
    let pipeline = d.join("ramp.toml");
    std::fs::write(
        &pipeline,
        "[cycle.up]\nkind = \"ramp\"\nramp = \"up\"\nn = 1024\nphi = 0.8\nrate = 1e-2\nrate_end = 1e-1\n\
         kappa = 0.05\nwindow = 5\n\n\
         [cycle.down]\nkind = \"ramp\"\nramp = \"down\"\nfrom = \"up\"\nn = 1024\nphi = 0.8\nrate = 1e-1\n\
         rate_end = 1e-2\nkappa = 5e-4\nwindow = 100\ncheckpoint_every = 2000\ncheckpoint_interval = 0\n",
    )
    .unwrap();
    let file = pipeline.to_str().unwrap();
    let (a, b) = (d.join("runs-a"), d.join("runs-b"));
    run_ok(&["run", file, "--quiet", "--runs-dir", a.to_str().unwrap()]);
    let child = spawn(&["run", file, "--quiet", "--runs-dir", b.to_str().unwrap()]);
    let cache = b.join("cache");
    let in_work = |prefix: &str| {
        std::fs::read_dir(&cache)
            .into_iter()
            .flatten()
            .flatten()
            .find(|e| e.file_name().to_string_lossy().starts_with(prefix))
            .map(|e| e.path())
    };
    let checkpointed = || in_work(".work-ramp-").is_some_and(|w| w.join("checkpoint.bin").exists());
    wait_for("the ramp's first checkpoint", checkpointed);
    signal(&child, libc::SIGTERM);
    let (code, text) = finish(child);
    assert_eq!(code, Some(143), "{text}");
    assert!(text.contains("1 of 2 stages finished"), "{text}");
    assert!(checkpointed(), "the checkpoint survives for the next run");
    let resume = continue_command(&text);
    let out = run_ok(&resume.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(out.contains("1 computed, 1 cached"), "{out}");
    // Both ramps, by cache key: the same names in both runs directories.
    let stage_dirs = |runs: &Path| {
        let mut v: Vec<PathBuf> = std::fs::read_dir(runs.join("cache"))
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with("ramp-"))
            .map(|e| e.path())
            .collect();
        v.sort();
        v
    };
    let tables = [
        "ramp.parquet",
        "series.parquet",
        "tracks.parquet",
        "state.bin",
    ];
    let (da, db) = (stage_dirs(&a), stage_dirs(&b));
    assert_eq!(da.len(), 2);
    for (x, y) in da.iter().zip(&db) {
        assert_eq!(x.file_name(), y.file_name());
        assert_eq!(
            bytes_of(x, &tables),
            bytes_of(y, &tables),
            "same ramp after the resume"
        );
    }
    assert!(
        in_work(".work-ramp-").is_none(),
        "the work directory is gone"
    );
}
