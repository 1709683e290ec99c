//! The kinematics and fit stages from the user's side (CLI), on generated tracks with a
//! known answer.

use crate::common;
use crate::common::{cli as run, tmpdir};
use pillar_pipe::geom::Mat2;
use pillar_pipe::io::write_tracks;
use pillar_pipe::synth::{bidisperse_packing, two_frame_tracks};
use std::path::PathBuf;

/// A plain canonical CSV (no sidecar, no species) in the minimal column set.
fn plain_csv(dir: &std::path::Path, shuffle: bool) -> PathBuf {
    let p = bidisperse_packing(600, 1.0, 0.1, 3);
    let t = two_frame_tracks(&p, Mat2::new(1.0, 0.04, 0.0, 0.99), 0.01, 5);
    let mut rows: Vec<String> = (0..t.len())
        .map(|r| {
            format!(
                "{},{},{:.17e},{:.17e},{}",
                t.frame[r],
                t.particle[r] * 7 + 3,
                t.x[r],
                t.y[r],
                t.radius[r]
            )
        })
        .collect();
    if shuffle {
        // A fixed permutation: reverse, then interleave halves.
        rows.reverse();
        let (a, b) = rows.split_at(rows.len() / 2);
        rows = a
            .iter()
            .zip(b)
            .flat_map(|(x, y)| [y.clone(), x.clone()])
            .collect();
    }
    let path = dir.join(if shuffle {
        "shuffled.csv"
    } else {
        "tracks.csv"
    });
    std::fs::write(
        &path,
        format!("frame,particle,x,y,radius\n{}\n", rows.join("\n")),
    )
    .unwrap();
    path
}

