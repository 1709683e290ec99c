use super::*;
use crate::rng::Rng;
use crate::synth::bidisperse_packing;

/// About `n` centres, D = 1: disks of the synthetic packing (d = 3D/4 and D, 50:50, in
/// its periodic box at φ ≈ 0.84) dropped at uniform random places, their overlaps then
/// pushed apart until they barely touch — a quench, disordered without the holes of
/// random points and without the rows of a lattice, along which a band would measure
/// the lattice rather than the method.
fn packing(n: usize, seed: u64) -> Vec<Vec2> {
    let p = bidisperse_packing(n, 1.0, 0.0, seed);
    let b = p.simbox;
    let mut rng = Rng::new(seed + 100);
    let mut x: Vec<Vec2> = (0..p.pos.len())
        .map(|_| Vec2::new(b.x_lo + b.lx * rng.uniform(), b.y_lo + b.ly * rng.uniform()))
        .collect();
    for _ in 0..300 {
        let cl = CellList::new(&x, 1.0, Cutoff::Strict, Some(b)).unwrap();
        let mut push = vec![Vec2::ZERO; x.len()];
        for (i, dx) in push.iter_mut().enumerate() {
            cl.for_each_within(x[i], |j, r| {
                let (s, dist) = (p.radius[i] + p.radius[j], r.norm());
                if j != i && dist < s && dist > 0.0 {
                    *dx -= r * (0.5 * (s - dist) / dist);
                }
            });
        }
        for (q, dx) in x.iter_mut().zip(&push) {
            *q = b.wrap(*q + *dx);
        }
    }
    x
}

fn centre(pos: &[Vec2]) -> Vec2 {
    pos.iter().fold(Vec2::ZERO, |s, &p| s + p) * (1.0 / pos.len() as f64)
}

/// Log-normal J2 of median 1 and log-spread `sigma`: a background of grains that deform
/// a little each.
fn background(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    (0..n).map(|_| (sigma * rng.normal()).exp()).collect()
}

/// Unit vector `deg` degrees from the compression axis +y towards +x.
fn axis(deg: f64) -> Vec2 {
    let t = deg.to_radians();
    Vec2::new(t.sin(), t.cos())
}

/// Multiply J2 by `factor` for the grains whose centres lie within `w/2` of the line
/// through `c` along `u`; returns how many.
fn plant(pos: &[Vec2], j2: &mut [f64], c: Vec2, u: Vec2, w: f64, factor: f64) -> usize {
    let mut n = 0;
    for (p, v) in pos.iter().zip(j2.iter_mut()) {
        if (*p - c).cross(u).abs() < 0.5 * w {
            *v *= factor;
            n += 1;
        }
    }
    n
}

fn detect(pos: &[Vec2], j2: &[f64]) -> ShearLines {
    shear_lines(pos, j2, 1.0, &ShearLineOptions::default()).unwrap()
}

/// A band 2 D wide of ten times the background's J2, at 45°, 30° and 60° to the
/// compression axis (30° and 60° lie along the lattice's row directions): one line, at
/// its angle within 3°, 2 D wide within 15 %, holding about the planted grains; the same
/// in centimetres with D = 0.635 cm.
#[test]
fn a_planted_band_is_found_at_its_angle_and_width() {
    for (deg, seed) in [(45.0, 1), (30.0, 2), (60.0, 3)] {
        let pos = packing(3000, seed);
        let mut j2 = background(pos.len(), 0.3, seed);
        let planted = plant(&pos, &mut j2, centre(&pos), axis(deg), 2.0, 10.0);
        let r = detect(&pos, &j2);
        assert_eq!(r.lines.len(), 1, "{deg}°: {r:#?}");
        let l = &r.lines[0];
        assert!((l.angle_deg - deg).abs() < 3.0, "{deg}°: {l:?}");
        assert!(
            (l.direction_deg - (90.0 - deg)).abs() < 3.0,
            "{deg}°: {l:?}"
        );
        assert!((l.width_d - 2.0).abs() < 0.3, "{deg}°: {l:?}");
        assert!(l.length_d > 30.0 && l.elongation > 10.0, "{deg}°: {l:?}");
        let got = l.n_grains as f64 / planted as f64;
        assert!((0.95..=1.02).contains(&got), "{deg}°: {l:?}, {planted}");
        assert!(l.j2_contrast > 5.0 && r.summary.compact == 0, "{r:#?}");
        let cm = 0.635;
        let scaled: Vec<Vec2> = pos.iter().map(|&p| p * cm).collect();
        let s = shear_lines(&scaled, &j2, cm, &ShearLineOptions::default()).unwrap();
        assert!((s.lines[0].width_d - l.width_d).abs() < 1e-9);
        assert!((s.lines[0].x - cm * l.x).abs() < 1e-9);
    }
}

