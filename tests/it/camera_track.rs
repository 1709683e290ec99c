//! The experimental chain on emulated frames, driven as a user drives it: `render`
//! draws a known packing, `locate` / `track` find it again, `ingest` reads the result;
//! then what `locate` and `track` write, and what they refuse.

use crate::common::{BIN, cli, file_names, tmpdir};
use pillar_pipe::camera::score::{Truth, score};
use pillar_pipe::camera::{Feature, Frame, read_frame, write_frame};
use pillar_pipe::io::{read_tracks, sha256_file};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Pixels per length unit of the renders.
const PX: f64 = 20.0;
const NX: usize = 10;
const NY: usize = 6;
const GRAINS: usize = NX * NY;
const FRAMES: usize = 6;
/// Lattice spacing, length units: 34 px, loose enough that every grain (20 or 15 px
/// across) is located on its own.
const SPACING: f64 = 1.7;

/// trackpy's feature columns in its order, as `locate` writes them.
const FEATURE_HEADER: &str = "y,x,mass,size,ecc,signal,raw_mass,ep,frame";

/// One true grain of the tracks table, length units.
#[derive(Debug, Clone, Copy)]
struct Grain {
    frame: i64,
    particle: i64,
    x: f64,
    y: f64,
    species: i32,
}

/// A canonical tracks CSV: `GRAINS` grains on an `NX` × `NY` lattice `SPACING` apart,
/// large (radius 0.5) and small (0.375) in a checkerboard, over `FRAMES` frames; frame f
/// is the lattice compressed about its middle by 1 % per frame along x and 0.4 % along y,
/// plus per-grain, per-frame offsets of up to 0.04 units (0.8 px). Ids start at 100 so
/// that they differ from the linker's 0, 1, ….
fn lattice_tracks(path: &Path) -> Vec<Grain> {
    let (cx, cy) = (
        SPACING * (NX - 1) as f64 / 2.0,
        SPACING * (NY - 1) as f64 / 2.0,
    );
    let mut text = String::from("frame,particle,x,y,radius,time,species\n");
    let mut grains = Vec::new();
    for f in 0..FRAMES {
        let (sx, sy) = (1.0 - 0.01 * f as f64, 1.0 - 0.004 * f as f64);
        for p in 0..GRAINS {
            let (i, j) = (p % NX, p / NX);
            let species = i32::from((i + j) % 2 == 0);
            let radius = if species == 1 { 0.5 } else { 0.375 };
            let (pf, ff) = (p as f64, f as f64);
            let x = cx + (SPACING * i as f64 - cx) * sx + 0.04 * (1.3 * pf + 0.7 * ff).sin();
            let y = cy + (SPACING * j as f64 - cy) * sy + 0.04 * (0.9 * pf + 1.1 * ff).cos();
            let particle = 100 + p as i64;
            text += &format!("{f},{particle},{x},{y},{radius},{},{species}\n", 0.1 * ff);
            grains.push(Grain {
                frame: f as i64,
                particle,
                x,
                y,
                species,
            });
        }
    }
    std::fs::write(path, text).unwrap();
    grains
}

/// Renders the lattice into `dir/frames` at `PX` px per unit, 8 bit, with low noise
/// (1 grey level of read noise, 5000 photons at full scale): the frames folder and
/// the true grains.
fn rendered(dir: &Path) -> (PathBuf, Vec<Grain>) {
    let input = dir.join("lattice.csv");
    let grains = lattice_tracks(&input);
    let frames = dir.join("frames");
    let (ok, text) = cli(&[
        "render",
        input.to_str().unwrap(),
        "-o",
        frames.to_str().unwrap(),
        "--px-per-unit",
        &PX.to_string(),
        "--read-noise",
        "1",
        "--photons",
        "5000",
        "--quiet",
    ]);
    assert!(ok, "{text}");
    (frames, grains)
}

