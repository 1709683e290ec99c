//! `pillar-pipe shear-lines` from the user's side: tracks with a known slip band, through
//! `kinematics`, to one line at the band's angle; and bad inputs named as such.

use crate::common::{cli as run, tmpdir};
use pillar_pipe::geom::{Mat2, Vec2};
use pillar_pipe::io::table::read_table;
use pillar_pipe::io::write_tracks;
use pillar_pipe::synth::{bidisperse_packing, two_frame_tracks};
use std::path::{Path, PathBuf};

/// Two frames of a packing (D = 1, about 2500 grains) where a band `w` D wide at 45°
/// to the compression axis y shears by γ = 0.1 between rigid blocks (displacement along
/// the band ∝ the offset across it, clamped at the band's edges), with tracking noise of
/// 0.002 D per axis everywhere.
fn slip_band_tracks(dir: &Path, w: f64) -> PathBuf {
    let p = bidisperse_packing(2500, 1.0, 0.1, 11);
    let mut t = two_frame_tracks(&p, Mat2::IDENTITY, 0.002, 12);
    let n = p.pos.len();
    let c = p.pos.iter().fold(Vec2::ZERO, |s, &q| s + q) * (1.0 / n as f64);
    let u = Vec2::new(0.5f64.sqrt(), 0.5f64.sqrt());
    for (i, q) in p.pos.iter().enumerate() {
        let across = (*q - c).cross(u).clamp(-0.5 * w, 0.5 * w);
        t.x[n + i] += 0.1 * across * u.x;
        t.y[n + i] += 0.1 * across * u.y;
    }
    let path = dir.join("band.tracks.parquet");
    write_tracks(&t, &path).unwrap();
    path
}

