//! Ingest from the user's side: the CLI on the shared trackpy sample (checked against its
//! ground truth), round trips, and every bad input of issue 2 with its message and no
//! output left behind.

use crate::common;
use crate::common::{cli as run, tmpdir};
use pillar_pipe::io::read_tracks;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The shared sample with its ground truth (present in the project workspace and CI).
fn sample_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/trackpy-sample")
}

/// The bundled copy of the same trackpy file (always in the repository).
fn bundled_tracks() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/sample/tracks.csv")
}

fn scaled_sample(dir: &Path) -> PathBuf {
    let src = bundled_tracks();
    let out = dir.join("t.parquet");
    let (ok, text) = run(&[
        "ingest",
        src.to_str().unwrap(),
        "--format",
        "trackpy",
        "--px-per-unit",
        "31.496063",
        "--unit",
        "cm",
        "--frame-time",
        "15",
        "--origin-px",
        "165.980,850",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("frames        40 (0 .. 39)"), "{text}");
    assert!(text.contains("gaps"), "{text}");
    out
}

#[allow(clippy::needless_range_loop)]
/// Species and positions against the sample's ground truth: every detection in frame 0
/// lies within 0.1 cm of a true grain, and the species agrees for >= 99 % of them.
#[test]
fn sample_matches_ground_truth() {
    let dir = tmpdir("gt");
    let out = scaled_sample(&dir);
    let (t, _) = read_tracks(&out).unwrap();
    assert_eq!(t.meta.length_unit, "cm");
    assert_eq!(t.meta.frame_time, Some(15.0));
    let Ok(gt) = std::fs::read_to_string(sample_dir().join("ground_truth.csv")) else {
        common::cannot_check(
            "no ../shared/data/trackpy-sample/ground_truth.csv here: ground-truth check skipped",
        );
        return;
    };
    let mut truth = Vec::new(); // (x, y, large)
    let mut lines = gt.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|c| *c == n).unwrap();
    let (cf, cs, cx, cy) = (col("frame"), col("species"), col("x_cm"), col("y_cm"));
    for l in lines {
        let v: Vec<&str> = l.split(',').collect();
        if v[cf] == "0" {
            truth.push((
                v[cx].parse::<f64>().unwrap(),
                v[cy].parse::<f64>().unwrap(),
                v[cs] == "L",
            ));
        }
    }
    assert_eq!(truth.len(), 1000);
    let species = t.species.as_ref().expect("species assigned");
    let (mut n, mut agree, mut worst) = (0usize, 0usize, 0.0f64);
    for r in 0..t.len() {
        if t.frame[r] != 0 {
            continue;
        }
        let (bd, large) = truth
            .iter()
            .map(|&(x, y, l)| (((x - t.x[r]).powi(2) + (y - t.y[r]).powi(2)).sqrt(), l))
            .fold((f64::MAX, false), |a, b| if b.0 < a.0 { b } else { a });
        n += 1;
        worst = worst.max(bd);
        agree += usize::from(large == (species[r] == 1));
        let want_r = if large { 0.3175 } else { 0.238125 };
        assert!(
            (t.radius[r] - want_r).abs() < 0.02,
            "radius {}",
            t.radius[r]
        );
    }
    assert!(n >= 980, "{n} detections in frame 0");
    assert!(worst < 0.1, "worst position error {worst} cm");
    assert!(agree as f64 >= 0.99 * n as f64, "species agree {agree}/{n}");
}

#[test]
fn parquet_round_trips_to_csv() {
    let dir = tmpdir("rt");
    let pq = scaled_sample(&dir);
    let csv = dir.join("t.csv");
    let (ok, text) = run(&["ingest", pq.to_str().unwrap(), "-o", csv.to_str().unwrap()]);
    assert!(ok, "{text}");
    let head = std::fs::read_to_string(&csv).unwrap();
    let first = head.lines().next().unwrap();
    assert_eq!(first, "frame,particle,x,y,radius,time,species");
    let (a, _) = read_tracks(&pq).unwrap();
    let (b, _) = read_tracks(&csv).unwrap();
    assert_eq!(a.len(), b.len());
    assert_eq!(a.particle, b.particle);
    for r in 0..a.len() {
        assert!((a.x[r] - b.x[r]).abs() < 1e-9 && (a.y[r] - b.y[r]).abs() < 1e-9);
    }
    assert_eq!(b.meta.length_unit, "cm");
}