/// `--diameter 23`: odd and above the large grains' 20 px plus their blurred edge (21
/// cuts that edge and biases the large grains' centres by 0.1 px).
const DIAMETER: &str = "23";

/// The other locate parameters for these frames. `--separation 15`: well below the
/// 34 px spacing, so no grain is dropped as a brighter neighbour's double;
/// `--percentile 10`: flat-topped grains with an 8 % brightness spread put trackpy's
/// default 64th percentile above the dimmer grains' peaks (42 of the 360 go unseen);
/// `--minmass 2000`: the dimmest grain's mass is about 16000, a noise blob's below 500.
const LOCATE: &[&str] = &[
    "--separation",
    "15",
    "--percentile",
    "10",
    "--minmass",
    "2000",
];

/// Linking: grains move at most 2.3 px per frame, the lattice is 34 px: 6 px finds
/// every grain and no neighbour.
const LINK: &[&str] = &["--search-range", "6"];

/// `pillar-pipe track FRAMES -o out` with `LOCATE`, `LINK` and `extra`.
fn track(frames: &Path, out: &Path, extra: &[&str]) -> (bool, String) {
    track_d(frames, out, DIAMETER, extra)
}

fn track_d(frames: &Path, out: &Path, diameter: &str, extra: &[&str]) -> (bool, String) {
    let mut args = vec![
        "track",
        frames.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--diameter",
        diameter,
    ];
    args.extend_from_slice(LOCATE);
    args.extend_from_slice(LINK);
    args.extend_from_slice(extra);
    cli(&args)
}

/// `pillar-pipe locate FRAMES… -o out` with `LOCATE` and `extra`.
fn locate(frames: &[&Path], out: &Path, extra: &[&str]) -> (bool, String) {
    locate_d(frames, out, DIAMETER, extra)
}

fn locate_d(frames: &[&Path], out: &Path, diameter: &str, extra: &[&str]) -> (bool, String) {
    let mut args = vec!["locate"];
    args.extend(frames.iter().map(|f| f.to_str().unwrap()));
    args.extend_from_slice(&[
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--diameter",
        diameter,
    ]);
    args.extend_from_slice(LOCATE);
    args.extend_from_slice(extra);
    cli(&args)
}

/// A CSV file's header line and its rows split on commas.
fn read_csv(path: &Path) -> (String, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default().to_string();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

fn num(s: &str) -> f64 {
    s.parse()
        .unwrap_or_else(|e| panic!("'{s}' is not a number: {e}"))
}

/// `ground_truth.csv`: each drawn grain's true centre in px and its species.
fn ground_truth(frames: &Path) -> Vec<(Truth, i32)> {
    let (header, rows) = read_csv(&frames.join("ground_truth.csv"));
    assert_eq!(
        header,
        "frame,particle,species,x_px,y_px,radius_px,x,y,radius"
    );
    assert_eq!(
        header,
        pillar_pipe::schema::load("ground_truth").names().join(",")
    );
    rows.iter()
        .map(|r| {
            let t = Truth {
                frame: num(&r[0]) as i64,
                particle: num(&r[1]) as i64,
                x: num(&r[3]),
                y: num(&r[4]),
            };
            (t, num(&r[2]) as i32)
        })
        .collect()
}

/// A table in trackpy's columns (`particle` last when linked): the features and ids.
fn read_features(path: &Path) -> (String, Vec<Feature>, Vec<i64>) {
    let (header, rows) = read_csv(path);
    let features = rows
        .iter()
        .map(|r| Feature {
            y: num(&r[0]),
            x: num(&r[1]),
            mass: num(&r[2]),
            size: num(&r[3]),
            ecc: num(&r[4]),
            signal: num(&r[5]),
            raw_mass: num(&r[6]),
            ep: num(&r[7]),
            frame: num(&r[8]) as i64,
        })
        .collect();
    let ids = rows
        .iter()
        .filter(|r| r.len() > 9)
        .map(|r| num(&r[9]) as i64)
        .collect();
    (header, features, ids)
}

/// The true grain nearest `f` in its frame, within 3 px.
fn nearest<'a>(truth: &'a [(Truth, i32)], f: &Feature) -> &'a (Truth, i32) {
    truth
        .iter()
        .filter(|(t, _)| t.frame == f.frame)
        .map(|g| ((g.0.x - f.x).hypot(g.0.y - f.y), g))
        .filter(|(d, _)| *d < 3.0)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or_else(|| panic!("no true grain within 3 px of {f:?}"))
        .1
}

