//! `ingest-force`: a force sensor's CSV → bar_forces and stress_strain (li-granular-pillars
//! Fig. 4a), with the simulator's definitions of ε and σ; bad input named by file, line
//! and column.

use crate::common::{cli, tmpdir};
use pillar_pipe::dem::pillar::params::PillarParams;
use pillar_pipe::io::table::read_table;
use std::path::Path;

fn col(p: &Path, name: &str) -> Vec<f64> {
    read_table(p, &[]).unwrap().f64(name).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300)
}

/// m g μ / D of the paper's grains (N/m): the default stress unit.
fn paper_unit() -> f64 {
    PillarParams::paper().stress_unit()
}

/// Constant force at a constant bar speed: σ = F / W on every row, ε = v t / H0; units
/// and geometry from `ingest.toml` beside the file, the force's unit in the header.
#[test]
fn constant_force_gives_constant_stress() {
    let d = tmpdir("force-const");
    std::fs::write(
        d.join("ingest.toml"),
        "unit = \"cm\"\nbar_speed = 0.01\nheight = 10.0\nwidth = 5.0\ntime_unit = \"s\"\n",
    )
    .unwrap();
    let csv = d.join("sensor.csv");
    let mut text = String::from("time,force [N]\n");
    for k in 0..=20 {
        text.push_str(&format!("{},0.5\n", 5 * k));
    }
    std::fs::write(&csv, text).unwrap();
    let (ok, out) = cli(&["ingest-force", csv.to_str().unwrap()]);
    assert!(ok, "{out}");
    assert!(out.contains("ingest.toml"), "{out}");
    let bar = d.join("sensor.bar_forces.parquet");
    let ss = d.join("sensor.stress_strain.parquet");
    // bar_forces: the simulator's columns and units (s, N, cm).
    assert_eq!(
        read_table(&bar, &[]).unwrap().columns(),
        pillar_pipe::schema::load("bar_forces").names()
    );
    let (t, top_y) = (col(&bar, "time"), col(&bar, "top_y"));
    for (t, y) in t.iter().zip(&top_y) {
        assert!(close(*y, 10.0 - 0.01 * t), "top_y {y} at t {t}");
    }
    assert!(col(&bar, "bottom_y").iter().all(|y| *y == 0.0));
    assert!(col(&bar, "top_force").iter().all(|f| *f == 0.5));
    // σ = 0.5 N / 0.05 m = 10 N/m; ε = 0.01 cm/s × t / 10 cm.
    let (e, s, r) = (
        col(&ss, "strain"),
        col(&ss, "stress"),
        col(&ss, "stress_reduced"),
    );
    let time = col(&ss, "time");
    for i in 0..e.len() {
        assert!(close(s[i], 10.0), "σ {}", s[i]);
        assert!(close(r[i], 10.0 / paper_unit()), "σ/(mgμ/D) {}", r[i]);
        assert!((e[i] - 0.001 * time[i]).abs() < 1e-12, "ε {}", e[i]);
    }
    assert!(close(*e.last().unwrap(), 0.1));
    // P_in = F v_c = 0.5 N × 1e-4 m/s.
    assert!(col(&ss, "p_in").iter().all(|p| close(*p, 5e-5)));
    // Every stress_strain column written is one of the simulator's, the required all.
    let sch = pillar_pipe::schema::load("stress_strain");
    let written = read_table(&ss, &[]).unwrap().columns();
    for c in &written {
        assert!(sch.column(c).is_some(), "{c} not in the schema");
    }
    for c in sch.required() {
        assert!(written.iter().any(|w| w == c), "{c} required, not written");
    }
}

