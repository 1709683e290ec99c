//! `pillar-pipe render`, the camera emulator, driven as a user does: frames, ground
//! truth and camera.json from small tracks tables, a pillar run's bars, and the errors.

use crate::common::{BIN, cli, file_names, tmpdir};
use pillar_pipe::camera::{Frame, read_frame};
use serde_json::Value;
use std::path::Path;

/// A canonical tracks CSV: `grains` grains on a loose grid (well apart, so each can
/// be measured alone), drifting by a known step per frame, two radii, a time column.
fn grid_tracks(
    path: &Path,
    frames: usize,
    grains: usize,
    dt: f64,
) -> Vec<(i64, i64, f64, f64, f64)> {
    let mut rows = Vec::new();
    let mut s = String::from("frame,particle,x,y,radius,time,species\n");
    for f in 0..frames {
        for p in 0..grains {
            let (i, j) = ((p % 5) as f64, (p / 5) as f64);
            // Sub-pixel offsets that differ grain to grain and frame to frame.
            let x = 1.0 + 1.7 * i + 0.013 * f as f64 + 0.0071 * p as f64;
            let y = 2.0 + 1.9 * j - 0.021 * f as f64 + 0.0043 * p as f64;
            let (r, sp) = if p % 2 == 0 { (0.3, 1) } else { (0.22, 0) };
            s += &format!("{f},{},{x},{y},{r},{},{sp}\n", p + 10, f as f64 * dt);
            rows.push((f as i64, p as i64 + 10, x, y, r));
        }
    }
    std::fs::write(path, s).unwrap();
    rows
}

fn camera_json(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("camera.json")).unwrap()).unwrap()
}