/// `dir` holds nothing (no table, no sidecar, no temporary file).
fn assert_empty(dir: &Path, what: &str) {
    assert!(
        !dir.exists() || file_names(dir).is_empty(),
        "{what}: left {:?}",
        file_names(dir)
    );
}

/// render → track → ingest: every grain found in every frame, none spurious, centres
/// within 0.04 px rms of the truth, one trajectory per grain without a switch, and
/// `ingest` turns the trajectories back into the tracks that were drawn.
#[test]
fn camera_track_recovers_the_rendered_tracks_and_ingest_reads_them() {
    let d = tmpdir("ctrack-chain");
    let (frames, grains) = rendered(&d);
    let out = d.join("tracked").join("tracks.csv");
    let (ok, text) = track(&frames, &out, &[]);
    assert!(ok, "{text}");
    let truth = ground_truth(&frames);
    assert_eq!(truth.len(), GRAINS * FRAMES);
    let (header, found, ids) = read_features(&out);
    assert_eq!(header, format!("{FEATURE_HEADER},particle"));
    assert_eq!(ids.len(), found.len());

    let t: Vec<Truth> = truth.iter().map(|g| g.0).collect();
    // 3 px: a tenth of the spacing, thirty times the largest error seen.
    let s = score(&t, &found, Some(&ids), 3.0);
    assert_eq!(
        (s.truth, s.detections, s.matched, s.lost, s.spurious),
        (360, 360, 360, 0, 0),
        "{s:?}"
    );
    // Measured: 0.012 px rms, 0.04 px at most (shot and read noise). 0.04 px rms is
    // three times that, while the errors a wrong convention or method makes are larger:
    // a half-pixel origin slip 0.5 px, a mask that cuts the large grains' edge
    // (--diameter 21) 0.1 px rms.
    assert!(s.rms_error_px < 0.04, "{s:?}");
    assert!(s.max_error_px < 0.15, "{s:?}");
    assert!(s.rms_displacement_error_px_lag1 < 0.05, "{s:?}");
    assert_eq!(s.id_switches, Some(0), "{s:?}");
    assert_eq!(s.trajectory_breaks, Some(0), "{s:?}");
    let distinct: BTreeSet<i64> = ids.iter().copied().collect();
    assert_eq!(distinct.len(), GRAINS, "one trajectory per grain");
    // Each trajectory follows one true grain: its id → that grain's.
    let mut grain_of: BTreeMap<i64, i64> = BTreeMap::new();
    for (f, id) in found.iter().zip(&ids) {
        let g = nearest(&truth, f).0.particle;
        assert_eq!(*grain_of.entry(*id).or_insert(g), g, "trajectory {id}");
    }

    // ingest with the render's mapping as origin: x = (x_px − ox)/s, y = (oy − y_px)/s
    // gives back the tracks' own coordinates.
    let cam: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(frames.join("camera.json")).unwrap())
            .unwrap();
    let (x0, y0) = (
        cam["pixel_map"]["x0"].as_f64().unwrap(),
        cam["pixel_map"]["y0"].as_f64().unwrap(),
    );
    let origin = format!("--origin-px={},{}", -x0 * PX, y0 * PX);
    let ingested = d.join("tracks.parquet");
    let (ok, text) = cli(&[
        "ingest",
        out.to_str().unwrap(),
        "--px-per-unit",
        &PX.to_string(),
        "--unit",
        "mm",
        &origin,
        "-o",
        ingested.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let (tr, _) = read_tracks(&ingested).unwrap();
    assert_eq!(tr.meta.length_unit, "mm");
    assert_eq!(tr.frame.len(), GRAINS * FRAMES, "{text}");
    let ingested_ids: BTreeSet<i64> = tr.particle.iter().copied().collect();
    assert_eq!(ingested_ids.len(), GRAINS, "{text}");
    let species = tr
        .species
        .as_ref()
        .expect("ingest splits the species by size");
    let by_key: BTreeMap<(i64, i64), Grain> =
        grains.iter().map(|g| ((g.frame, g.particle), *g)).collect();
    let mut worst: f64 = 0.0;
    for r in 0..tr.len() {
        let g = by_key[&(tr.frame[r], grain_of[&tr.particle[r]])];
        assert_eq!(species[r], g.species, "row {r}: the size split");
        worst = worst.max((tr.x[r] - g.x).hypot(tr.y[r] - g.y));
    }
    assert!(worst < 0.15 / PX, "worst position {worst} units");
}

/// `locate` writes trackpy's columns and a sidecar with every frame's SHA-256; the two
/// species separate by `size`; `track` is `locate` plus the `particle` column.
#[test]
fn camera_track_locate_writes_trackpys_table_and_hashes_the_frames() {
    let d = tmpdir("ctrack-locate");
    let (frames, _) = rendered(&d);
    let out = d.join("features.csv");
    let (ok, text) = locate(&[&frames], &out, &[]);
    assert!(ok, "{text}");
    let (header, found, ids) = read_features(&out);
    assert_eq!(header, FEATURE_HEADER);
    // As documented in data_schema/features.schema.json, `particle` apart.
    let names = pillar_pipe::schema::load("features").names().join(",");
    assert_eq!(format!("{header},particle"), names);
    assert!(ids.is_empty());
    assert_eq!(found.len(), GRAINS * FRAMES);

    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("features.csv.meta.json")).unwrap())
            .unwrap();
    assert_eq!(meta["command"], "locate");
    assert_eq!(meta["tool"], "pillar-pipe");
    let hashes: Vec<String> = (0..FRAMES)
        .map(|k| sha256_file(&frames.join(format!("frame_{k:05}.png"))).unwrap())
        .collect();
    assert_eq!(meta["locate"]["frame_sha256"], serde_json::json!(hashes));
    assert_eq!(meta["locate"]["params"]["diameter"], 23);

    // Every large grain's radius of gyration above every small grain's.
    let truth = ground_truth(&frames);
    let (mut small, mut large) = (f64::NEG_INFINITY, f64::INFINITY);
    for f in &found {
        if nearest(&truth, f).1 == 1 {
            large = large.min(f.size);
        } else {
            small = small.max(f.size);
        }
    }
    assert!(
        small < large,
        "small up to {small} px, large from {large} px"
    );

    // track = locate + link: the same rows, in the same order, plus particle.
    let tracked = d.join("tracks.csv");
    let (ok, text) = track(&frames, &tracked, &[]);
    assert!(ok, "{text}");
    let (_, rows_l) = read_csv(&out);
    let (header_t, rows_t) = read_csv(&tracked);
    assert_eq!(header_t, names);
    assert_eq!(rows_l.len(), rows_t.len());
    for (a, b) in rows_l.iter().zip(&rows_t) {
        assert_eq!(a[..], b[..9]);
    }
}