#[test]
fn canonical_csv_gives_the_documented_columns_and_row_order_does_not_matter() {
    let dir = tmpdir("cols");
    let a = plain_csv(&dir, false);
    let b = plain_csv(&dir, true);
    let (ok, text) = run(&[
        "kinematics",
        a.to_str().unwrap(),
        "--lag",
        "1",
        "-o",
        dir.join("a.csv").to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("1 frame pairs"), "{text}");
    let (ok, text) = run(&[
        "kinematics",
        b.to_str().unwrap(),
        "--lag",
        "1",
        "-o",
        dir.join("b.csv").to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let out_a = std::fs::read_to_string(dir.join("a.csv")).unwrap();
    let out_b = std::fs::read_to_string(dir.join("b.csv")).unwrap();
    let header = out_a.lines().next().unwrap();
    let schema = pillar_pipe::schema::load("kinematics");
    assert_eq!(header.split(',').collect::<Vec<_>>(), schema.names());
    assert_eq!(
        out_a, out_b,
        "shuffled input rows must give identical output"
    );
    let input_rows = std::fs::read_to_string(&a).unwrap().lines().count() - 1;
    assert_eq!(
        out_a.lines().count() - 1,
        input_rows / 2,
        "one row per particle of the pair"
    );
    // Sidecar with provenance and R_c.
    let meta = std::fs::read_to_string(dir.join("a.csv.meta.json")).unwrap();
    assert!(
        meta.contains("\"rc\": 1.25") && meta.contains("source_sha256"),
        "{meta}"
    );
}

#[test]
fn ovito_convention_scales_d2min_by_neighbour_count() {
    let dir = tmpdir("ovito");
    let a = plain_csv(&dir, false);
    let p = dir.join("p.csv");
    let o = dir.join("o.csv");
    assert!(
        run(&[
            "kinematics",
            a.to_str().unwrap(),
            "--lag",
            "1",
            "-o",
            p.to_str().unwrap(),
            "--rc",
            "1.2"
        ])
        .0
    );
    assert!(
        run(&[
            "kinematics",
            a.to_str().unwrap(),
            "--lag",
            "1",
            "-o",
            o.to_str().unwrap(),
            "--rc",
            "1.2",
            "--convention",
            "ovito"
        ])
        .0
    );
    let read = |f: &PathBuf| -> Vec<Vec<String>> {
        std::fs::read_to_string(f)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(String::from).collect())
            .collect()
    };
    let (rp, ro) = (read(&p), read(&o));
    assert_eq!(rp.len(), ro.len());
    let mut checked = 0;
    for (x, y) in rp.iter().zip(&ro) {
        // columns: n_neighbors 7, valid 8, status 9, d2min 20
        if x[8] == "true" && x[9] == "ok" && x[7] == y[7] {
            let n: f64 = x[7].parse().unwrap();
            let (dp, dov): (f64, f64) = (x[20].parse().unwrap(), y[20].parse().unwrap());
            assert!(
                (dp * n - dov).abs() <= 1e-9 * dov.abs().max(1e-30),
                "{dp} * {n} vs {dov}"
            );
            checked += 1;
        }
    }
    assert!(checked > 500);
}

#[test]
fn kinematics_bad_requests_fail_clearly() {
    let dir = tmpdir("bad");
    let a = plain_csv(&dir, false);
    let out = dir.join("k.parquet");
    let (ok, text) = run(&[
        "kinematics",
        a.to_str().unwrap(),
        "--lag",
        "5",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("no frame pair"), "{text}");
    let (ok, text) = run(&[
        "kinematics",
        a.to_str().unwrap(),
        "--lag",
        "0",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains(">= 1"), "{text}");
    let (ok, text) = run(&[
        "kinematics",
        a.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("--lag"), "{text}");
    let (ok, text) = run(&[
        "kinematics",
        a.to_str().unwrap(),
        "--lag-time",
        "1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && text.contains("frame time"), "{text}");
    assert!(!out.exists());
    assert!(!dir.join("k.parquet.meta.json").exists());
}

/// Synthetic tracks written through the library, read by the CLI: J is the map.
#[test]
fn synth_tracks_through_the_stage_recover_the_map() {
    let dir = tmpdir("synth");
    let p = bidisperse_packing(2000, 1.0, 0.1, 9);
    let f = Mat2::new(0.98, 0.03, 0.01, 1.01);
    let t = two_frame_tracks(&p, f, 0.0, 0);
    let tp = dir.join("s.parquet");
    write_tracks(&t, &tp).unwrap();
    let out = dir.join("k.csv");
    let (ok, text) = run(&[
        "kinematics",
        tp.to_str().unwrap(),
        "--lag",
        "1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let body = std::fs::read_to_string(&out).unwrap();
    let want =
        pillar_pipe::kinematics::strain_from_j(&f, pillar_pipe::kinematics::Convention::Paper);
    for l in body.lines().skip(1) {
        let v: Vec<f64> = l
            .split(',')
            .map(|x| {
                if x == "true" {
                    1.0
                } else {
                    x.parse().unwrap_or(f64::NAN)
                }
            })
            .collect();
        // Columns after `valid` (8) and `status` (9): j11 10, j12 11, eta_s 18, d2min 20.
        assert!(l.split(',').nth(9) == Some("ok"), "{l}");
        assert!((v[10] - 0.98).abs() < 1e-10 && (v[11] - 0.03).abs() < 1e-10);
        assert!((v[18] - want.eta_s).abs() < 1e-10);
        assert!(v[20].abs() < 1e-20);
    }
}

/// Ingest one of the real LAMMPS dumps (`tests/data/lammps/make_dumps.py`) with a frame
/// time, then run kinematics at `lag`: (particle, vx, vy, d2min, eta_s) of start frame 0.
fn lammps_kinematics(dir: &std::path::Path, name: &str, dt: f64, lag: u32) -> Vec<[f64; 5]> {
    let dump =
        std::path::Path::new(common::ROOT).join(format!("tests/data/lammps/sheared_{name}.dump"));
    let tracks = dir.join(format!("{name}.parquet"));
    let (ok, text) = run(&[
        "ingest",
        dump.to_str().unwrap(),
        "--frame-time",
        &dt.to_string(),
        "-o",
        tracks.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let out = dir.join(format!("{name}.k.parquet"));
    let (ok, text) = run(&[
        "kinematics",
        tracks.to_str().unwrap(),
        "--lag",
        &lag.to_string(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let k = pillar_pipe::io::table::read_table(&out, &[]).unwrap();
    let (frame, particle) = (k.i64("frame").unwrap(), k.i64("particle").unwrap());
    let cols = ["vx", "vy", "d2min", "eta_s"].map(|c| k.f64(c).unwrap());
    (0..frame.len())
        .filter(|&r| frame[r] == 0)
        .map(|r| {
            [
                particle[r] as f64,
                cols[0][r],
                cols[1][r],
                cols[2][r],
                cols[3][r],
            ]
        })
        .collect()
}

/// Issue 24: a LAMMPS dump with image flags and one with unwrapped columns give the
/// same velocities (and strains); a dump with neither gives velocities that differ,
/// for the grains that crossed the sheared boundary, by whole multiples of the
/// Lees–Edwards image velocity Δxy/Δt, while D²min and η^s agree.
#[test]
fn lammps_image_flags_give_the_unwrapped_velocities() {
    let dir = tmpdir("lmp-kin");
    // One snapshot every 1000 steps of 0.05 tau.
    let flags = lammps_kinematics(&dir, "xs_ys_ix_iy", 50.0, 1);
    let unwrapped = lammps_kinematics(&dir, "xu_yu", 50.0, 1);
    assert_eq!(flags.len(), 128);
    assert_eq!(flags.len(), unwrapped.len());
    let mut worst = [0.0f64; 5];
    for (a, b) in flags.iter().zip(&unwrapped) {
        assert_eq!(a[0], b[0]);
        for c in 1..5 {
            worst[c] = worst[c].max((a[c] - b[c]).abs());
        }
    }
    // Grains move ~1e-2 per tau here; the dumps keep 10 digits.
    assert!(
        worst[1] < 1e-8 && worst[2] < 1e-8,
        "velocities differ by {worst:?}"
    );
    assert!(
        worst[3] < 1e-6 && worst[4] < 1e-6,
        "strains differ by {worst:?}"
    );

    // The wrapped dump holds snapshots 0 and 8 of the others: compare at lag 8.
    let wrapped = lammps_kinematics(&dir, "x_y", 400.0, 1);
    let unwrapped = lammps_kinematics(&dir, "xu_yu", 50.0, 8);
    let t = pillar_pipe::io::read_tracks(&dir.join("xu_yu.parquet"))
        .unwrap()
        .0;
    let (b0, b8) = (t.meta.box_at(0).unwrap(), t.meta.box_at(8).unwrap());
    let image_velocity = (b8.xy - b0.xy) / 400.0;
    let mut crossed = 0;
    for (w, u) in wrapped.iter().zip(&unwrapped) {
        assert_eq!(w[0], u[0]);
        let n = (u[1] - w[1]) / image_velocity;
        assert!(
            (n - n.round()).abs() < 1e-5 && (u[2] - w[2]).abs() < 1e-9,
            "particle {}: velocities differ by ({}, {}), not a multiple of {image_velocity}",
            w[0],
            u[1] - w[1],
            u[2] - w[2]
        );
        crossed += usize::from(n.round() != 0.0);
        assert!((u[3] - w[3]).abs() < 1e-4 * u[3].max(1e-3), "{u:?} {w:?}");
        assert!((u[4] - w[4]).abs() < 1e-4, "{u:?} {w:?}");
    }
    assert!(crossed >= 3, "{crossed} grains with an image velocity");
}

/// Issue 24: a kinematics output that cannot be written (a file-size limit) leaves no
/// table, no sidecar and no temporary file, exits non-zero, and the message names the
/// output and states the cause once.
#[test]
fn failed_kinematics_write_leaves_no_sidecar_and_states_the_cause_once() {
    let dir = tmpdir("kin-efbig");
    let input = plain_csv(&dir, false);
    for name in ["k.parquet", "k.csv"] {
        let before = common::file_names(&dir);
        let out = dir.join(name);
        let (ok, text) = common::cli_file_limit(
            16,
            &[
                "kinematics",
                input.to_str().unwrap(),
                "--lag",
                "1",
                "-o",
                out.to_str().unwrap(),
            ],
        );
        assert!(!ok, "{name}: {text}");
        assert_eq!(common::file_names(&dir), before, "{name}: {text}");
        assert!(text.contains(out.to_str().unwrap()), "{name}: {text}");
        assert_eq!(
            text.matches("File too large").count(),
            1,
            "{name}: the cause should appear once: {text}"
        );
        assert!(!text.contains("panicked"), "{name}: {text}");
        // The same command without the limit writes both.
        let (ok, text) = run(&[
            "kinematics",
            input.to_str().unwrap(),
            "--lag",
            "1",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
        assert!(out.is_file() && dir.join(format!("{name}.meta.json")).is_file());
    }
}

/// `kinematics --lag 1 --json` on tracks `t` written into `dir`: the report, the table
/// it wrote and its row groups, and the tracks as the command read them.
fn kinematics_lag1(
    dir: &std::path::Path,
    t: &pillar_pipe::tracks::Tracks,
) -> (
    serde_json::Value,
    polars::prelude::DataFrame,
    usize,
    pillar_pipe::tracks::Tracks,
) {
    let tp = dir.join("tracks.parquet");
    write_tracks(t, &tp).unwrap();
    let (report, got, groups) = kinematics_of(&tp, "k.parquet", &[]);
    let (tracks, _) = pillar_pipe::io::read_tracks(&tp).unwrap();
    (report, got, groups, tracks)
}

/// `kinematics TRACKS --lag 1 --json -o DIR/OUT` plus `extra`: the report, the table
/// and its row groups.
fn kinematics_of(
    tracks: &std::path::Path,
    out: &str,
    extra: &[&str],
) -> (serde_json::Value, polars::prelude::DataFrame, usize) {
    use polars::prelude::*;
    let out = tracks.with_file_name(out);
    let mut args = vec![
        "kinematics",
        tracks.to_str().unwrap(),
        "--lag",
        "1",
        "-o",
        out.to_str().unwrap(),
        "--json",
    ];
    args.extend(extra);
    let (ok, text) = run(&args);
    assert!(ok, "{text}");
    let report = serde_json::from_str(&text).unwrap();
    let mut reader = ParquetReader::new(std::fs::File::open(&out).unwrap());
    let groups = reader.get_metadata().unwrap().row_groups.len();
    (report, reader.finish().unwrap(), groups)
}

/// The table's rows are `want`'s frame pairs one after another (starting at frames
/// `starts`), bit for bit.
fn assert_rows_are(
    got: &polars::prelude::DataFrame,
    want: &[pillar_pipe::kinematics::KinematicsColumns],
    starts: &[i64],
) {
    use pillar_pipe::kinematics::F64_COLUMNS;
    let ids: Vec<i64> = got["particle"].i64().unwrap().into_no_null_iter().collect();
    let want_ids: Vec<i64> = want.iter().flat_map(|c| c.particle.clone()).collect();
    assert_eq!(ids, want_ids, "rows in pair order, particles ascending");
    let frames: Vec<i64> = got["frame"].i64().unwrap().into_no_null_iter().collect();
    let want_frames: Vec<i64> = want
        .iter()
        .zip(starts)
        .flat_map(|(c, &f)| std::iter::repeat_n(f, c.len()))
        .collect();
    assert_eq!(frames, want_frames);
    for (k, name) in F64_COLUMNS.iter().enumerate() {
        let v: Vec<u64> = got[*name]
            .f64()
            .unwrap()
            .into_no_null_iter()
            .map(f64::to_bits)
            .collect();
        let w: Vec<u64> = want
            .iter()
            .flat_map(|c| c.f64s[k].iter().map(|x| x.to_bits()))
            .collect();
        assert!(v == w, "column {name} differs from the one-pass results");
    }
    let status: Vec<String> = got["status"]
        .str()
        .unwrap()
        .iter()
        .map(|s| s.unwrap_or("").to_string())
        .collect();
    let want_status: Vec<&str> = want
        .iter()
        .flat_map(|c| c.status.iter().map(|s| s.name()))
        .collect();
    assert_eq!(status, want_status);
}

/// A frame pair of more rows than one block of the command (65,536 rows, one Parquet
/// row group each), with particles missing from either frame and isolated ones (too
/// few neighbours): the table the command writes in blocks, overlapping the writing of
/// one with the computing of the next, is the library's one-pass result bit for bit,
/// in as many row groups as blocks, with the same counts.
#[test]
fn a_pair_larger_than_a_block_is_the_one_pass_result() {
    use pillar_pipe::kinematics::{Convention, KinematicsParams, frame_pair_columns};
    let dir = tmpdir("blocks");
    let p = bidisperse_packing(140_000, 1.0, 0.1, 4);
    let t = two_frame_tracks(&p, Mat2::new(1.0, 0.02, 0.0, 0.99), 0.01, 2);
    let n = p.pos.len();
    let keep: Vec<usize> = (0..t.len())
        .filter(|&r| {
            let (frame, id) = (t.frame[r], t.particle[r]);
            !(frame == 1 && id % 5000 == 1 || frame == 0 && id % 7000 == 2)
        })
        .collect();
    let pick = |v: &[f64]| keep.iter().map(|&r| v[r]).collect::<Vec<f64>>();
    let mut u = t.clone();
    u.frame = keep.iter().map(|&r| t.frame[r]).collect();
    u.particle = keep.iter().map(|&r| t.particle[r]).collect();
    u.x = pick(&t.x);
    u.y = pick(&t.y);
    u.radius = pick(&t.radius);
    u.time = t.time.as_deref().map(pick);
    u.species = t
        .species
        .as_ref()
        .map(|s| keep.iter().map(|&r| s[r]).collect());
    // Three particles far from the rest in frame 0: no neighbours.
    for id in [10, 70_000, n as i64 - 3] {
        let r = (0..u.len())
            .find(|&r| u.frame[r] == 0 && u.particle[r] == id)
            .unwrap();
        u.x[r] += 1e6 * (1.0 + id as f64);
    }
    let (report, got, groups, tracks) = kinematics_lag1(&dir, &u);
    let fr = tracks.frame_ranges();
    let a = tracks.view(fr[0].0, fr[0].1.clone());
    let b = tracks.view(fr[1].0, fr[1].1.clone());
    let params = KinematicsParams {
        rc: 1.25,
        convention: Convention::Paper,
    };
    let (want, counts) = frame_pair_columns(&a, &b, 1.0, &params).unwrap();
    assert!(
        want.len() > 2 * 65_536,
        "{} rows: more than two blocks",
        want.len()
    );
    assert!(counts.invalid_few_neighbors >= 3, "{counts:?}");
    assert!(counts.missing_at_end > 0 && counts.missing_at_start > 0);
    assert_eq!(
        report["counts"],
        serde_json::to_value(counts).unwrap(),
        "counts summed over the blocks"
    );
    assert_eq!(
        groups,
        want.len().div_ceil(65_536),
        "one row group per block"
    );
    assert_rows_are(&got, &[want], &[0]);
}

/// Many frame pairs smaller than a block (a movie): consecutive pairs share a block,
/// computed in parallel, one row group for several pairs; the table is still every
/// pair's one-pass result in pair order, bit for bit, with the same counts.
#[test]
fn small_pairs_share_blocks_and_keep_their_order() {
    use pillar_pipe::kinematics::{Convention, KinematicsParams, PairCounts, frame_pair_columns};
    use pillar_pipe::tracks::Tracks;
    let dir = tmpdir("movie");
    let p = bidisperse_packing(3000, 1.0, 0.1, 6);
    let frames = 40i64;
    let mut t = Tracks {
        meta: two_frame_tracks(&p, Mat2::IDENTITY, 0.0, 0).meta,
        ..Default::default()
    };
    let (mut time, mut species) = (Vec::new(), Vec::new());
    for k in 0..frames {
        let e = 0.002 * k as f64;
        let f = two_frame_tracks(
            &p,
            Mat2::new(1.0 + e, 0.5 * e, 0.0, 1.0 - e),
            0.01,
            k as u64,
        );
        let n = p.pos.len();
        for r in n..2 * n {
            // A few particles missing from some frames, so pairs differ in size.
            if (f.particle[r] + k) % 97 == 0 {
                continue;
            }
            t.frame.push(k);
            t.particle.push(f.particle[r]);
            t.x.push(f.x[r]);
            t.y.push(f.y[r]);
            t.radius.push(f.radius[r]);
            time.push(k as f64);
            species.push(f.species.as_ref().unwrap()[r]);
        }
    }
    t.time = Some(time);
    t.species = Some(species);
    let (report, got, groups, tracks) = kinematics_lag1(&dir, &t);
    let fr = tracks.frame_ranges();
    let params = KinematicsParams {
        rc: 1.25,
        convention: Convention::Paper,
    };
    let mut counts = PairCounts::default();
    let mut want = Vec::new();
    for w in fr.windows(2) {
        let a = tracks.view(w[0].0, w[0].1.clone());
        let b = tracks.view(w[1].0, w[1].1.clone());
        let (cols, c) = frame_pair_columns(&a, &b, 1.0, &params).unwrap();
        counts.add(&c);
        want.push(cols);
    }
    assert_eq!(report["counts"], serde_json::to_value(counts).unwrap());
    assert!(groups < 4, "39 pairs of ~3000 rows in {groups} row groups");
    let starts: Vec<i64> = fr[..fr.len() - 1].iter().map(|(f, _)| *f).collect();
    assert_rows_are(&got, &want, &starts);
}

/// `--columns` writes the keys and the columns asked for, in the table's order, with
/// the full table's numbers bit for bit, both where frame pairs share a block (a movie)
/// and where one pair spans several blocks; the sidecar names the columns. An unknown
/// name is refused before anything is written, naming the choices; a later stage that
/// needs a column the table lacks names it.
#[test]
fn columns_option_writes_the_same_numbers_in_fewer_columns() {
    let dir = tmpdir("select");
    let cases = [
        (
            bidisperse_packing(3000, 1.0, 0.1, 6),
            6,
            "d2min,status,eta_s",
        ),
        (bidisperse_packing(70_000, 1.0, 0.1, 7), 2, "d2min"),
    ];
    for (k, (p, frames, cols)) in cases.into_iter().enumerate() {
        let mut t = two_frame_tracks(&p, Mat2::IDENTITY, 0.0, 0);
        t.frame.clear();
        t.particle.clear();
        t.x.clear();
        t.y.clear();
        t.radius.clear();
        t.time = None;
        t.species = None;
        for f in 0..frames {
            let e = 0.003 * f as f64;
            let m = two_frame_tracks(&p, Mat2::new(1.0 + e, e, 0.0, 1.0 - e), 0.01, f as u64);
            let n = p.pos.len();
            t.frame.extend(std::iter::repeat_n(f as i64, n));
            t.particle.extend(&m.particle[n..]);
            t.x.extend(&m.x[n..]);
            t.y.extend(&m.y[n..]);
            t.radius.extend(&m.radius[n..]);
        }
        if k == 1 {
            // Rows in no spatial order: the pair's fits are computed in cell order.
            t = pillar_pipe::synth::relabelled(&t);
        }
        let tp = dir.join(format!("tracks{k}.parquet"));
        write_tracks(&t, &tp).unwrap();
        let (_, full, _) = kinematics_of(&tp, &format!("full{k}.parquet"), &[]);
        let part_name = format!("part{k}.parquet");
        let (report, part, groups) = kinematics_of(&tp, &part_name, &["--columns", cols]);
        let asked: Vec<&str> = cols.split(',').collect();
        let want: Vec<&str> = full
            .get_column_names()
            .into_iter()
            .map(|c| c.as_str())
            .filter(|c| ["frame", "frame_end", "particle"].contains(c) || asked.contains(c))
            .collect();
        let got: Vec<&str> = part
            .get_column_names()
            .into_iter()
            .map(|c| c.as_str())
            .collect();
        assert_eq!(
            got, want,
            "the keys and the columns asked for, in the table's order"
        );
        assert_eq!(report["columns"], serde_json::json!(want));
        assert_eq!(part.height(), full.height());
        if k == 1 {
            assert!(groups >= 2, "a pair over several blocks");
        }
        for c in &want {
            assert!(
                part[*c].equals_missing(&full[*c]),
                "column {c} differs from the full table's"
            );
            if let Ok(v) = part[*c].f64() {
                let bits = |s: &polars::prelude::Float64Chunked| {
                    s.iter().map(|x| x.map(f64::to_bits)).collect::<Vec<_>>()
                };
                assert_eq!(bits(v), bits(full[*c].f64().unwrap()), "{c} bit for bit");
            }
        }
        let side = std::fs::read_to_string(dir.join(format!("{part_name}.meta.json"))).unwrap();
        let side: serde_json::Value = serde_json::from_str(&side).unwrap();
        assert_eq!(side["columns"], serde_json::json!(want));
        assert_eq!(
            side["provenance"]["parameters"]["columns"],
            serde_json::json!(want)
        );
        let side = std::fs::read_to_string(dir.join(format!("full{k}.parquet.meta.json"))).unwrap();
        assert!(
            !side.contains("\"columns\""),
            "a full table's sidecar is as before"
        );
    }
    // Refused before anything is written.
    let out = dir.join("bad.parquet");
    let (ok, text) = run(&[
        "kinematics",
        dir.join("tracks0.parquet").to_str().unwrap(),
        "--lag",
        "1",
        "--columns",
        "d2min,D2min",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        text.contains("columns") && text.contains("'D2min'") && text.contains("eta_s"),
        "{text}"
    );
    assert!(!text.contains("panicked"), "{text}");
    assert!(!out.exists());
    // The fit needs eta_s, which a d2min-only table lacks.
    let (ok, text) = run(&[
        "fit",
        dir.join("part1.parquet").to_str().unwrap(),
        "-o",
        dir.join("fit.json").to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        text.contains("eta_s") && text.contains("part1.parquet"),
        "{text}"
    );
    assert!(!text.contains("panicked"), "{text}");
}
