//! The size scan in a pipeline (li-granular-pillars Sec. V): two pillar branches of
//! different sizes and an experiment branch in one report give a "Size scan" section
//! with Figs. 2, 9 and 10, the checks table and the scan's tables beside the report; a
//! second run computes nothing.

use crate::common::{computed, latest, pp, run_ok, tmpdir};
use pillar_pipe::io::table::read_table;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

#[test]
fn a_pipeline_of_two_sizes_reports_the_size_scan() {
    let d = tmpdir("size-scan");
    let runs = d.join("runs");
    let file = d.join("sizes.toml");
    let branch = |name: &str, n: u32| {
        format!(
            "[{name}.simulate]\npreset = \"fast\"\nn = {n}\nstrain = 0.2\nseed = 2\n\n[{name}.kinematics]\ninput = \"{name}.simulate\"\nlags = [8]\n\n"
        )
    };
    std::fs::write(
        &file,
        format!(
            "[pipeline]\nroot = '{ROOT}'\n\n[experiment.ingest]\ninput = \"data/sample/tracks.csv\"\n\n{}{}[report]\ndatasets = [\"experiment\", \"small\", \"large\"]\n",
            branch("small", 120),
            branch("large", 360)
        ),
    )
    .unwrap();
    let out = run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let m = latest(&runs);
    let run_dir = runs.join(m["run_id"].as_str().unwrap());
    assert!(run_dir.join("report.html").is_file(), "no report:\n{out}");
    let html = std::fs::read_to_string(run_dir.join("report.html")).unwrap();
    assert!(
        html.contains("Size scan (li-granular-pillars Sec. V)"),
        "no size-scan section"
    );
    for needle in [
        "Fig. 10a",
        "Fig. 10b",
        "Fig. 10c",
        "Fig. 10d",
        "Fig. 9",
        "Fig. 2",
        "⟨σ⟩/W0 independent of size",
        "σ_y/W0 independent of size",
        "ε_y (95 %)",
        "Stress–strain with the yield point (Fig. 4)",
        "Fig. 11",
        "shear-line width between 1.5 and 3 D",
    ] {
        assert!(html.contains(needle), "report lacks {needle}");
    }
    for fig in [
        "sizes_stress",
        "sizes_sigma_w0",
        "sizes_pressure",
        "sizes_kappa",
        "sizes_chi",
        "sizes_outline_10",
        "sizes_outline_20",
        "sizes_gofr_small",
        "sizes_gofr_large",
        "sizes_line_angles",
        "sizes_line_widths",
        "sizes_j2_lines",
    ] {
        for ext in ["png", "svg"] {
            let p = run_dir.join("figures").join(format!("{fig}.{ext}"));
            assert!(p.is_file(), "{} missing", p.display());
        }
    }
    // Issue 36 item 6: the J2 maps of every size stand at one strain, not at each
    // run's busiest frame pair, and say which.
    assert!(
        html.contains("starting nearest ε = 0.1 (the same strain for every size"),
        "the Fig. 11 maps' caption names their common strain"
    );
    let g = std::fs::read_to_string(run_dir.join("figures/sizes_gofr_large.svg")).unwrap();
    assert!(
        g.contains("experiment"),
        "the experiment's g(r) is overlaid"
    );
    // The scan's table: both sizes, the wider pillar at the higher stress.
    let t = read_table(&run_dir.join("size_scan.csv"), &[]).unwrap();
    let (n, sigma) = (t.i64("n").unwrap(), t.f64("sigma_mean").unwrap());
    assert_eq!(n, vec![120, 360]);
    assert!(sigma[1] > 1.4 * sigma[0], "{sigma:?}");
    // Nothing is computed again.
    run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let again = latest(&runs);
    assert!(
        computed(&again).iter().all(|s| s == "report") || computed(&again).is_empty(),
        "second run computed {:?}",
        computed(&again)
    );
    // The scan is a cached stage of its own: a report-only change redraws it from the
    // cache and computes nothing else (issue 33).
    run_ok(
        &[
            "run",
            file.to_str().unwrap(),
            "--quiet",
            "--set",
            "report.map_stages=2",
        ],
        &runs,
    );
    let redrawn = latest(&runs);
    assert_eq!(computed(&redrawn), vec!["report".to_string()]);
    let again_dir = runs.join(redrawn["run_id"].as_str().unwrap());
    assert_eq!(
        std::fs::read(again_dir.join("size_scan.csv")).unwrap(),
        std::fs::read(run_dir.join("size_scan.csv")).unwrap()
    );
    assert!(
        std::fs::read_to_string(again_dir.join("report.html"))
            .unwrap()
            .contains("Size scan (li-granular-pillars Sec. V)")
    );
    // Named in a pipeline without a report, the same stage (the same cache entry)
    // gives the scan's tables.
    let alone = d.join("alone.toml");
    std::fs::write(
        &alone,
        format!(
            "[pipeline]\nroot = '{ROOT}'\n\n[experiment.ingest]\ninput = \"data/sample/tracks.csv\"\n\n{}{}[sizes]\ndatasets = [\"experiment\", \"small\", \"large\"]\n",
            branch("small", 120),
            branch("large", 360)
        ),
    )
    .unwrap();
    run_ok(&["run", alone.to_str().unwrap(), "--quiet"], &runs);
    assert!(computed(&latest(&runs)).is_empty(), "the scan was cached");
    // A report with one pillar run has no size-scan section.
    let one = d.join("one.toml");
    std::fs::write(
        &one,
        format!(
            "[pipeline]\nroot = '{ROOT}'\n\n{}[report]\ndatasets = [\"small\"]\n",
            branch("small", 120)
        ),
    )
    .unwrap();
    let (ok, o, e) = pp(&["run", one.to_str().unwrap(), "--quiet"], &runs);
    assert!(ok, "{o}\n{e}");
    let m = latest(&runs);
    let html =
        std::fs::read_to_string(runs.join(m["run_id"].as_str().unwrap()).join("report.html"));
    assert!(!html.unwrap().contains("Size scan"), "one run is no scan");
}
