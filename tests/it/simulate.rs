//! `simulate pillar` and `pack` from the user's side (issue 5 acceptance): outputs and
//! their schemas, kinematics reading the trajectories, checkpoint–kill–resume equal to
//! an uninterrupted run, and clear refusals.

use crate::common::{BIN, cli as run, tmpdir};
use pillar_pipe::io::table::read_table;
use pillar_pipe::schema;
use std::path::Path;
use std::process::Command;

fn columns(p: &Path) -> Vec<String> {
    read_table(p, &[]).unwrap().columns()
}

/// Every table of a run, as rows of strings (exact values, for equality).
/// Every value of every output table, bit for bit (column name and f64 bits).
fn contents(dir: &Path) -> Vec<(String, Vec<u64>)> {
    let mut out = Vec::new();
    for t in ["tracks", "bar_forces", "stress_strain", "forces"] {
        let table = read_table(&dir.join(format!("{t}.parquet")), &[]).unwrap();
        for c in table.columns() {
            let v = table.f64_or_nan(&c).unwrap();
            out.push((format!("{t}.{c}"), v.iter().map(|x| x.to_bits()).collect()));
        }
    }
    out
}

/// A 120-grain fast run; `extra` may replace the preset or strain.
fn small(dir: &Path, extra: &[&str]) -> (bool, String) {
    let mut a = vec!["simulate", "pillar", "--n", "120", "--quiet"];
    if !extra.contains(&"--preset") {
        a.extend_from_slice(&["--preset", "fast"]);
    }
    if !extra.contains(&"--strain") {
        a.extend_from_slice(&["--strain", "0.04"]);
    }
    a.extend_from_slice(extra);
    a.extend_from_slice(&["-o", dir.to_str().unwrap()]);
    run(&a)
}

#[test]
fn acceptance_run_writes_every_output_and_kinematics_reads_it() {
    let dir = tmpdir("acc");
    let out = dir.join("p");
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--n",
        "200",
        "--preset",
        "fast",
        "--strain",
        "0.1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    for t in ["tracks", "bar_forces", "stress_strain", "forces"] {
        let cols = columns(&out.join(format!("{t}.parquet")));
        assert_eq!(
            cols,
            schema::load(t).names(),
            "{t} columns match data_schema/{t}.schema.json"
        );
    }
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["params"]["preset"], "fast");
    assert!(
        m["checks"]["eq12_ratio_2kn_vc_dt_over_m_g_mu"]
            .as_f64()
            .unwrap()
            < 0.1
    );
    assert!(m["tool_version"].is_string() && m["setup"]["seed"] == 1);
    assert!(!out.join("checkpoint.bin").exists() && !out.join(".parts").exists());
    // The run reached ε = 0.1 and loaded the bar.
    let ss = read_table(&out.join("stress_strain.parquet"), &[]).unwrap();
    let strain = ss.f64("strain").unwrap();
    assert!((strain.last().unwrap() - 0.1).abs() < 1e-3);
    let stress = ss.f64("stress_reduced").unwrap();
    let late: Vec<f64> = stress
        .iter()
        .zip(&strain)
        .filter(|(_, e)| **e > 0.05)
        .map(|(s, _)| *s)
        .collect();
    assert!(
        late.iter().all(|s| *s > 0.5),
        "the pillar resists: {late:?}"
    );
    // Substrate friction takes most of the input power (li-granular-pillars Fig. 10d).
    let kappa = ss.f64("kappa_exact").unwrap_or_default();
    assert!(
        kappa.iter().skip(10).all(|k| *k > 0.2 && *k <= 1.05),
        "{kappa:?}"
    );

    let k = dir.join("k.parquet");
    let (ok, text) = run(&[
        "kinematics",
        out.join("tracks.parquet").to_str().unwrap(),
        "--lag",
        "10",
        "-o",
        k.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let kt = read_table(&k, &[]).unwrap();
    assert!(kt.df.height() >= 200 * 4, "{}", kt.df.height());
}

#[test]
fn checkpoint_halt_resume_equals_an_uninterrupted_run() {
    let dir = tmpdir("resume");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let (ok, text) = small(&a, &[]);
    assert!(ok, "{text}");
    let (ok, text) = small(&b, &["--checkpoint-every", "4000", "--halt-after", "9000"]);
    assert!(!ok && text.contains("halted"), "{text}");
    assert!(b.join("checkpoint.bin").exists() && !b.join("manifest.json").exists());
    assert!(
        !b.join("tracks.parquet").exists(),
        "no complete-looking table from an interrupted run"
    );
    // The benchmark times a real run's state from its checkpoint (and checks that the
    // frozen-grain skip changes nothing there).
    let ck = b.join("checkpoint.bin");
    let (ok, text) = run(&[
        "bench",
        "dem",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--steps",
        "300",
        "--json",
    ]);
    assert!(ok, "{text}");
    let v: serde_json::Value = serde_json::from_str(text.trim()).expect("json");
    assert_eq!(v["n"], 120);
    let frozen = v["reused_fraction"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&frozen) && v["ns_per_particle_step"].as_f64().unwrap() > 0.0);
    // Whether the timed run fell back to one thread is part of the figure.
    assert!(v["fell_back"].is_boolean(), "{text}");
    // Resuming with different physics is refused; with the same, it finishes.
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--n",
        "120",
        "--preset",
        "fast",
        "--strain",
        "0.05",
        "--quiet",
        "--resume",
        b.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("differ"), "{text}");
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--n",
        "120",
        "--preset",
        "fast",
        "--strain",
        "0.04",
        "--quiet",
        "--checkpoint-every",
        "4000",
        "--resume",
        b.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert_eq!(contents(&a), contents(&b));
    // The manifest counts the wall time of both sessions.
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("manifest.json")).unwrap()).unwrap();
    let (this, total) = (
        m["report"]["elapsed_s"].as_f64().unwrap(),
        m["report"]["elapsed_total_s"].as_f64().unwrap(),
    );
    assert!(
        total > this
            && m["steps_this_session"].as_u64().unwrap() < m["report"]["steps"].as_u64().unwrap()
    );
}

