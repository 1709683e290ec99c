//! Pipelines that must not run: malformed files and overrides are rejected naming key
//! and line; a failed or killed stage leaves nothing that looks complete, and the next
//! run resumes after the last finished stage.

use crate::common;
use crate::common::*;
use serde_json::Value;
use std::process::Command;

#[test]
fn malformed_pipelines_are_rejected_with_key_and_line() {
    let d = tmpdir("bad");
    let runs = d.join("runs");
    let cases: &[(&str, &str, &str, &[&str])] = &[
        (
            "unknown-key",
            "[experiment.fit]\ninput = \"experiment.ingest\"\nmetod = \"points\"\n",
            "metod",
            &[
                "experiment.fit.metod",
                "unknown key",
                "allowed: input, diameter",
            ],
        ),
        (
            "wrong-type",
            "[experiment.fit]\ninput = \"experiment.ingest\"\nbootstrap = \"many\"\n",
            "bootstrap",
            &[
                "experiment.fit.bootstrap",
                "expected an integer",
                "\"many\"",
            ],
        ),
        (
            "below-minimum",
            "[experiment.fit]\ninput = \"experiment.ingest\"\nbootstrap = 3\n",
            "bootstrap",
            &["experiment.fit.bootstrap", "minimum 10"],
        ),
        (
            "unknown-reference",
            "[experiment.fit]\ninput = \"experiment.ingestt\"\n",
            "input = \"experiment.ingestt\"",
            &[
                "experiment.fit.input",
                "no stage 'experiment.ingestt'",
                "stages: experiment.ingest",
            ],
        ),
        (
            "cycle",
            "[experiment.kinematics]\ninput = \"experiment.fit\"\n\n[experiment.fit]\ninput = \"experiment.kinematics\"\n",
            "input = \"experiment.kinematics\"",
            &["reference cycle", "experiment.fit -> experiment.kinematics"],
        ),
        (
            "wrong-output",
            "[experiment.kinematics]\ninput = \"experiment.fit\"\n\n[experiment.fit]\ninput = \"ingest\"\n",
            "input = \"experiment.fit\"",
            &[
                "experiment.kinematics.input",
                "produces fit",
                "takes tracks",
            ],
        ),
        (
            "missing-required",
            "[experiment.fit]\nbootstrap = 20\n",
            "[experiment.fit]",
            &["experiment.fit", "missing required key 'input'"],
        ),
        (
            "unknown-kind",
            "[experiment.fitt]\ninput = \"experiment.ingest\"\n",
            "[experiment.fitt]",
            &["unknown stage kind 'fitt'"],
        ),
        (
            "unknown-branch",
            "[report]\ndatasets = [\"experimentt\"]\n",
            "datasets",
            &["report.datasets", "no branch 'experimentt'"],
        ),
        (
            "conflict",
            "[experiment.kinematics]\ninput = \"ingest\"\nlags = [2]\nlag_time = 3.0\n",
            "lag_time",
            &["lag_time", "not both"],
        ),
        (
            "syntax",
            "[experiment.fit]\ninput = \"experiment.ingest\"\nbootstrap = 20\nbootstrap = 30\n",
            "bootstrap = 30",
            &["duplicate key"],
        ),
    ];
    for (name, body, at, expect) in cases {
        let text = with_ingest(body);
        let file = d.join(format!("{name}.toml"));
        std::fs::write(&file, &text).unwrap();
        let (ok, out, err) = pp(&["run", file.to_str().unwrap()], &runs);
        assert!(!ok, "{name}: accepted\n{out}");
        let line = line_of(&text, at);
        assert!(
            err.contains(&format!("line {line}")),
            "{name}: no 'line {line}' in: {err}"
        );
        assert!(
            err.contains(&file.display().to_string()),
            "{name}: file not named: {err}"
        );
        for e in *expect {
            assert!(err.contains(e), "{name}: no '{e}' in: {err}");
        }
    }
    assert!(!runs.exists(), "nothing runs when the file is invalid");

    // Overrides and --force are checked too, naming the argument and what is allowed.
    let exp = bundled("experiment-only");
    for (args, expect) in [
        (
            vec!["--set", "fit.metod=points"],
            vec![
                "fit.metod=points",
                "unknown key 'metod'",
                "allowed: input, diameter",
            ],
        ),
        (
            vec!["--set", "fitt.bootstrap=20"],
            vec!["'fitt' is no stage or stage kind", "experiment.fit"],
        ),
        (
            vec!["--set", "fit.bootstrap"],
            vec!["expected STAGE.KEY=VALUE"],
        ),
        (
            vec!["--set", "fit.bootstrap=many"],
            vec!["--set fit.bootstrap=many", "expected an integer"],
        ),
        (vec!["--force", "fitt"], vec!["--force", "'fitt'"]),
    ] {
        let mut a = vec!["run", exp.as_str()];
        a.extend(args.iter().copied());
        let (ok, _, err) = pp(&a, &runs);
        assert!(!ok, "{args:?} accepted");
        for e in expect {
            assert!(err.contains(e), "{args:?}: no '{e}' in: {err}");
        }
    }
}

