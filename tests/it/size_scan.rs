//! The size scan in a pipeline (li-granular-pillars Sec. V): two pillar branches of
//! different sizes and an experiment branch in one report give a "Size scan" section
//! with Figs. 2, 9 and 10, the checks table and the scan's tables beside the report; a
//! second run computes nothing.

use crate::common::{cli, computed, latest, pp, run_ok, tmpdir};
use pillar_pipe::io::table::read_table;
use std::path::Path;

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
        "the moving/resting front at about 45° at every size",
        "angle to the bar, median [quartiles]",
        // Issue 36 item 5 and Eqs. 20-21: the newer claims, each with a verdict.
        "input power P_in ∝ W0² (Eq. 20)",
        "substrate dissipation P_g-s = κ P_in ∝ N (Eq. 21)",
        "local stress rises from the lateral edges at the same rate",
        "Local stress against distance from the edge (Sec. V)",
        "Check — the lines are transient (Sec. V)",
        "Check — bigger pillars have more lines",
        "line grains in a line again next pair",
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
        "sizes_edge_stress",
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
    // The powers grow with the size, and the edge stress rises into the interior.
    let (p_in, edge) = (t.f64("p_in_mean").unwrap(), t.f64("edge_rate").unwrap());
    assert!(p_in[1] > 2.0 * p_in[0], "{p_in:?}");
    assert!(edge.iter().all(|r| *r > 0.0), "{edge:?}");
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

    // The structure analyses as stages: the same tables as their commands write.
    let analyses = d.join("analyses.toml");
    std::fs::write(
        &analyses,
        format!(
            "[pipeline]\nroot = '{ROOT}'\n\n{}{}[small.gofr]\ninput = \"small.simulate\"\nbins = 40\n\n[small.outline]\ninput = \"small.simulate\"\nagainst = \"large.simulate\"\n\n[large.shear_lines]\ninput = \"large.kinematics\"\n\n[small.bar_pressure]\ninput = \"small.simulate\"\n\n[small.edge_stress]\ninput = \"small.simulate\"\n\n[large.shear_line_tracks]\ninput = \"large.kinematics\"\n",
            branch("small", 120),
            branch("large", 360)
        ),
    )
    .unwrap();
    run_ok(&["run", analyses.to_str().unwrap(), "--quiet"], &runs);
    let m = latest(&runs);
    let mut got = computed(&m);
    got.sort();
    assert_eq!(
        got,
        [
            "large.shear_line_tracks",
            "large.shear_lines",
            "small.bar_pressure",
            "small.edge_stress",
            "small.gofr",
            "small.outline",
        ]
    );
    let stage_file = |name: &str| {
        let s = m["stages"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == name)
            .unwrap_or_else(|| panic!("no stage {name}"));
        let (dir, outs) = (
            s["dir"].as_str().unwrap(),
            s["outputs"].as_object().unwrap(),
        );
        let first = outs.values().next().unwrap().as_str().unwrap();
        runs.join(dir).join(first)
    };
    // The line tables from the larger pillar: 120 grains may have no line at all.
    let (sim, large, kin) = (
        stage_file("small.simulate").parent().unwrap().to_path_buf(),
        stage_file("large.simulate").parent().unwrap().to_path_buf(),
        stage_file("large.kinematics"),
    );
    let tracks = sim.join("tracks.parquet");
    let cmd = d.join("cmd");
    std::fs::create_dir_all(&cmd).unwrap();
    let out = |f: &str| cmd.join(f).to_str().unwrap().to_string();
    for (args, stage) in [
        (
            vec![
                "gofr".to_string(),
                tracks.display().to_string(),
                "--bins".into(),
                "40".into(),
                "-o".into(),
                out("gofr.parquet"),
            ],
            "small.gofr",
        ),
        (
            vec![
                "outline".to_string(),
                tracks.display().to_string(),
                "--against".into(),
                large.join("tracks.parquet").display().to_string(),
                "-o".into(),
                out("outline.parquet"),
            ],
            "small.outline",
        ),
        (
            vec![
                "shear-lines".to_string(),
                kin.display().to_string(),
                "-o".into(),
                out("shear_lines.parquet"),
            ],
            "large.shear_lines",
        ),
        (
            vec![
                "bar-pressure".to_string(),
                sim.display().to_string(),
                "-o".into(),
                out("bar_pressure.parquet"),
            ],
            "small.bar_pressure",
        ),
        (
            vec![
                "edge-stress".to_string(),
                sim.display().to_string(),
                "-o".into(),
                out("edge_stress.parquet"),
            ],
            "small.edge_stress",
        ),
        (
            vec![
                "shear-line-tracks".to_string(),
                kin.display().to_string(),
                "-o".into(),
                out("shear_line_tracks.parquet"),
            ],
            "large.shear_line_tracks",
        ),
    ] {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let (ok, o) = cli(&a);
        assert!(ok, "{a:?}: {o}");
        let stage_t = read_table(&stage_file(stage), &[]).unwrap();
        let cmd_t = read_table(Path::new(args.last().unwrap()), &[]).unwrap();
        assert_eq!(stage_t.df.height(), cmd_t.df.height(), "{stage}");
        assert!(stage_t.df.height() > 0, "{stage} is empty");
        let names: Vec<String> = stage_t
            .df
            .get_column_names()
            .iter()
            .map(|n| n.to_string())
            .collect();
        assert!(!names.is_empty());
        for c in names {
            if let (Ok(x), Ok(y)) = (stage_t.f64(&c), cmd_t.f64(&c)) {
                assert_eq!(
                    x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    y.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{stage}: column {c}"
                );
            }
        }
    }
    // Bar pressure reads a simulation's force snapshots: another stage is refused at
    // load, at its key.
    let wrong = d.join("wrong.toml");
    std::fs::write(
        &wrong,
        format!(
            "[pipeline]\nroot = '{ROOT}'\n\n[experiment.ingest]\ninput = \"data/sample/tracks.csv\"\n\n[experiment.bar_pressure]\ninput = \"experiment.ingest\"\n\n[experiment.edge_stress]\ninput = \"experiment.ingest\"\n"
        ),
    )
    .unwrap();
    let (ok, _, e) = pp(&["run", wrong.to_str().unwrap(), "--quiet"], &runs);
    assert!(!ok);
    assert!(
        (e.contains("experiment.bar_pressure.input") || e.contains("experiment.edge_stress.input"))
            && e.contains("simulate stage"),
        "{e}"
    );
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
