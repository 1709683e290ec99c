//! `pillar-pipe gofr` on a jammed bidisperse packing (li-granular-pillars Fig. 2): the
//! contact peaks sit where the species' diameters put them and g(r) → 1 far out.

use crate::common::{cli as run, tmpdir};
use pillar_pipe::io::table::read_table;

#[test]
fn g_of_r_peaks_at_contact_distances_by_species() {
    let d = tmpdir("gofr");
    let pack = d.join("pack.parquet");
    let (ok, text) = run(&[
        "pack",
        "--n",
        "600",
        "--seed",
        "2",
        "--quiet",
        "-o",
        pack.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let out = d.join("g.parquet");
    let (ok, text) = run(&[
        "gofr",
        pack.to_str().unwrap(),
        "--r-max",
        "4",
        "--bins",
        "80",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("centres counted"), "{text}");
    let t = read_table(&out, &[]).unwrap();
    assert_eq!(t.columns(), pillar_pipe::schema::load("gofr").names());
    let (r, all, s, l) = (
        t.f64("r_over_d").unwrap(),
        t.f64("g_all").unwrap(),
        t.f64("g_small").unwrap(),
        t.f64("g_large").unwrap(),
    );
    let argmax = |g: &[f64]| r[(0..g.len()).max_by(|&a, &b| g[a].total_cmp(&g[b])).unwrap()];
    // Small-centred: its highest peak at a small–small (0.75 D) or small–large (0.875 D)
    // contact; large-centred: large–small (0.875 D) or large–large (1 D). Nothing closer
    // than two small radii.
    let (ps, pl) = (argmax(&s), argmax(&l));
    assert!((0.72..0.92).contains(&ps), "small-centred peak at {ps} D");
    assert!((0.85..1.06).contains(&pl), "large-centred peak at {pl} D");
    assert!(
        pl > ps,
        "large centres' contacts lie farther out: {pl} vs {ps}"
    );
    for k in 0..r.len() {
        if r[k] < 0.7 {
            assert_eq!(all[k], 0.0, "overlap at r = {} D", r[k]);
        }
    }
    let far: Vec<f64> = (0..r.len())
        .filter(|&k| r[k] > 3.0)
        .map(|k| all[k])
        .collect();
    let mean = far.iter().sum::<f64>() / far.len() as f64;
    assert!((mean - 1.0).abs() < 0.1, "g → 1 far out: {mean}");
    // A frame that is not there is an error naming it.
    let (ok, text) = run(&[
        "gofr",
        pack.to_str().unwrap(),
        "--frame",
        "7",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("no frame 7"), "{text}");
}

/// Outlines (Fig. 9) of two pillar sizes at the same strain are closer, once rescaled by
/// their W0, than one pillar's outlines at strain 0 and at the end: the shape evolves
/// with strain and, rescaled, hardly with size (the paper's self-similarity). On the
/// `fast` preset at ε = 0.2, N = 200 and 800 are 0.04 W0 apart (rms of the half-widths),
/// one pillar's strains 0 and 0.2 are 0.19 W0 apart.
#[test]
fn rescaled_outlines_of_two_sizes_agree_better_than_two_strains() {
    let d = tmpdir("outline");
    let sim = |n: &str, seed: &str| {
        let out = d.join(format!("p{n}"));
        let (ok, text) = run(&[
            "simulate",
            "pillar",
            "--n",
            n,
            "--seed",
            seed,
            "--preset",
            "fast",
            "--strain",
            "0.15",
            "--quiet",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
        out.join("tracks.parquet")
    };
    let (small, big) = (sim("150", "3"), sim("400", "4"));
    let distance = |a: &std::path::Path, fa: Option<&str>, b: &std::path::Path| -> f64 {
        let out = d.join("o.csv");
        let mut args = vec!["outline", a.to_str().unwrap(), "-o", out.to_str().unwrap()];
        if let Some(f) = fa {
            args.extend(["--frame", f]);
        }
        args.extend(["--against", b.to_str().unwrap()]);
        let (ok, text) = run(&args);
        assert!(ok, "{text}");
        let t = read_table(&out, &[]).unwrap();
        assert_eq!(t.columns(), ["y_over_w0", "left_over_w0", "right_over_w0"]);
        text.split("half-widths: ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{text}"))
    };
    let sizes = distance(&small, None, &big);
    let strains = distance(&small, Some("0"), &small);
    assert!(
        sizes < 0.5 * strains,
        "sizes {sizes} W0 apart, strains {strains} W0"
    );
}

/// A size scan (Fig. 10a, b): ⟨σ⟩ over 0.05 ≤ ε ≤ 0.2 grows in proportion to W0 — the
/// substrate holds every grain with m g μ, so the bar must push a column as tall as the
/// pillar (H0 ∝ W0) — and the fit through the origin says so with an interval; κ stays
/// between 0 and 1. (N = 200, 400, 800 on the `fast` preset: c = 0.714 [0.688, 0.740]
/// m g μ/D per D.) A run that stopped short of ε = 0.2 or a sheared-disk run is refused.
#[test]
fn flow_stress_scales_with_the_width() {
    let d = tmpdir("sizes");
    let sim = |n: &str, strain: &str| {
        let out = d.join(format!("p{n}-{strain}"));
        let (ok, text) = run(&[
            "simulate",
            "pillar",
            "--n",
            n,
            "--seed",
            "2",
            "--preset",
            "fast",
            "--strain",
            strain,
            "--quiet",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
        out
    };
    let (a, b) = (sim("120", "0.2"), sim("360", "0.2"));
    let out = d.join("sizes.csv");
    let (curves, pressure) = (d.join("curves.csv"), d.join("pressure.csv"));
    let (ok, text) = run(&[
        "sizes",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--curves",
        curves.to_str().unwrap(),
        "--pressure",
        pressure.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("check       <sigma>/W0"), "{text}");
    let t = read_table(&out, &[]).unwrap();
    let (w, s, k) = (
        t.f64("w0_over_d").unwrap(),
        t.f64("sigma_mean").unwrap(),
        t.f64("kappa_mean").unwrap(),
    );
    assert!(w[1] > 1.5 * w[0], "{w:?}");
    let (ra, rb) = (s[0] / w[0], s[1] / w[1]);
    assert!(
        (ra / rb - 1.0).abs() < 0.25,
        "σ/W0 {ra} vs {rb}: not proportional"
    );
    assert!(
        s[1] > 1.4 * s[0],
        "the wider pillar flows at a higher stress: {s:?}"
    );
    assert!(k.iter().all(|&x| x > 0.0 && x < 1.0), "{k:?}");
    assert!(text.contains("c = "), "{text}");
    // Shape scaling: the pillar widens as it is compressed, alike at both sizes.
    let (c1, c2) = (t.f64("chi_at_0_1").unwrap(), t.f64("chi_at_0_2").unwrap());
    for k in 0..2 {
        assert!(c1[k] > 1.05 && c2[k] > c1[k], "χ {c1:?} {c2:?}");
    }
    assert!((c2[0] / c2[1] - 1.0).abs() < 0.15, "χ(0.2) {c2:?}");
    // Yield (Sec. III): both curves yield at a small strain (0.011 and 0.018 here), below
    // the flow stress and near it, the wider pillar at the higher stress; each point inside
    // its interval; the check of σ_y/W0 across sizes is printed with its verdict.
    let col = |name: &str| t.f64(name).unwrap();
    let (ey, ey_lo, ey_hi) = (col("eps_y"), col("eps_y_lo"), col("eps_y_hi"));
    let (sy, sy_lo, sy_hi) = (col("sigma_y"), col("sigma_y_lo"), col("sigma_y_hi"));
    for k in 0..2 {
        assert!(ey[k] > 0.002 && ey[k] < 0.05, "ε_y {ey:?}");
        assert!(ey_lo[k] <= ey[k] && ey[k] <= ey_hi[k] && ey_lo[k] >= 0.0);
        assert!(sy_lo[k] <= sy[k] && sy[k] <= sy_hi[k]);
        assert!(
            sy[k] > 0.5 * s[k] && sy[k] < 1.2 * s[k],
            "σ_y {sy:?} against ⟨σ⟩ {s:?}"
        );
    }
    assert!(sy[1] > 1.4 * sy[0], "σ_y {sy:?}");
    assert!(text.contains("yield       N =    120  eps_y = "), "{text}");
    assert!(
        text.contains("check       sigma_y/W0 equal across sizes within 10 %: spread"),
        "{text}"
    );
    let cv = read_table(&curves, &[]).unwrap();
    let (n, chi) = (cv.i64("n").unwrap(), cv.f64("chi").unwrap());
    assert!(n.contains(&120) && n.contains(&360));
    assert!(chi.iter().all(|v| v.is_finite() && *v > 0.5), "χ curve");
    // Fig. 10c: near zero at the interface's edges, highest around its centre, and the
    // centre's pressure grows with the width as the flow stress does.
    let pt = read_table(&pressure, &[]).unwrap();
    let (pn, x, p) = (
        pt.i64("n").unwrap(),
        pt.f64("x_over_w").unwrap(),
        pt.f64("p").unwrap(),
    );
    let centre = t.f64("p_centre").unwrap();
    for (k, size) in [120, 360].into_iter().enumerate() {
        let edge: Vec<f64> = (0..p.len())
            .filter(|&i| pn[i] == size && (x[i] - 0.5).abs() > 0.4)
            .map(|i| p[i])
            .collect();
        assert_eq!(edge.len(), 2, "two edge bins");
        let edge = edge.iter().sum::<f64>() / 2.0;
        assert!(
            edge < 0.75 * centre[k],
            "N = {size}: edge {edge} centre {}",
            centre[k]
        );
    }
    assert!(
        centre[1] > 1.2 * centre[0],
        "p at the centre grows with W0: {centre:?}"
    );
    let short = sim("120", "0.1");
    let (ok, text) = run(&[
        "bar-pressure",
        short.to_str().unwrap(),
        "--strain",
        "0.15,0.2",
        "-o",
        d.join("p.csv").to_str().unwrap(),
    ]);
    assert!(
        !ok && text.contains("forces.parquet") && text.contains("reached ε = 0.1"),
        "{text}"
    );
    let (ok, text) = run(&[
        "sizes",
        short.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("run to ε = 0.2"), "{text}");
}

/// The `.meta.json` sidecar beside `table`, read, after checking that it names each of
/// `inputs` with that file's SHA-256 (the README's promise for every table).
fn sidecar_naming(table: &std::path::Path, inputs: &[&std::path::Path]) -> serde_json::Value {
    let side = pillar_pipe::io::sidecar_path(table);
    let text = std::fs::read_to_string(&side)
        .unwrap_or_else(|e| panic!("no sidecar {}: {e}", side.display()));
    for input in inputs {
        let sha = pillar_pipe::io::sha256_file(input).unwrap();
        assert!(
            text.contains(&sha),
            "{} lacks {sha}:\n{text}",
            side.display()
        );
    }
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["provenance"]["tool"], "pillar-pipe", "{text}");
    assert!(v["provenance"]["tool_version"].is_string(), "{text}");
    assert!(v["provenance"]["parameters"].is_object(), "{text}");
    v
}

/// A short pillar run on the `fast` preset, to ε = 0.2 with force snapshots.
fn short_pillar(d: &std::path::Path) -> std::path::PathBuf {
    let out = d.join("pillar");
    let (ok, text) = run(&[
        "simulate",
        "pillar",
        "--n",
        "120",
        "--seed",
        "2",
        "--preset",
        "fast",
        "--strain",
        "0.2",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    out
}

#[test]
fn gofr_writes_a_sidecar_naming_its_input() {
    let d = tmpdir("gofr-sidecar");
    let pack = d.join("pack.parquet");
    let (ok, text) = run(&[
        "pack",
        "--n",
        "150",
        "--seed",
        "3",
        "--quiet",
        "-o",
        pack.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let out = d.join("g.csv");
    let (ok, text) = run(&[
        "gofr",
        pack.to_str().unwrap(),
        "--r-max",
        "2",
        "--bins",
        "20",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let v = sidecar_naming(&out, &[&pack]);
    assert_eq!(v["table"], "gofr");
    assert_eq!(v["provenance"]["parameters"]["bins"], 20);
}

#[test]
fn outline_writes_a_sidecar_naming_its_inputs() {
    let d = tmpdir("outline-sidecar");
    let tracks = short_pillar(&d).join("tracks.parquet");
    let out = d.join("o.parquet");
    let (ok, text) = run(&[
        "outline",
        tracks.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let v = sidecar_naming(&out, &[&tracks]);
    assert_eq!(v["table"], "outline");
    assert!(v["provenance"]["against"].is_null());
    let (ok, text) = run(&[
        "outline",
        tracks.to_str().unwrap(),
        "--frame",
        "0",
        "--against",
        tracks.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let v = sidecar_naming(&out, &[&tracks]);
    assert_eq!(v["provenance"]["parameters"]["frame"], 0);
    assert!(v["shape_distance_over_w0"].is_number(), "{v}");
}

#[test]
fn bar_pressure_writes_a_sidecar_naming_its_inputs() {
    let d = tmpdir("bar-pressure-sidecar");
    let sim = short_pillar(&d);
    let out = d.join("p.csv");
    let (ok, text) = run(&[
        "bar-pressure",
        sim.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let inputs = ["stress_strain.parquet", "forces.parquet", "tracks.parquet"].map(|f| sim.join(f));
    let v = sidecar_naming(&out, &inputs.each_ref().map(|p| p.as_path()));
    assert_eq!(v["table"], "bar_pressure");
    assert!(v["snapshots"].as_u64().unwrap() > 0, "{v}");
}

/// Issue 36: `front` finds a planted moving/resting front at its angle (a V at 45° on
/// a lattice, moving grains above it), on both sides, and refuses a table without
/// speeds, a tracks table and a fraction out of (0, 1), naming what is wrong.
#[test]
fn front_finds_a_planted_45_degree_front_and_refuses_bad_input() {
    use crate::common::{cli, tmpdir};
    let d = tmpdir("front");
    let kin = d.join("k.csv");
    let mut text = String::from("frame,frame_end,x,y,j2,speed\n");
    for i in 0..80 {
        for j in 0..60 {
            let (x, y) = (0.25 + 0.5 * i as f64, 0.25 + 0.5 * j as f64);
            let v = if y > 8.0 + (x - 20.0f64).abs() {
                1.0
            } else {
                0.01
            };
            text.push_str(&format!("0,1,{x},{y},0.1,{v}\n"));
        }
    }
    std::fs::write(&kin, &text).unwrap();
    let out = d.join("front.csv");
    let (ok, o) = cli(&[
        "front",
        kin.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--diameter",
        "1",
    ]);
    assert!(ok, "{o}");
    assert!(o.contains("1 frame pairs"), "{o}");
    let t = pillar_pipe::io::table::read_table(&out, &[]).unwrap();
    let angles = t.f64("angle_deg").unwrap();
    assert_eq!(angles.len(), 2, "left and right");
    for a in angles {
        assert!((a - 45.0).abs() < 2.0, "{a}");
    }
    assert!(d.join("front.csv.meta.json").is_file(), "sidecar");
    // No speed column.
    let no_speed = d.join("ns.csv");
    std::fs::write(&no_speed, "frame,frame_end,x,y,j2\n0,1,0,0,1\n").unwrap();
    let (ok, o) = cli(&[
        "front",
        no_speed.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--diameter",
        "1",
    ]);
    assert!(!ok && o.contains("speed") && o.contains("ns.csv"), "{o}");
    // A tracks table.
    let tracks = d.join("t.csv");
    std::fs::write(&tracks, "frame,particle,x,y,radius\n0,1,0,0,0.5\n").unwrap();
    let (ok, o) = cli(&[
        "front",
        tracks.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && o.contains("not a kinematics table"), "{o}");
    let (ok, o) = cli(&[
        "front",
        kin.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--moving",
        "1.5",
    ]);
    assert!(!ok && o.contains("moving"), "{o}");
}

/// `edge-stress` on a short pillar: a sidecar naming the run's three tables, a profile
/// that rises from the edge (the paper's "larger local stress in the interior"), bad
/// windows named; and its printout piped into a reader that stops at once ends the
/// command quietly (SIGPIPE), not with a panic.
#[test]
fn edge_stress_rises_from_the_edges_and_refuses_bad_windows() {
    let d = tmpdir("edge-stress");
    let sim = short_pillar(&d);
    let out = d.join("e.csv");
    let (ok, text) = run(&[
        "edge-stress",
        sim.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let inputs = ["stress_strain.parquet", "forces.parquet", "tracks.parquet"].map(|f| sim.join(f));
    let v = sidecar_naming(&out, &inputs.each_ref().map(|p| p.as_path()));
    assert_eq!(v["table"], "edge_stress");
    assert!(v["rate"].as_f64().unwrap() > 0.0, "{v}");
    let t = pillar_pipe::io::table::read_table(&out, &[]).unwrap();
    let p = t.f64("p").unwrap();
    assert_eq!(t.columns(), ["d_over_d", "p", "grains"]);
    assert!(p[0] < p[2], "the edge bin is below the interior: {p:?}");

    let (ok, text) = run(&[
        "edge-stress",
        sim.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--strain",
        "0.5,0.6",
    ]);
    assert!(
        !ok && text.contains("forces.parquet") && text.contains("reached"),
        "{text}"
    );
    let (ok, text) = run(&[
        "edge-stress",
        sim.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--strain",
        "0.2,0.1",
    ]);
    assert!(!ok && text.contains("strain"), "{text}");
    let (ok, text) = run(&[
        "edge-stress",
        d.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("stress_strain.parquet"), "{text}");
    assert!(!text.contains("panicked"), "{text}");

    // The reader is gone before the command prints.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_pillar-pipe"))
        .args([
            "edge-stress",
            sim.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let res = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(!err.contains("panicked"), "{err}");
}
