//! The camera stage kinds in a pipeline: a few dozen grains (ingest) → render → track →
//! kinematics runs; the track stage's canonical tracks are the rendered ones again, in
//! the length unit (a noise-free render, so the only error is the locator's); a second
//! run is all cached; bad locate/link keys and wrong references are refused, naming the
//! stage and key, before anything runs; a folder of frames (`frames`) tracks like the
//! render stage it came from.

use crate::common::*;
use pillar_pipe::io::read_tracks;
use std::collections::BTreeMap;
use std::path::Path;

/// Rendered at 20 px per unit: large grains (r = 0.5) 20 px across, small 15 px.
const SCALE: f64 = 20.0;

/// A 6 × 6 checkerboard of large and small grains, 1.15 apart (no two touching),
/// sheared a little more each of 5 frames (≤ 2.3 px per frame).
fn write_grains(path: &Path) {
    let mut s = String::from("frame,particle,x,y,radius,species\n");
    for f in 0..5 {
        for i in 0..6 {
            for j in 0..6 {
                let id = i * 6 + j;
                let large = (i + j) % 2 == 0;
                let (x0, y0) = (1.15 * j as f64, 1.15 * i as f64);
                let x = x0 + 0.02 * f as f64 * y0;
                let y = y0 * (1.0 - 0.004 * f as f64);
                let (r, sp) = if large { (0.5, 1) } else { (0.375, 0) };
                s += &format!("{f},{id},{x},{y},{r},{sp}\n");
            }
        }
    }
    std::fs::write(path, s).unwrap();
}

fn pipeline(dir: &Path, track: &str) -> String {
    format!(
        r#"[pipeline]
root = '{root}'

[grains.ingest]
input = "grains.csv"
unit = "cm"
frame_time = 0.1

[grains.render]
input = "ingest"
px_per_unit = {SCALE}
profile = "dome"
photons = 0
read_noise = 0

[grains.track]
{track}

[grains.kinematics]
input = "track"
lags = [1]
"#,
        root = dir.display()
    )
}

/// `bench track`'s settings; the percentile low, as the frames are mostly background
/// (at 64, the default, the dimmest large grain's peak is under it).
const TRACK: &str = "input = \"render\"\ndiameter = 19\nminmass = 1000\nseparation = 9\nnoise_size = 2\npercentile = 10\nsearch_range = 8";

