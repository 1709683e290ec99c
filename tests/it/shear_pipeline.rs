//! Sheared-disk stages in pipelines (issue 21): `shear` and `sweep` stages cached like
//! the pillar's, every grid point of a sweep cached on its own (a grown grid computes
//! only its new points; a `shear` stage equal to a grid point is the same entry), the
//! sweep's table, validation naming file, line and key, and the report's sections.

use crate::common::*;
use serde_json::Value;
use std::path::Path;

/// A tiny grid: 32 disks (box side 6.8 d_s), strain 0.3, γ̇ τ_e ≥ 1e-2 (≈ 600 steps).
fn tiny(phi: &str, extra: &str) -> String {
    format!(
        "[pipeline]\nname = \"tiny-sweep\"\n\n[flow.sweep]\nphi = {phi}\nq = [1]\nrate = [1e-2, 3e-2]\n\
         n = 32\nstrain = 0.3\nsample_every = 2\n\n[flow.shear]\nphi = 0.84\nrate = 1e-2\nn = 32\nstrain = 0.3\nsample_every = 2\n{extra}"
    )
}

/// A report of one data set in `out`; its HTML.
fn report_of(out: &Path, d: pillar_pipe::stages::report::DatasetInputs) -> String {
    let r = pillar_pipe::stages::report::run(
        out,
        &pillar_pipe::stages::report::ReportOptions {
            title: d.label.clone(),
            datasets: vec![d],
            map_stages: 1,
            provenance: serde_json::json!({}),
            sizes: None,
        },
    )
    .unwrap();
    std::fs::read_to_string(&r.html).unwrap()
}

/// The figure `stem` exists in `out/figures` as PNG and SVG.
fn assert_figure(out: &Path, stem: &str) {
    for ext in ["png", "svg"] {
        let f = out.join(format!("figures/{stem}.{ext}"));
        assert!(f.is_file(), "{}", f.display());
    }
}

fn table_rows(p: &Path) -> usize {
    let t = pillar_pipe::io::table::read_table(p, &[]).unwrap();
    t.f64("phi").unwrap().len()
}

#[test]
fn sweep_points_are_cached_one_by_one() {
    let d = tmpdir("shear-sweep");
    let runs = d.join("runs");
    let file = d.join("s.toml");
    std::fs::write(&file, tiny("[0.78, 0.84]", "")).unwrap();
    let f = file.to_str().unwrap();
    run_ok(&["run", f, "--quiet"], &runs);
    let m = latest(&runs);
    // Four grid points, the sweep; the shear stage is the point φ = 0.84, γ̇ = 1e-2.
    assert_eq!(
        computed(&m),
        [
            "flow.sweep:phi=0.78,q=1,rate=1e-2",
            "flow.sweep:phi=0.78,q=1,rate=3e-2",
            "flow.sweep:phi=0.84,q=1,rate=1e-2",
            "flow.sweep:phi=0.84,q=1,rate=3e-2",
            "flow.sweep",
        ],
        "{m}"
    );
    let st = |m: &Value, name: &str| -> Value {
        m["stages"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == name)
            .cloned()
            .unwrap_or_else(|| panic!("no stage {name} in {m}"))
    };
    assert_eq!(
        st(&m, "flow.shear")["dir"],
        st(&m, "flow.sweep:phi=0.84,q=1,rate=1e-2")["dir"]
    );
    let sweep_dir = runs.join(st(&m, "flow.sweep")["dir"].as_str().unwrap());
    let grid: Value =
        serde_json::from_str(&std::fs::read_to_string(sweep_dir.join("sweep.json")).unwrap())
            .unwrap();
    assert_eq!(grid["grid"].as_array().unwrap().len(), 4, "{grid}");
    assert_eq!(grid["missing"].as_array().unwrap().len(), 0, "{grid}");
    let shear_dir = runs.join(st(&m, "flow.shear")["dir"].as_str().unwrap());
    for out in ["summary", "series", "tracks", "collision_angles"] {
        let rel = st(&m, "flow.shear")["outputs"][out]
            .as_str()
            .map(String::from);
        assert!(
            rel.is_some_and(|r| shear_dir.join(r).is_file()),
            "{out}: {m}"
        );
    }
    assert!(m["metrics"]["flow.shear"]["z"].is_f64(), "{m}");
    // The run's manifest names its tables where the stage keeps them.
    let man: Value =
        serde_json::from_str(&std::fs::read_to_string(shear_dir.join("manifest.json")).unwrap())
            .unwrap();
    assert_eq!(man["tables"]["series"], "series.parquet", "{man}");
    assert!(man["options"].get("quiet").is_none(), "{man}");
    assert_eq!(table_rows(&sweep_dir.join("sweep.parquet")), 4);
    // The table's columns are the schema's: phi, q, rate, then every quantity and its
    // error in name order, the required ones all there.
    let t = pillar_pipe::io::table::read_table(&sweep_dir.join("sweep.parquet"), &[]).unwrap();
    let sch = pillar_pipe::schema::load("sweep");
    let cols = t.columns();
    let documented: Vec<&str> = sch
        .names()
        .into_iter()
        .filter(|n| cols.iter().any(|c| c == n))
        .collect();
    assert_eq!(
        cols, documented,
        "every column documented, in the schema's order"
    );
    for r in sch.required() {
        assert!(cols.iter().any(|c| c == r), "required column {r} missing");
    }

    // Again: nothing computed.
    run_ok(&["run", f, "--quiet"], &runs);
    assert!(computed(&latest(&runs)).is_empty());

    // A grown grid computes its new points and the table only.
    run_ok(
        &["run", f, "--quiet", "--set", "sweep.phi=[0.78, 0.80, 0.84]"],
        &runs,
    );
    let m = latest(&runs);
    assert_eq!(
        computed(&m),
        [
            "flow.sweep:phi=0.8,q=1,rate=1e-2",
            "flow.sweep:phi=0.8,q=1,rate=3e-2",
            "flow.sweep",
        ],
        "{m}"
    );
    let sweep_dir = runs.join(st(&m, "flow.sweep")["dir"].as_str().unwrap());
    assert_eq!(table_rows(&sweep_dir.join("sweep.parquet")), 6);

    // --force on the sweep recomputes its points too.
    run_ok(&["run", f, "--quiet", "--force", "flow.sweep"], &runs);
    let m = latest(&runs);
    assert_eq!(computed(&m).len(), 4 + 1, "the points and the sweep: {m}");
}

