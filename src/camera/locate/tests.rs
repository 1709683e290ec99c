use super::*;

/// A frame with Gaussian spots (σ px, peak above a background of 10 grey levels).
fn gaussian_frame(w: usize, h: usize, spots: &[(f64, f64, f64, f64)]) -> Frame {
    let mut f = Frame::new(w, h, 16);
    for (i, v) in f.pixels.iter_mut().enumerate() {
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        let mut s = 10.0;
        for &(cx, cy, sigma, peak) in spots {
            s += peak * (-((x - cx).powi(2) + (y - cy).powi(2)) / (2.0 * sigma * sigma)).exp();
        }
        *v = s as f32;
    }
    f
}

/// Uniform disks of radius r (px), each pixel's coverage found on a 16 × 16 sub-grid.
fn disk_frame(w: usize, h: usize, disks: &[(f64, f64, f64)], level: f64) -> Frame {
    let mut f = Frame::new(w, h, 8);
    for &(cx, cy, r) in disks {
        let (x0, x1) = (
            (cx - r - 1.0).floor() as usize,
            (cx + r + 1.0).ceil() as usize,
        );
        let (y0, y1) = (
            (cy - r - 1.0).floor() as usize,
            (cy + r + 1.0).ceil() as usize,
        );
        for y in y0..=y1.min(h - 1) {
            for x in x0..=x1.min(w - 1) {
                let mut n = 0;
                for sy in 0..16 {
                    for sx in 0..16 {
                        let px = x as f64 - 0.5 + (sx as f64 + 0.5) / 16.0;
                        let py = y as f64 - 0.5 + (sy as f64 + 0.5) / 16.0;
                        if (px - cx).powi(2) + (py - cy).powi(2) <= r * r {
                            n += 1;
                        }
                    }
                }
                f.pixels[y * w + x] += (level * n as f64 / 256.0) as f32;
            }
        }
    }
    f.pixels.iter_mut().for_each(|v| *v = v.round() + 5.0);
    f
}

#[test]
fn a_gaussian_spot_is_found_within_005_px() {
    let params = LocateParams {
        diameter: 15,
        ..Default::default()
    };
    for &(cx, cy) in &[(40.3, 37.71), (41.5, 38.5), (39.87, 40.12), (40.0, 40.0)] {
        let f = gaussian_frame(80, 80, &[(cx, cy, 2.5, 3000.0)]);
        let found = locate(&f, 0, &params).unwrap();
        assert_eq!(found.len(), 1, "{found:?}");
        let g = found[0];
        assert!(
            (g.x - cx).abs() < 0.05 && (g.y - cy).abs() < 0.05,
            "true ({cx}, {cy}), found ({}, {})",
            g.x,
            g.y
        );
        assert!(g.ecc < 0.05, "a round spot: ecc {}", g.ecc);
        assert!(g.ep.is_finite() && g.ep > 0.0);
    }
}

#[test]
fn two_species_separate_by_size() {
    // A grid of large (r 10 px) and small (r 7.5 px) disks, as the shared sample's
    // 20 px and 15 px grains; at diameter 21 the radius of gyration tells them apart.
    let mut disks = Vec::new();
    let mut truth = Vec::new();
    for row in 0..4 {
        for col in 0..5 {
            let large = (row + col) % 2 == 0;
            let r = if large { 10.0 } else { 7.5 };
            let (x, y) = (
                30.0 + 26.0 * col as f64 + 0.3 * row as f64,
                30.0 + 26.0 * row as f64 + 0.17 * col as f64,
            );
            disks.push((x, y, r));
            truth.push((x, y, large));
        }
    }
    let f = disk_frame(170, 140, &disks, 200.0);
    let params = LocateParams {
        diameter: 21,
        separation: Some(9.0),
        noise_size: 1.0,
        ..Default::default()
    };
    let found = locate(&f, 0, &params).unwrap();
    assert_eq!(found.len(), truth.len(), "{found:?}");
    let (mut max_small, mut min_large) = (0.0f64, f64::INFINITY);
    for &(x, y, large) in &truth {
        let g = found
            .iter()
            .min_by(|a, b| ((a.x - x).hypot(a.y - y)).total_cmp(&(b.x - x).hypot(b.y - y)))
            .unwrap();
        // The boxcar background (21 px) takes in more of the neighbours on one side than
        // the other: a bias of about 0.15 px, which trackpy shares.
        assert!(
            (g.x - x).hypot(g.y - y) < 0.25,
            "({x}, {y}) found at ({}, {})",
            g.x,
            g.y
        );
        if large {
            min_large = min_large.min(g.size);
        } else {
            max_small = max_small.max(g.size);
        }
    }
    assert!(
        max_small < min_large,
        "small up to {max_small} px, large from {min_large} px"
    );
}