/// `--resume DIR` alone continues with the run's own options, not the command line's
/// defaults; a typed option must match the run's unless it only says how the run
/// proceeds (issue 33, item 4).
#[test]
fn resume_alone_continues_with_the_runs_own_options() {
    let dir = tmpdir("resume-alone");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let (a_s, b_s) = (a.to_str().unwrap(), b.to_str().unwrap());
    let opts = [
        "simulate", "pillar", "--n", "120", "--seed", "7", "--strain", "0.05", "--quiet",
    ];
    let with = |extra: &[&str]| run(&[&opts[..], extra].concat());
    let (ok, text) = with(&["-o", a_s]);
    assert!(ok, "{text}");
    let (ok, text) = with(&[
        "--checkpoint-every",
        "4000",
        "--halt-after",
        "5000",
        "-o",
        b_s,
    ]);
    assert!(!ok && text.contains("halted"), "{text}");
    let (ok, text) = run(&[
        "simulate", "pillar", "--strain", "0.06", "--seed", "7", "--resume", b_s,
    ]);
    assert!(
        !ok && text.contains("strain: then 0.05, now 0.06")
            && !text.contains("seed: then")
            && text.contains("-o NEW_DIR"),
        "{text}"
    );
    assert!(b.join("checkpoint.bin").exists() && !b.join("manifest.json").exists());
    // Run-only options may differ; a typed option equal to the run's is no difference.
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--seed",
        "7",
        "--checkpoint-every",
        "3000",
        "--checkpoint-interval",
        "0",
        "--halt-after",
        "9000",
        "--resume",
        b_s,
    ]);
    assert!(
        !ok && text.contains("halted")
            && text.contains("taken from the run: n = 120, strain = 0.05"),
        "{text}"
    );
    let (ok, text) = run(&["simulate", "pillar", "--resume", b_s]);
    assert!(
        ok && text.contains("taken from the run: n = 120, seed = 7, strain = 0.05"),
        "{text}"
    );
    assert_eq!(contents(&a), contents(&b));
    for t in ["tracks", "bar_forces", "stress_strain", "forces"] {
        let f = format!("{t}.parquet");
        assert!(
            std::fs::read(a.join(&f)).unwrap() == std::fs::read(b.join(&f)).unwrap(),
            "{f} differs byte for byte"
        );
    }
}