/// A force ramp F = a·d against bar travel d (no time column: t = d / v_c), in mN and mm,
/// units in comment lines: σ(ε) = a H0 / W · ε, a known slope.
#[test]
fn force_ramp_gives_known_slope() {
    let d = tmpdir("force-ramp");
    let csv = d.join("ramp.csv");
    // a = 40 mN/mm = 40 N/m; H0 = 200 mm, W = 100 mm: dσ/dε = 40 × 0.2 / 0.1 = 80 N/m.
    let mut text = String::from(
        "# force sensor, bar travel from the crosshead\n# force_unit = mN\n# unit = mm\n# height = 200\n# width = 100\n# bar_speed = 0.5\nindex;displacement;force\n",
    );
    for k in 0..=40 {
        let disp = 0.5 * k as f64;
        text.push_str(&format!("{k};{disp};{}\n", 40.0 * disp));
    }
    std::fs::write(&csv, text).unwrap();
    let ss = d.join("ss.csv");
    let (ok, out) = cli(&[
        "ingest-force",
        csv.to_str().unwrap(),
        "-o",
        d.join("bf.parquet").to_str().unwrap(),
        "--stress-strain",
        ss.to_str().unwrap(),
    ]);
    assert!(ok, "{out}");
    let (e, s, t) = (col(&ss, "strain"), col(&ss, "stress"), col(&ss, "time"));
    for i in 0..e.len() {
        assert!(
            (s[i] - 80.0 * e[i]).abs() < 1e-9,
            "σ {} at ε {}",
            s[i],
            e[i]
        );
        // t = d / v_c, d = 0.5 k mm at 0.5 mm/s.
        assert!((t[i] - i as f64).abs() < 1e-9, "t {}", t[i]);
    }
    assert!(close(e[40], 0.1));
    // A flag overrides the file's comment: W = 50 mm doubles σ.
    let (ok, out) = cli(&[
        "ingest-force",
        csv.to_str().unwrap(),
        "--width",
        "50",
        "--stress-strain",
        ss.to_str().unwrap(),
    ]);
    assert!(ok, "{out}");
    let (e, s) = (col(&ss, "strain"), col(&ss, "stress"));
    assert!((s[40] - 160.0 * e[40]).abs() < 1e-9, "σ {}", s[40]);
}

/// Run on `text` and return the error output (the command must fail).
fn refused(name: &str, text: &str, extra: &[&str]) -> String {
    let d = tmpdir(name);
    let csv = d.join("bad.csv");
    std::fs::write(&csv, text).unwrap();
    let mut a = vec!["ingest-force", csv.to_str().unwrap()];
    a.extend_from_slice(extra);
    let (ok, out) = cli(&a);
    assert!(!ok, "accepted:\n{out}");
    assert!(out.contains("bad.csv"), "no file name: {out}");
    out
}

const GEOMETRY: &str = "# unit = cm\n# height = 20\n# width = 10\n# bar_speed = 0.01\n";

#[test]
fn a_missing_force_column_is_named() {
    let out = refused(
        "force-nocol",
        &format!("{GEOMETRY}# force_unit = N\ntime,load_cell_volts\n0,1\n1,2\n"),
        &[],
    );
    assert!(out.contains("line 6, column 'force'"), "{out}");
    assert!(out.contains("no force column"), "{out}");
}

#[test]
fn a_non_monotonic_time_is_named() {
    let out = refused(
        "force-time",
        &format!("{GEOMETRY}time [s],force [N]\n0,0\n1,0.1\n3,0.2\n2,0.3\n"),
        &[],
    );
    // Line 9 (`2,0.3`) goes back in time.
    assert!(out.contains("line 9, column 'time [s]'"), "{out}");
    assert!(out.contains("does not increase"), "{out}");
    // Without a time column, the displacement must increase likewise.
    let out = refused(
        "force-disp",
        &format!("{GEOMETRY}displacement,force [N]\n0,0\n0.1,0.1\n0.1,0.2\n"),
        &[],
    );
    assert!(out.contains("line 8, column 'displacement'"), "{out}");
}

