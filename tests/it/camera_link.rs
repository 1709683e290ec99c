//! `pillar-pipe link` from the user's side: features in, trackpy's linked table out,
//! which `ingest` reads; bad input named by file and column.

use crate::common::{cli, tmpdir};
use pillar_pipe::io::read_tracks;
use std::path::{Path, PathBuf};

fn bundled_tracks() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/sample/tracks.csv")
}

/// The columns of a CSV file: header names and rows of fields.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn column(header: &[String], rows: &[Vec<String>], name: &str) -> Vec<String> {
    let i = header.iter().position(|h| h == name).unwrap();
    rows.iter().map(|r| r[i].clone()).collect()
}

/// Grains on a lattice 18 px apart, the whole packing squeezed towards its middle at a
/// rate that reaches 7 px per frame at the edges (more than a third of the spacing), in
/// pandas' `to_csv` layout (an unnamed index column first), no particle column. Linked
/// with prediction, every grain keeps its id; ingest reads the result.
#[test]
fn link_writes_particles_that_ingest_reads() {
    let dir = tmpdir("link-cli");
    let feats = dir.join("features.csv");
    let mut text = String::from(",y,x,mass,size,ecc,signal,raw_mass,ep,frame\n");
    let (nx, ny, frames) = (12usize, 10usize, 6usize);
    let mut truth = Vec::new();
    let mut row = 0;
    for t in 0..frames {
        // Strain rate growing frame by frame (compression in x, expansion in y).
        let sx = 1.0 - 0.008 * (t * t) as f64;
        let sy = 1.0 + 0.002 * (t * t) as f64;
        for i in 0..nx * ny {
            let (cx, cy) = (18.0 * (i % nx) as f64 - 99.0, 18.0 * (i / nx) as f64 - 81.0);
            let size = if i % 3 == 0 { 5.2 } else { 3.9 };
            let (x, y) = (400.0 + cx * sx, 300.0 + cy * sy);
            text += &format!("{row},{y},{x},2000.0,{size},0.05,40.0,9000.0,0.003,{t}\n");
            truth.push(i.to_string());
            row += 1;
        }
    }
    std::fs::write(&feats, text).unwrap();
    let out = dir.join("linked.csv");
    let (ok, text) = cli(&[
        "link",
        feats.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--search-range",
        "5",
        "--json",
    ]);
    assert!(ok, "{text}");
    let json: serde_json::Value = serde_json::from_str(&text[..text.rfind('}').unwrap() + 1])
        .unwrap_or_else(|e| panic!("{e}: {text}"));
    let r = &json["report"];
    assert_eq!(r["trajectories"], nx * ny, "{text}");
    assert_eq!(r["links"], nx * ny * (frames - 1));
    assert_eq!(r["subnets_greedy"], 0);
    assert!(
        text.contains("subnets       "),
        "the report on stderr: {text}"
    );
    let (header, rows) = read_csv(&out);
    assert_eq!(
        header.join(","),
        "y,x,mass,size,ecc,signal,raw_mass,ep,frame,particle"
    );
    assert_eq!(column(&header, &rows, "particle"), truth);
    assert!(out.with_extension("csv.meta.json").exists());

    // Without prediction the edges are lost (7 px > 5 px), so the test means something.
    let (ok, text) = cli(&[
        "link",
        feats.to_str().unwrap(),
        "-o",
        dir.join("np.csv").to_str().unwrap(),
        "--search-range",
        "5",
        "--no-predict",
    ]);
    assert!(ok, "{text}");
    let (h, rows) = read_csv(&dir.join("np.csv"));
    assert_ne!(column(&h, &rows, "particle"), truth);

    let tracks = dir.join("tracks.parquet");
    let (ok, text) = cli(&[
        "ingest",
        out.to_str().unwrap(),
        "--px-per-unit",
        "10",
        "--unit",
        "mm",
        "-o",
        tracks.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{text}");
    let (t, _) = read_tracks(&tracks).unwrap();
    assert_eq!(t.frame.len(), nx * ny * frames, "{text}");
    let mut ids = t.particle.clone();
    ids.sort();
    ids.dedup();
    assert_eq!(ids.len(), nx * ny);
}

/// The bundled sample (trackpy output) with its particle column dropped, linked as
/// trackpy links it (search range 8 px, memory 3, no prediction): the same particle
/// column, row for row, and ingest makes the same tracks of it.
#[test]
fn relinking_the_bundled_sample_gives_trackpys_particles() {
    let dir = tmpdir("link-sample");
    let (header, rows) = read_csv(&bundled_tracks());
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| header[i] != "particle")
        .collect();
    let mut text = keep
        .iter()
        .map(|&i| header[i].as_str())
        .collect::<Vec<_>>()
        .join(",");
    text.push('\n');
    for r in &rows {
        text += &keep
            .iter()
            .map(|&i| r[i].as_str())
            .collect::<Vec<_>>()
            .join(",");
        text.push('\n');
    }
    let feats = dir.join("features.csv");
    std::fs::write(&feats, text).unwrap();
    let out = dir.join("relinked.csv");
    let (ok, text) = cli(&[
        "link",
        feats.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--search-range",
        "8",
        "--memory",
        "3",
        "--no-predict",
    ]);
    assert!(ok, "{text}");
    let (h2, rows2) = read_csv(&out);
    assert_eq!(
        column(&h2, &rows2, "particle"),
        column(&header, &rows, "particle")
    );
    let ingest = |input: &Path, output: &Path| {
        let (ok, text) = cli(&[
            "ingest",
            input.to_str().unwrap(),
            "--px-per-unit",
            "31.496063",
            "--unit",
            "cm",
            "--origin-px",
            "165.980,850",
            "-o",
            output.to_str().unwrap(),
        ]);
        assert!(ok, "{text}");
        read_tracks(output).unwrap().0
    };
    let a = ingest(&bundled_tracks(), &dir.join("a.parquet"));
    let b = ingest(&out, &dir.join("b.parquet"));
    assert_eq!(
        (&a.frame, &a.particle, &a.x, &a.y, &a.radius),
        (&b.frame, &b.particle, &b.x, &b.y, &b.radius)
    );
}

#[test]
fn bad_input_is_named_by_file_and_column() {
    let dir = tmpdir("link-bad");
    let feats = dir.join("nox.csv");
    std::fs::write(&feats, "y,mass,frame\n1.0,2.0,0\n1.5,2.0,1\n").unwrap();
    let out = dir.join("out.csv");
    let (ok, text) = cli(&[
        "link",
        feats.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--search-range",
        "5",
    ]);
    assert!(!ok);
    assert!(
        text.contains("nox.csv") && text.contains("missing required column(s) [\"x\"]"),
        "{text}"
    );
    assert!(!out.exists());
    let feats = dir.join("badx.csv");
    std::fs::write(&feats, "y,x,frame\n1.0,2.0,0\n1.5,oops,1\n").unwrap();
    let (ok, text) = cli(&[
        "link",
        feats.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--search-range",
        "5",
    ]);
    assert!(!ok);
    assert!(text.contains("badx.csv: line 3, column 'x'"), "{text}");
    let (ok, text) = cli(&[
        "link",
        dir.join("nox.csv").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--search-range",
        "0",
    ]);
    assert!(!ok && text.contains("search_range"), "{text}");
    assert!(!out.exists());
}
