//! The kinematics and fit stages from the user's side (CLI), on generated tracks with a
//! known answer.

mod common;

use common::{cli as run, tmpdir};
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
        // columns: n_neighbors 7, valid 8, d2min 19
        if x[8] == "true" && x[7] == y[7] {
            let n: f64 = x[7].parse().unwrap();
            let (dp, dov): (f64, f64) = (x[19].parse().unwrap(), y[19].parse().unwrap());
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
        assert!((v[9] - 0.98).abs() < 1e-10 && (v[10] - 0.03).abs() < 1e-10);
        assert!((v[17] - want.eta_s).abs() < 1e-10);
        assert!(v[19].abs() < 1e-20);
    }
}
