//! Strain-rate ramps in pipelines (issue 21; vagberg-sheared-disks Sec. III.4, Fig. 31):
//! `ramp` stages cached like `shear` stages, validated at load naming file, line and
//! key, and the report's hysteresis figure and table.

use crate::common::*;
use serde_json::Value;
use std::path::Path;

/// A ramp up and a ramp down of 64 disks between γ̇ τ_e = 1e-2 and 1e-1 at κ̃ = 0.05:
/// 20 changes of γ̇, 400 steps each way; windows of 4 τ_e. The ramp down starts where
/// the ramp up ended (`from`), a cycle as in Fig. 31.
fn tiny(up_extra: &str, shear_extra: &str) -> String {
    format!(
        "[pipeline]\nname = \"tiny-ramps\"\n\n\
         [hyst.up]\nkind = \"ramp\"\nramp = \"up\"\nphi = 0.8\nn = 64\nrate = 1e-2\nrate_end = 1e-1\n\
         kappa = 0.05\nwindow = 4\nsample_every = 5\n{up_extra}\n\
         [hyst.down]\nkind = \"ramp\"\nramp = \"down\"\nphi = 0.8\nn = 64\nrate = 1e-1\nrate_end = 1e-2\n\
         kappa = 0.05\nwindow = 4\nsample_every = 5\nfrom = \"up\"\n\n\
         [hyst.shear]\nphi = 0.8\nn = 32\nrate = 1e-2\nstrain = 0.2\n{shear_extra}\n\
         [report]\ndatasets = [\"hyst\"]\n"
    )
}

fn stage(m: &Value, name: &str) -> Value {
    m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == name)
        .cloned()
        .unwrap_or_else(|| panic!("no stage {name} in {m}"))
}

#[test]
fn ramp_stages_run_are_cached_and_reported() {
    let d = tmpdir("ramp-pipe");
    let runs = d.join("runs");
    let file = d.join("r.toml");
    std::fs::write(&file, tiny("", "")).unwrap();
    let f = file.to_str().unwrap();
    run_ok(&["run", f, "--quiet"], &runs);
    let m = latest(&runs);
    assert_eq!(
        computed(&m),
        ["hyst.up", "hyst.down", "hyst.shear", "report"],
        "{m}"
    );
    for (name, first, last) in [("hyst.up", 1e-2, 1e-1), ("hyst.down", 1e-1, 1e-2)] {
        let st = stage(&m, name);
        let dir = runs.join(st["dir"].as_str().unwrap());
        assert!(st["dir"].as_str().unwrap().contains("ramp-"), "{st}");
        let table = dir.join(st["outputs"]["ramp"].as_str().unwrap());
        let t = pillar_pipe::io::table::read_table(&table, &[]).unwrap();
        let rate = t.f64("rate").unwrap();
        assert_eq!(rate.len(), 5, "20 τ_e in windows of 4: {rate:?}");
        // Window means of γ̇ move from the first rate towards the last, monotonically.
        assert!(
            rate.windows(2)
                .all(|w| (w[1] - w[0]) * (last - first) > 0.0)
        );
        assert!(rate[0] > first.min(last) && rate[4] < first.max(last));
        let metrics = &m["metrics"][name];
        assert_eq!(metrics["windows"], 5, "{metrics}");
        let end = metrics["rate_end"].as_f64().unwrap();
        assert!((end / last - 1.0).abs() < 1e-9, "{metrics}");
    }
    let rep = stage(&m, "report");
    let rep_dir = runs.join(rep["dir"].as_str().unwrap());
    let html = std::fs::read_to_string(rep_dir.join("report.html")).unwrap();
    for ext in ["png", "svg"] {
        let fig = rep_dir.join(format!("figures/ramp_hyst_sigma.{ext}"));
        assert!(fig.is_file(), "{}", fig.display());
    }
    assert!(
        html.contains("Fig. 31") && html.contains("Σ down / Σ up"),
        "{html}"
    );
    assert!(
        html.contains("<td>random positions</td>") && html.contains("<td>where a ramp ended</td>"),
        "the ramp up starts afresh, the ramp down continues it"
    );
    // Both directions drawn: the legend names them.
    let svg = std::fs::read_to_string(rep_dir.join("figures/ramp_hyst_sigma.svg")).unwrap();
    assert!(svg.contains("up, κ̃ = 5e-2") && svg.contains("down, κ̃ = 5e-2"));

    // Again: nothing computed.
    run_ok(&["run", f, "--quiet"], &runs);
    assert!(computed(&latest(&runs)).is_empty());

    // The ramp down continued the ramp up: its clock goes on from the up's last sample
    // (20 τ_e), at the rate the up ended on.
    let series = |name: &str| {
        let st = stage(&m, name);
        let dir = runs.join(st["dir"].as_str().unwrap());
        pillar_pipe::io::table::read_table(&dir.join("series.parquet"), &[]).unwrap()
    };
    let (up, down) = (series("hyst.up"), series("hyst.down"));
    let (ut, dt) = (up.f64("time").unwrap(), down.f64("time").unwrap());
    assert!(
        (dt[0] - ut.last().unwrap()).abs() < 1e-9,
        "{} vs {}",
        dt[0],
        ut.last().unwrap()
    );
    assert!((down.f64("rate").unwrap()[0] / 1e-1 - 1.0).abs() < 1e-12);
    assert!(stage(&m, "hyst.up")["outputs"]["state"].is_string(), "{m}");

    // A changed key of the ramp up recomputes it, the ramp down that continues it, and
    // the report.
    run_ok(&["run", f, "--quiet", "--set", "hyst.up.seed=2"], &runs);
    assert_eq!(computed(&latest(&runs)), ["hyst.up", "hyst.down", "report"]);
}