#[test]
fn sweep_and_shear_keys_are_validated_before_anything_runs() {
    let d = tmpdir("shear-bad");
    let runs = d.join("runs");
    let file = d.join("bad.toml");
    let refuse = |text: &str, needles: &[&str]| refused(&file, &runs, text, needles);
    let text = tiny("[0.78, 2.0]", "");
    refuse(
        &text,
        &[
            &format!("line {}", line_of(&text, "[flow.sweep]")),
            "flow.sweep",
            "φ = 2",
            "phi must be in",
        ],
    );
    let text = tiny("[0.78]", "visc = 3\n");
    refuse(
        &text,
        &[
            &format!("line {}", line_of(&text, "visc")),
            "flow.shear.visc",
            "unknown key",
        ],
    );
    refuse(&tiny("[]", ""), &["flow.sweep.phi", "non-empty"]);
    refuse(
        &tiny("[0.8]", "model = \"cdx\"\n"),
        &["flow.shear.model", "cd, cdrot"],
    );
    assert!(!runs.join("cache").exists(), "nothing ran");
}

/// A synthetic sweep summary: p = c γ̇^exp with 2 % errors, and the other quantities.
fn summary(rate: f64, exp: f64) -> Value {
    let p = 5.0 * rate.powf(exp);
    let q = |m: f64, e: f64| serde_json::json!({"mean": m, "err": e});
    serde_json::json!({
        "p": q(p, 0.02 * p), "eta_p": q(p / rate, 0.02 * p / rate), "b_p": q(p / rate / rate, 0.02 * p / rate / rate),
        "z": q(3.0, 0.05), "two_tau_dur_nu_coll": q(2.95, 0.1), "mu": q(0.3, 0.01),
        "theta_dot_over_gamma_dot": q(-0.5, 0.01), "r_v": q(1.5, 0.1),
    })
}