#[test]
fn an_empty_frame_gives_no_features() {
    let mut f = Frame::new(64, 48, 8);
    f.pixels.iter_mut().for_each(|v| *v = 17.0);
    assert!(locate(&f, 0, &LocateParams::default()).unwrap().is_empty());
    let f = Frame::new(64, 48, 8);
    assert!(locate(&f, 0, &LocateParams::default()).unwrap().is_empty());
}

#[test]
fn minmass_and_separation_drop_what_trackpy_drops() {
    // A bright and a dim spot 6 px apart with separation 12: the dim one goes.
    let f = gaussian_frame(
        80,
        80,
        &[(35.0, 40.0, 2.0, 2000.0), (41.0, 40.0, 2.0, 800.0)],
    );
    let p = LocateParams {
        diameter: 11,
        separation: Some(12.0),
        ..Default::default()
    };
    let found = locate(&f, 0, &p).unwrap();
    assert_eq!(found.len(), 1);
    assert!(found[0].x < 38.0);
    // A spot whose mass is below minmass is dropped.
    let f = gaussian_frame(80, 80, &[(40.0, 40.0, 2.0, 100.0)]);
    let m = locate(
        &f,
        0,
        &LocateParams {
            diameter: 11,
            ..Default::default()
        },
    )
    .unwrap()[0]
        .mass;
    let p = LocateParams {
        diameter: 11,
        minmass: m * 1.01,
        ..Default::default()
    };
    assert!(locate(&f, 0, &p).unwrap().is_empty());
}

#[test]
fn bad_parameters_are_refused_by_name() {
    let f = Frame::new(10, 10, 8);
    for (p, name) in [
        (
            LocateParams {
                diameter: 10,
                ..Default::default()
            },
            "diameter",
        ),
        (
            LocateParams {
                smoothing_size: Some(8),
                ..Default::default()
            },
            "smoothing_size",
        ),
        (
            LocateParams {
                noise_size: 20.0,
                ..Default::default()
            },
            "noise_size",
        ),
        (
            LocateParams {
                percentile: 120.0,
                ..Default::default()
            },
            "percentile",
        ),
    ] {
        let e = locate(&f, 0, &p).unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
    }
}

#[test]
fn frames_of_another_size_are_refused_and_threads_do_not_change_the_result() {
    let dir = std::env::temp_dir().join(format!("pp-locate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut paths = Vec::new();
    for k in 0..4 {
        let spots: Vec<_> = (0..6)
            .map(|i| {
                (
                    15.0 + 11.0 * i as f64 + 0.1 * k as f64,
                    20.0 + 3.0 * (i % 3) as f64,
                    2.0,
                    900.0,
                )
            })
            .collect();
        let mut f = gaussian_frame(90, 45, &spots);
        f.bit_depth = 16;
        let p = dir.join(format!("f{k}.png"));
        crate::camera::write_frame(&f, &p).unwrap();
        paths.push(p);
    }
    let p = LocateParams {
        diameter: 9,
        ..Default::default()
    };
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| locate_frames(&paths, &p, &|| {}).unwrap())
    };
    let (one, rep) = run(1);
    let (two, _) = run(3);
    assert_eq!(one, two);
    assert_eq!(rep.frames, 4);
    assert_eq!(rep.features, 24);
    assert!(one.windows(2).all(|w| w[0].frame <= w[1].frame));
    let odd = dir.join("odd.png");
    crate::camera::write_frame(&Frame::new(80, 45, 16), &odd).unwrap();
    paths.push(odd);
    let e = locate_frames(&paths, &p, &|| {}).unwrap_err().to_string();
    assert!(
        e.contains("odd.png") && e.contains("80×45") && e.contains("90×45"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_percentile_is_numpys_on_the_non_zero_values() {
    // numpy: np.percentile([1, 2, 3, 4], 64) = 2.92; np.percentile([5, 5, 9], 50) = 5.
    let img = [0.0, 3.0, 0.0, 1.0, 4.0, 2.0];
    assert!((percentile_of_nonzero(&img, 64.0, 255.0).unwrap() - 2.92).abs() < 1e-6);
    assert_eq!(
        percentile_of_nonzero(&[9.0, 5.0, 0.0, 5.0], 50.0, 255.0),
        Some(5.0)
    );
    assert_eq!(percentile_of_nonzero(&[7.0], 64.0, 255.0), Some(7.0));
    assert_eq!(percentile_of_nonzero(&[0.0, 0.0], 64.0, 255.0), None);
    assert_eq!(
        percentile_of_nonzero(&[65535.0, 1.0], 100.0, 65535.0),
        Some(65535.0)
    );
}