#[test]
fn failed_stage_leaves_no_complete_looking_output() {
    let d = tmpdir("fail");
    let runs = d.join("runs");
    let csv = d.join("bad.csv");
    std::fs::write(
        &csv,
        "frame,particle,x,y,radius\n0,0,1.0,2.0,0.5\n0,1,abc,2.0,0.5\n",
    )
    .unwrap();
    let file = d.join("p.toml");
    std::fs::write(&file, "[experiment.ingest]\ninput = \"bad.csv\"\n\n[experiment.fit]\ninput = \"ingest\"\nbootstrap = 20\n").unwrap();
    let (ok, out, err) = pp(&["run", file.to_str().unwrap()], &runs);
    assert!(!ok, "{out}");
    assert!(
        err.contains("stage 'experiment.ingest' (ingest) failed"),
        "{err}"
    );
    assert!(
        err.contains("line 3"),
        "the ingest error still points into the CSV: {err}"
    );
    assert!(
        std::fs::read_dir(runs.join("cache"))
            .unwrap()
            .next()
            .is_none(),
        "a failed stage left files in the cache"
    );
    let m = latest(&runs);
    assert_eq!(m["status"], "failed");
    assert_eq!(m["failed_stage"], "experiment.ingest");

    // A stage directory without its completion marker is not trusted.
    std::fs::write(
        &csv,
        "frame,particle,x,y,radius\n0,0,1.0,2.0,0.5\n0,1,2.0,2.0,0.5\n",
    )
    .unwrap();
    // Not `ingest.toml`: that name beside the CSV would be read as its ingest settings.
    let only_ingest = d.join("only-ingest.toml");
    std::fs::write(&only_ingest, "[experiment.ingest]\ninput = \"bad.csv\"\n").unwrap();
    run_ok(&["run", only_ingest.to_str().unwrap()], &runs);
    let dirs = final_dirs(&runs);
    assert_eq!(dirs.len(), 1);
    std::fs::remove_file(dirs[0].join(".complete")).unwrap();
    run_ok(&["run", only_ingest.to_str().unwrap()], &runs);
    assert_eq!(computed(&latest(&runs)), ["experiment.ingest"]);
    final_dirs(&runs);
}

#[test]
fn killed_run_resumes_from_completed_stages() {
    let d = tmpdir("kill");
    let runs = d.join("runs");
    let exp = bundled("experiment-only");
    // Enough replicates that the fit outlasts the moment the kinematics stage completes
    // (a fixed sleep raced the fit once it got fast).
    let args = ["run", &exp, "--set", "fit.bootstrap=20000", "--quiet"];
    let mut child = Command::new(BIN)
        .args(args)
        .arg("--runs-dir")
        .arg(&runs)
        .spawn()
        .unwrap();
    // Kill (SIGKILL: no clean-up runs) as soon as ingest and kinematics are complete,
    // while the fit computes.
    let kinematics_done = || {
        std::fs::read_dir(runs.join("cache")).is_ok_and(|rd| {
            rd.flatten().any(|e| {
                e.file_name().to_string_lossy().starts_with("kinematics-")
                    && e.path().join(".complete").is_file()
            })
        })
    };
    let t0 = std::time::Instant::now();
    while !kinematics_done() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before its kinematics stage completed"
        );
        assert!(t0.elapsed().as_secs() < 120, "kinematics never completed");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    assert!(
        child.try_wait().unwrap().is_none(),
        "the run finished before it could be killed: the fit is too short for this test"
    );
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(
        latest(&runs)["status"],
        "incomplete",
        "a killed run is listed as such"
    );
    let complete: Vec<String> = final_dirs(&runs)
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    run_ok(&args, &runs);
    let m = latest(&runs);
    assert_eq!(m["status"], "ok");
    for s in m["stages"].as_array().unwrap() {
        let dir = s["dir"].as_str().unwrap().trim_start_matches("cache/");
        assert_eq!(
            s["cached"],
            Value::Bool(complete.iter().any(|c| c == dir)),
            "{s}"
        );
    }
    final_dirs(&runs);
    let leftovers = std::fs::read_dir(runs.join("cache"))
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(".tmp-"))
        .count();
    assert_eq!(
        leftovers, 0,
        "the killed run's temporary directory was swept"
    );
}

/// A simulate stage killed mid-run resumes from its last checkpoint on the next run
/// (its work directory survives the sweep of temporary stage directories), and ends with
/// the same trajectories as an uninterrupted run.
#[test]
fn killed_simulation_stage_resumes_from_its_checkpoint() {
    let d = tmpdir("simkill");
    let pipeline = d.join("sim.toml");
    std::fs::write(
        &pipeline,
        "[simulation.simulate]\npreset = \"fast\"\nn = 120\nstrain = 0.08\nseed = 2\ncheckpoint_every = 20000\n",
    )
    .unwrap();
    let file = pipeline.to_str().unwrap();
    let (a, b) = (d.join("runs-a"), d.join("runs-b"));
    run_ok(&["run", file, "--quiet"], &a);
    let mut child = Command::new(BIN)
        .args(["run", file, "--quiet", "--runs-dir"])
        .arg(&b)
        .spawn()
        .unwrap();
    let cache = b.join("cache");
    let t0 = std::time::Instant::now();
    let checkpointed = || common::simulation_checkpointed(&cache);
    while !checkpointed() && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let _ = child.kill();
    let _ = child.wait();
    let resumed = checkpointed();
    run_ok(&["run", file, "--quiet"], &b);
    let tracks = |runs: &std::path::Path| {
        let dir = final_dirs(runs)
            .into_iter()
            .find(|p| {
                p.file_name()
                    .unwrap()
                    .to_string_lossy()
                    .starts_with("simulate-")
            })
            .unwrap();
        std::fs::read(dir.join("tracks.parquet")).unwrap()
    };
    assert_eq!(tracks(&a), tracks(&b), "same trajectories after the resume");
    assert!(
        !std::fs::read_dir(&cache)
            .unwrap()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with(".work-")),
        "the work directory is gone once the stage is complete"
    );
    eprintln!("killed after a checkpoint: {resumed}");
}