/// The width tracks the band: 1, 3 and 4 D wide bands read 1, 3 and 4 D within 15 %.
#[test]
fn the_width_follows_the_planted_width() {
    for (w, seed) in [(1.0, 4), (3.0, 5), (4.0, 6)] {
        let pos = packing(3000, seed);
        let mut j2 = background(pos.len(), 0.3, seed);
        plant(&pos, &mut j2, centre(&pos), axis(40.0), w, 10.0);
        let r = detect(&pos, &j2);
        assert_eq!(r.lines.len(), 1, "{w} D: {r:#?}");
        let l = &r.lines[0];
        assert!((l.width_d / w - 1.0).abs() < 0.15, "{w} D: {l:?}");
        assert!((l.angle_deg - 40.0).abs() < 3.0, "{w} D: {l:?}");
    }
}

/// Log-normal J2 with a wide spread, scattered at random (with threshold 2 at log-spread
/// 1, 14 % of the grains are high): high grains and small clusters, never a line. (The
/// longest chance chains hold up to 12 grains over 7 D, thinner than a band: hence 15
/// grains at least.)
#[test]
fn noise_gives_no_lines() {
    for (sigma, threshold) in [(1.0, 3.0), (1.5, 3.0), (1.0, 2.0)] {
        let o = ShearLineOptions {
            threshold,
            ..Default::default()
        };
        for seed in 1..=3 {
            let pos = packing(4000, seed);
            let j2 = background(pos.len(), sigma, 10 + seed);
            let r = shear_lines(&pos, &j2, 1.0, &o).unwrap();
            assert!(
                r.lines.is_empty(),
                "{sigma} {threshold} {seed}: {:#?}",
                r.lines
            );
            assert!(r.summary.high > 200, "{:?}", r.summary);
        }
    }
}

/// A round patch of high J2 (radius 5 D) is compact, not a line (the local directions
/// through a disk are radial, so it may come out as a few compact pieces).
#[test]
fn a_round_patch_is_not_a_line() {
    let pos = packing(3000, 7);
    let mut j2 = background(pos.len(), 0.3, 7);
    let c = centre(&pos);
    for (p, v) in pos.iter().zip(j2.iter_mut()) {
        if (*p - c).norm() < 5.0 {
            *v *= 10.0;
        }
    }
    let r = detect(&pos, &j2);
    assert!(r.lines.is_empty(), "{:#?}", r.lines);
    assert!(r.summary.compact >= 1, "{:?}", r.summary);
}

/// Conjugate bands crossing in an X (45° either side of the compression axis) are two
/// lines, not one cluster without a direction: directions 45° and 135° from +x.
#[test]
fn two_crossing_bands_are_two_lines() {
    let pos = packing(4000, 8);
    let mut j2 = background(pos.len(), 0.3, 8);
    let c = centre(&pos);
    for u in [axis(45.0), axis(-45.0)] {
        let mut band = vec![1.0; pos.len()];
        plant(&pos, &mut band, c, u, 2.0, 10.0);
        for (v, b) in j2.iter_mut().zip(&band) {
            if *b > 1.0 && *v < 3.0 {
                *v *= b;
            }
        }
    }
    let r = detect(&pos, &j2);
    assert_eq!(r.lines.len(), 2, "{:#?}", r);
    let mut dirs: Vec<f64> = r.lines.iter().map(|l| l.direction_deg).collect();
    dirs.sort_by(f64::total_cmp);
    assert!(
        (dirs[0] - 45.0).abs() < 3.0 && (dirs[1] - 135.0).abs() < 3.0,
        "{dirs:?}"
    );
    for l in &r.lines {
        assert!((l.angle_deg - 45.0).abs() < 3.0, "{l:?}");
        assert!((l.width_d - 2.0).abs() < 0.4, "{l:?}");
    }
}