/// A killed sweep (points missing): the report shows the flow curves and the
/// classification of what exists and names what is missing; φ = 0.76 with p ∝ γ̇² is
/// Bagnoldian, φ = 0.82 with p ∝ γ̇ Newtonian, and φ_c is bracketed between them.
#[test]
fn report_of_a_sweep_with_missing_points() {
    use pillar_pipe::stages::report::DatasetInputs;
    use pillar_pipe::stages::shear::ShearOptions;
    let d = tmpdir("shear-report");
    let sweep = d.join("sweep");
    std::fs::create_dir_all(&sweep).unwrap();
    let rates = [1e-4, 1e-3, 1e-2];
    let mut grid = Vec::new();
    let mut points = Vec::new();
    for (phi, exp) in [(0.76, 2.0), (0.80, 1.5), (0.82, 1.0)] {
        for &rate in &rates {
            grid.push((phi, 1.0, rate));
            // φ = 0.80 was killed after its first run.
            if phi != 0.80 || rate == 1e-4 {
                points.push(((phi, 1.0, rate), summary(rate, exp)));
            }
        }
    }
    pillar_pipe::stages::sweep::write_outputs(&sweep, &grid, &points, &ShearOptions::default())
        .unwrap();
    let out = d.join("report");
    let html = report_of(
        &out,
        DatasetInputs {
            label: "flow".into(),
            sweep: Some(sweep.clone()),
            ..Default::default()
        },
    );
    assert!(html.contains("7 of 9 grid points finished"), "{html}");
    assert!(
        html.contains("Missing (2 grid points")
            && html.contains("φ = 0.8, Q = 1, γ̇ τ_e = 1e-3")
            && html.contains("φ = 0.8, Q = 1, γ̇ τ_e = 1e-2"),
        "the missing points are named"
    );
    for fig in [
        "eta_p",
        "b_p",
        "z",
        "mu",
        "rotation",
        "r_v",
        "phase_phi_rate_q1",
    ]
    .map(|fig| format!("sweep_flow_{fig}"))
    {
        assert_figure(&out, &fig);
    }
    assert!(
        html.contains("Figs. 2, 11, 16") && html.contains("Fig. 23") && html.contains("Fig. 24")
    );
    let c: Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("classification_flow.json")).unwrap(),
    )
    .unwrap();
    let class = |phi: f64| -> String {
        c["slopes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["phi"] == phi && s["scope"] == "all")
            .map(|s| s["class"].as_str().unwrap().to_string())
            .unwrap_or_default()
    };
    assert_eq!(class(0.76), "bagnoldian", "{c}");
    assert_eq!(class(0.82), "newtonian", "{c}");
    assert_eq!(class(0.80), "", "one rate left: no slope");
    let t = c["transitions"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["along"] == "phi" && t["rate_lo"] == 1e-4 && t["rate_hi"] == 1e-2)
        .unwrap_or_else(|| panic!("no φ_c over all rates: {c}"));
    assert_eq!(
        (t["lo"].as_f64(), t["hi"].as_f64()),
        (Some(0.76), Some(0.82))
    );
    assert!(html.contains("φ_c(Q = 1) between 0.76 and 0.82"), "{html}");
}