#[test]
fn a_slip_band_is_one_line_at_its_angle() {
    let dir = tmpdir("shear-lines");
    let tracks = slip_band_tracks(&dir, 2.0);
    let kin = dir.join("band.kinematics.parquet");
    let (ok, text) = run(&[
        "kinematics",
        tracks.to_str().unwrap(),
        "--lag",
        "1",
        "--quiet",
        "-o",
        kin.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let out = dir.join("lines.csv");
    let (ok, text) = run(&[
        "shear-lines",
        kin.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("lines       1: median angle 45"), "{text}");
    assert!(Path::new(&format!("{}.meta.json", out.display())).is_file());
    let t = read_table(&out, &[]).unwrap();
    assert_eq!(
        t.columns(),
        pillar_pipe::schema::load("shear_lines").required()
    );
    let (angle, dir_deg, width) = (
        t.f64("angle_deg").unwrap(),
        t.f64("direction_deg").unwrap(),
        t.f64("width_d").unwrap(),
    );
    assert_eq!(angle.len(), 1, "{text}");
    assert!((angle[0] - 45.0).abs() < 3.0, "{text}");
    assert!((dir_deg[0] - 45.0).abs() < 3.0, "{text}");
    // J2 is a fit over neighbours within R_c = 1.25 D, so grains up to about R_c outside
    // the slip band see part of its shear: the J2 band is wider than the slip band.
    assert!(width[0] > 2.0 && width[0] < 4.5, "{text}");
    assert_eq!(t.i64("frame").unwrap(), [0]);
    assert_eq!(t.i64("frame_end").unwrap(), [1]);
    // The default output sits beside the input.
    let (ok, text) = run(&["shear-lines", kin.to_str().unwrap()]);
    assert!(ok, "{text}");
    assert!(dir.join("band.shear_lines.csv").is_file(), "{text}");

    // A frame that is not there: the file and the pairs it has.
    let (ok, text) = run(&["shear-lines", kin.to_str().unwrap(), "--frame", "7"]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("no frame 7") && text.contains("0->1") && text.contains("band.kinematics"),
        "{text}"
    );
    // Tracks instead of kinematics: said so, with the file, not a panic.
    let (ok, text) = run(&["shear-lines", tracks.to_str().unwrap()]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("band.tracks.parquet") && text.contains("not a kinematics table"),
        "{text}"
    );
    assert!(!text.contains("panicked"), "{text}");
    // A table without j2: the missing column by name.
    let bare = dir.join("bare.csv");
    std::fs::write(&bare, "frame,frame_end,x,y\n0,1,0.0,0.0\n").unwrap();
    let (ok, text) = run(&["shear-lines", bare.to_str().unwrap(), "--diameter", "1"]);
    assert!(
        !ok && text.contains("bare.csv") && text.contains("j2"),
        "{text}"
    );
}

/// Six frames of the packing of [`slip_band_tracks`] with 0.002 D of tracking noise
/// per axis in each, where band A (45° through the centre) slips in pairs 0, 1 and 2,
/// band B (135°, 12 D to one side) in pair 3 and band C (135°, 12 D to the other) in
/// pair 4, each 2 D wide with γ = 0.1.
fn three_band_tracks(dir: &Path) -> PathBuf {
    let p = bidisperse_packing(2500, 1.0, 0.1, 11);
    let n = p.pos.len();
    let c = p.pos.iter().fold(Vec2::ZERO, |s, &q| s + q) * (1.0 / n as f64);
    let s = 0.5f64.sqrt();
    let (u45, u135) = (Vec2::new(s, s), Vec2::new(-s, s));
    let bands = [
        (u45, 0.0),
        (u45, 0.0),
        (u45, 0.0),
        (u135, 12.0),
        (u135, -12.0),
    ];
    let mut rng = pillar_pipe::rng::Rng::new(13);
    let mut t = pillar_pipe::tracks::Tracks {
        meta: two_frame_tracks(&p, Mat2::IDENTITY, 0.0, 0).meta,
        ..Default::default()
    };
    let (mut species, mut time) = (Vec::new(), Vec::new());
    let mut cur = p.pos.clone();
    for k in 0..=bands.len() {
        if k > 0 {
            let (u, offset) = bands[k - 1];
            for (i, q) in p.pos.iter().enumerate() {
                let across = (*q - c).cross(u) - offset;
                cur[i] += u * (0.1 * across.clamp(-1.0, 1.0));
            }
        }
        for (i, q) in cur.iter().enumerate() {
            t.frame.push(k as i64);
            t.particle.push(i as i64);
            t.x.push(q.x + 0.002 * rng.normal());
            t.y.push(q.y + 0.002 * rng.normal());
            t.radius.push(p.radius[i]);
            species.push(p.species[i]);
            time.push(k as f64);
        }
    }
    t.species = Some(species);
    t.time = Some(time);
    let path = dir.join("bands.tracks.parquet");
    write_tracks(&t, &path).unwrap();
    path
}

/// `shear-line-tracks`: band A lives three pairs (censored: alive at the first), B one
/// (uncensored), C one (censored: alive at the last); the table's `track` ties A's rows.
#[test]
fn line_tracks_follow_a_persistent_band_and_see_new_ones_born() {
    let dir = tmpdir("line-tracks");
    let tracks = three_band_tracks(&dir);
    let kin = dir.join("bands.kinematics.parquet");
    let (ok, text) = run(&[
        "kinematics",
        tracks.to_str().unwrap(),
        "--lag",
        "1",
        "--quiet",
        "-o",
        kin.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    let (ok, text) = run(&["shear-line-tracks", kin.to_str().unwrap(), "--json"]);
    assert!(ok, "{text}");
    let rep: serde_json::Value = serde_json::from_str(&text).unwrap();
    let s = &rep["summary"];
    assert_eq!(rep["pairs"], 5, "{text}");
    assert_eq!(
        (s["lines"].as_u64(), s["tracks"].as_u64()),
        (Some(5), Some(3)),
        "{text}"
    );
    assert_eq!(s["censored"], 2, "{text}");
    assert_eq!(s["lifetime_counts"], serde_json::json!([1]), "{text}");
    // Lines of pairs 0–3 (those with a next pair): A, A, A, B; continued: A twice.
    assert_eq!(s["continued_fraction"], 0.5, "{text}");
    // B and C born in pairs 1–4.
    assert_eq!(s["births_per_pair"], 0.5, "{text}");
    let out = dir.join("bands.shear_line_tracks.csv");
    let t = read_table(&out, &[]).unwrap();
    let schema = pillar_pipe::schema::load("shear_lines");
    assert_eq!(
        t.columns(),
        schema.names(),
        "the schema names the track columns"
    );
    let (track, life, frame) = (
        t.i64("track").unwrap(),
        t.i64("track_pairs").unwrap(),
        t.i64("frame").unwrap(),
    );
    assert_eq!(frame, [0, 1, 2, 3, 4]);
    assert_eq!(track[0], track[1]);
    assert_eq!(track[1], track[2]);
    assert!(track[3] != track[2] && track[4] != track[3]);
    assert_eq!(life, [3, 3, 3, 1, 1]);

    // Bad input: an overlap outside (0, 1], and --frame, named.
    let (ok, text) = run(&[
        "shear-line-tracks",
        kin.to_str().unwrap(),
        "--min-overlap",
        "0",
    ]);
    assert!(!ok && text.contains("min-overlap"), "{text}");
    let (ok, text) = run(&["shear-line-tracks", kin.to_str().unwrap(), "--frame", "1"]);
    assert!(
        !ok && text.contains("--frame"),
        "one pair is `shear-lines`' option: {text}"
    );
    // A kinematics table without particle ids: the file and the column.
    let bare = dir.join("bare.csv");
    std::fs::write(&bare, "frame,frame_end,x,y,j2\n0,1,0.0,0.0,1.0\n").unwrap();
    let (ok, text) = run(&[
        "shear-line-tracks",
        bare.to_str().unwrap(),
        "--diameter",
        "1",
    ]);
    assert!(
        !ok && text.contains("bare.csv") && text.contains("particle"),
        "{text}"
    );
    assert!(!text.contains("panicked"), "{text}");
}