/// A flat frame has no grains: a table with the header only, for `locate` and
/// `track`. A flat frame in the middle of a movie: with `--memory 1` every grain's
/// trajectory bridges it; without, every grain starts a new one after it.
#[test]
fn camera_track_empty_frames_give_header_only_tables() {
    let d = tmpdir("ctrack-empty");
    let blank_dir = d.join("blank");
    std::fs::create_dir_all(&blank_dir).unwrap();
    let mut blank = Frame::new(90, 70, 8);
    blank.pixels.iter_mut().for_each(|v| *v = 13.0);
    write_frame(&blank, &blank_dir.join("flat.png")).unwrap();
    let out = d.join("features.csv");
    let (ok, text) = locate(&[&blank_dir], &out, &[]);
    assert!(ok, "{text}");
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "y,x,mass,size,ecc,signal,raw_mass,ep,frame\n"
    );
    let tracked = d.join("tracks.csv");
    let (ok, text) = track(&blank_dir, &tracked, &[]);
    assert!(ok, "{text}");
    assert_eq!(
        std::fs::read_to_string(&tracked).unwrap(),
        format!("{FEATURE_HEADER},particle\n")
    );

    // Frame 3 of the movie replaced by its background.
    let (frames, _) = rendered(&d);
    let f0 = read_frame(&frames.join("frame_00000.png")).unwrap();
    let mut flat = Frame::new(f0.width, f0.height, 8);
    flat.pixels.iter_mut().for_each(|v| *v = 13.0);
    write_frame(&flat, &frames.join("frame_00003.png")).unwrap();
    let trajectories = |extra: &[&str], name: &str| {
        let out = d.join(name);
        let (ok, text) = track(&frames, &out, extra);
        assert!(ok, "{text}");
        let (_, found, ids) = read_features(&out);
        assert_eq!(found.len(), GRAINS * (FRAMES - 1));
        assert!(found.iter().all(|f| f.frame != 3));
        ids.into_iter().collect::<BTreeSet<_>>().len()
    };
    assert_eq!(trajectories(&["--memory", "1"], "memory.csv"), GRAINS);
    assert_eq!(trajectories(&[], "no_memory.csv"), 2 * GRAINS);
}

