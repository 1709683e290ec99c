//! Pipelines through the CLI, as a user runs them: a run writes its report and manifest,
//! a re-run recomputes nothing, a changed fit parameter reruns only what depends on it,
//! `runs compare` shows both fits; the bundled pipelines validate; the simulate stage is
//! wired; the schema file matches the code.

use crate::common::*;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

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

/// The main job: experiment and simulation meet in compare and report; a fit parameter
/// reruns both fits, compare and report, and nothing upstream.
#[test]
fn quickstart_pipeline_runs_both_branches() {
    let d = tmpdir("quick");
    let runs = d.join("runs");
    let qs = bundled("quickstart");
    run_ok(&["run", &qs, "--set", "fit.bootstrap=20", "--quiet"], &runs);
    let m = latest(&runs);
    assert_eq!(computed(&m).len(), 8, "{m}");
    for st in ["experiment.fit", "simulation.fit"] {
        assert!(m["metrics"][st]["theta"].is_f64(), "{st}: {m}");
    }
    assert!(m["metrics"]["compare"]["theta_agree"].is_boolean());
    assert_eq!(m["metrics"]["simulation.simulate"]["n"], 200);
    assert_eq!(m["seeds"]["simulation.simulate"], 1);
    let dir = runs.join(m["run_id"].as_str().unwrap());
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.contains("fig-stress-strain") && html.contains("simulation"));
    assert!(dir.join("figures/stress_strain.svg").is_file());
    // The simulate stage's forces reach the report (Fig. 6), and both rows of maps are at
    // matching strains.
    for f in ["forces_fn", "forces_ft", "forces_sub", "kappa"] {
        assert!(dir.join(format!("figures/{f}.svg")).is_file(), "{f}");
    }
    assert!(html.contains("experiment: ε ≈") && html.contains("simulation: ε = "));

    let out = run_ok(&["run", &qs, "--set", "fit.bootstrap=20"], &runs);
    assert!(out.contains("0 computed, 8 cached"), "{out}");
    run_ok(
        &[
            "run",
            &qs,
            "--set",
            "fit.bootstrap=20",
            "--set",
            "fit.method=points",
            "--quiet",
        ],
        &runs,
    );
    assert_eq!(
        computed(&latest(&runs)),
        ["experiment.fit", "simulation.fit", "compare", "report"]
    );
}

#[test]
fn bundled_pipelines_validate() {
    let d = tmpdir("bundled");
    // Every file under pipelines/, so that a new one is covered the day it is added.
    let mut names: Vec<String> = std::fs::read_dir(Path::new(ROOT).join("pipelines"))
        .unwrap()
        .flatten()
        .filter_map(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.strip_suffix(".toml").map(str::to_string)
        })
        .collect();
    names.sort();
    for must in [
        "quickstart",
        "shear-flow-curves",
        "shear-ramps",
        "paper-sizes",
        "camera-check",
        "pillar-parameters",
    ] {
        assert!(names.iter().any(|n| n == must), "{must}: {names:?}");
    }
    for name in &names {
        let out = run_ok(&["run", &bundled(name), "--dry-run"], &d.join("runs"));
        assert!(out.contains("is valid"), "{name}: {out}");
    }
    assert!(!d.join("runs").exists(), "--dry-run writes nothing");
}

/// A simulate stage runs from a pipeline file, its tables are the stage's outputs,
/// and the `normal_law` key reaches the simulator (the Hertzian law runs on the scalar
/// reference; its manifest says so); a law the simulator does not know is refused
/// naming the key and the choices.
#[test]
fn simulate_stage_runs_with_the_hertzian_law() {
    let d = tmpdir("sim");
    let runs = d.join("runs");
    let file = d.join("sim.toml");
    std::fs::write(
        &file,
        "[simulation.simulate]\npreset = \"fast\"\nn = 200\nstrain = 0.02\nseed = 3\nnormal_law = \"hertz\"\n",
    )
    .unwrap();
    let (ok, out, err) = pp(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    assert!(ok, "{out}\n{err}");
    let m = latest(&runs);
    let st = &m["stages"][0];
    let dir = runs.join(st["dir"].as_str().unwrap());
    let tracks = dir.join(st["outputs"]["tracks"].as_str().unwrap());
    assert!(tracks.is_file(), "{}", tracks.display());
    assert!(m["metrics"]["simulation.simulate"]["n"].is_u64(), "{m}");
    let sim: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(sim["params"]["normal_law"], "hertz", "{sim}");
    assert_eq!(sim["pair_kernel_this_session"], "scalar", "{sim}");

    std::fs::write(
        &file,
        "[simulation.simulate]\npreset = \"fast\"\nn = 200\nnormal_law = \"hooke\"\n",
    )
    .unwrap();
    let (ok, out, err) = pp(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    assert!(!ok, "{out}");
    assert!(
        err.contains("normal_law") && err.contains("linear") && err.contains("hertz"),
        "{err}"
    );
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
    // `kind = "..."` accepts every registered kind, and only those.
    let kind_key = s.common_keys.iter().find(|k| k.name == "kind").unwrap();
    let mut allowed = kind_key.allowed.clone().unwrap();
    let mut names: Vec<String> = Kind::ALL.iter().map(|k| k.name().to_string()).collect();
    allowed.sort();
    names.sort();
    assert_eq!(allowed, names, "the kind key's allowed list");
    for &kind in Kind::ALL {
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