#[test]
fn killed_run_resumes_to_the_same_result() {
    let dir = tmpdir("kill");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let (ok, text) = small(&a, &["--strain", "0.06"]);
    assert!(ok, "{text}");
    let mut child = Command::new(BIN)
        .args([
            "simulate", "pillar", "--n", "120", "--preset", "fast", "--strain", "0.06",
        ])
        .args([
            "--quiet",
            "--checkpoint-every",
            "3000",
            "-o",
            b.to_str().unwrap(),
        ])
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !b.join("checkpoint.bin").exists() && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let _ = child.kill(); // SIGKILL: no chance to clean up
    child.wait().unwrap();
    if !b.join("manifest.json").exists() {
        let (ok, text) = run(&[
            "simulate",
            "pillar",
            "--n",
            "120",
            "--preset",
            "fast",
            "--strain",
            "0.06",
            "--quiet",
            "--checkpoint-every",
            "3000",
            "--resume",
            b.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
    }
    assert_eq!(contents(&a), contents(&b));
}

#[test]
fn bad_requests_are_refused_clearly() {
    let dir = tmpdir("bad");
    let (ok, text) = small(&dir.join("x"), &["--preset", "slow"]);
    assert!(
        !ok && text.contains("unknown preset 'slow'") && text.contains("paper, fast"),
        "{text}"
    );
    let (ok, text) = small(&dir.join("x"), &["--strain", "1.5"]);
    assert!(!ok && text.contains("strain"), "{text}");
    let (ok, text) = small(&dir.join("x"), &["--param", "k_nn=3"]);
    assert!(
        !ok && text.contains("unknown parameter 'k_nn'") && text.contains("k_n"),
        "{text}"
    );
    let (ok, text) = small(&dir.join("x"), &["--param", "dt=0.01"]);
    assert!(!ok && text.contains("too large"), "{text}");
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--resume",
        dir.join("nothing").to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("no checkpoint"), "{text}");
    // A finished run is not overwritten.
    let done = dir.join("done");
    assert!(small(&done, &["--strain", "0.01"]).0);
    let (ok, text) = small(&done, &["--strain", "0.01"]);
    assert!(
        !ok && text.contains("already holds a finished run"),
        "{text}"
    );
    // A packing in pixels cannot be simulated.
    let px = dir.join("px.csv");
    std::fs::write(&px, "frame,particle,x,y,radius\n0,0,0,0,5\n0,1,10,0,5\n").unwrap();
    std::fs::write(
        dir.join("px.csv.meta.json"),
        r#"{"schema":"tracks","schema_version":1,"length_unit":"px","time_unit":"s","frame_time":null,"coordinate_frame":"x"}"#,
    )
    .unwrap();
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--packing",
        px.to_str().unwrap(),
        "-o",
        dir.join("y").to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("'px'"), "{text}");
}

#[test]
fn pack_then_simulate_from_the_packing_file() {
    let dir = tmpdir("pack");
    let pk = dir.join("packing.parquet");
    let (ok, text) = run(&[
        "pack",
        "--n",
        "100",
        "--seed",
        "7",
        "-o",
        pk.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("φ ="), "{text}");
    let t = read_table(&pk, &[]).unwrap();
    assert_eq!(t.df.height(), 100);
    let out = dir.join("sim");
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--packing",
        pk.to_str().unwrap(),
        "--strain",
        "0.01",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["setup"]["n"], 100);
    assert!(m["setup"]["packing_sha256"].as_str().unwrap().len() == 64);
    // The same seed gives the same packing.
    let pk2 = dir.join("packing2.parquet");
    assert!(
        run(&[
            "pack",
            "--n",
            "100",
            "--seed",
            "7",
            "-o",
            pk2.to_str().unwrap(),
            "--quiet"
        ])
        .0
    );
    assert_eq!(
        format!("{:?}", read_table(&pk, &[]).unwrap().df),
        format!("{:?}", read_table(&pk2, &[]).unwrap().df)
    );
}

