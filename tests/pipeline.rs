//! Pipelines through the CLI, as a user runs them: a run writes its report and manifest,
//! a re-run recomputes nothing, a changed fit parameter reruns only what depends on it,
//! `runs compare` shows both fits, malformed files are rejected with key and line, and
//! failed or killed stages leave nothing that looks complete.

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

const BIN: &str = env!("CARGO_BIN_EXE_pillar-pipe");
const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pp-pipeline-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn bundled(name: &str) -> String {
    Path::new(ROOT)
        .join("pipelines")
        .join(format!("{name}.toml"))
        .display()
        .to_string()
}

/// Run the CLI with `--runs-dir runs`: (success, stdout, stderr).
fn pp(args: &[&str], runs: &Path) -> (bool, String, String) {
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

fn run_ok(args: &[&str], runs: &Path) -> String {
    let (ok, out, err) = pp(args, runs);
    assert!(ok, "pillar-pipe {args:?} failed:\n{out}\n{err}");
    out
}

/// The newest run's manifest.
fn latest(runs: &Path) -> Value {
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

/// Names of the stages a run computed (not taken from the cache).
fn computed(m: &Value) -> Vec<String> {
    m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["cached"] == Value::Bool(false))
        .map(|s| s["name"].as_str().unwrap().to_string())
        .collect()
}

/// Every file under the cache with its modification time.
fn cache_files(dir: &Path, out: &mut BTreeMap<PathBuf, SystemTime>) {
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
fn final_dirs(runs: &Path) -> Vec<PathBuf> {
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

#[test]
fn experiment_only_runs_caches_and_reruns_only_what_changed() {
    let d = tmpdir("exp");
    let runs = d.join("runs");
    let exp = bundled("experiment-only");
    run_ok(&["run", &exp, "--set", "fit.bootstrap=20"], &runs);
    let m1 = latest(&runs);
    let id1 = m1["run_id"].as_str().unwrap().to_string();
    assert_eq!(m1["status"], "ok");
    assert_eq!(computed(&m1).len(), 4, "{m1}");
    let dir1 = runs.join(&id1);
    let html = std::fs::read_to_string(dir1.join("report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("Provenance"));
    let figs: Vec<String> = std::fs::read_dir(dir1.join("figures"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(figs.iter().any(|f| f.ends_with(".png")) && figs.iter().any(|f| f.ends_with(".svg")));
    // The manifest records what ran and what came out.
    assert_eq!(m1["pipeline"]["sha256"].as_str().unwrap().len(), 64);
    assert_eq!(m1["parameters"]["experiment.fit"]["bootstrap"], 20);
    assert_eq!(m1["parameters"]["experiment.fit"]["rc_over_d"], 1.25);
    assert_eq!(m1["seeds"]["experiment.fit"], 1);
    assert_eq!(
        m1["inputs"]["experiment.ingest.input"]["sha256"]
            .as_str()
            .unwrap()
            .len(),
        64
    );
    assert!(
        m1["inputs"]["experiment.ingest.input.settings"].is_object(),
        "ingest.toml is an input"
    );
    let fit = &m1["metrics"]["experiment.fit"];
    assert!(fit["theta"].is_f64() && fit["eta_c"].is_f64(), "{fit}");
    assert_eq!(fit["theta_interval"].as_array().unwrap().len(), 2);
    assert_eq!(fit["eta_c_interval"].as_array().unwrap().len(), 2);
    assert_eq!(m1["metrics"]["experiment.ingest"]["frames"], 40);
    assert!(m1["stages"][0]["elapsed_s"].is_f64());

    // Unchanged: nothing recomputed, nothing in the cache touched, a new run recorded.
    let mut before = BTreeMap::new();
    cache_files(&runs.join("cache"), &mut before);
    let out = run_ok(&["run", &exp, "--set", "fit.bootstrap=20"], &runs);
    assert_eq!(
        out.lines().filter(|l| l.contains(" cached ")).count(),
        4,
        "{out}"
    );
    assert!(out.contains("0 computed, 4 cached"), "{out}");
    let m2 = latest(&runs);
    assert!(computed(&m2).is_empty());
    assert_ne!(m2["run_id"], m1["run_id"]);
    let mut after = BTreeMap::new();
    cache_files(&runs.join("cache"), &mut after);
    assert_eq!(before, after, "a cached re-run rewrote cache files");
    assert!(
        runs.join(m2["run_id"].as_str().unwrap())
            .join("report.html")
            .is_file()
    );
    assert_eq!(m2["metrics"], m1["metrics"]);

    // A fit parameter reruns the fit and what depends on it only.
    run_ok(
        &[
            "run",
            &exp,
            "--set",
            "fit.bootstrap=20",
            "--set",
            "fit.method=points",
        ],
        &runs,
    );
    let m3 = latest(&runs);
    assert_eq!(computed(&m3), ["experiment.fit", "report"]);
    let id3 = m3["run_id"].as_str().unwrap().to_string();

    // Side by side: both runs' Θ and η_c with intervals, and the changed parameter.
    let out = run_ok(&["runs", "compare", &id1, &id3], &runs);
    assert!(out.contains(&id1) && out.contains(&id3), "{out}");
    for row in ["experiment.fit.theta", "experiment.fit.eta_c"] {
        let line = out
            .lines()
            .find(|l| l.starts_with(row))
            .unwrap_or_else(|| panic!("no {row} row:\n{out}"));
        assert_eq!(line.matches('[').count(), 2, "{line}");
    }
    let changed = out.split("changed parameters").nth(1).unwrap();
    let line = changed
        .lines()
        .find(|l| l.starts_with("experiment.fit.method"))
        .unwrap();
    assert!(
        line.contains("binned-median") && line.contains("points"),
        "{line}"
    );
    assert!(
        !changed.contains("experiment.fit.bootstrap"),
        "unchanged parameters are not listed"
    );

    let out = run_ok(&["runs", "list"], &runs);
    assert_eq!(
        out.lines()
            .filter(|l| l.contains("experiment-only"))
            .count(),
        3,
        "{out}"
    );
    let out = run_ok(&["runs", "show", "latest"], &runs);
    assert!(
        out.contains(&id3) && out.contains("experiment.fit.theta"),
        "{out}"
    );

    // --dry-run says what is cached; --force recomputes a stage and its dependents.
    let out = run_ok(
        &["run", &exp, "--set", "fit.bootstrap=20", "--dry-run"],
        &runs,
    );
    assert_eq!(
        out.lines().filter(|l| l.contains(" cached ")).count(),
        4,
        "{out}"
    );
    run_ok(
        &[
            "run",
            &exp,
            "--set",
            "fit.bootstrap=20",
            "--force",
            "kinematics",
            "--quiet",
        ],
        &runs,
    );
    assert_eq!(
        computed(&latest(&runs)),
        ["experiment.kinematics", "report"]
    );
    final_dirs(&runs);
}

#[test]
fn bundled_pipelines_validate() {
    let d = tmpdir("bundled");
    for name in ["quickstart", "paper-n1000", "experiment-only"] {
        let out = run_ok(&["run", &bundled(name), "--dry-run"], &d.join("runs"));
        assert!(out.contains("is valid"), "{out}");
    }
    assert!(!d.join("runs").exists(), "--dry-run writes nothing");
}

/// A pipeline with the bundled sample's ingest stage, then `body`.
fn with_ingest(body: &str) -> String {
    format!(
        "[pipeline]\nroot = '{ROOT}'\n\n[experiment.ingest]\ninput = \"data/sample/tracks.csv\"\n\n{body}"
    )
}

fn line_of(text: &str, needle: &str) -> usize {
    1 + text.lines().position(|l| l.starts_with(needle)).unwrap()
}

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
    let args = ["run", &exp, "--set", "fit.bootstrap=150", "--quiet"];
    let mut child = Command::new(BIN)
        .args(args)
        .arg("--runs-dir")
        .arg(&runs)
        .spawn()
        .unwrap();
    // Long enough for ingest and kinematics, short of the fit (SIGKILL: no clean-up runs).
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let _ = child.kill();
    let _ = child.wait();
    if runs.exists() {
        assert_eq!(
            latest(&runs)["status"],
            "incomplete",
            "a killed run is listed as such"
        );
    }
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

#[test]
fn simulate_stage_runs_or_says_it_is_not_implemented() {
    let d = tmpdir("sim");
    let runs = d.join("runs");
    let file = d.join("sim.toml");
    std::fs::write(
        &file,
        "[simulation.simulate]\npreset = \"fast\"\nn = 200\nstrain = 0.02\nseed = 3\n",
    )
    .unwrap();
    let (ok, out, err) = pp(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let m = latest(&runs);
    if ok {
        // Once the simulator is merged: its tables are the stage's outputs.
        let st = &m["stages"][0];
        assert!(st["outputs"]["tracks"].is_string(), "{st}");
        let tracks = runs
            .join(st["dir"].as_str().unwrap())
            .join(st["outputs"]["tracks"].as_str().unwrap());
        assert!(tracks.is_file(), "{}", tracks.display());
        assert!(m["metrics"]["simulation.simulate"]["n"].is_u64(), "{m}");
    } else {
        assert!(
            err.contains("stage 'simulation.simulate' (simulate) failed")
                && err.contains("not implemented"),
            "{out}\n{err}"
        );
        assert_eq!(m["failed_stage"], "simulation.simulate");
    }
}

/// The schema file documents exactly the keys the option structs take, with the same
/// defaults, and the embedded copy is the file on disk.
#[test]
fn pipeline_schema_and_code_agree() {
    use pillar_pipe::pipeline::{Kind, params, schema};
    let on_disk =
        std::fs::read_to_string(Path::new(ROOT).join("data_schema/pipeline.schema.json")).unwrap();
    assert_eq!(on_disk, schema::SCHEMA_TEXT);
    let s = schema::load();
    assert_eq!(s.stages.len(), Kind::ALL.len());
    for kind in Kind::ALL {
        let spec = s.stage(kind);
        let rust = params::rust_defaults(kind);
        let rust_keys: Vec<&String> = rust.as_object().unwrap().keys().collect();
        let mut a: Vec<&str> = rust_keys.iter().map(|k| k.as_str()).collect();
        let mut b: Vec<&str> = spec.keys.iter().map(|k| k.name.as_str()).collect();
        a.sort();
        b.sort();
        assert_eq!(
            a,
            b,
            "{}: keys in Rust vs data_schema/pipeline.schema.json",
            kind.name()
        );
        for k in &spec.keys {
            assert!(s.key(kind, &k.name).is_some());
            if k.required {
                assert!(
                    k.default.is_none(),
                    "{}.{}: required keys have no default",
                    kind.name(),
                    k.name
                );
                continue;
            }
            let want = k.default.clone().unwrap_or(Value::Null);
            let got = &rust[&k.name];
            let same = match (want.as_f64(), got.as_f64()) {
                (Some(x), Some(y)) => x == y,
                _ => &want == got,
            };
            assert!(
                same,
                "{}.{}: schema default {want} but Rust default {got}",
                kind.name(),
                k.name
            );
        }
    }
}