#[test]
fn ramp_keys_are_validated_at_load() {
    let d = tmpdir("ramp-bad");
    let runs = d.join("runs");
    let file = d.join("bad.toml");
    let refuse = |text: &str, needles: &[&str]| refused(&file, &runs, text, needles);
    let text = tiny("", "").replace("ramp = \"up\"", "ramp = \"sideways\"");
    refuse(
        &text,
        &[
            &format!("line {}", line_of(&text, "ramp = \"sideways\"")),
            "hyst.up.ramp",
            "up, down",
        ],
    );
    // Up, yet the end rate is below the start.
    let text = tiny("", "").replace("rate_end = 1e-1", "rate_end = 1e-3");
    refuse(
        &text,
        &[
            &format!("line {}", line_of(&text, "rate_end = 1e-3")),
            "hyst.up.rate_end",
            "cannot end at",
        ],
    );
    let text = tiny("strain = 3\n", "");
    refuse(
        &text,
        &[
            &format!("line {}", line_of(&text, "strain = 3")),
            "hyst.up.strain",
            "unknown key for a ramp stage",
        ],
    );
    refuse(
        &tiny("", "").replacen("kappa = 0.05", "kappa = 2", 1),
        &["hyst.up.kappa", "κ̃ must be in (0, 1)"],
    );
    refuse(
        &tiny("", "").replacen("rate_end = 1e-1\n", "", 1),
        &["hyst.up", "missing required key 'rate_end'"],
    );
    refuse(
        &tiny("dt = 0.03\n", ""),
        &["hyst.up.dt", "dt must divide 1"],
    );
    // A cycle continues the same disks only, and only from a ramp.
    let text = tiny("", "").replacen(
        "phi = 0.8\nn = 64\nrate = 1e-1",
        "phi = 0.81\nn = 64\nrate = 1e-1",
        1,
    );
    refuse(
        &text,
        &[
            &format!("line {}", line_of(&text, "from = ")),
            "hyst.down.from",
            "phi = 0.8 there, 0.81 here",
        ],
    );
    refuse(
        &tiny("", "").replace("from = \"up\"", "from = \"shear\""),
        &["hyst.down.from", "shear_run", "shear_ramp"],
    );
    // A ramp in a shear stage points at the ramp kind.
    let text = tiny("", "ramp = \"up\"\n");
    refuse(
        &text,
        &[
            "hyst.shear.ramp",
            "unknown key for a shear stage",
            "kind = \"ramp\"",
        ],
    );
    assert!(!runs.join("cache").exists(), "nothing ran");
}

