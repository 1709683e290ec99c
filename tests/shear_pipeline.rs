//! Sheared-disk stages in pipelines (issue 21): `shear` and `sweep` stages cached like
//! the pillar's, every grid point of a sweep cached on its own (a grown grid computes
//! only its new points; a `shear` stage equal to a grid point is the same entry), the
//! sweep's table, validation naming file, line and key, and the report's sections.

mod common;

use common::*;
use serde_json::Value;
use std::path::Path;

/// A tiny grid: 32 disks (box side 6.8 d_s), strain 0.3, γ̇ τ_e ≥ 1e-2 (≈ 600 steps).
fn tiny(phi: &str, extra: &str) -> String {
    format!(
        "[pipeline]\nname = \"tiny-sweep\"\n\n[flow.sweep]\nphi = {phi}\nq = [1]\nrate = [1e-2, 3e-2]\n\
         n = 32\nstrain = 0.3\nsample_every = 2\n\n[flow.shear]\nphi = 0.84\nrate = 1e-2\nn = 32\nstrain = 0.3\nsample_every = 2\n{extra}"
    )
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
    assert_eq!(table_rows(&sweep_dir.join("sweep.parquet")), 4);

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
    let f = file.to_str().unwrap();
    let refuse = |text: &str, needles: &[&str]| {
        std::fs::write(&file, text).unwrap();
        let (ok, out, err) = pp(&["run", f, "--quiet"], &runs);
        assert!(!ok, "{out}");
        for n in needles {
            assert!(err.contains(n), "missing '{n}' in: {err}");
        }
        assert!(err.contains("bad.toml"), "{err}");
    };
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