fn ground_truth(dir: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(dir.join("ground_truth.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "frame,particle,species,x_px,y_px,radius_px,x,y,radius"
    );
    lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn num(s: &str) -> f64 {
    s.parse().unwrap()
}

#[test]
fn camera_render_writes_frames_ground_truth_and_camera_json() {
    let d = tmpdir("render-grid");
    let input = d.join("grid.csv");
    let rows = grid_tracks(&input, 5, 20, 0.5);
    let out = d.join("frames");
    let (ok, text) = cli(&[
        "render",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--px-per-unit",
        "20",
        "--every",
        "2",
        "--quiet",
    ]);
    assert!(ok, "{text}");
    // Frames 0, 2, 4 of the tracks → three images, one size, 8 bit.
    assert_eq!(
        file_names(&out),
        [
            "camera.json",
            "frame_00000.png",
            "frame_00001.png",
            "frame_00002.png",
            "ground_truth.csv"
        ]
    );
    let cam = camera_json(&out);
    let (w, h) = (
        cam["camera"]["width"].as_u64().unwrap() as usize,
        cam["camera"]["height"].as_u64().unwrap() as usize,
    );
    for k in 0..3 {
        let f = read_frame(&out.join(format!("frame_{k:05}.png"))).unwrap();
        assert_eq!((f.width, f.height, f.bit_depth), (w, h, 8));
    }
    assert_eq!(cam["frames"], 3);
    assert_eq!(cam["source_frames"], serde_json::json!([0, 2, 4]));
    assert_eq!(
        cam["frame_interval"].as_f64().unwrap(),
        1.0,
        "2 frames × 0.5"
    );
    assert_eq!(cam["input_format"], "canonical");
    assert_eq!(
        cam["input_sha256"].as_str().unwrap(),
        pillar_pipe::io::sha256_file(&input).unwrap()
    );
    assert_eq!(cam["seed"], 1);
    assert_eq!(cam["tool"], "pillar-pipe");
    // The ground truth is the tracks through the recorded mapping.
    let map = &cam["pixel_map"];
    let (s, x0, y0) = (
        map["px_per_unit"].as_f64().unwrap(),
        map["x0"].as_f64().unwrap(),
        map["y0"].as_f64().unwrap(),
    );
    assert_eq!(s, 20.0);
    let gt = ground_truth(&out);
    assert_eq!(gt.len(), 3 * 20);
    let margin = cam["margin_px"].as_f64().unwrap();
    for g in &gt {
        let (img, particle) = (num(&g[0]) as i64, num(&g[1]) as i64);
        let src = rows
            .iter()
            .find(|r| r.0 == 2 * img && r.1 == particle)
            .unwrap_or_else(|| panic!("no track row for {g:?}"));
        let (x, y, r) = (num(&g[6]), num(&g[7]), num(&g[8]));
        assert_eq!((x, y, r), (src.2, src.3, src.4), "{g:?}");
        let (xp, yp, rp) = (num(&g[3]), num(&g[4]), num(&g[5]));
        assert!(
            (xp - (x - x0) * s).abs() < 1e-9 && (yp - (y0 - y) * s).abs() < 1e-9,
            "{g:?}"
        );
        assert!((rp - r * s).abs() < 1e-9);
        assert_eq!(g[2], if particle % 2 == 0 { "1" } else { "0" });
        // Within the frame, the margin clear of every edge.
        assert!(xp - rp >= margin - 0.5 - 1e-9 && xp + rp <= w as f64 - 0.5 - margin + 1e-9);
        assert!(yp - rp >= margin - 0.5 - 1e-9 && yp + rp <= h as f64 - 0.5 - margin + 1e-9);
    }
    // y up in the tracks, rows down in the image.
    let first = |p: i64| {
        gt.iter()
            .find(|g| num(&g[0]) == 0.0 && num(&g[1]) as i64 == p)
            .unwrap()
            .clone()
    };
    assert!(
        num(&first(10)[4]) > num(&first(25)[4]),
        "grain 25 is higher up"
    );
}

/// The intensity-weighted centroid of the frame above `bg` within `half` px of (x, y).
fn centroid(f: &Frame, bg: f64, x: f64, y: f64, half: f64) -> (f64, f64) {
    let (mut m, mut mx, mut my) = (0.0, 0.0, 0.0);
    let (c0, c1) = ((x - half).floor() as usize, (x + half).ceil() as usize);
    let (r0, r1) = ((y - half).floor() as usize, (y + half).ceil() as usize);
    for row in r0..=r1.min(f.height - 1) {
        for col in c0..=c1.min(f.width - 1) {
            let v = f.at(row, col) as f64 - bg;
            m += v;
            mx += v * col as f64;
            my += v * row as f64;
        }
    }
    (mx / m, my / m)
}

#[test]
fn camera_render_grains_sit_where_the_ground_truth_says() {
    // Noise off, 16 bit: every grain's centroid in the frame is its ground-truth centre.
    let d = tmpdir("render-centroids");
    let input = d.join("grid.csv");
    grid_tracks(&input, 2, 20, 1.0);
    let out = d.join("frames");
    let (ok, text) = cli(&[
        "render",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--px-per-unit",
        "20",
        "--bit-depth",
        "16",
        "--photons",
        "0",
        "--read-noise",
        "0",
        "--spread",
        "0.1",
        "--format",
        "tiff",
        "--quiet",
    ]);
    assert!(ok, "{text}");
    let bg = (0.05f64 * 65535.0).round();
    let mut worst: f64 = 0.0;
    for g in ground_truth(&out) {
        let f = read_frame(&out.join(format!("frame_{:05}.tif", num(&g[0]) as usize))).unwrap();
        assert_eq!(f.bit_depth, 16);
        let (x, y, r) = (num(&g[3]), num(&g[4]), num(&g[5]));
        // Grains are 34 px apart: a window of r + 8 px holds one grain and its edge.
        let (cx, cy) = centroid(&f, bg, x, y, r + 8.0);
        worst = worst.max((cx - x).abs()).max((cy - y).abs());
    }
    assert!(worst < 0.01, "worst centroid error {worst} px");
}

#[test]
fn camera_render_same_on_one_and_two_threads_and_seeded() {
    let d = tmpdir("render-threads");
    let input = d.join("grid.csv");
    grid_tracks(&input, 4, 20, 1.0);
    let render = |name: &str, threads: &str, seed: &str| {
        let out = d.join(name);
        let o = std::process::Command::new(BIN)
            .env("RAYON_NUM_THREADS", threads)
            .args([
                "render",
                input.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .args(["--px-per-unit", "15", "--seed", seed, "--quiet"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (0..4)
            .map(|k| std::fs::read(out.join(format!("frame_{k:05}.png"))).unwrap())
            .collect::<Vec<_>>()
    };
    let one = render("one", "1", "3");
    assert_eq!(one, render("two", "2", "3"));
    let other = render("other", "2", "4");
    assert!(
        one.iter().zip(&other).all(|(a, b)| a != b),
        "another seed, other noise"
    );
}

#[test]
fn camera_render_draws_a_pillar_runs_bars() {
    let d = tmpdir("render-pillar");
    let run = d.join("run");
    let (ok, text) = cli(&[
        "simulate",
        "pillar",
        "--n",
        "60",
        "--preset",
        "fast",
        "--strain",
        "0.02",
        "--quiet",
        "-o",
        run.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let out = d.join("frames");
    let (ok, text) = cli(&[
        "render",
        run.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--px-per-unit",
        "31.496",
        "--quiet",
    ]);
    assert!(ok, "{text}");
    let cam = camera_json(&out);
    let bars = &cam["bars"];
    assert!(bars.is_object(), "{cam}");
    assert_eq!(cam["length_unit"], "cm");
    assert!(cam["frame_interval"].as_f64().unwrap() > 0.0);
    let n = cam["frames"].as_u64().unwrap() as usize;
    assert!(n >= 2);
    assert_eq!(
        file_names(&out)
            .iter()
            .filter(|n| n.starts_with("frame_"))
            .count(),
        n
    );
    // The top bar's face sits on the top grains: the brightness just above the highest
    // grain is the bar's, far above the background.
    let gt = ground_truth(&out);
    let top = gt
        .iter()
        .filter(|g| g[0] == "0")
        .map(|g| num(&g[4]) - num(&g[5]))
        .fold(f64::INFINITY, f64::min);
    let f = read_frame(&out.join("frame_00000.png")).unwrap();
    let row = (top - 8.0).round() as usize;
    let mid = f.width / 2;
    let bar_level = (0.25 + 0.05) * 255.0;
    let seen: f64 = (mid - 5..mid + 5).map(|c| f.at(row, c) as f64).sum::<f64>() / 10.0;
    assert!(
        (seen - bar_level).abs() < 10.0,
        "row {row}: {seen} vs {bar_level}"
    );
    // Without bars that row is background.
    let out2 = d.join("nobars");
    let (ok, text) = cli(&[
        "render",
        run.to_str().unwrap(),
        "-o",
        out2.to_str().unwrap(),
        "--px-per-unit",
        "31.496",
        "--no-bars",
        "--quiet",
    ]);
    assert!(ok, "{text}");
    assert!(camera_json(&out2)["bars"].is_null());
}

#[test]
fn camera_render_refuses_bad_input_naming_the_flag_or_file() {
    let d = tmpdir("render-bad");
    let input = d.join("grid.csv");
    grid_tracks(&input, 2, 5, 1.0);
    let out = d.join("frames");
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    for p in ["0", "-3", "nan"] {
        let flag = format!("--px-per-unit={p}");
        let (ok, text) = cli(&["render", i, "-o", o, &flag]);
        assert!(!ok && text.contains("px-per-unit"), "{p}: {text}");
    }
    for (flag, v) in [
        ("--bit-depth", "12"),
        ("--blur", "-1"),
        ("--read-noise", "-2"),
        ("--every", "0"),
    ] {
        let arg = format!("{flag}={v}");
        let (ok, text) = cli(&["render", i, "-o", o, "--px-per-unit", "10", &arg]);
        assert!(!ok && text.contains(&flag[2..]), "{flag} {v}: {text}");
    }
    assert!(!out.exists(), "a refused render writes nothing");
    // A tracks table without radius: the file and the column are named.
    let bare = d.join("bare.csv");
    std::fs::write(&bare, "frame,particle,x,y\n0,1,0,0\n0,2,1,0\n").unwrap();
    let (ok, text) = cli(&[
        "render",
        bare.to_str().unwrap(),
        "-o",
        o,
        "--px-per-unit",
        "10",
    ]);
    assert!(
        !ok && text.contains("bare.csv") && text.contains("radius"),
        "{text}"
    );
    // A LAMMPS dump without radius asks for --radii.
    let dump = d.join("noradius.dump");
    std::fs::write(
        &dump,
        "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n0 10\n0 10\n-0.5 0.5\nITEM: ATOMS id x y\n1 1 1\n2 3 3\n",
    )
    .unwrap();
    let (ok, text) = cli(&[
        "render",
        dump.to_str().unwrap(),
        "-o",
        o,
        "--px-per-unit",
        "10",
    ]);
    assert!(
        !ok && text.contains("noradius.dump") && text.contains("--radii"),
        "{text}"
    );
    let missing = d.join("missing.csv");
    let (ok, text) = cli(&[
        "render",
        missing.to_str().unwrap(),
        "-o",
        o,
        "--px-per-unit",
        "10",
    ]);
    assert!(!ok && text.contains("missing.csv"), "{text}");
    // An earlier render is kept unless --overwrite, which removes its stale frames.
    let (ok, text) = cli(&["render", i, "-o", o, "--px-per-unit", "10", "--quiet"]);
    assert!(ok, "{text}");
    assert_eq!(file_names(&out).len(), 4);
    let (ok, text) = cli(&["render", i, "-o", o, "--px-per-unit", "10", "--every", "2"]);
    assert!(!ok && text.contains("--overwrite"), "{text}");
    let (ok, text) = cli(&[
        "render",
        i,
        "-o",
        o,
        "--px-per-unit",
        "10",
        "--every",
        "2",
        "--overwrite",
        "--quiet",
    ]);
    assert!(ok, "{text}");
    assert_eq!(
        file_names(&out),
        ["camera.json", "frame_00000.png", "ground_truth.csv"]
    );
}
