//! `fit` and `compare` from the user's side (issue 4 acceptance).

use crate::common;
use crate::common::{cli as run, tmpdir};
use pillar_pipe::fit::d2min_over_r2;
use pillar_pipe::rng::Rng;
use std::path::Path;

/// A `kinematics` CSV whose (η^s, D²min) follow Eq. 19 (D = 1, so R² = 1/4) with
/// multiplicative log-normal scatter `s`; 10 start frames, lags 1, 2, 4.
fn kinematics_csv(path: &Path, theta: f64, eta_c: f64, s: f64, lo: f64, hi: f64, seed: u64) {
    let mut rng = Rng::new(seed);
    let mut out = String::from(
        "frame,frame_end,dt,particle,x,y,species,n_neighbors,valid,j11,j12,j21,j22,eta_xx,eta_xy,eta_yy,eta_m,eta_s,j2,d2min,vx,vy,speed\n",
    );
    for start in 0..10 {
        for lag in [1, 2, 4] {
            for p in 0..150 {
                let eta = (lo.ln() + rng.uniform() * (hi.ln() - lo.ln())).exp();
                let d2 = 0.25 * d2min_over_r2(eta, theta, eta_c) * (s * rng.normal()).exp();
                out += &format!(
                    "{start},{},{lag}.0,{p},0,0,1,6,true,1,0,0,1,0,0,0,0,{eta},{eta},{d2},0,0,0\n",
                    start + lag
                );
            }
            // A valid grain with only 2 neighbours: its D²min is round-off (≡ 0 in exact
            // arithmetic) and must not enter the log-space fit.
            out += &format!(
                "{start},{},{lag}.0,998,0,0,1,2,true,1,0,0,1,0,0,0,0,0.01,0.01,1e-31,0,0,0\n",
                start + lag
            );
            // An invalid row that must be ignored.
            out += &format!(
                "{start},{},{lag}.0,999,0,0,1,1,false,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n",
                start + lag
            );
        }
    }
    std::fs::write(path, out).unwrap();
}