/// `pillar-pipe ingest FILE` typed just so: settings beside the input, default output.
#[test]
fn bare_ingest_uses_settings_and_default_output() {
    let dir = tmpdir("bare");
    std::fs::copy(bundled_tracks(), dir.join("tracks.csv")).unwrap();
    let (ok, text) = run(&["ingest", dir.join("tracks.csv").to_str().unwrap()]);
    assert!(!ok);
    assert!(text.contains("no scale was given"), "{text}");
    assert!(!dir.join("tracks.tracks.parquet").exists());
    std::fs::write(
        dir.join("ingest.toml"),
        "px_per_unit = 31.496063\nunit = \"cm\"\nframe_time = 15.0\n",
    )
    .unwrap();
    let (ok, text) = run(&["ingest", dir.join("tracks.csv").to_str().unwrap()]);
    assert!(ok, "{text}");
    assert!(text.contains("settings      from"), "{text}");
    assert!(dir.join("tracks.tracks.parquet").exists());
    assert!(dir.join("tracks.tracks.parquet.meta.json").exists());
    std::fs::write(
        dir.join("ingest.toml"),
        "px_per_unit = 31.4\nunits = \"cm\"\n",
    )
    .unwrap();
    let (ok, text) = run(&["ingest", dir.join("tracks.csv").to_str().unwrap()]);
    assert!(!ok);
    assert!(
        text.contains("ingest.toml") && text.contains("units"),
        "{text}"
    );
}

/// Each bad input: non-zero exit, the message names file/line/column, and no output.
#[test]
fn bad_inputs_fail_clearly_and_leave_nothing() {
    let dir = tmpdir("bad");
    let hdr = "frame,particle,x,y,radius\n";
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        ("num.csv", format!("{hdr}0,1,0,0,0.5\n0,2,1.x,0,0.5\n"), vec!["line 3", "'x'", "1.x"]),
        ("miss.csv", "frame,particle,x,radius\n0,1,0,0.5\n".into(), vec!["missing required column", "\"y\"", "found columns"]),
        ("nan.csv", format!("{hdr}0,1,0,0,0.5\n0,2,NaN,0,0.5\n"), vec!["line 3", "'x'", "finite"]),
        ("inf.csv", format!("{hdr}0,1,0,0,0.5\n0,2,0,-inf,0.5\n"), vec!["line 3", "'y'", "finite"]),
        ("dup.csv", format!("{hdr}0,1,0,0,0.5\n1,1,0,0,0.5\n0,1,1,0,0.5\n"), vec!["duplicate", "frame 0", "particle 1", "line 2", "line 4"]),
        ("neg.csv", format!("{hdr}0,1,0,0,0.5\n-1,1,0,0,0.5\n"), vec!["line 3", "'frame'", "negative"]),
        ("unk.csv", "a,b,c\n1,2,3\n".into(), vec!["unknown format", "trackpy", "lammps", "canonical"]),
        ("empty.csv", String::new(), vec!["empty file"]),
        ("header.csv", hdr.into(), vec!["no data rows"]),
        ("cut.dump", "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n3\nITEM: BOX BOUNDS pp pp pp\n0 10\n0 10\n-0.5 0.5\nITEM: ATOMS id type x y radius\n1 1 1 1 0.5\n2 1 2 2 0.5\n".into(), vec!["cut off", "line 11"]),
        ("px.csv", "y,x,mass,size,ecc,signal,raw_mass,ep,frame,particle\n10,20,100,4,0.1,5,200,0.1,0,0\n".into(), vec!["pixels", "--px-per-unit"]),
        ("rad.csv", format!("{hdr}0,1,0,0,-0.5\n"), vec!["line 2", "'radius'"]),
    ];
    for (name, body, needles) in cases {
        let input = dir.join(name);
        std::fs::write(&input, body).unwrap();
        let out = dir.join(format!("{name}.out.parquet"));
        let (ok, text) = run(&[
            "ingest",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(!ok, "{name} should fail: {text}");
        assert!(
            text.contains(name),
            "{name}: message must name the file: {text}"
        );
        for n in needles {
            assert!(text.contains(n), "{name}: expected '{n}' in: {text}");
        }
        assert!(!text.contains("panicked"), "{name}: {text}");
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|f| f.contains(".out.") || f.contains("partial"))
            .collect();
        assert!(left.is_empty(), "{name}: left behind {left:?}");
    }
}