/// `bench pack` runs the whole command and its reference, the packer before
/// 2026-11-27 (`--serial --f-tol 0`): each gives what that `pack` command gives.
#[test]
fn bench_pack_times_the_command_against_the_old_packer() {
    let (ok, text) = run(&["bench", "pack", "--n", "80", "--seeds", "3", "--json"]);
    assert!(ok, "{text}");
    let v: serde_json::Value = serde_json::from_str(text.trim()).expect("json");
    let runs = v["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2);
    assert_eq!(runs[0]["variant"], "default");
    assert_eq!(runs[1]["variant"], "reference");
    assert_eq!(runs[0]["f_tol"], 1e-3);
    assert_eq!(
        runs[1]["f_tol"], 0.0,
        "the reference is the energy rule alone"
    );
    let dir = tmpdir("bench-pack");
    for (k, extra) in [(0, &[][..]), (1, &["--serial", "--f-tol", "0"][..])] {
        let out = dir.join(format!("{k}.parquet"));
        let mut args = vec!["pack", "--n", "80", "--seed", "3", "--quiet", "-o"];
        args.push(out.to_str().unwrap());
        args.extend_from_slice(extra);
        let (ok, text) = run(&args);
        assert!(ok, "{text}");
        let meta: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.with_extension("parquet.meta.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(runs[k]["phi"], meta["summary"]["phi"], "{extra:?}");
        assert_eq!(runs[k]["cg_iterations"], meta["summary"]["cg_iterations"]);
    }
    assert!(runs[0]["cg_iterations"].as_u64().unwrap() > 0);
    assert!(runs[0]["run"]["cpu_seconds"].as_f64().unwrap() > 0.0);
}

/// A force tolerance that is negative or not a number is refused by name, and nothing
/// is written.
#[test]
fn pack_refuses_a_bad_force_tolerance() {
    let dir = tmpdir("pack-ftol");
    let out = dir.join("pk.parquet");
    for bad in ["-0.001", "NaN", "inf"] {
        let arg = format!("--f-tol={bad}");
        let (ok, text) = run(&["pack", "--n", "20", &arg, "-o", out.to_str().unwrap()]);
        assert!(!ok, "{bad}: {text}");
        assert!(
            text.contains("f_tol") && text.contains(bad),
            "{bad}: {text}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn the_thread_count_changes_nothing() {
    let dir = tmpdir("threads");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let (ok, text) = small(&a, &["--threads", "1"]);
    assert!(ok, "{text}");
    let (ok, text) = small(&b, &["--threads", "2"]);
    assert!(ok, "{text}");
    assert_eq!(contents(&a), contents(&b));
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["threads_this_session"], 2);
}

/// Issue 36: a pipeline's simulation starts from the experiment's grains by naming its
/// ingest stage (`packing_stage`), and gets the same run as the command line given that
/// stage's tracks file as `--packing`; `packing` and `packing_stage` together are refused.
#[test]
fn a_simulate_stage_packs_from_an_ingest_stage_as_the_cli_does_from_its_file() {
    use crate::common::{latest, refused, run_ok};
    let d = tmpdir("packing-stage");
    let runs = d.join("runs");
    let file = d.join("p.toml");
    let text = format!(
        r#"[pipeline]
root = '{root}'

[experiment.ingest]
input = "data/sample/tracks.csv"

[simulation.simulate]
preset = "fast"
packing_stage = "experiment.ingest"
strain = 0.005
"#,
        root = env!("CARGO_MANIFEST_DIR")
    );
    std::fs::write(&file, &text).unwrap();
    run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let m = latest(&runs);
    let dir_of = |name: &str| crate::common::stage_dir(&m, &runs, name);
    let packing = dir_of("experiment.ingest").join("tracks.parquet");
    assert!(packing.is_file(), "{m}");
    let cli_run = d.join("cli");
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--preset",
        "fast",
        "--strain",
        "0.005",
        "--packing",
        packing.to_str().unwrap(),
        "--quiet",
        "-o",
        cli_run.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let stage = pillar_pipe::io::read_tracks(&dir_of("simulation.simulate").join("tracks.parquet"))
        .unwrap()
        .0;
    let cli = pillar_pipe::io::read_tracks(&cli_run.join("tracks.parquet"))
        .unwrap()
        .0;
    let exp = pillar_pipe::io::read_tracks(&packing).unwrap().0;
    let first = exp.frame.iter().min().copied().unwrap();
    let grains = exp.frame.iter().filter(|f| **f == first).count();
    assert_eq!(
        m["metrics"]["simulation.simulate"]["n"].as_u64(),
        Some(grains as u64),
        "the experiment's first frame, grain for grain: {m}"
    );
    assert_eq!(stage.x, cli.x, "the same run as --packing FILE");
    assert_eq!(stage.y, cli.y);
    // Both keys: refused before anything runs.
    let both = text.replace(
        "packing_stage = ",
        "packing = \"data/sample/tracks.csv\"\npacking_stage = ",
    );
    refused(&file, &d.join("runs2"), &both, &["packing"]);
}

/// Issue 35: a `pack` stage is one packing every simulate stage that names it starts
/// from (packed once, shared from the cache): two runs of a parameter study begin from
/// the same grains, the packing is `pillar-pipe pack`'s with the same options bit for
/// bit, and a rerun packs nothing.
#[test]
fn a_pack_stage_is_packed_once_and_shared_by_the_simulations_that_name_it() {
    use crate::common::{computed, latest, run_ok};
    let d = tmpdir("pack-stage");
    let runs = d.join("runs");
    let file = d.join("p.toml");
    let sim = |name: &str, k_n: &str| {
        format!(
            "[{name}.simulate]\npreset = \"fast\"\npacking_stage = \"pack\"\nstrain = 0.004\nset = {{ k_n = {k_n} }}\n\n"
        )
    };
    std::fs::write(
        &file,
        format!(
            "[pipeline]\nroot = '{}'\n\n[pack]\nn = 150\nseed = 3\nf_tol = 0.0\n\n{}{}",
            env!("CARGO_MANIFEST_DIR"),
            sim("soft", "1000.0"),
            sim("stiff", "3000.0")
        ),
    )
    .unwrap();
    run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let m = latest(&runs);
    let mut got = computed(&m);
    got.sort();
    assert_eq!(got, ["pack", "soft.simulate", "stiff.simulate"]);
    let dir_of = |name: &str| crate::common::stage_dir(&m, &runs, name);
    let packing = dir_of("pack").join("tracks.parquet");
    let cli_pack = d.join("pk.parquet");
    let (ok, text) = run(&[
        "pack",
        "--n",
        "150",
        "--seed",
        "3",
        "--f-tol",
        "0",
        "--quiet",
        "-o",
        cli_pack.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    // The stage's `f_tol` reached the packer (the energy rule alone) and is recorded.
    let meta: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(packing.with_extension("parquet.meta.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(meta["provenance"]["parameters"]["protocol"]["f_tol"], 0.0);
    let (a, b) = (
        pillar_pipe::io::read_tracks(&packing).unwrap().0,
        pillar_pipe::io::read_tracks(&cli_pack).unwrap().0,
    );
    assert_eq!(a.x, b.x, "the stage's packing is the command's");
    assert_eq!(a.y, b.y);
    // Both runs start from it: their first frames hold the same grains, and their
    // manifests name the one packing by its hash.
    let sha = pillar_pipe::io::sha256_file(&packing).unwrap();
    let first = |name: &str| {
        let t = pillar_pipe::io::read_tracks(&dir_of(name).join("tracks.parquet"))
            .unwrap()
            .0;
        let n = t.frame.iter().filter(|f| **f == t.frame[0]).count();
        (t.x[..n].to_vec(), t.y[..n].to_vec())
    };
    assert_eq!(first("soft.simulate"), first("stiff.simulate"));
    for name in ["soft.simulate", "stiff.simulate"] {
        let text = std::fs::read_to_string(dir_of(name).join("manifest.json")).unwrap();
        assert!(text.contains(&sha), "{name} names another packing");
    }
    run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    assert!(computed(&latest(&runs)).is_empty(), "a rerun packs nothing");
}

/// Issue 36: `vary` runs a stage at several values of its keys, each point a stage of
/// its own with the cache key a hand-written one gets; the grid gathers ⟨σ⟩, κ and the
/// yield point per point into grid.csv, and a report draws the study with its checks.
#[test]
fn vary_makes_a_parameter_study_of_cached_points_and_a_report_section() {
    use crate::common::{computed, latest, pp, run_ok};
    use pillar_pipe::io::table::read_table;
    let d = tmpdir("vary");
    let runs = d.join("runs");
    let root = env!("CARGO_MANIFEST_DIR");
    let file = d.join("study.toml");
    std::fs::write(
        &file,
        format!(
            "[pipeline]\nroot = '{root}'\n\n[pack]\nn = 100\nseed = 2\n\n[kn.simulate]\npreset = \"fast\"\npacking_stage = \"pack\"\nstrain = 0.2\nvary = {{ \"set.k_n\" = [1000.0, 3000.0], \"set.dt\" = [4e-5, 3e-5] }}\n\n[report]\ndatasets = [\"kn\"]\n"
        ),
    )
    .unwrap();
    run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let m = latest(&runs);
    let mut got = computed(&m);
    got.sort();
    assert_eq!(
        got,
        [
            "kn.simulate",
            "kn.simulate:set.dt=0.00003,set.k_n=3000.0",
            "kn.simulate:set.dt=0.00004,set.k_n=1000.0",
            "pack",
            "report"
        ]
    );
    let dir_of = |name: &str| crate::common::stage_dir(&m, &runs, name);
    let t = read_table(&dir_of("kn.simulate").join("grid.csv"), &[]).unwrap();
    let rec = std::fs::read_to_string(dir_of("kn.simulate").join("grid.json")).unwrap();
    assert!(rec.contains("\"sigma_y\": \"m g mu / D\""), "units: {rec}");
    assert_eq!(t.f64("set.k_n").unwrap(), vec![1000.0, 3000.0]);
    for c in ["sigma_mean", "kappa_mean", "steps"] {
        let v = t.f64(c).unwrap();
        assert!(v.iter().all(|x| x.is_finite() && *x > 0.0), "{c}: {v:?}");
    }
    let run_dir = runs.join(m["run_id"].as_str().unwrap());
    let html = std::fs::read_to_string(run_dir.join("report.html")).unwrap();
    assert!(
        html.contains("Parameter study: set.dt, set.k_n (kn)"),
        "no study section"
    );
    assert!(
        html.contains("against set.k_n"),
        "k_n is the axis, dt varies with it"
    );
    assert!(html.contains("flow stress not significantly influenced by k_n"));
    // A hand-written stage with a point's values is that point: cached.
    let one = d.join("one.toml");
    std::fs::write(
        &one,
        format!(
            "[pipeline]\nroot = '{root}'\n\n[pack]\nn = 100\nseed = 2\n\n[x.simulate]\npreset = \"fast\"\npacking_stage = \"pack\"\nstrain = 0.2\nset = {{ k_n = 3000.0, dt = 3e-5 }}\n"
        ),
    )
    .unwrap();
    run_ok(&["run", one.to_str().unwrap(), "--quiet"], &runs);
    assert!(computed(&latest(&runs)).is_empty(), "the point was cached");
    // Faults are named at the key.
    for (body, needles) in [
        (
            "[a.simulate]\nvary = { \"set.k_n\" = [1000.0, 2000.0], seed = [1] }\n",
            &["a.simulate.vary", "as long"][..],
        ),
        (
            "[a.simulate]\nvary = { bogus = [1] }\n",
            &["a.simulate.vary.bogus", "not a key"][..],
        ),
        (
            "[a.simulate]\nvary = { packing = [\"x\"] }\n",
            &["a.simulate.vary.packing", "cannot be varied"][..],
        ),
        (
            "[a.simulate]\n\n[report]\ndatasets = [\"a\"]\nvary = { map_stages = [1, 2] }\n",
            &["report.vary", "gathers"][..],
        ),
    ] {
        let f = d.join("bad.toml");
        std::fs::write(&f, format!("[pipeline]\nroot = '{root}'\n\n{body}")).unwrap();
        let (ok, _, e) = pp(&["run", f.to_str().unwrap(), "--quiet"], &runs);
        assert!(!ok, "{body}");
        for n in needles {
            assert!(e.contains(n), "{body}: {e}");
        }
    }
}