#[test]
fn a_unit_not_understood_is_named() {
    // In the header.
    let out = refused(
        "force-unit-h",
        &format!("{GEOMETRY}time [s],force [stone]\n0,0\n1,1\n"),
        &[],
    );
    assert!(out.contains("line 5, column 'force [stone]'"), "{out}");
    assert!(
        out.contains("'stone' not understood") && out.contains("mN"),
        "{out}"
    );
    // In a comment line.
    let out = refused(
        "force-unit-c",
        &format!("# force_unit = pound\n{GEOMETRY}time [s],force\n0,0\n1,1\n"),
        &[],
    );
    assert!(out.contains("line 1, column 'force_unit'"), "{out}");
    // In ingest.toml beside the file: that file, the key's line.
    let d = tmpdir("force-unit-t");
    std::fs::write(
        d.join("ingest.toml"),
        "unit = \"cm\"\ntime_unit = \"jiffy\"\n",
    )
    .unwrap();
    let csv = d.join("s.csv");
    std::fs::write(&csv, format!("{GEOMETRY}time,force [N]\n0,0\n1,1\n")).unwrap();
    let (ok, out) = cli(&["ingest-force", csv.to_str().unwrap()]);
    assert!(!ok, "{out}");
    assert!(
        out.contains("ingest.toml: line 2, column 'time_unit'") && out.contains("'jiffy'"),
        "{out}"
    );
    // A flag.
    let out = refused(
        "force-unit-f",
        &format!("{GEOMETRY}time,force [N]\n0,0\n1,1\n"),
        &["--time-unit", "fortnight"],
    );
    assert!(
        out.contains("--time-unit") && out.contains("fortnight"),
        "{out}"
    );
    // No unit at all.
    let out = refused(
        "force-unit-none",
        &format!("{GEOMETRY}time [s],force\n0,0\n1,1\n"),
        &[],
    );
    assert!(
        out.contains("line 5, column 'force'") && out.contains("no force unit"),
        "{out}"
    );
    // Header and setting disagree.
    let out = refused(
        "force-unit-clash",
        &format!("# force_unit = N\n{GEOMETRY}time [s],force [mN]\n0,0\n1,1\n"),
        &[],
    );
    assert!(out.contains("disagrees with force_unit"), "{out}");
}

#[test]
fn a_bad_number_and_missing_geometry_are_named() {
    let out = refused(
        "force-num",
        &format!("{GEOMETRY}time [s],force [N]\n0,0\n1,abc\n"),
        &[],
    );
    assert!(
        out.contains("line 7, column 'force [N]'") && out.contains("'abc'"),
        "{out}"
    );
    let out = refused(
        "force-noh",
        "# unit = cm\n# width = 10\ntime [s],force [N]\n0,0\n1,1\n",
        &["--bar-speed", "0.01"],
    );
    assert!(out.contains("height") && out.contains("H0"), "{out}");
}

#[test]
fn help_states_units() {
    let (ok, out) = cli(&["ingest-force", "--help"]);
    assert!(ok, "{out}");
    for needle in [
        "N, mN, kN",
        "s, ms, us, min",
        "m, cm, mm, um",
        "length unit per second",
        "m g μ / D",
        "time s, forces N, bar faces cm",
    ] {
        assert!(out.contains(needle), "--help lacks '{needle}':\n{out}");
    }
}