/// A LAMMPS triclinic dump with scaled coordinates gives the box tilt per frame.
#[test]
fn lammps_triclinic_scaled() {
    let dir = tmpdir("lmp");
    let mut s = String::new();
    for (ts, xy) in [(0, 0.0), (100, 1.0)] {
        s += &format!(
            "ITEM: TIMESTEP\n{ts}\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS xy xz yz pp pp pp\n0 11 {xy}\n0 10 0\n-0.5 0.5 0\nITEM: ATOMS id type xs ys diameter\n1 1 0.5 0.5 1.0\n2 2 0.25 0.0 1.4\n"
        );
    }
    let input = dir.join("run.dump");
    std::fs::write(&input, s).unwrap();
    let out = dir.join("run.parquet");
    let (ok, text) = run(&[
        "ingest",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let (t, _) = read_tracks(&out).unwrap();
    assert_eq!(t.len(), 4);
    assert_eq!(t.meta.boxes.len(), 2);
    assert!((t.meta.boxes[1].xy - 1.0).abs() < 1e-12);
    // frame 1, particle 1: x = xlo + xs*lx + ys*xy with lx = xhi - xlo for xy >= 0
    let r = (0..t.len())
        .find(|&r| t.frame[r] == 1 && t.particle[r] == 1)
        .unwrap();
    assert!((t.y[r] - 5.0).abs() < 1e-12);
    assert!((t.radius[r] - 0.5).abs() < 1e-12);
}

/// The table the code writes has exactly the columns the schema file documents, and
/// every schema file parses.
#[test]
fn schema_files_and_code_agree() {
    use pillar_pipe::schema;
    for (name, _) in schema::SCHEMA_FILES {
        let s = schema::load(name);
        assert_eq!(&s.table, name);
        assert!(!s.columns.is_empty());
        for c in &s.columns {
            assert!(c.unit.is_some(), "{name}.{} has no unit", c.name);
        }
    }
    let sch = schema::load("tracks");
    let expect: Vec<&str> = pillar_pipe::io::tracks_io::TRACKS_EXPECT
        .iter()
        .map(|(n, _)| *n)
        .collect();
    assert_eq!(sch.names(), expect);
    // The camera's tables: trackpy's feature columns as the reader parses them (and the
    // columns it requires), then `particle`; render's ground truth.
    use pillar_pipe::io::csvdiag::Expect;
    use pillar_pipe::io::features::{FEATURE_COLUMNS, REQUIRED};
    let sch = schema::load("features");
    let mut expect: Vec<(&str, &str)> = FEATURE_COLUMNS
        .iter()
        .map(|&(n, e)| (n, if e == Expect::Int { "int64" } else { "float64" }))
        .collect();
    expect.push(("particle", "int64"));
    let found: Vec<(&str, &str)> = sch
        .columns
        .iter()
        .map(|c| (c.name.as_str(), c.dtype.as_str()))
        .collect();
    assert_eq!(found, expect);
    let mut required = sch.required();
    required.sort_unstable();
    let mut reader_requires = REQUIRED.to_vec();
    reader_requires.sort_unstable();
    assert_eq!(required, reader_requires);
    assert_eq!(
        schema::load("ground_truth").names(),
        pillar_pipe::stages::render::GROUND_TRUTH_COLUMNS
    );
    // The files on disk are the embedded ones (no stale copy in the binary).
    for (name, text) in schema::SCHEMA_FILES {
        let p =
            Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("data_schema/{name}.schema.json"));
        assert_eq!(std::fs::read_to_string(p).unwrap(), *text);
    }
}

/// An output that exists and is not a regular file (a FIFO, a device such as
/// /dev/null) is refused rather than replaced by a file.
#[test]
fn non_regular_output_is_refused_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tmpdir("fifo");
    let fifo = dir.join("out.parquet");
    let st = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(st.success());
    let input = dir.join("t.csv");
    std::fs::write(&input, "frame,particle,x,y,radius\n0,1,0,0,0.5\n").unwrap();
    let (ok, text) = run(&[
        "ingest",
        input.to_str().unwrap(),
        "-o",
        fifo.to_str().unwrap(),
    ]);
    assert!(!ok, "{text}");
    assert!(text.contains("not a regular file"), "{text}");
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
}

/// The real LAMMPS dumps of `tests/data/lammps/make_dumps.py` (a sheared 2D packing).
fn lammps_dump(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/lammps/sheared_{name}.dump"))
}