/// A sweep over two Q: P^el, τ_dur/τ_e and ν_coll/γ̇ are drawn against φ (Figs. 15, 22;
/// 6, 14) and, with more than one Q, against Q (Figs. 1, 10; 6, 14).
#[test]
fn report_of_a_sweep_draws_p_el_and_the_collision_times() {
    use pillar_pipe::stages::report::DatasetInputs;
    use pillar_pipe::stages::shear::ShearOptions;
    let d = tmpdir("shear-report-el");
    let sweep = d.join("sweep");
    std::fs::create_dir_all(&sweep).unwrap();
    let q = |m: f64| serde_json::json!({"mean": m, "err": 0.05 * m});
    let mut grid = Vec::new();
    let mut points = Vec::new();
    for phi in [0.78, 0.82] {
        for qf in [1.0, 10.0] {
            for rate in [1e-4, 1e-3] {
                grid.push((phi, qf, rate));
                let mut s = summary(rate, 1.5);
                s["p_el"] = q(phi * rate / qf);
                s["eta_p_el"] = q(phi / qf * qf);
                s["b_p_el"] = q(phi / qf / rate);
                s["sigma"] = q(0.3 * s["p"]["mean"].as_f64().unwrap());
                s["theta_dot_over_gamma_dot_var"] = q(0.1 + phi);
                s["tau_dur"] = q(1.0 + phi);
                s["nu_coll"] = q(0.3 * rate);
                // Collision angles (Eq. 27): making in bin 80, breaking in bin 60, and
                // grazing ones (bins 74, 75) more often at small Q.
                let mut mk = vec![0u64; 100];
                let mut br = vec![0u64; 100];
                mk[80] = 100;
                br[60] = 100;
                mk[75] = (50.0 / qf) as u64;
                br[74] = (50.0 / qf) as u64;
                let total = 200.0 + 2.0 * (50.0 / qf).floor();
                s["p_theta_90"] = q((50.0 / qf).floor() / (total * 3.6));
                s["collision_angle_making"] = serde_json::json!(mk);
                s["collision_angle_breaking"] = serde_json::json!(br);
                points.push(((phi, qf, rate), s));
            }
        }
    }
    pillar_pipe::stages::sweep::write_outputs(&sweep, &grid, &points, &ShearOptions::default())
        .unwrap();
    let out = d.join("report");
    let html = report_of(
        &out,
        DatasetInputs {
            label: "flow".into(),
            sweep: Some(sweep.clone()),
            ..Default::default()
        },
    );
    let angles =
        pillar_pipe::io::table::read_table(&sweep.join("sweep_angles.parquet"), &[]).unwrap();
    assert_eq!(
        angles.columns(),
        pillar_pipe::schema::load("sweep_angles").names()
    );
    let pdf = angles.f64("pdf").unwrap();
    assert_eq!(pdf.len(), 8 * 100);
    // Run 0 (φ = 0.78, Q = 1): 100 + 50 making, 100 + 50 breaking, in four bins.
    assert!((pdf[80] - 100.0 / (300.0 * 3.6)).abs() < 1e-12);
    assert!((pdf[75] - 50.0 / (300.0 * 3.6)).abs() < 1e-12);
    for fig in [
        "eta_p_el",
        "eta_p_el_vs_q",
        "b_p_el",
        "b_p_el_vs_q",
        "rotation_var",
        "z_vs_q",
        "sigma_vs_rate",
        "p_rate_runs",
        "p_sigma_runs",
        "p_theta_90",
        "theta_phi_0p78",
        "theta_phi_0p82",
        "p_el",
        "p_el_vs_q",
        "tau_dur",
        "tau_dur_vs_q",
        "nu_coll",
        "nu_coll_vs_q",
    ]
    .map(|fig| format!("sweep_flow_{fig}"))
    {
        assert_figure(&out, &fig);
    }
    // No run within 0.02 of φ_J (φ ≤ 0.82): μ_J is not fitted, and why.
    assert!(
        html.contains(
            "μ_J not fitted: it needs three runs within 0.02 of φ_J = 0.8433, the paper's, held"
        ),
        "μ_J"
    );
    assert!(
        html.contains("no run has R_v &gt; 3") || html.contains("no run has R_v > 3"),
        "coexistence"
    );
    // No boundary on this grid: the paper's Figs. 25, 26, 29 are not drawn, and the
    // report says why; the runs are drawn by class under titles citing no figure.
    assert!(html.contains("the paper's figures are not drawn"), "why");
    assert!(!out.join("figures/sweep_flow_p_rate_plane.png").exists());
    for caption in [
        "Fig. 2(a,c) for CD, Fig. 11(a,c) for CDrot",
        "Fig. 20(b)",
        "Figs. 4–5 for CD, 12–13 for CDrot",
        "Fig. 30",
        "Fig. 26",
        "Fig. 29",
        "Figs. 9 for CD, 19 for CDrot",
        "Figs. 8 for CD, 18 for CDrot",
        "Fig. 22",
        "Fig. 10",
        "Figs. 6(a,c), 14(a,c)",
        "Figs. 6(b,d), 14(b,d)",
    ] {
        assert!(html.contains(caption), "{caption}");
    }
}

/// One run's section draws the contact velocities (Fig. 21), the profiles (Fig. 28) and
/// the local fields (Fig. 27); the moments tabulated come from the run's table, where
/// V^C_T = V_T + V^R contact by contact (Eq. 33), so their means add up.
#[test]
fn report_of_one_run_draws_contacts_profiles_and_fields() {
    use pillar_pipe::stages::report::DatasetInputs;
    use pillar_pipe::stages::report::shear::run_figures::contact_moments;
    use pillar_pipe::stages::shear::ShearOptions;
    let d = tmpdir("shear-report-run");
    let sim = d.join("run");
    let opt = ShearOptions {
        n: 128,
        phi: 0.8,
        rate: 1e-2,
        strain: 0.5,
        quiet: true,
        ..Default::default()
    };
    pillar_pipe::stages::shear::run(&sim, &opt).unwrap();
    let m = contact_moments(&sim.join("contact_velocities.parquet")).unwrap();
    assert_eq!(m.len(), 3, "{m:?}");
    let (vt_vr, vct_vr) = (&m[0].1, &m[1].1);
    assert!(vt_vr.n > 100, "{m:?}");
    let sum = vt_vr.mean.0 + vt_vr.mean.1;
    assert!(
        (vct_vr.mean.0 - sum).abs() <= 1e-9 * sum.abs().max(1.0),
        "mean V^C_T {} vs mean V_T + V^R {sum}",
        vct_vr.mean.0
    );
    let out = d.join("report");
    let html = report_of(
        &out,
        DatasetInputs {
            label: "one".into(),
            shear: Some(sim.clone()),
            ..Default::default()
        },
    );
    for fig in [
        "contacts_vt_vr",
        "contacts_vct_vr",
        "contacts_vct_vn",
        "profile_vx",
        "profile_gamma_dot",
        "profile_phi",
        "field_phi",
        "field_gamma_dot",
    ]
    .map(|fig| format!("shear_one_{fig}"))
    {
        assert_figure(&out, &fig);
    }
    for caption in ["Fig. 21(a, b)", "Fig. 21(e, f)", "Fig. 28", "Fig. 27"] {
        assert!(html.contains(caption), "{caption}");
    }
    assert!(html.contains("<th>correlation r</th>"), "the moments table");
    assert!(
        html.contains("Band values") && html.contains("f′ = "),
        "band values"
    );
}