/// A truncated frame, a frame of another size, an even diameter, a Parquet name for
/// linked features: each refused, the error naming the file or the parameter, nothing
/// written.
#[test]
fn camera_track_bad_frames_and_parameters_are_named_and_write_nothing() {
    let d = tmpdir("ctrack-bad");
    let (frames, _) = rendered(&d);
    let copy = |name: &str| {
        let dir = d.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        for k in 0..FRAMES {
            let f = format!("frame_{k:05}.png");
            std::fs::copy(frames.join(&f), dir.join(&f)).unwrap();
        }
        dir
    };
    let out_dir = d.join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    let (features, tracks) = (out_dir.join("features.csv"), out_dir.join("tracks.csv"));

    // Truncated: cut frame 3 in half.
    let cut = copy("cut");
    let bad = cut.join("frame_00003.png");
    let bytes = std::fs::read(&bad).unwrap();
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).unwrap();
    let (ok, text) = locate(&[&cut], &features, &[]);
    assert!(!ok && text.contains("frame_00003.png"), "{text}");
    assert_empty(&out_dir, "locate, truncated frame");
    let (ok, text) = track(&cut, &tracks, &[]);
    assert!(!ok && text.contains("frame_00003.png"), "{text}");
    assert_empty(&out_dir, "track, truncated frame");

    // Another size: frame 2 is 64 × 48.
    let odd = copy("odd");
    let first = read_frame(&odd.join("frame_00000.png")).unwrap();
    let mut small = Frame::new(64, 48, 8);
    small.pixels.iter_mut().for_each(|v| *v = 13.0);
    write_frame(&small, &odd.join("frame_00002.png")).unwrap();
    let first_size = format!("{}×{}", first.width, first.height);
    for (cmd, out) in [("locate", &features), ("track", &tracks)] {
        let (ok, text) = if cmd == "locate" {
            locate(&[&odd], out, &[])
        } else {
            track(&odd, out, &[])
        };
        assert!(
            !ok && text.contains("frame_00002.png")
                && text.contains("64×48")
                && text.contains(&first_size),
            "{cmd}: {text}"
        );
        assert_empty(&out_dir, cmd);
    }

    // An even diameter (trackpy's rule: odd).
    let (ok, text) = locate_d(&[&frames], &features, "22", &[]);
    assert!(!ok && text.contains("parameter 'diameter'"), "{text}");
    let (ok, text) = track_d(&frames, &tracks, "22", &[]);
    assert!(!ok && text.contains("parameter 'diameter'"), "{text}");
    assert_empty(&out_dir, "even diameter");

    // Linked features are CSV: a Parquet name is refused before any work.
    let pq = out_dir.join("x.parquet");
    let (ok, text) = track(&frames, &pq, &[]);
    assert!(
        !ok && text.contains("output") && text.contains("x.parquet"),
        "{text}"
    );
    assert_empty(&out_dir, "track to parquet");
    // Regression: so are located ones; `locate` used to write CSV text under the
    // Parquet name, which `link` then could not read.
    let (ok, text) = locate(&[&frames], &pq, &[]);
    assert!(
        !ok && text.contains("output") && text.contains("x.parquet"),
        "{text}"
    );
    assert_empty(&out_dir, "locate to parquet");
}