fn ingest_dump(dir: &Path, name: &str) -> (pillar_pipe::tracks::Tracks, String) {
    let out = dir.join(format!("{name}.parquet"));
    let (ok, text) = run(&[
        "ingest",
        lammps_dump(name).to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{name}: {text}");
    (read_tracks(&out).unwrap().0, text)
}

/// Issue 24: the same LAMMPS snapshots written as `xs ys ix iy`, `x y ix iy` and `xu yu`
/// ingest to the same, continuous tracks (image flags unwrap with the tilted box).
#[test]
fn lammps_image_flags_unwrap_like_xu_yu() {
    let dir = tmpdir("lmp-img");
    let (u, text) = ingest_dump(&dir, "xu_yu");
    assert!(!text.contains("wrapped"), "{text}");
    // The dump's own timesteps survive next to ingest's summary (one per snapshot).
    let steps = u.meta.summary["lammps_timesteps"].as_array().map(Vec::len);
    assert_eq!(steps, Some(9), "{:?}", u.meta.summary);
    assert!(u.meta.summary["frames"].is_number(), "{:?}", u.meta.summary);
    let lx = u.meta.boxes[0].lx;
    let ly = u.meta.boxes[0].ly;
    let d = u.large_diameter().unwrap();
    assert_eq!(u.meta.boxes.len(), 9);
    assert!(
        u.meta.boxes[8].xy > 0.4 * ly,
        "sheared: {:?}",
        u.meta.boxes[8]
    );
    assert!(u.meta.warnings.is_empty(), "{:?}", u.meta.warnings);
    for name in ["xs_ys_ix_iy", "x_y_ix_iy"] {
        let (t, text) = ingest_dump(&dir, name);
        assert!(!text.contains("wrapped"), "{name}: {text}");
        assert!(t.meta.warnings.is_empty(), "{name}: {:?}", t.meta.warnings);
        assert_eq!((&t.frame, &t.particle), (&u.frame, &u.particle), "{name}");
        let worst = (0..t.len())
            .map(|r| (t.x[r] - u.x[r]).abs().max((t.y[r] - u.y[r]).abs()))
            .fold(0.0, f64::max);
        // 10 significant digits in the dumps: ~1e-9 of the box.
        assert!(worst < 1e-7 * lx, "{name}: max |Δ| = {worst} (box {lx})");
    }
    // Continuous: no grain moves more than a diameter between snapshots (raw
    // coordinates, no minimum image) ...
    let by_particle = |t: &pillar_pipe::tracks::Tracks| {
        let mut m = std::collections::BTreeMap::<i64, Vec<(f64, f64)>>::new();
        for r in 0..t.len() {
            m.entry(t.particle[r]).or_default().push((t.x[r], t.y[r]));
        }
        m
    };
    let tracks = by_particle(&u);
    let worst_step = tracks
        .values()
        .flat_map(|p| {
            p.windows(2)
                .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        })
        .fold(0.0, f64::max);
    assert!(worst_step < d, "largest step {worst_step} (D = {d})");
    // ... while the same grains wrapped into each snapshot's box cross its boundaries
    // (otherwise this test would not exercise the image flags).
    let (mut across_x, mut across_y) = (0, 0);
    for r in 0..u.len() {
        let b = u.meta.box_at(u.frame[r]).unwrap();
        let w = b.wrap(pillar_pipe::geom::Vec2::new(u.x[r], u.y[r]));
        let n_y = ((u.y[r] - w.y) / ly).round();
        let n_x = ((u.x[r] - w.x - n_y * b.xy) / lx).round();
        across_x += usize::from(u.frame[r] == 8 && n_x != 0.0);
        across_y += usize::from(u.frame[r] == 8 && n_y != 0.0);
    }
    assert!(
        across_x >= 10 && across_y >= 3,
        "grains outside the box at the end: {across_x} along x, {across_y} along y"
    );
}

/// A dump with neither image flags nor unwrapped columns is read wrapped, and says so
/// (printed and in the sidecar); its positions are the wrapped ones.
#[test]
fn lammps_dump_without_image_flags_warns_and_stays_wrapped() {
    let dir = tmpdir("lmp-wrap");
    let (t, text) = ingest_dump(&dir, "x_y");
    assert!(
        text.contains("warning: positions are wrapped along x (no ix), y (no iy)")
            && text.contains("dump 'ix iy' or 'xu yu'"),
        "{text}"
    );
    assert_eq!(t.meta.warnings.len(), 1, "{:?}", t.meta.warnings);
    assert!(t.meta.warnings[0].contains("neither image flags"));
    for r in 0..t.len() {
        let b = t.meta.box_at(t.frame[r]).unwrap();
        let lo = b.x_lo + (t.y[r] - b.y_lo) / b.ly * b.xy;
        assert!(
            (b.y_lo..b.y_lo + b.ly).contains(&t.y[r])
                && (lo - 1e-9..lo + b.lx + 1e-9).contains(&t.x[r]),
            "row {r} outside the box: ({}, {})",
            t.x[r],
            t.y[r]
        );
    }
    // Its second snapshot is the flagged dumps' last: the same grains, wrapped.
    let (u, _) = ingest_dump(&dir, "xu_yu");
    let n = t.len() / 2;
    let moved = (n..t.len())
        .filter(|&r| {
            let k = 8 * n + (r - n);
            assert_eq!(
                (t.frame[r], t.particle[r], u.frame[k]),
                (1, u.particle[k], 8)
            );
            (u.x[k] - t.x[r]).abs() > 1.0 || (u.y[k] - t.y[r]).abs() > 1.0
        })
        .count();
    assert!(
        moved >= 10,
        "{moved} grains differ from their unwrapped position"
    );
    // A non-periodic box needs no flags: no warning.
    let open = "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS ff ff pp\n0 10\n0 10\n-0.5 0.5\nITEM: ATOMS id type x y radius\n1 1 1 1 0.5\n";
    std::fs::write(dir.join("open.dump"), open).unwrap();
    let (ok, text) = run(&[
        "ingest",
        dir.join("open.dump").to_str().unwrap(),
        "-o",
        dir.join("open.parquet").to_str().unwrap(),
    ]);
    assert!(ok && !text.contains("wrapped"), "{text}");
}

/// Issue 24: an ingest whose tracks cannot be written (a file-size limit) leaves no
/// table, no sidecar and no temporary file, and states the cause once.
#[test]
fn failed_tracks_write_leaves_no_sidecar() {
    let dir = tmpdir("ingest-efbig");
    let input = dir.join("in.csv");
    let mut s = String::from("frame,particle,x,y,radius\n");
    for f in 0..20 {
        for p in 0..200 {
            // Distinct, incompressible values: the Parquet output too outgrows the limit.
            let h = (f * 200 + p) as u64 * 2_654_435_761 % 1_000_000_007;
            s += &format!(
                "{f},{p},{},{},0.5\n",
                h as f64 / 7e7,
                (h % 65_537) as f64 / 3e3
            );
        }
    }
    std::fs::write(&input, s).unwrap();
    for name in ["t.csv", "t.parquet"] {
        let out = dir.join(name);
        let (ok, text) = common::cli_file_limit(
            16,
            &[
                "ingest",
                input.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
        );
        assert!(!ok, "{name}: {text}");
        assert_eq!(common::file_names(&dir), ["in.csv"], "{name}: {text}");
        assert!(text.contains(out.to_str().unwrap()), "{name}: {text}");
        assert_eq!(text.matches("File too large").count(), 1, "{name}: {text}");
    }
}

/// A small trackpy file: a 4 x 4 lattice of grains (two sizes) in two frames, with the
/// value of `x` at row `bad_row` replaced by `bad`.
fn trackpy_lattice(bad_row: usize, bad: &str) -> String {
    let mut s = "y,x,mass,size,ecc,signal,raw_mass,ep,frame,particle\n".to_string();
    let mut row = 0;
    for f in 0..2 {
        for p in 0..16 {
            let (x, y) = (100.0 + 20.0 * (p % 4) as f64, 100.0 + 20.0 * (p / 4) as f64);
            let size = if p % 2 == 0 { 4.0 } else { 5.5 };
            let x = if row == bad_row {
                bad.to_string()
            } else {
                format!("{x}")
            };
            s += &format!("{y},{x},2000,{size},0.1,20,13000,0.03,{f},{p}\n");
            row += 1;
        }
    }
    s
}

fn ingest_in_process(
    input: &Path,
) -> pillar_pipe::Result<pillar_pipe::stages::ingest::IngestReport> {
    let opt = pillar_pipe::stages::ingest::IngestOptions {
        px_per_unit: Some(10.0),
        unit: Some("cm".into()),
        ..Default::default()
    };
    pillar_pipe::stages::ingest::run(input, &input.with_extension("parquet"), &opt)
}

/// Issue 24: a trackpy coordinate of 1e40 px panicked in the radius estimate's cell list
/// ("min > max"). It is refused with the file, line, column and value; so is any value
/// past the documented bound (data_schema/tracks.schema.json, `max_abs`), while a value
/// at the bound still reads.
#[test]
fn absurd_trackpy_coordinate_is_refused_with_its_place() {
    let dir = tmpdir("huge-coord");
    let input = dir.join("t.csv");
    std::fs::write(&input, trackpy_lattice(99, "")).unwrap();
    ingest_in_process(&input).expect("the clean lattice reads");
    for bad in ["1e40", "-1e40", "1.5e12", "1e308"] {
        std::fs::write(&input, trackpy_lattice(5, bad)).unwrap();
        let e = ingest_in_process(&input).expect_err(bad).to_string();
        let want_value = format!("{:e} px", bad.parse::<f64>().unwrap());
        for part in [
            input.to_str().unwrap(),
            "line 7",
            "column 'x'",
            &want_value,
            "1e12",
        ] {
            assert!(e.contains(part), "{bad}: '{part}' missing from: {e}");
        }
    }
}

/// The same bound for canonical tables (in their length unit) and LAMMPS dumps, which
/// reach the cell lists of kinematics and the simulators.
#[test]
fn absurd_canonical_and_lammps_coordinates_are_refused() {
    let dir = tmpdir("huge-canon");
    let csv = dir.join("c.csv");
    std::fs::write(
        &csv,
        "frame,particle,x,y,radius\n0,1,0,0,0.5\n0,2,1,0,0.5\n0,3,0,2e13,0.5\n",
    )
    .unwrap();
    let e = read_tracks(&csv)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    for part in [
        csv.to_str().unwrap(),
        "line 4",
        "column 'y'",
        "2e13",
        "1e12",
    ] {
        assert!(e.contains(part), "'{part}' missing from: {e}");
    }
    std::fs::write(&csv, "frame,particle,x,y,radius\n0,1,0,0,1e40\n").unwrap();
    let e = read_tracks(&csv)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    assert!(e.contains("line 2") && e.contains("'radius'"), "{e}");
    let dump = dir.join("d.dump");
    std::fs::write(
        &dump,
        "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n0 10\n0 10\n-1 1\nITEM: ATOMS id x y radius\n1 1 1 0.5\n2 -1e40 3 0.5\n",
    )
    .unwrap();
    let e = pillar_pipe::io::lammps::read_lammps(&dump, &Default::default())
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    for part in [dump.to_str().unwrap(), "line 11", "column 'x'", "-1e40"] {
        assert!(e.contains(part), "'{part}' missing from: {e}");
    }
}

/// The bound the code enforces is the one the schema documents.
#[test]
fn coordinate_bound_matches_the_schema() {
    let sch = pillar_pipe::schema::load("tracks");
    for c in ["x", "y", "radius"] {
        assert_eq!(
            sch.column(c).unwrap().max_abs,
            Some(pillar_pipe::tracks::MAX_ABS_COORD),
            "{c}"
        );
    }
}

/// A species with fewer than 2 grains cannot have its radius estimated: the error names
/// the file (it was a bare message before).
#[test]
fn radius_estimate_failure_names_the_file() {
    let dir = tmpdir("one-small");
    let input = dir.join("t.csv");
    std::fs::write(
        &input,
        "y,x,size,frame,particle\n10,10,4,0,1\n10,30,6,0,2\n10,50,6,0,3\n",
    )
    .unwrap();
    let e = ingest_in_process(&input)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains(input.to_str().unwrap()) && e.contains("cannot estimate the radius"),
        "{e}"
    );
}

/// A file whose first line is not UTF-8 is refused naming the byte; one whose first
/// line is fine but a later value is not reaches the reader, which names the line.
#[test]
fn non_utf8_input_is_placed() {
    let dir = tmpdir("utf8");
    let input = dir.join("t.csv");
    std::fs::write(&input, b"frame,particle,x,\xffy,radius\n0,1,0,0,0.5\n").unwrap();
    let e = ingest_in_process(&input)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    assert!(e.contains("line 1") && e.contains("byte 17"), "{e}");
    std::fs::write(
        &input,
        b"frame,particle,x,y,radius\n0,1,0,0,0.5\n0,2,0,\xff1,0.5\n",
    )
    .unwrap();
    let e = ingest_in_process(&input)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    assert!(e.contains("line 3"), "{e}");
}

/// Issue 24's fuzz (seed 1, case 7603): a trackpy header naming a column twice made
/// polars' CSV reader panic ("slice index starts at 1 but ends at 0"). It is refused
/// naming the file, line 1 and the column.
#[test]
fn repeated_column_name_is_refused_not_a_panic() {
    let dir = tmpdir("dup-col");
    let input = dir.join("t.csv");
    let text = trackpy_lattice(99, "").replacen("y,x,mass", "y,ep,mass", 1);
    std::fs::write(&input, text).unwrap();
    let e = ingest_in_process(&input)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    for part in [input.to_str().unwrap(), "line 1", "'ep'", "repeated"] {
        assert!(e.contains(part), "'{part}' missing from: {e}");
    }
}

/// Parquet files whose page headers claim ~2^61 values (found by `scripts/fuzz.sh 20000
/// 1 2`): polars sized a buffer from the count and the failed allocation aborted the
/// process (exit 134, no file named). The page headers are checked first now.
#[test]
fn corrupt_parquet_page_headers_are_refused_not_an_abort() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corrupt");
    for k in 1..=4 {
        let p = dir.join(format!("parquet-page-header-{k}.parquet"));
        let e = pillar_pipe::io::table::read_table(&p, &[])
            .map(|_| ())
            .expect_err("refused");
        let e = e.to_string();
        assert!(
            e.contains(p.to_str().unwrap())
                && e.contains("reading Parquet: corrupt file")
                && e.contains("column"),
            "{e}"
        );
        // And through the CLI, as a user meets it: an error, not an abort.
        let (ok, text) = run(&[
            "kinematics",
            p.to_str().unwrap(),
            "--lag",
            "1",
            "-o",
            "/dev/null/x.parquet",
        ]);
        assert!(
            !ok && text.contains("reading Parquet: corrupt file"),
            "{text}"
        );
    }
    // A valid table passes the check unchanged.
    let d = tmpdir("pq-guard");
    let (ok, text) = run(&["synth", "-o", d.join("t.parquet").to_str().unwrap()]);
    assert!(ok, "{text}");
    pillar_pipe::io::parquet_guard::check(&d.join("t.parquet")).unwrap();
}

/// Parquet tracks from another tool with column types this build cannot hold (decimal,
/// struct; `tests/data/foreign/README.md`): as extra columns they are ignored with a
/// warning (tracks are read a column at a time, and only the tracks' columns are
/// converted); as `x` they are an error naming the file, never a panic.
#[test]
fn foreign_parquet_column_types_are_ignored_or_refused_not_a_panic() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/foreign");
    let extra = dir.join("extra-decimal-struct.parquet");
    let (t, warnings) = pillar_pipe::io::read_tracks(&extra).unwrap();
    assert_eq!(t.len(), 6);
    assert_eq!(t.x, [0.0, 1.0, 0.5, 0.01, 1.01, 0.51]);
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("weight") && w.contains("pos")),
        "{warnings:?}"
    );
    let bad = dir.join("x-decimal.parquet");
    let e = pillar_pipe::io::read_tracks(&bad).unwrap_err().to_string();
    assert!(
        e.contains(bad.to_str().unwrap()) && e.contains("reading Parquet"),
        "{e}"
    );
    let out = tmpdir("foreign");
    let (ok, text) = run(&[
        "kinematics",
        bad.to_str().unwrap(),
        "--lag",
        "1",
        "-o",
        out.join("k.parquet").to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("reading Parquet"), "{text}");
    // The panic polars raised is in the error, not printed as a crash beside it.
    assert!(!text.contains("panicked"), "{text}");
}