/// `run --jobs 2` computes a sweep's independent grid points side by side (the second
/// starts before the first is done) and gives what a serial run gives: the same stages,
/// keys and manifest order, the same tables byte for byte (issue 35).
#[test]
fn independent_stages_run_at_once_with_the_numbers_of_a_serial_run() {
    let d = tmpdir("jobs");
    let file = d.join("s.toml");
    std::fs::write(
        &file,
        "[pipeline]\nname = \"jobs\"\n\n[flow.sweep]\nphi = [0.80, 0.82]\nq = [1]\nrate = [1e-3]\n\
         n = 256\nstrain = 3\n",
    )
    .unwrap();
    let f = file.to_str().unwrap();
    let (a, b) = (d.join("runs-a"), d.join("runs-b"));
    let out = run_ok(&["run", f, "--jobs", "2"], &a);
    run_ok(&["run", f, "--jobs", "1", "--quiet"], &b);
    let lines: Vec<&str> = out.lines().collect();
    let first_done = lines.iter().position(|l| l.contains("computed")).unwrap();
    let second_running = lines
        .iter()
        .position(|l| l.starts_with("[2/3]") && l.contains("running"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(second_running < first_done, "not side by side:\n{out}");
    let (ma, mb) = (latest(&a), latest(&b));
    let stages = |m: &Value| -> Vec<(String, String)> {
        m["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| (s["name"].to_string(), s["key"].to_string()))
            .collect()
    };
    assert_eq!(stages(&ma), stages(&mb));
    assert_eq!(computed(&ma).len(), 3, "{ma}");
    for s in ma["stages"].as_array().unwrap() {
        let rel = s["dir"].as_str().unwrap();
        for (name, file) in s["outputs"].as_object().unwrap() {
            let file = file.as_str().unwrap();
            if !file.ends_with(".parquet") {
                continue;
            }
            let (x, y) = (a.join(rel).join(file), b.join(rel).join(file));
            assert_eq!(
                std::fs::read(&x).unwrap(),
                std::fs::read(&y).unwrap(),
                "{name}: {}",
                x.display()
            );
        }
    }
    // One at a time gives the usual order of lines.
    let out = run_ok(&["run", f, "--jobs", "1", "--force", "all"], &b);
    let order: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with('[') && (l.contains("running") || l.contains("computed")))
        .map(|l| l.split_whitespace().nth(2).unwrap_or(""))
        .collect();
    assert_eq!(order.len(), 6, "{out}");
    assert!(
        out.lines().nth(1).is_some_and(|l| l.contains("computed")),
        "{out}"
    );
}

/// A pillar simulation spreads over every core with threads of its own, so it runs
/// alone even with `--jobs 2`: the sheared-disk stage beside it in the file starts only
/// after it, and the sweep points after that run side by side again.
#[test]
fn a_pillar_simulation_runs_alone() {
    let d = tmpdir("jobs-alone");
    let file = d.join("s.toml");
    std::fs::write(
        &file,
        "[pipeline]\nname = \"alone\"\n\n[a.simulate]\npreset = \"fast\"\nn = 200\nstrain = 0.02\n\n\
         [b.shear]\nphi = 0.8\nrate = 1e-2\nn = 32\nstrain = 0.3\nsample_every = 2\n",
    )
    .unwrap();
    let out = run_ok(
        &["run", file.to_str().unwrap(), "--jobs", "2"],
        &d.join("runs"),
    );
    let at = |needle: &str| {
        out.lines()
            .position(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("{needle}: {out}"))
    };
    let sim_done = out
        .lines()
        .position(|l| l.contains("a.simulate") && l.contains("computed"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        at("b.shear") > sim_done,
        "the shear stage started beside the pillar:\n{out}"
    );
}

/// A planted CDrot-like sweep with every figure of the Appendix A criteria, φ_J, the
/// constant-P construction and the contact rms: Z/γ̇ differs between the two rates
/// below Q = 3 (Fig. 32), B_p^el above φ = 0.80 (Fig. 33); P^el vanishes with γ̇ up to
/// φ = 0.82 and not at 0.86, so φ_J = 0.84 [0.82, 0.86]; P = e^{10(φ − 0.78)} γ̇^1.5 at
/// Q = 1 is crossed by a contour at every φ, banded (R_v = 10) at φ = 0.80.
#[test]
fn report_of_a_sweep_draws_appendix_a_phi_j_constant_p_and_contact_rms() {
    use pillar_pipe::stages::report::DatasetInputs;
    use pillar_pipe::stages::shear::ShearOptions;
    use polars::prelude::*;
    let d = tmpdir("shear-report-appendix");
    let sweep = d.join("sweep");
    std::fs::create_dir_all(&sweep).unwrap();
    let q = |m: f64| serde_json::json!({"mean": m, "err": 1e-4 * m.abs()});
    let mut grid = Vec::new();
    let mut points = Vec::new();
    for phi in [0.78, 0.79, 0.80, 0.81, 0.82, 0.86] {
        for qf in [0.3f64, 1.0, 3.0, 10.0] {
            for rate in [1e-4f64, 1e-3] {
                grid.push((phi, qf, rate));
                let p = (10.0 * (phi - 0.78f64)).exp() * rate.powf(1.5);
                let mut s = summary(rate, 1.5);
                s["p"] = q(p);
                s["mu"] = q(if phi == 0.80 { 0.35 } else { 0.3 + phi - 0.78 });
                s["sigma"] = q(p * s["mu"]["mean"].as_f64().unwrap());
                s["r_v"] = q(if phi == 0.80 { 10.0 } else { 1.0 });
                s["z"] = q(1e3 * rate + 0.1 * (3.0 / qf).ln().max(0.0));
                s["b_p_el"] = q(2.0 + 1e-3 * (phi - 0.80f64).max(0.0) / rate);
                s["p_el"] = q(if phi < 0.84 { 1e2 * rate } else { 1e-3 });
                points.push(((phi, qf, rate), s));
            }
        }
    }
    pillar_pipe::stages::sweep::write_outputs(&sweep, &grid, &points, &ShearOptions::default())
        .unwrap();
    // Two runs' sampled contacts: v_n = ±1, ±3 (rms √5) and v_t = 2 throughout.
    let mut dirs = Vec::new();
    for (k, &point) in grid.iter().take(2).enumerate() {
        let dir = d.join(format!("run{k}"));
        std::fs::create_dir_all(&dir).unwrap();
        let col = |n: &str, v: [f64; 4]| Column::new(n.into(), &v);
        let mut df = DataFrame::new(
            4,
            vec![
                col("v_t", [2.0; 4]),
                col("v_r", [0.0; 4]),
                col("v_c_t", [2.0; 4]),
                col("v_n", [1.0, -1.0, 3.0, -3.0]),
            ],
        )
        .unwrap();
        pillar_pipe::io::table::write_table(&mut df, &dir.join("contact_velocities.parquet"))
            .unwrap();
        dirs.push((point, dir));
    }
    pillar_pipe::stages::sweep::write_contacts(&sweep, &dirs).unwrap();
    let t = pillar_pipe::io::table::read_table(&sweep.join("sweep_contacts.parquet"), &[]).unwrap();
    assert_eq!(
        t.columns(),
        pillar_pipe::schema::load("sweep_contacts").names()
    );
    let vn = t.f64("v_n_rms").unwrap();
    assert_eq!(vn.len(), 2);
    assert!((vn[0] - 5f64.sqrt()).abs() < 1e-12 && t.f64("v_t_rms").unwrap()[1] == 2.0);
    let out = d.join("report");
    let html = report_of(
        &out,
        DatasetInputs {
            label: "cdrot".into(),
            sweep: Some(sweep.clone()),
            ..Default::default()
        },
    );
    for fig in [
        "appendix_a_z",
        "appendix_a_b",
        "appendix_a_lines",
        "coexistence_plane",
        "mu_contour_phi",
        "mu_contour_rate",
        "phi_star",
        "contact_rms_q",
    ] {
        assert_figure(&out, &format!("sweep_cdrot_{fig}"));
    }
    for text in [
        "(Fig. 32)",
        "(Fig. 33)",
        "(Fig. 17)",
        "(Fig. 25)",
        "(Fig. 34a)",
        "(Fig. 34b)",
        "(Fig. 35)",
        "φ_J = 0.8400 [0.8200, 0.8600] from P^el",
        "Q = 0.3: 0.82 – 0.86",
        "Sec. III.1; no figure in the paper",
    ] {
        assert!(html.contains(text), "{text}");
    }
}

/// Two sweeps of one model at N = 256 and 1024: R_v of both on one figure (Fig. 36)
/// and each size's brackets, the smaller banded over a narrower stretch.
#[test]
fn report_of_two_sizes_overlays_r_v() {
    use pillar_pipe::stages::report::DatasetInputs;
    use pillar_pipe::stages::shear::ShearOptions;
    let d = tmpdir("shear-report-sizes");
    let mut datasets = Vec::new();
    for (n, lo, hi) in [(1024usize, 0.785, 0.815), (256, 0.795, 0.805)] {
        let sweep = d.join(format!("sweep{n}"));
        std::fs::create_dir_all(&sweep).unwrap();
        let mut grid = Vec::new();
        let mut points = Vec::new();
        for phi in [0.78, 0.79, 0.80, 0.81, 0.82] {
            grid.push((phi, 1.0, 1e-4));
            let mut s = summary(1e-4, 1.5);
            let rv: f64 = if (lo..hi).contains(&phi) { 10.0 } else { 1.0 };
            s["r_v"] = serde_json::json!({"mean": rv, "err": 0.1});
            points.push(((phi, 1.0, 1e-4), s));
        }
        let base = ShearOptions {
            n,
            ..Default::default()
        };
        pillar_pipe::stages::sweep::write_outputs(&sweep, &grid, &points, &base).unwrap();
        datasets.push(DatasetInputs {
            label: format!("n{n}"),
            sweep: Some(sweep),
            ..Default::default()
        });
    }
    let out = d.join("report");
    let r = pillar_pipe::stages::report::run(
        &out,
        &pillar_pipe::stages::report::ReportOptions {
            title: "sizes".into(),
            datasets,
            map_stages: 1,
            provenance: serde_json::json!({}),
            sizes: None,
        },
    )
    .unwrap();
    let html = std::fs::read_to_string(&r.html).unwrap();
    assert_figure(&out, "sweep_sizes_r_v_sizes_cdrot");
    assert!(html.contains("(Fig. 36)"), "title");
    assert!(
        html.contains("<td>1024</td>") || html.contains(">1024<"),
        "table"
    );
    assert!(
        html.contains("0.78 – 0.79") && html.contains("0.79 – 0.8"),
        "brackets"
    );
}

/// Issue 36, one sweep mechanism: a `shear` stage with `vary` over φ and γ̇ is the same
/// study as a `sweep` of those points. Its points are the sweep's cache entries (computed
/// once), its grid writes the sweep's table with the same numbers, and the report draws
/// it as a sweep (the flow curves), not as a pillar parameter study.
#[test]
fn a_shear_stage_with_vary_is_a_sweep() {
    let d = tmpdir("shear-vary");
    let runs = d.join("runs");
    let file = d.join("v.toml");
    std::fs::write(
        &file,
        "[pipeline]\nname = \"vary-sweep\"\n\n[flow.sweep]\nphi = [0.78, 0.84]\nq = [1]\nrate = [1e-2, 3e-2]\n\
         n = 32\nstrain = 0.3\nsample_every = 2\n\n[study.shear]\nn = 32\nstrain = 0.3\nsample_every = 2\n\
         vary = { phi = [0.78, 0.78, 0.84, 0.84], rate = [1e-2, 3e-2, 1e-2, 3e-2] }\n\n\
         [report]\ndatasets = [\"study\"]\n",
    )
    .unwrap();
    run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let m = latest(&runs);
    let done = computed(&m);
    let shear_runs = done.iter().filter(|s| s.contains(":phi=")).count();
    assert_eq!(shear_runs, 4, "each point computed once for both: {done:?}");
    let dir_of = |name: &str| {
        let s = m["stages"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == name)
            .unwrap_or_else(|| panic!("no stage {name} in {m}"));
        runs.join(s["dir"].as_str().unwrap())
    };
    let (sweep, grid) = (dir_of("flow.sweep"), dir_of("study.shear"));
    let read =
        |p: &Path| pillar_pipe::io::table::read_table(&p.join("sweep.parquet"), &[]).unwrap();
    let (a, b) = (read(&sweep), read(&grid));
    assert_eq!(a.columns(), b.columns());
    for c in ["phi", "rate", "p", "z", "mu"] {
        assert_eq!(a.f64(c).unwrap(), b.f64(c).unwrap(), "{c}");
    }
    assert!(grid.join("grid.csv").is_file());
    let html =
        std::fs::read_to_string(runs.join(m["run_id"].as_str().unwrap()).join("report.html"))
            .unwrap();
    assert!(html.contains("Flow curves"), "drawn as a sweep");
    assert!(!html.contains("Parameter study"), "not as a pillar study");
}

/// The bundled pipeline that draws the sheared-disk paper's figures
/// (`pipelines/shear-paper.toml`), run as a user runs it but tiny (32 disks, strain 0.2,
/// overridden with `--set`): it loads, every stage runs, and the report draws the
/// paper's figures that do not hang on what the data show — the Q axes of CD and CDrot
/// (Figs. 1, 2, 4–6, 9, 10–14, 19), P(ϑ) (Figs. 8, 18), Appendix A (Figs. 32, 33), the φ
/// axis (Figs. 15, 16, 20, 22–24, 30), R_v at two sizes (Fig. 36), one run in detail
/// (Figs. 21, 27, 28) and the CDn check. (Which figures need a feature of the data — a
/// drop of P^el for Fig. 3, banded runs for Figs. 25, 26, 29 — the unit tests plant.)
#[test]
fn the_bundled_paper_pipeline_runs_and_draws_the_papers_figures() {
    let d = tmpdir("shear-paper");
    let runs = d.join("runs");
    let file = bundled("shear-paper");
    let out = run_ok(
        &[
            "run",
            &file,
            "--quiet",
            "--set",
            "sweep.n=32",
            // Fig. 36 needs the small copy at another size than the φ sweep's.
            "--set",
            "coexist_small.sweep.n=48",
            "--set",
            "sweep.strain=0.2",
            "--set",
            "shear.n=32",
            "--set",
            "shear.strain=0.2",
        ],
        &runs,
    );
    let m = latest(&runs);
    let detail = m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "coexist.shear")
        .cloned()
        .unwrap_or_else(|| panic!("no detail run: {out}"));
    assert_eq!(
        detail["cached"],
        Value::Bool(true),
        "the sweep's own point: {detail}"
    );
    let dir = runs.join(m["run_id"].as_str().unwrap());
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    let figs = |stems: &[&str]| {
        for s in stems {
            assert_figure(&dir, s);
        }
    };
    for model in ["cd", "cdrot"] {
        figs(&[
            &format!("sweep_{model}_p_el_vs_q"),
            &format!("sweep_{model}_eta_p_el_vs_q"),
            &format!("sweep_{model}_b_p_el_vs_q"),
            &format!("sweep_{model}_z_vs_q"),
            &format!("sweep_{model}_tau_dur_vs_q"),
            &format!("sweep_{model}_nu_coll_vs_q"),
            &format!("sweep_{model}_p_theta_90"),
            &format!("sweep_{model}_theta_phi_0p76"),
            &format!("sweep_{model}_appendix_a_z"),
        ]);
    }
    figs(&[
        "sweep_coexist_p_el",
        "sweep_coexist_eta_p_el",
        "sweep_coexist_b_p_el",
        "sweep_coexist_rotation",
        "sweep_coexist_rotation_var",
        "sweep_coexist_mu",
        "sweep_coexist_r_v",
        "sweep_coexist_sigma_vs_rate",
        "sweep_coexist_appendix_a_b",
        "sweep_sizes_r_v_sizes_cdrot",
    ]);
    for text in [
        "(Figs. 1, 10)",
        "(Figs. 2(a,c), 11(a,c))",
        "(Figs. 4–5, 12–13)",
        "(Figs. 6(a,c), 14(a,c))",
        "(Figs. 8, 18)",
        "(Figs. 9, 19)",
        "(Fig. 16(a,c))",
        "(Fig. 20a)",
        "(Fig. 20b, Eq. 28)",
        "(Fig. 21",
        "(Fig. 23)",
        "(Fig. 24)",
        "(Fig. 28)",
        "(Fig. 30)",
        "(Fig. 32)",
        "(Fig. 33)",
        "(Fig. 36)",
        "Check — CDn is Bagnoldian as γ̇ → 0",
        "μ_J",
    ] {
        assert!(html.contains(text), "{text}");
    }
}