/// Writes a ramp's directory as `simulate shear --ramp` would: Σ = c γ̇² at every
/// window, γ̇ from `r0` to `r1` in 21 steps of 0.1 decade.
fn synthetic_ramp(dir: &Path, dir_name: &str, r0: f64, r1: f64, c: f64) {
    use polars::prelude::*;
    std::fs::create_dir_all(dir).unwrap();
    let rate: Vec<f64> = (0..21)
        .map(|k| r0 * (r1 / r0).powf(k as f64 / 20.0))
        .collect();
    let sigma: Vec<f64> = rate.iter().map(|r| c * r * r).collect();
    let col = |n: &str, v: &[f64]| Column::new(n.into(), v);
    let mut df = DataFrame::new(
        21,
        vec![
            col("time", &(0..21).map(f64::from).collect::<Vec<_>>()),
            col("rate", &rate),
            col("p", &sigma.iter().map(|s| 3.0 * s).collect::<Vec<_>>()),
            col("sigma", &sigma),
            col("p_el", &sigma),
            col("sigma_el", &sigma),
            col("z", &[3.0; 21]),
        ],
    )
    .unwrap();
    pillar_pipe::io::table::write_table(&mut df, &dir.join("ramp.parquet")).unwrap();
    let summary = serde_json::json!({
        "ramp": dir_name, "kappa_tilde": 1e-3, "rate_start": r0, "rate_end": r1,
        "window_tau_e": 50.0, "windows": 21, "strain": 1.0,
        "params": {"n": 1024, "phi": 0.802, "q": 1.0, "model": "cdrot"},
    });
    std::fs::write(dir.join("summary.json"), summary.to_string()).unwrap();
}

/// Up and down branches that differ by a factor 2 in Σ at every γ̇ (power laws, so the
/// log-log interpolation is exact): the table compares them at six rates over the
/// overlap of their ranges, and the figure draws both.
#[test]
fn the_ramp_report_draws_both_branches_and_compares_them() {
    use pillar_pipe::stages::report::shear::ramp::{matching_rates, read_ramp};
    use pillar_pipe::stages::report::{DatasetInputs, ReportOptions, run};
    let d = tmpdir("ramp-report");
    let (up, down) = (d.join("up"), d.join("down"));
    synthetic_ramp(&up, "up", 1e-4, 1e-2, 100.0);
    synthetic_ramp(&down, "down", 3e-2, 1e-3, 200.0);
    let branch = |p: &Path| -> Vec<(f64, f64)> {
        let mut v: Vec<(f64, f64)> = read_ramp(p)
            .unwrap()
            .points
            .iter()
            .map(|q| (q.0, q.1))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    };
    let m = matching_rates(&branch(&up), &branch(&down), 6);
    assert_eq!(m.len(), 6, "{m:?}");
    assert!((m[0].0 / 1e-3 - 1.0).abs() < 1e-12 && (m[5].0 / 1e-2 - 1.0).abs() < 1e-12);
    for (r, su, sd) in &m {
        assert!((su / (100.0 * r * r) - 1.0).abs() < 1e-9, "{r}: {su}");
        assert!((sd / su - 2.0).abs() < 1e-9, "{r}: {sd} vs {su}");
    }
    let out = d.join("report");
    run(
        &out,
        &ReportOptions {
            title: "ramps".into(),
            datasets: vec![DatasetInputs {
                label: "cycle".into(),
                ramps: vec![up.clone(), down.clone()],
                ..Default::default()
            }],
            map_stages: 1,
            provenance: serde_json::json!({}),
            sizes: None,
        },
    )
    .unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_eq!(html.matches("<td>2.000</td>").count(), 6, "{html}");
    assert!(html.contains("<td>1.000e-3</td><td>1.0000e-4</td><td>2.0000e-4</td>"));
    assert!(html.contains("Fig. 31"));
    let svg = std::fs::read_to_string(out.join("figures/ramp_cycle_sigma.svg")).unwrap();
    assert!(svg.contains("up, κ̃ = 1e-3") && svg.contains("down, κ̃ = 1e-3"));
    // 21 markers a branch: filled going up, open going down (Fig. 31's convention).
    assert!(out.join("figures/ramp_cycle_sigma.png").is_file());
}