/// The same frames give the same bytes on one thread and on two.
#[test]
fn camera_track_same_bytes_on_one_and_two_threads() {
    let d = tmpdir("ctrack-threads");
    let (frames, _) = rendered(&d);
    let run = |threads: &str| {
        let out = d.join(format!("tracks_{threads}.csv"));
        let o = std::process::Command::new(BIN)
            .env("RAYON_NUM_THREADS", threads)
            .args([
                "track",
                frames.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .args(["--quiet", "--diameter", DIAMETER])
            .args(LOCATE)
            .args(LINK)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(out).unwrap()
    };
    let one = run("1");
    assert!(one.len() > 360 * 50, "a full table");
    assert!(one == run("2"), "one thread and two differ");
}

/// Regression: the record of `locate` (its sidecar, `--json`) and of `track` names
/// every frame file beside its SHA-256. It used to hold two `frames` keys, the file
/// list and the report's count, and the count replaced the list in the sidecars.
#[test]
fn camera_track_records_name_every_frame_file_beside_its_hash() {
    let d = tmpdir("ctrack-record");
    let (frames, _) = rendered(&d);
    let names: Vec<String> = (0..FRAMES).map(|k| format!("frame_{k:05}.png")).collect();
    let hashes: Vec<String> = names
        .iter()
        .map(|n| sha256_file(&frames.join(n)).unwrap())
        .collect();
    let check = |rec: &serde_json::Value, what: &str| {
        assert_eq!(rec["frames"], FRAMES, "{what}: {rec}");
        let files: Vec<String> = rec["frame_files"]
            .as_array()
            .unwrap_or_else(|| panic!("{what}: no frame_files in {rec}"))
            .iter()
            .map(|f| {
                let p = PathBuf::from(f.as_str().unwrap());
                assert!(p.starts_with(&frames), "{what}: {}", p.display());
                p.file_name().unwrap().to_string_lossy().into_owned()
            })
            .collect();
        assert_eq!(files, names, "{what}");
        assert_eq!(rec["frame_sha256"], serde_json::json!(hashes), "{what}");
    };
    let read_json = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };

    let out = d.join("features.csv");
    let o = std::process::Command::new(BIN)
        .args([
            "locate",
            frames.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .args(["--json", "--diameter", DIAMETER])
        .args(LOCATE)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8(o.stdout).unwrap();
    assert_eq!(stdout.matches("\"frames\"").count(), 1, "{stdout}");
    check(&serde_json::from_str(&stdout).unwrap(), "locate --json");
    check(
        &read_json(&d.join("features.csv.meta.json"))["locate"],
        "locate sidecar",
    );

    let tracked = d.join("tracks.csv");
    let (ok, text) = track(&frames, &tracked, &[]);
    assert!(ok, "{text}");
    check(
        &read_json(&d.join("tracks.csv.meta.json"))["track"]["locate"],
        "track sidecar",
    );
}