/// Grains with NaN J2 (or NaN positions) are left out of everything, J2_ref included:
/// the result equals that of the input without them.
#[test]
fn undetermined_grains_are_ignored() {
    let pos = packing(3000, 9);
    let mut j2 = background(pos.len(), 0.3, 9);
    plant(&pos, &mut j2, centre(&pos), axis(45.0), 2.0, 10.0);
    let mut pos_nan = pos.clone();
    for (i, v) in j2.iter_mut().enumerate() {
        // Far more undetermined grains among the low ones, so J2_ref would shift if they
        // counted as anything.
        if i % 3 == 0 && *v < 3.0 || i % 17 == 0 {
            *v = f64::NAN;
        }
    }
    pos_nan[1] = Vec2::new(f64::NAN, 0.0);
    let with = detect(&pos_nan, &j2);
    let keep: Vec<usize> = (0..pos.len())
        .filter(|&i| j2[i].is_finite() && pos_nan[i].is_finite())
        .collect();
    let p: Vec<Vec2> = keep.iter().map(|&i| pos[i]).collect();
    let v: Vec<f64> = keep.iter().map(|&i| j2[i]).collect();
    let mut without = detect(&p, &v);
    // The same grains, indexed into the shorter arrays there.
    for l in &mut without.lines {
        l.members = l.members.iter().map(|&k| keep[k]).collect();
    }
    assert_eq!(with, without);
    assert_eq!(with.summary.determined, keep.len());
    assert_eq!(with.lines.len(), 1, "{with:#?}");
}

/// A pillar mostly not deforming, as a simulated one: the bottom at rest (J2 of
/// round-off, 1e-17), a middle that creeps (J2 ~ 1e-3), the top flowing (J2 ~ 1) with
/// a band in it. The median J2 lies in the creep, so 3 × it would mark the whole top as
/// high (one compact cluster, no line); J2_ref is set by the flowing grains and the band
/// is the one line.
#[test]
fn a_pillar_mostly_at_rest_is_referred_to_its_deforming_grains() {
    let pos = packing(3000, 10);
    let mut j2 = background(pos.len(), 0.3, 10);
    let c = centre(&pos);
    plant(
        &pos,
        &mut j2,
        c + Vec2::new(0.0, 12.0),
        axis(45.0),
        2.0,
        10.0,
    );
    let mut rng = Rng::new(11);
    for (p, v) in pos.iter().zip(j2.iter_mut()) {
        if p.y < c.y - 5.0 {
            *v = 1e-17 * rng.uniform();
        } else if p.y < c.y + 5.0 {
            *v *= 1e-3;
        }
    }
    let mut sorted = j2.clone();
    let median = crate::stats::median_select(&mut sorted);
    assert!(median < 1e-2, "the median lies in the creep: {median}");
    let r = detect(&pos, &j2);
    assert!(r.summary.j2_ref > 0.3, "{:?}", r.summary);
    assert_eq!(r.lines.len(), 1, "{r:#?}");
    assert!((r.lines[0].angle_deg - 45.0).abs() < 3.0);
}

#[test]
fn bad_input_is_refused() {
    let p = vec![Vec2::ZERO; 3];
    let o = ShearLineOptions::default();
    assert!(shear_lines(&p, &[1.0; 2], 1.0, &o).is_err());
    assert!(shear_lines(&p, &[1.0; 3], 0.0, &o).is_err());
    assert!(shear_lines(&p, &[1.0; 3], f64::NAN, &o).is_err());
    let t = ShearLineOptions {
        threshold: 0.0,
        ..o
    };
    assert!(shear_lines(&p, &[1.0; 3], 1.0, &t).is_err());
    // Nothing determined is no line, not an error.
    let r = shear_lines(&p, &[f64::NAN; 3], 1.0, &o).unwrap();
    assert!(r.lines.is_empty() && r.summary.determined == 0);
}