#[test]
fn recovers_theta_and_eta_c_from_a_kinematics_table() {
    let dir = tmpdir("acc");
    let k = dir.join("kinematics.csv");
    kinematics_csv(&k, 0.3, 0.05, 0.1, 1e-3, 1.0, 1);
    let fit = dir.join("fit.json");
    let (ok, text) = run(&[
        "fit",
        k.to_str().unwrap(),
        "--diameter",
        "1",
        "-o",
        fit.to_str().unwrap(),
        "--bootstrap",
        "200",
    ]);
    assert!(ok, "{text}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fit).unwrap()).unwrap();
    let (th, ec) = (j["theta"].as_f64().unwrap(), j["eta_c"].as_f64().unwrap());
    assert!((th / 0.3 - 1.0).abs() < 0.05, "{th}");
    assert!((ec / 0.05 - 1.0).abs() < 0.05, "{ec}");
    assert!(
        j["theta_interval"][0].as_f64().unwrap() <= 0.3
            && j["theta_interval"][1].as_f64().unwrap() >= 0.3 * 0.99
    );
    assert_eq!(j["method"], "binned-median");
    assert_eq!(j["n_points"], 4500);
    for e in ["binned-median", "binned-mean", "points", "weighted-mean"] {
        assert!(j["estimators"][e]["theta"].is_number(), "{e}");
    }
    // A kinematics table has one R_c: the sensitivity table varies the estimator and the
    // range's upper end only.
    let sens = j["sensitivity"].as_array().unwrap();
    assert_eq!(sens.len(), 4 * 4, "{sens:?}");
    assert!(sens.iter().all(|r| r["rc_over_d"] == 1.25));
    assert!(j["seed"].is_number() && j["input_sha256"].as_str().unwrap().len() == 64);
    assert!(Path::new(j["scatter"].as_str().unwrap()).exists());
    assert!(text.contains("Theta") && text.contains("eta_c"), "{text}");
    assert!(
        text.contains("30 valid samples with only 2 neighbours left out"),
        "{text}"
    );
}

#[test]
fn compare_agrees_on_same_law_and_refuses_different_estimators() {
    let dir = tmpdir("cmp");
    let (ka, kb) = (dir.join("a.csv"), dir.join("b.csv"));
    kinematics_csv(&ka, 0.3, 0.05, 0.2, 1e-3, 1.0, 2);
    kinematics_csv(&kb, 0.3, 0.05, 0.2, 1e-3, 1.0, 3);
    let (fa, fb, fc) = (dir.join("a.json"), dir.join("b.json"), dir.join("c.json"));
    for (k, f, m) in [
        (&ka, &fa, "binned-median"),
        (&kb, &fb, "binned-median"),
        (&kb, &fc, "binned-mean"),
    ] {
        let (ok, text) = run(&[
            "fit",
            k.to_str().unwrap(),
            "--diameter",
            "1",
            "-o",
            f.to_str().unwrap(),
            "--method",
            m,
            "--bootstrap",
            "100",
        ]);
        assert!(ok, "{text}");
    }
    let (ok, text) = run(&["compare", fa.to_str().unwrap(), fb.to_str().unwrap()]);
    assert!(ok, "{text}");
    assert!(text.contains("theta") && text.contains("yes"), "{text}");
    let (ok, text) = run(&["compare", fa.to_str().unwrap(), fc.to_str().unwrap()]);
    assert!(!ok);
    assert!(text.contains("different estimators"), "{text}");
}

#[test]
fn degenerate_inputs_are_flagged_or_refused() {
    let dir = tmpdir("deg");
    // Ballistic only: η_c cannot be determined.
    let k = dir.join("k.csv");
    kinematics_csv(&k, 0.3, 0.05, 0.1, 1e-4, 4e-3, 4);
    let f = dir.join("f.json");
    let (ok, text) = run(&[
        "fit",
        k.to_str().unwrap(),
        "--diameter",
        "1",
        "-o",
        f.to_str().unwrap(),
        "--bootstrap",
        "50",
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("not constrained"), "{text}");
    let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
    assert_eq!(j["eta_c_constrained"], false);
    // No diameter anywhere: refused with the flag to pass.
    let (ok, text) = run(&[
        "fit",
        k.to_str().unwrap(),
        "-o",
        dir.join("g.json").to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("--diameter"), "{text}");
    assert!(!dir.join("g.json").exists());
    // Two points.
    let tiny = dir.join("tiny.csv");
    std::fs::write(&tiny, "frame,frame_end,particle,valid,eta_s,d2min\n0,1,1,true,0.01,0.001\n0,1,2,true,0.02,0.002\n").unwrap();
    let (ok, text) = run(&[
        "fit",
        tiny.to_str().unwrap(),
        "--diameter",
        "1",
        "-o",
        dir.join("h.json").to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("too few"), "{text}");
}

/// End to end through the real kinematics stage. A perfect periodic triangular lattice is
/// sheared by γ_k between frames 2k and 2k+1 (Lees–Edwards box), and each grain also takes a
/// step δ_c of its sublattice c ∈ {0, 1, 2} (the lattice's 3-colouring), the three steps of
/// equal length |δ| at 120° in a random direction. Every grain's 6 neighbours alternate
/// between the other two sublattices at directions summing to zero, so the fit's J is
/// exactly the imposed shear (η^s = the imposed η) and D²min = (3·3|δ|²)·2/6 = 3|δ|². With
/// |δ|² = R² Eq.19(η_k; Θ, η_c) · e^{s·N(0,1)} / 3 the steps grow with the strain, D²min/R²
/// follows Eq. 19 with log-normal scatter over start times, and the fit must give back Θ
/// and η_c.
#[test]
fn random_steps_sized_by_strain_give_back_theta_and_eta_c() {
    use pillar_pipe::geom::{SimBox, Vec2};
    use pillar_pipe::synth::bidisperse_packing;
    use pillar_pipe::tracks::{FrameBox, Tracks, TracksMeta};
    let (theta, eta_c) = (0.3, 0.05);
    let dir = tmpdir("e2e");
    // 36 columns (a multiple of 3) × an even number of rows: the colouring is periodic.
    let p = bidisperse_packing(1500, 1.0, 0.0, 1);
    let b = p.simbox;
    let nx = (b.lx / p.spacing).round() as usize;
    assert_eq!(nx % 3, 0);
    let colour = |i: usize| {
        let (r, c) = ((i / nx) as i64, (i % nx) as i64);
        (c - r / 2 - r).rem_euclid(3) as usize
    };
    let r = 0.5; // R = D/2, D = 1
    let mut t = Tracks {
        meta: TracksMeta {
            length_unit: "D".into(),
            time_unit: "s".into(),
            frame_time: Some(1.0),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut rng = Rng::new(77);
    let pairs = 14;
    for k in 0..pairs {
        let gamma = 2e-3 * (200f64).powf(k as f64 / (pairs - 1) as f64); // 2e-3 … 0.4
        let eta = 0.5 * gamma * (1.0 + 0.25 * gamma * gamma).sqrt();
        let step2 = r * r * d2min_over_r2(eta, theta, eta_c) * (0.1 * rng.normal()).exp() / 3.0;
        let phi = 2.0 * std::f64::consts::PI * rng.uniform();
        let steps: Vec<Vec2> = (0..3)
            .map(|c| {
                let a = phi + 2.0 * std::f64::consts::PI * c as f64 / 3.0;
                Vec2::new(a.cos(), a.sin()) * step2.sqrt()
            })
            .collect();
        for (f, g) in [(2 * k as i64, 0.0), (2 * k as i64 + 1, gamma)] {
            let bk = SimBox { xy: g * b.ly, ..b };
            for (i, q) in p.pos.iter().enumerate() {
                let mut v = Vec2::new(q.x + g * (q.y - b.y_lo), q.y);
                if g > 0.0 {
                    v += steps[colour(i)];
                }
                let w = bk.wrap(v);
                t.frame.push(f);
                t.particle.push(i as i64);
                t.x.push(w.x);
                t.y.push(w.y);
                t.radius.push(p.radius[i]);
            }
            t.meta.boxes.push(FrameBox::from_simbox(f, &bk));
        }
    }
    let tp = dir.join("t.parquet");
    pillar_pipe::io::write_tracks(&t, &tp).unwrap();
    let kp = dir.join("k.parquet");
    let (ok, text) = run(&[
        "kinematics",
        tp.to_str().unwrap(),
        "--lag",
        "1",
        "--every",
        "2",
        "--rc",
        "1.25",
        "-o",
        kp.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(ok, "{text}");
    assert!(text.contains(&format!("{pairs} frame pairs")), "{text}");
    for method in ["binned-median", "binned-mean", "points"] {
        let fj = dir.join(format!("fit-{method}.json"));
        let (ok, text) = run(&[
            "fit",
            kp.to_str().unwrap(),
            "--diameter",
            "1",
            "--method",
            method,
            "--bootstrap",
            "200",
            "-o",
            fj.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&fj).unwrap()).unwrap();
        let (th, ec) = (j["theta"].as_f64().unwrap(), j["eta_c"].as_f64().unwrap());
        assert!(
            (th / theta - 1.0).abs() < 0.05,
            "{method}: theta {th}\n{text}"
        );
        assert!(
            (ec / eta_c - 1.0).abs() < 0.1,
            "{method}: eta_c {ec}\n{text}"
        );
        let ci = &j["eta_c_interval"];
        assert!(
            ci[0].as_f64().unwrap() <= eta_c && ci[1].as_f64().unwrap() >= eta_c,
            "{method}: {ci}"
        );
    }
}

/// A `fast` pillar of 150 grains simulated to `strain` in `dir/sim`, then fitted from its
/// tracks with 20 bootstrap replicates into `dir/fit.json`: (fit.json, what `fit` printed).
fn simulated_fit(dir: &Path, strain: &str) -> (std::path::PathBuf, String) {
    let sim = dir.join("sim");
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--n",
        "150",
        "--preset",
        "fast",
        "--strain",
        strain,
        "--quiet",
        "-o",
        sim.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let fit = dir.join("fit.json");
    let (ok, text) = run(&[
        "fit",
        sim.join("tracks.parquet").to_str().unwrap(),
        "--bootstrap",
        "20",
        "--quiet",
        "-o",
        fit.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    (fit, text)
}

/// From tracks the protocol is rerun with R_c = 1.0 and 1.5 D for the sensitivity table:
/// every estimator × upper end × R_c, the R_c = 1.25 D cells the headline's own samples.
#[test]
fn sensitivity_from_tracks_varies_estimator_range_and_rc() {
    let dir = tmpdir("sens");
    let (fit, text) = simulated_fit(&dir, "0.08");
    assert!(
        text.contains("sensitivity") && text.contains("range "),
        "{text}"
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fit).unwrap()).unwrap();
    let sens = j["sensitivity"].as_array().unwrap();
    assert_eq!(sens.len(), 4 * 4 * 3);
    let cell = |m: &str, rc: f64| {
        sens.iter()
            .find(|r| r["method"] == m && r["rc_over_d"] == rc && r["hi"].is_null())
            .and_then(|r| r["theta"].as_f64())
            .unwrap_or_else(|| panic!("{m} {rc}: {sens:?}"))
    };
    // Other neighbourhoods, other numbers (the point of showing them).
    let (a, b, c) = (
        cell("binned-median", 1.0),
        cell("binned-median", 1.25),
        cell("binned-median", 1.5),
    );
    assert!(a != b && b != c, "{a} {b} {c}");
    let range = &j["range"];
    assert_eq!(range["rule"], "coverage");
    assert!(range["lo"].as_f64().unwrap() > 0.0 && range["excluded"].is_array());
}

/// Tracking noise on real trackpy output with ground truth (`../shared/data/
/// trackpy-sample`): the fit's estimate from the data (the two shortest lags' D²min
/// extrapolated to zero lag) gives the displacement noise the tracker actually made
/// (`tracking_error.json`: 0.185 px rms over both axes at one frame) within 15 %, while
/// trackpy's own `ep`, carried through ingest, is an order of magnitude too small. The
/// floor leaves the noise-dominated bins out, naming the reason. A simulated pillar,
/// whose positions carry no noise, gets no floor.
#[test]
fn tracking_noise_from_the_data_matches_the_ground_truth() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/trackpy-sample");
    if !shared.join("tracking_error.json").is_file() {
        return common::cannot_check("../shared/data/trackpy-sample (ground truth) is missing");
    }
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shared.join("tracking_error.json")).unwrap())
            .unwrap();
    let px_per_cm = 31.496063;
    let lag1_rms_px = truth["rms_displacement_error_px_lag1"].as_f64().unwrap();
    let true_s = lag1_rms_px / 2f64.sqrt() / px_per_cm;
    let dir = tmpdir("noise");
    let tracks = dir.join("t.parquet");
    let (ok, text) = run(&[
        "ingest",
        shared.join("tracks.csv").to_str().unwrap(),
        "--px-per-unit",
        "31.496063",
        "--unit",
        "cm",
        "--frame-time",
        "15",
        "--origin-px",
        "165.98,850",
        "--bar-speed",
        "0.0084667",
        "-o",
        tracks.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let fit = dir.join("fit.json");
    let (ok, text) = run(&[
        "fit",
        tracks.to_str().unwrap(),
        "--bootstrap",
        "20",
        "--quiet",
        "-o",
        fit.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("noise "), "{text}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fit).unwrap()).unwrap();
    let n = &j["noise"];
    assert_eq!(n["source"], "data", "{n}");
    let s = n["data_displacement_noise"].as_f64().unwrap();
    assert!(
        (s / true_s - 1.0).abs() < 0.15,
        "displacement noise from the data {s:.5} cm vs the tracker's true {true_s:.5} cm"
    );
    let ep = n["trackpy_ep"].as_f64().unwrap();
    assert!(
        ep * 2f64.sqrt() < 0.2 * s,
        "trackpy's ep ({ep:.2e} cm) was expected to understate the noise ({s:.2e} cm)"
    );
    let left_out = n["bins_left_out"].as_u64().unwrap();
    assert!(left_out >= 1, "{n}");
    let reasons = j["range"]["excluded"].as_array().unwrap();
    assert!(
        reasons
            .iter()
            .filter(|b| b["reason"].as_str().unwrap().starts_with("tracking noise"))
            .count() as u64
            == left_out
    );
    // A simulation: no floor, whatever the data's intercept.
    let sim_dir = tmpdir("noise-sim");
    let (sfit, _) = simulated_fit(&sim_dir, "0.05");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&sfit).unwrap()).unwrap();
    assert!(j["noise"]["floor"].is_null(), "{}", j["noise"]);
    assert_eq!(j["noise"]["bins_left_out"], 0);
}