/// The simulator's own bar_forces, turned into stress–strain by `ingest-force`'s code
/// with the simulator's widths, give the simulator's ε, σ, σ/(m g μ / D) and P_in: one
/// definition for Fig. 4a and Fig. 4b.
#[test]
fn the_simulators_bar_forces_give_its_stress_strain() {
    let d = tmpdir("force-sim");
    let (ok, out) = cli(&[
        "simulate",
        "pillar",
        "--n",
        "120",
        "--preset",
        "fast",
        "--strain",
        "0.02",
        "--quiet",
        "-o",
        d.to_str().unwrap(),
    ]);
    assert!(ok, "{out}");
    let bar = read_table(&d.join("bar_forces.parquet"), &[]).unwrap();
    let ss = d.join("stress_strain.parquet");
    let p = PillarParams::fast();
    let top_y = bar.f64("top_y").unwrap();
    let mine = pillar_pipe::stages::force::stress_strain(
        &bar.df,
        top_y[0],
        &col(&ss, "width"),
        p.stress_unit(),
        p.bar_speed,
    )
    .unwrap();
    let t = pillar_pipe::io::table::Table {
        df: mine,
        file: "mine".into(),
        format: pillar_pipe::io::table::TableFormat::Parquet,
    };
    for c in [
        "time",
        "strain",
        "stress",
        "stress_reduced",
        "p_in",
        "top_force",
    ] {
        let (a, b) = (t.f64(c).unwrap(), col(&ss, c));
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-9 * y.abs().max(1e-9), "{c}: {x} vs {y}");
        }
    }
    assert!(col(&ss, "stress").iter().any(|s| *s > 0.0));
}

/// In a pipeline, an ingest stage's `force` file gives the branch's measured
/// stress–strain, drawn in the report beside the simulated one (Fig. 4a beside 4b).
#[test]
fn a_pipeline_reports_measured_beside_simulated() {
    let d = tmpdir("force-pipe");
    let csv = d.join("sensor.csv");
    // 0.5 N, H0 = 24.69 cm (the sample's top bar at frame 0) at 0.0084667 cm/s; no
    // width, so W comes from the sample's tracks frame by frame.
    let mut text = String::from(
        "# unit = cm\n# height = 24.69\n# bar_speed = 0.0084667\ntime [s],force [N]\n",
    );
    for k in 0..=30 {
        text.push_str(&format!("{},0.5\n", 10 * k));
    }
    std::fs::write(&csv, text).unwrap();
    let file = d.join("p.toml");
    std::fs::write(
        &file,
        crate::common::with_ingest(
            "[simulation.simulate]\nn = 120\nstrain = 0.02\n\n[report]\ndatasets = [\"experiment\", \"simulation\"]\n",
        )
        .replace(
            "input = \"data/sample/tracks.csv\"\n",
            &format!("input = \"data/sample/tracks.csv\"\nforce = '{}'\n", csv.display()),
        ),
    )
    .unwrap();
    let runs = d.join("runs");
    crate::common::run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
    let m = crate::common::latest(&runs);
    assert_eq!(m["metrics"]["experiment.ingest"]["force_rows"], 31, "{m}");
    let dir = runs.join(m["run_id"].as_str().unwrap());
    // W from the sample's tracks: about 12 cm at the start, widening as it flows.
    let ss = runs
        .join("cache")
        .read_dir()
        .unwrap()
        .flatten()
        .map(|e| e.path().join("stress_strain.parquet"))
        .find(|p| p.is_file() && p.to_string_lossy().contains("ingest"))
        .expect("the ingest stage's stress_strain");
    let w = col(&ss, "width");
    assert!(w[0] > 10.0 && w[0] < 14.0, "W {w:?}");
    assert!(w[30] > w[0], "W {w:?}");
    let svg = std::fs::read_to_string(dir.join("figures/stress_strain.svg")).unwrap();
    assert!(
        svg.contains("experiment") && svg.contains("simulation"),
        "{svg}"
    );
    // The simulation's κ is still drawn (the sensor has none).
    assert!(dir.join("figures/kappa.svg").is_file());
}