/// `export` (issue 37): a sheared run with its kinematics as a LAMMPS dump reads back
/// through `ingest` with every position, radius and species bit for bit and the
/// Lees–Edwards box as the tilt (reduced to |xy| ≤ L/2; L_x within rounding of the
/// bounding-box form); as extended XYZ, each frame's
/// lattice, property list and D²min are those of the tables. No format, no guess.
#[test]
fn export_writes_files_ovito_opens_that_read_back_exactly() {
    let d = tmpdir("export");
    let run_dir = d.join("s");
    let (ok, text) = run(&[
        "simulate",
        "shear",
        "--n",
        "64",
        "--phi",
        "0.8",
        "--rate",
        "1e-2",
        "--strain",
        "0.6",
        "--quiet",
        "-o",
        run_dir.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let kin = d.join("k.parquet");
    let tracks = run_dir.join("tracks.parquet");
    let (ok, text) = run(&[
        "kinematics",
        tracks.to_str().unwrap(),
        "--lag",
        "1",
        "--rc",
        "1.5",
        "-o",
        kin.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let (t, _) = read_tracks(&tracks).unwrap();
    // LAMMPS dump → ingest.
    let dump = d.join("s.dump");
    let (ok, text) = run(&[
        "export",
        run_dir.to_str().unwrap(),
        "--kinematics",
        kin.to_str().unwrap(),
        "-o",
        dump.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(d.join("s.dump.meta.json").is_file(), "sidecar");
    let back = d.join("back.parquet");
    let (ok, text) = run(&[
        "ingest",
        dump.to_str().unwrap(),
        "-o",
        back.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let (b, _) = read_tracks(&back).unwrap();
    assert_eq!(b.frame, t.frame);
    assert_eq!(b.particle, t.particle);
    assert_eq!(b.x, t.x);
    assert_eq!(b.y, t.y);
    assert_eq!(b.radius, t.radius);
    assert_eq!(b.species, t.species);
    let sheared = t.meta.boxes.iter().filter(|x| x.xy != 0.0).count();
    assert!(sheared > 2, "the run sheared its box");
    for (x, y) in t.meta.boxes.iter().zip(&b.meta.boxes) {
        let reduced = x.xy - x.lx * (x.xy / x.lx).round();
        // A tilted dump gives its bounding box, xhi + xy: L_x comes back within rounding.
        assert!(
            (y.xy - reduced).abs() < 1e-12 && (y.lx - x.lx).abs() < 1e-12 && y.ly == x.ly,
            "{x:?} {y:?}"
        );
    }
    // Extended XYZ: lattice, properties and D²min of every particle with kinematics.
    let xyz = d.join("s.xyz");
    let (ok, text) = run(&[
        "export",
        tracks.to_str().unwrap(),
        "--kinematics",
        kin.to_str().unwrap(),
        "-o",
        xyz.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let k = pillar_pipe::io::table::read_table(&kin, &[]).unwrap();
    let (kf, kp, kd) = (
        k.i64("frame").unwrap(),
        k.i64("particle").unwrap(),
        k.f64_or_nan("d2min").unwrap(),
    );
    let d2: std::collections::HashMap<(i64, i64), f64> = kf
        .iter()
        .zip(&kp)
        .zip(&kd)
        .map(|((f, p), v)| ((*f, *p), *v))
        .collect();
    let text = std::fs::read_to_string(&xyz).unwrap();
    let mut lines = text.lines();
    let (mut frames, mut checked) = (0, 0);
    while let Some(n) = lines.next() {
        let n: usize = n.parse().unwrap();
        let head = lines.next().unwrap();
        let frame: i64 = head.rsplit("frame=").next().unwrap().parse().unwrap();
        let bx = t.meta.boxes.iter().find(|b| b.frame == frame).unwrap();
        let xy = bx.xy - bx.lx * (bx.xy / bx.lx).round();
        let lattice = format!("Lattice=\"{} 0 0 {} {} 0 0 0 1\"", bx.lx, xy, bx.ly);
        assert!(head.contains(&lattice), "{head}");
        let props = head
            .split("Properties=")
            .nth(1)
            .unwrap()
            .split(' ')
            .next()
            .unwrap();
        let names: Vec<&str> = props.split(':').step_by(3).collect();
        assert_eq!(&names[..5], ["id", "type", "pos", "radius", "velo"]);
        // Columns: id, type, x y z, radius, vx vy vz, then one each.
        let col = 9 + names[5..].iter().position(|n| *n == "d2min").unwrap();
        for _ in 0..n {
            let f: Vec<&str> = lines.next().unwrap().split(' ').collect();
            let id: i64 = f[0].parse().unwrap();
            let v: f64 = f[col].parse().unwrap();
            match d2.get(&(frame, id)) {
                Some(w) if w.is_nan() => assert!(v.is_nan()),
                Some(w) => {
                    assert_eq!(v, *w, "frame {frame} particle {id}");
                    checked += 1;
                }
                None => assert!(v.is_nan(), "no kinematics: NaN"),
            }
        }
        frames += 1;
    }
    assert_eq!(frames, t.frame_ranges().len());
    assert!(checked > 100, "{checked} D²min compared");
    // An extension that names no format is refused, naming the file and the option.
    let (ok, text) = run(&["export", tracks.to_str().unwrap(), "-o", "out.txt"]);
    assert!(
        !ok && text.contains("out.txt") && text.contains("--format"),
        "{text}"
    );
    // A directory without tracks is refused, naming it.
    let (ok, text) = run(&["export", d.to_str().unwrap(), "-o", "x.xyz"]);
    assert!(!ok && text.contains("tracks.parquet"), "{text}");
}

/// Found by the camera tests: with radii that make a loose lattice look like no packing
/// (every grain's neighbours farther than 1.25 D), ingest dropped every trajectory as a
/// "detached" tracker artefact and succeeded with an empty table. It now refuses, naming
/// the file and the way out; `--keep-detached` keeps them.
#[test]
fn every_trajectory_detached_is_an_error_not_an_empty_table() {
    let dir = tmpdir("all-detached");
    let input = dir.join("t.csv");
    std::fs::write(&input, trackpy_lattice(99, "")).unwrap();
    // 20 px apart at 10 px/cm is 2 cm; with D = 0.5 cm that is 4 D.
    let mut opt = pillar_pipe::stages::ingest::IngestOptions {
        px_per_unit: Some(10.0),
        unit: Some("cm".into()),
        radii: Some((0.2, 0.25)),
        ..Default::default()
    };
    let out = input.with_extension("parquet");
    let e = pillar_pipe::stages::ingest::run(&input, &out, &opt)
        .expect_err("every trajectory detached")
        .to_string();
    for part in [
        input.to_str().unwrap(),
        "all 16 trajectories",
        "--keep-detached",
    ] {
        assert!(e.contains(part), "'{part}' missing from: {e}");
    }
    assert!(!out.exists());
    opt.keep_detached = true;
    let r = pillar_pipe::stages::ingest::run(&input, &out, &opt).expect("kept");
    assert_eq!(r.summary.particles_per_frame_max, 16);
}
