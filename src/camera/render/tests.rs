use super::*;

fn quiet(w: usize, h: usize) -> Camera {
    Camera {
        width: w,
        height: h,
        bit_depth: 16,
        background: 0.0,
        photons: 0.0,
        read_noise: 0.0,
        brightness_spread: 0.0,
        ..Camera::default()
    }
}

/// (Σ v, Σ v·x, Σ v·y) of the frame above `bg` grey levels.
fn moments(f: &Frame, bg: f64) -> (f64, f64, f64) {
    let (mut m, mut mx, mut my) = (0.0, 0.0, 0.0);
    for row in 0..f.height {
        for col in 0..f.width {
            let v = f.at(row, col) as f64 - bg;
            m += v;
            mx += v * col as f64;
            my += v * row as f64;
        }
    }
    (m, mx / m, my / m)
}

#[test]
fn a_disk_sits_at_its_sub_pixel_centre_with_its_brightness() {
    let positions = [
        (30.0, 31.0),
        (30.37, 25.81),
        (31.5, 30.5),
        (29.93, 32.12),
        (30.25, 30.75),
    ];
    for profile in [Profile::Flat, Profile::Dome, Profile::Gaussian] {
        for (edge, blur) in [(0.5, 1.0), (0.25, 0.0), (1.0, 0.0), (0.1, 0.6)] {
            for r in [7.5, 10.0, 4.3] {
                for &(x, y) in &positions {
                    let cam = Camera {
                        profile,
                        edge_px: edge,
                        blur_px: blur,
                        ..quiet(64, 64)
                    };
                    let d = Disk {
                        x,
                        y,
                        radius: r,
                        brightness: 1.0,
                    };
                    let f = render_frame(&[d], &[], &cam, 0).unwrap();
                    let (m, cx, cy) = moments(&f, 0.0);
                    let what = format!("{profile:?} edge {edge} blur {blur} r {r} at ({x}, {y})");
                    assert!(
                        (cx - x).abs() < 0.01 && (cy - y).abs() < 0.01,
                        "{what}: centroid ({cx}, {cy})"
                    );
                    let level = cam.grain_level * 65535.0;
                    let expect = std::f64::consts::PI
                        * r
                        * r
                        * level
                        * match profile {
                            Profile::Flat => 1.0,
                            Profile::Dome => 1.0 - cam.dome_contrast / 3.0,
                            Profile::Gaussian => 0.5,
                        };
                    // The dome's edge cuts its rim: its integral is that of the sharp
                    // dome only where the edge is narrow beside the radius.
                    if profile != Profile::Dome || cam.edge_sigma() / r < 0.07 {
                        let tol = if profile == Profile::Dome { 0.02 } else { 0.01 };
                        assert!(
                            (m / expect - 1.0).abs() < tol,
                            "{what}: integral {m} vs {expect}"
                        );
                    }
                    if profile == Profile::Flat {
                        // The plateau is the level, the peak of every profile too.
                        let peak = f.pixels.iter().copied().fold(0.0f32, f32::max) as f64;
                        if r > 5.0 && blur < 1.0 {
                            assert!((peak / level - 1.0).abs() < 1e-3, "{what}: peak {peak}");
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn one_sample_of_the_widened_edge_is_the_pixel_integral() {
    // The fast path (an edge ≥ 0.9 px wide): each pixel against a 32 × 32 box
    // integral of the edge as the lens makes it.
    let phi = PhiTable::get();
    for (edge, blur, r) in [(0.5, 1.0, 7.5), (0.9, 0.0, 10.0), (0.3, 1.5, 4.0)] {
        let cam = Camera {
            edge_px: edge,
            blur_px: blur,
            ..quiet(40, 40)
        };
        assert_eq!(Shape::new(&cam, r, phi).n, 1);
        let (x, y) = (19.37, 20.81);
        let d = Disk {
            x,
            y,
            radius: r,
            brightness: 1.0,
        };
        let f = render_frame(&[d], &[], &cam, 0).unwrap();
        let s = cam.edge_sigma();
        let re = (r * r - s * s).sqrt();
        let level = cam.grain_level * 65535.0;
        let mut worst: f64 = 0.0;
        for row in 0..40 {
            for col in 0..40 {
                let mut acc = 0.0;
                for i in 0..32 {
                    for j in 0..32 {
                        let px = col as f64 - 0.5 + (j as f64 + 0.5) / 32.0;
                        let py = row as f64 - 0.5 + (i as f64 + 0.5) / 32.0;
                        acc += phi.at((re - (px - x).hypot(py - y)) / s);
                    }
                }
                let want = acc / 1024.0 * level;
                worst = worst.max((f.at(row, col) as f64 - want).abs() / level);
            }
        }
        assert!(
            worst < 3e-3,
            "edge {edge} blur {blur}: off by {worst} of the level"
        );
    }
}

#[test]
fn eight_bit_quantisation_keeps_the_centre() {
    let cam = Camera {
        bit_depth: 8,
        background: 0.05,
        ..quiet(48, 48)
    };
    let d = Disk {
        x: 23.71,
        y: 24.33,
        radius: 7.5,
        brightness: 1.0,
    };
    let f = render_frame(&[d], &[], &cam, 0).unwrap();
    let (m, cx, cy) = moments(&f, (0.05f64 * 255.0).round());
    assert!(
        (cx - d.x).abs() < 0.01 && (cy - d.y).abs() < 0.01,
        "({cx}, {cy})"
    );
    let expect = std::f64::consts::PI * 7.5 * 7.5 * 0.75 * 255.0;
    assert!((m / expect - 1.0).abs() < 0.01, "{m} vs {expect}");
}

#[test]
fn the_same_seed_gives_the_same_frame_another_seed_other_noise() {
    let disks: Vec<Disk> = (0..12)
        .map(|i| Disk {
            x: 10.0 + 13.3 * (i % 4) as f64,
            y: 12.0 + 15.1 * (i / 4) as f64,
            radius: 6.0,
            brightness: 1.0,
        })
        .collect();
    let cam = Camera {
        width: 64,
        height: 60,
        ..Camera::default()
    };
    let a = render_frame(&disks, &[], &cam, 3).unwrap();
    let b = render_frame(&disks, &[], &cam, 3).unwrap();
    assert_eq!(a, b);
    let c = render_frame(
        &disks,
        &[],
        &Camera {
            seed: 2,
            ..cam.clone()
        },
        3,
    )
    .unwrap();
    let differ = a
        .pixels
        .iter()
        .zip(&c.pixels)
        .filter(|(p, q)| p != q)
        .count();
    assert!(differ > a.pixels.len() / 2, "only {differ} pixels differ");
    // Another frame of the same camera has other noise as well.
    let d = render_frame(&disks, &[], &cam, 4).unwrap();
    assert!(
        a.pixels
            .iter()
            .zip(&d.pixels)
            .filter(|(p, q)| p != q)
            .count()
            > a.pixels.len() / 2
    );
    // With the noise off the seed only sets the grains' brightness.
    let q = Camera {
        photons: 0.0,
        read_noise: 0.0,
        brightness_spread: 0.0,
        ..cam.clone()
    };
    assert_eq!(
        render_frame(&disks, &[], &q, 3).unwrap(),
        render_frame(
            &disks,
            &[],
            &Camera {
                seed: 9,
                ..q.clone()
            },
            4
        )
        .unwrap()
    );
}

fn mean_std(v: &[f32]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().map(|&x| x as f64).sum::<f64>() / n;
    let var = v.iter().map(|&x| (x as f64 - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, var.sqrt())
}

#[test]
fn normals_are_standard_normal() {
    let mut g = Normals::new(5);
    let n = 2_000_000;
    let z: Vec<f64> = (0..n).map(|_| g.next()).collect();
    let m = z.iter().sum::<f64>() / n as f64;
    let var = z.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n as f64;
    let k4 = z.iter().map(|v| (v - m).powi(4)).sum::<f64>() / n as f64 / (var * var);
    assert!(
        m.abs() < 0.003 && (var - 1.0).abs() < 0.004,
        "mean {m} var {var}"
    );
    assert!((k4 - 3.0).abs() < 0.03, "kurtosis {k4}");
    // Tail fractions against 2Φ(−t): the layers, the wedges and the tail.
    for (t, p) in [
        (0.5, 0.617_075),
        (1.0, 0.317_311),
        (2.0, 0.045_500),
        (3.0, 0.002_700),
        (3.8, 1.446_8e-4),
    ] {
        let got = z.iter().filter(|v| v.abs() > t).count() as f64 / n as f64;
        let se = (p * (1.0 - p) / n as f64).sqrt();
        assert!(
            (got - p).abs() < 5.0 * se,
            "P(|z| > {t}) = {got}, expected {p}"
        );
    }
}

#[test]
fn noise_has_the_set_statistics() {
    // Read noise alone on a flat background (8 bit: rounding adds 1/12 to the variance).
    let cam = Camera {
        width: 256,
        height: 256,
        background: 0.4,
        photons: 0.0,
        read_noise: 3.0,
        ..quiet(1, 1)
    };
    let cam = Camera {
        bit_depth: 8,
        ..cam
    };
    let f = render_frame(&[], &[], &cam, 0).unwrap();
    let (m, s) = mean_std(&f.pixels);
    assert!((m - 0.4 * 255.0).abs() < 0.1, "mean {m}");
    let expect = (9.0f64 + 1.0 / 12.0).sqrt();
    assert!(
        (s / expect - 1.0).abs() < 0.05,
        "read noise std {s} vs {expect}"
    );
    // Shot noise alone at 16 bit: variance v · full / photons.
    let cam = Camera {
        bit_depth: 16,
        read_noise: 0.0,
        photons: 2000.0,
        ..cam
    };
    let f = render_frame(&[], &[], &cam, 1).unwrap();
    let (m, s) = mean_std(&f.pixels);
    let expect = (0.4 * 65535.0 * 65535.0 / 2000.0f64).sqrt();
    assert!((m / (0.4 * 65535.0) - 1.0).abs() < 1e-3, "mean {m}");
    assert!(
        (s / expect - 1.0).abs() < 0.05,
        "shot noise std {s} vs {expect}"
    );
    // Few photons: Poisson counts (mean = variance = 5 photons, whole numbers).
    let cam = Camera {
        photons: 100.0,
        background: 0.05,
        ..cam
    };
    let f = render_frame(&[], &[], &cam, 2).unwrap();
    let per = 65535.0 / 100.0;
    let counts: Vec<f32> = f.pixels.iter().map(|&v| (v as f64 / per) as f32).collect();
    assert!(counts.iter().all(|&c| (c - c.round()).abs() < 1e-3));
    let (m, s) = mean_std(&counts);
    assert!(
        (m - 5.0).abs() < 0.05 && (s * s / 5.0 - 1.0).abs() < 0.05,
        "Poisson mean {m} var {}",
        s * s
    );
    // Both together add in quadrature.
    let cam = Camera {
        photons: 1000.0,
        read_noise: 200.0,
        background: 0.3,
        ..cam
    };
    let f = render_frame(&[], &[], &cam, 3).unwrap();
    let (_, s) = mean_std(&f.pixels);
    let expect = (0.3 * 65535.0 * 65535.0 / 1000.0 + 200.0f64 * 200.0).sqrt();
    assert!((s / expect - 1.0).abs() < 0.05, "std {s} vs {expect}");
}

#[test]
fn quantisation_ranges_of_8_and_16_bit() {
    let disks = [
        Disk {
            x: 20.0,
            y: 20.0,
            radius: 8.0,
            brightness: 1.0,
        },
        Disk {
            x: 45.0,
            y: 20.0,
            radius: 8.0,
            brightness: 3.0,
        }, // saturates
    ];
    let mut by_depth = Vec::new();
    for depth in [8u8, 16] {
        let cam = Camera {
            width: 64,
            height: 40,
            bit_depth: depth,
            background: 0.0,
            read_noise: 5.0,
            ..Camera::default()
        };
        let f = render_frame(&disks, &[], &cam, 0).unwrap();
        let full = if depth == 8 { 255.0 } else { 65535.0 };
        assert_eq!(f.bit_depth, depth);
        assert!(
            f.pixels
                .iter()
                .all(|&v| v == v.round() && (0.0..=full).contains(&v))
        );
        assert_eq!(f.max_value(), full);
        assert_eq!(f.at(20, 45), full, "saturated grain clips at full scale");
        assert_eq!(
            f.pixels.iter().copied().fold(f32::MAX, f32::min),
            0.0,
            "noise clips at 0"
        );
        by_depth.push(f);
    }
    // The same scene: 16-bit levels are 257 × the 8-bit ones (up to noise).
    let (a, b) = (by_depth[0].at(20, 20) as f64, by_depth[1].at(20, 20) as f64);
    assert!((b / 257.0 - a).abs() < 12.0, "{a} vs {b}");
}

#[test]
fn frames_are_identical_on_one_and_four_threads() {
    use rayon::prelude::*;
    let disks: Vec<Disk> = (0..30)
        .map(|i| Disk {
            x: 8.0 + 9.7 * (i % 6) as f64,
            y: 8.0 + 10.3 * (i / 6) as f64,
            radius: 4.5,
            brightness: 0.8 + 0.01 * i as f64,
        })
        .collect();
    let cam = Camera {
        width: 70,
        height: 60,
        flicker: 0.1,
        gradient: 0.2,
        ..Camera::default()
    };
    let render = |threads: usize| -> Vec<Frame> {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                (0..8u64)
                    .into_par_iter()
                    .map(|k| render_frame(&disks, &[], &cam, k).unwrap())
                    .collect()
            })
    };
    assert_eq!(render(1), render(4));
}

#[test]
fn grain_factors_are_per_grain_and_spread_as_set() {
    let cam = Camera {
        brightness_spread: 0.1,
        ..Camera::default()
    };
    let f: Vec<f64> = (0..4000).map(|id| cam.grain_factor(id)).collect();
    assert_eq!(cam.grain_factor(17), f[17]);
    let n = f.len() as f64;
    let m = f.iter().sum::<f64>() / n;
    let s = (f.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n).sqrt();
    assert!(
        (m - 1.0).abs() < 0.01 && (s / 0.1 - 1.0).abs() < 0.05,
        "{m} {s}"
    );
    assert_ne!(
        Camera {
            seed: 2,
            ..cam.clone()
        }
        .grain_factor(17),
        f[17]
    );
}

#[test]
fn gradient_bars_and_bad_settings() {
    // A 20 % gradient to the right: the right edge 20 % brighter than the left.
    let cam = Camera {
        width: 101,
        height: 11,
        background: 0.5,
        gradient: 0.2,
        ..quiet(1, 1)
    };
    let f = render_frame(&[], &[], &cam, 0).unwrap();
    let (l, r) = (f.at(5, 0) as f64, f.at(5, 100) as f64);
    assert!(((r - l) / (0.5 * 65535.0) - 0.2).abs() < 1e-4, "{l} {r}");
    // A bar covers its pixels exactly, by area at its edges.
    let cam = Camera {
        blur_px: 0.0,
        ..quiet(20, 10)
    };
    let bar = Rect {
        x0: 2.25,
        y0: 1.5,
        x1: 15.5,
        y1: 4.0,
        level: 0.5,
    };
    let f = render_frame(&[], &[bar], &cam, 0).unwrap();
    let total: f64 = f.pixels.iter().map(|&v| v as f64).sum();
    assert!(
        (total / (13.25 * 2.5 * 0.5 * 65535.0) - 1.0).abs() < 1e-4,
        "{total}"
    );
    assert_eq!(f.at(3, 8), (0.5f64 * 65535.0).round() as f32);
    assert_eq!(f.at(3, 2), (0.25f64 * 0.5 * 65535.0).round() as f32);
    // Blurred, it keeps its brightness and its centre, and spreads as the blur says.
    let cam_b = Camera {
        blur_px: 1.5,
        ..quiet(40, 30)
    };
    let bar = Rect {
        x0: 8.25,
        y0: 10.5,
        x1: 30.5,
        y1: 18.0,
        level: 0.5,
    };
    let f = render_frame(&[], &[bar], &cam_b, 0).unwrap();
    let (m, cx, cy) = moments(&f, 0.0);
    assert!(
        (m / (22.25 * 7.5 * 0.5 * 65535.0) - 1.0).abs() < 1e-4,
        "{m}"
    );
    assert!(
        (cx - 19.375).abs() < 1e-3 && (cy - 14.25).abs() < 1e-3,
        "({cx}, {cy})"
    );
    // Half the level on the edge line x = 30.5 (the pixels at 30 and 31 straddle it).
    let edge = 0.5 * (f.at(14, 30) + f.at(14, 31)) as f64 / (0.5 * 65535.0);
    assert!((edge - 0.5).abs() < 0.02, "{edge}");
    assert!(f.at(14, 36) > 0.0 && f.at(14, 36) < f.at(14, 33));
    for (bad, flag) in [
        (
            Camera {
                bit_depth: 12,
                ..cam.clone()
            },
            "bit-depth",
        ),
        (
            Camera {
                blur_px: -1.0,
                ..cam.clone()
            },
            "blur",
        ),
        (
            Camera {
                read_noise: f64::NAN,
                ..cam.clone()
            },
            "read-noise",
        ),
        (
            Camera {
                edge_px: 0.0,
                blur_px: 0.0,
                ..cam.clone()
            },
            "edge",
        ),
        (
            Camera {
                width: 0,
                ..cam.clone()
            },
            "size",
        ),
    ] {
        let e = render_frame(&[], &[], &bad, 0).unwrap_err().to_string();
        assert!(e.contains(flag), "{e}");
    }
}

#[test]
fn pixel_map_fits_the_content_within_the_margin() {
    let (map, w, h) = PixelMap::fit((-2.0, 10.0), (1.0, 25.0), 31.5, 20.0);
    assert_eq!(
        (w, h),
        (
            (12.0f64 * 31.5 + 40.0).ceil() as usize,
            (24.0f64 * 31.5 + 40.0).ceil() as usize
        )
    );
    assert!((map.col(-2.0) + 0.5 - 20.0).abs() < 1e-9);
    assert!(w as f64 - 0.5 - map.col(10.0) >= 20.0 - 1e-9);
    assert!((map.row(25.0) + 0.5 - 20.0).abs() < 1e-9);
    assert!(h as f64 - 0.5 - map.row(1.0) >= 20.0 - 1e-9);
    assert!(map.row(1.0) > map.row(2.0), "y up in the tracks, rows down");
}
