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
        pillar_pipe::schema::load("shear_lines").names()
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