fn stage_dir(runs: &Path, m: &serde_json::Value, name: &str) -> std::path::PathBuf {
    let st = m["stages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == name)
        .unwrap_or_else(|| panic!("no stage {name}: {m}"));
    runs.join(st["dir"].as_str().unwrap())
}

#[test]
fn render_track_kinematics_recovers_the_grains_and_caches() {
    let d = tmpdir("camera-pipe");
    let runs = d.join("runs");
    write_grains(&d.join("grains.csv"));
    let file = d.join("camera.toml");
    std::fs::write(&file, pipeline(&d, TRACK)).unwrap();
    let f = file.to_str().unwrap();
    run_ok(&["run", f, "--quiet"], &runs);
    let m = latest(&runs);
    assert_eq!(m["status"], "ok", "{m}");
    assert_eq!(computed(&m).len(), 4, "{m}");
    let t = &m["metrics"]["grains.track"];
    assert_eq!(t["features"], 36 * 5, "{t}");
    assert_eq!(t["trajectories"], 36, "{t}");
    assert_eq!(t["frames"], 5, "{t}");
    assert!(m["metrics"]["grains.kinematics"]["rows"].as_u64().unwrap() > 0);

    // The canonical tracks against the render's ground truth, in the length unit.
    let frames = stage_dir(&runs, &m, "grains.render").join("frames");
    let track = stage_dir(&runs, &m, "grains.track");
    assert!(track.join("linked.csv").is_file());
    let (tracks, _) = read_tracks(&track.join("tracks.parquet")).unwrap();
    assert_eq!(tracks.meta.length_unit, "cm");
    assert_eq!(tracks.meta.frame_time, Some(0.1));
    let gt = std::fs::read_to_string(frames.join("ground_truth.csv")).unwrap();
    let mut truth: BTreeMap<i64, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for line in gt.lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        let v = |i: usize| c[i].parse::<f64>().unwrap();
        truth
            .entry(c[0].parse().unwrap())
            .or_default()
            .push((v(6), v(7), v(8)));
    }
    let ranges = tracks.frame_ranges();
    assert_eq!(ranges.len(), truth.len());
    // A noise-free render: the locator's error is a small fraction of a pixel.
    let tol = 0.5 / SCALE;
    let mut worst: f64 = 0.0;
    for ((frame, r), (tf, g)) in ranges.iter().zip(&truth) {
        assert_eq!(frame, tf);
        assert_eq!(r.len(), g.len(), "frame {frame}: grains");
        for &(x, y, radius) in g {
            let (k, dist) = r
                .clone()
                .map(|i| (i, (tracks.x[i] - x).hypot(tracks.y[i] - y)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            worst = worst.max(dist);
            assert!(
                dist < tol,
                "frame {frame}: ({x}, {y}) tracked {dist} cm away"
            );
            assert!((tracks.radius[k] - radius).abs() < 1e-9, "radius");
        }
    }
    eprintln!(
        "largest position error {worst:.2e} cm ({:.3} px)",
        worst * SCALE
    );

    // Unchanged: everything from the cache.
    let out = run_ok(&["run", f], &runs);
    assert!(out.contains("0 computed, 4 cached"), "{out}");

    // The same frames as a folder (real camera data): the same grains, by the
    // render's camera.json in it.
    let movie = d.join("movie");
    std::fs::create_dir_all(&movie).unwrap();
    for e in std::fs::read_dir(&frames).unwrap().flatten() {
        std::fs::copy(e.path(), movie.join(e.file_name())).unwrap();
    }
    let folder = |keys: &str| {
        format!(
            "[pipeline]\nroot = '{}'\n\n[movie.track]\nframes = \"movie\"\n{}\n{keys}\n",
            d.display(),
            TRACK.replace("input = \"render\"\n", "")
        )
    };
    let same_grains = |keys: &str| {
        let file = d.join("movie.toml");
        std::fs::write(&file, folder(keys)).unwrap();
        run_ok(&["run", file.to_str().unwrap(), "--quiet"], &runs);
        let m = latest(&runs);
        let dir = stage_dir(&runs, &m, "movie.track");
        let (t, _) = read_tracks(&dir.join("tracks.parquet")).unwrap();
        assert_eq!(t.len(), tracks.len());
        for i in 0..t.len() {
            assert_eq!(t.frame[i], tracks.frame[i]);
            assert!((t.x[i] - tracks.x[i]).abs() < 1e-9, "row {i}");
            assert!((t.y[i] - tracks.y[i]).abs() < 1e-9, "row {i}");
            assert!((t.radius[i] - tracks.radius[i]).abs() < 1e-9, "row {i}");
        }
        assert_eq!(t.meta.length_unit, "cm");
        m
    };
    let m = same_grains("");
    assert_eq!(computed(&m), ["movie.track"]);
    assert_eq!(
        m["inputs"]["movie.track.frames"]["sha256"]
            .as_str()
            .unwrap()
            .len(),
        64
    );

    // Without camera.json the keys give the mapping; without them, refused.
    let cam: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(movie.join("camera.json")).unwrap()).unwrap();
    let (x0, y0) = (
        cam["pixel_map"]["x0"].as_f64().unwrap(),
        cam["pixel_map"]["y0"].as_f64().unwrap(),
    );
    std::fs::remove_file(movie.join("camera.json")).unwrap();
    std::fs::remove_file(movie.join("ground_truth.csv")).unwrap();
    refused(
        &d.join("movie.toml"),
        &runs,
        &folder(""),
        &["movie.track.px_per_unit", "camera.json"],
    );
    let keys = format!(
        "px_per_unit = {SCALE}\nunit = \"cm\"\norigin_px = [{}, {}]\nframe_time = 0.1\nradii = [0.375, 0.5]",
        -x0 * SCALE,
        y0 * SCALE
    );
    same_grains(&keys);
}

#[test]
fn bad_camera_keys_are_refused_before_anything_runs() {
    let d = tmpdir("camera-bad");
    let runs = d.join("runs");
    write_grains(&d.join("grains.csv"));
    let file = d.join("bad.toml");
    let even = TRACK.replace("diameter = 19", "diameter = 18");
    refused(
        &file,
        &runs,
        &pipeline(&d, &even),
        &["grains.track.diameter", "18", "odd"],
    );
    let no_range = TRACK.replace("search_range = 8", "");
    refused(
        &file,
        &runs,
        &pipeline(&d, &no_range),
        &["grains.track", "search_range"],
    );
    let noise = TRACK.replace("noise_size = 2", "noise_size = 30");
    refused(
        &file,
        &runs,
        &pipeline(&d, &noise),
        &["grains.track.noise_size"],
    );
    // A track stage reads frames, not tracks.
    let wrong = TRACK.replace("input = \"render\"", "input = \"ingest\"");
    refused(
        &file,
        &runs,
        &pipeline(&d, &wrong),
        &["grains.track.input", "frames"],
    );
    let text = pipeline(&d, TRACK).replace("px_per_unit = 20", "px_per_unit = 0");
    refused(&file, &runs, &text, &["grains.render.px_per_unit"]);
    assert!(!runs.join("cache").exists(), "nothing ran");
}

/// The bundled camera check runs end to end: the simulation's own tracks and the
/// tracks from its frames are both fitted, compared and reported. (On the `fast`
/// preset here: the file's `paper` run takes 40 s and tests the same wiring.)
#[test]
fn bundled_camera_check_runs() {
    let d = tmpdir("camera-check");
    let runs = d.join("runs");
    let file = bundled("camera-check");
    run_ok(
        &[
            "run",
            &file,
            "--set",
            "fit.bootstrap=20",
            "--set",
            "simulate.preset=fast",
            "--quiet",
        ],
        &runs,
    );
    let m = latest(&runs);
    assert_eq!(computed(&m).len(), 9, "{m}");
    let t = &m["metrics"]["camera.track"];
    assert_eq!(t["n"], m["metrics"]["truth.simulate"]["n"], "{t}");
    assert_eq!(t["frames"], m["metrics"]["truth.simulate"]["frames"], "{t}");
    for st in ["truth.fit", "camera.fit"] {
        assert!(m["metrics"][st]["theta"].is_f64(), "{st}: {m}");
    }
    assert!(m["metrics"]["compare"]["theta_agree"].is_boolean(), "{m}");
    let html =
        std::fs::read_to_string(runs.join(m["run_id"].as_str().unwrap()).join("report.html"))
            .unwrap();
    assert!(html.contains("truth") && html.contains("camera"));
}