/// With the experiment's tracks, W is measured per frame by the simulator's rule (the
/// grains within 2 D of the top bar) and interpolated to the sensor's times: a planted
/// top row 11 cm wide at t = 0 and 21 cm at t = 10 s, over a wider base out of the band.
#[test]
fn tracks_give_the_width_per_frame() {
    let d = tmpdir("force-tracks");
    let mut rows = String::from("frame,particle,x,y,radius\n");
    let mut id = 0;
    for (frame, n_top) in [(0, 11), (1, 21)] {
        for i in 0..n_top {
            rows.push_str(&format!("{frame},{id},{}.5,19.5,0.5\n", i));
            id += 1;
        }
        // A base 101 cm wide, 19 cm below the top bar: outside the 2 cm band.
        for i in 0..101 {
            rows.push_str(&format!(
                "{frame},{},{}.0,0.5,0.5\n",
                1000 + i,
                i as i64 - 50
            ));
        }
        id = 100;
    }
    let raw = d.join("raw.csv");
    std::fs::write(&raw, rows).unwrap();
    let tracks = d.join("tracks.parquet");
    let (ok, out) = cli(&[
        "ingest",
        raw.to_str().unwrap(),
        "--unit",
        "cm",
        "--frame-time",
        "10",
        "-o",
        tracks.to_str().unwrap(),
    ]);
    assert!(ok, "{out}");
    let csv = d.join("sensor.csv");
    // H0 = 20 cm, the bar nearly still (1e-4 cm/s), D = 1 cm: the band is 2 cm.
    std::fs::write(
        &csv,
        "# unit = cm\n# height = 20\n# grain_size = 1\n# bar_speed = 0.0001\ntime [s],force [N]\n0,1.1\n5,1.6\n10,2.1\n15,2.1\n",
    )
    .unwrap();
    let ss = d.join("ss.csv");
    let (ok, out) = cli(&[
        "ingest-force",
        csv.to_str().unwrap(),
        "--tracks",
        tracks.to_str().unwrap(),
        "--stress-strain",
        ss.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{out}");
    // W = 11, 16 (interpolated), 21, 21 (held past the last frame) cm; F/W = 10 N/m.
    let w = col(&ss, "width");
    for (a, b) in w.iter().zip([11.0, 16.0, 21.0, 21.0]) {
        assert!((a - b).abs() < 1e-9, "W {w:?}");
    }
    assert!(col(&ss, "stress").iter().all(|s| (s - 10.0).abs() < 1e-9));
    assert!(out.contains("reach beyond the tracked frames"), "{out}");
    // Tracks whose grains never come near the top bar (a wrong height) are refused.
    std::fs::write(
        &csv,
        "# unit = cm\n# height = 40\n# grain_size = 1\n# bar_speed = 0.0001\ntime [s],force [N]\n0,1\n10,1\n",
    )
    .unwrap();
    let (ok, out) = cli(&[
        "ingest-force",
        csv.to_str().unwrap(),
        "--tracks",
        tracks.to_str().unwrap(),
    ]);
    assert!(
        !ok && out.contains("no grain within") && out.contains("tracks.parquet"),
        "{out}"
    );
}

/// A spreadsheet's export: byte-order mark, CRLF line ends, tabs, quoted names, units in
/// parentheses, an unused column.
#[test]
fn a_spreadsheet_export_reads() {
    let d = tmpdir("force-bom");
    let csv = d.join("export.csv");
    std::fs::write(
        &csv,
        "\u{feff}# height = 10\r\n# width = 5\r\n# unit = cm\r\n\"Time (ms)\"\t\"Load (gf)\"\tchannel\r\n0\t0\t1\r\n1000\t51\t1\r\n",
    )
    .unwrap();
    let ss = d.join("ss.csv");
    let (ok, out) = cli(&[
        "ingest-force",
        csv.to_str().unwrap(),
        "--bar-speed",
        "0.01",
        "--stress-strain",
        ss.to_str().unwrap(),
    ]);
    assert!(ok, "{out}");
    // 51 gf = 0.50014 N on 5 cm; t = 1 s, ε = 0.01 / 10.
    let (t, s, e) = (col(&ss, "time"), col(&ss, "stress"), col(&ss, "strain"));
    assert_eq!(t, [0.0, 1.0]);
    assert!(close(s[1], 51.0 * 9.80665e-3 / 0.05), "σ {s:?}");
    assert!(close(e[1], 0.001), "ε {e:?}");
}
