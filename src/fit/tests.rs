//! Recovery of known Θ, η_c from samples drawn from Eq. 19 (issue 4, "Correctness").

use super::*;

/// η log-uniform on [1e-3, 1] in `groups` start times of `per` points each, D²min/R²
/// = Eq. 19 × exp(s·N(0,1)) (log-normal: median = Eq. 19, mean = Eq. 19 · e^{s²/2}).
#[allow(clippy::too_many_arguments)]
fn draw(
    theta: f64,
    eta_c: f64,
    s: f64,
    lo: f64,
    hi: f64,
    groups: u32,
    per: usize,
    seed: u64,
) -> Samples {
    let mut rng = Rng::new(seed);
    let mut out = Samples::default();
    for g in 0..groups {
        for _ in 0..per {
            let eta = (lo.ln() + rng.uniform() * (hi.ln() - lo.ln())).exp();
            let y = d2min_over_r2(eta, theta, eta_c) * (s * rng.normal()).exp();
            out.push(eta, y, g);
        }
    }
    out
}

fn settings(method: Method) -> FitSettings {
    FitSettings {
        method,
        binning: Binning::default(),
        bootstrap: 200,
        seed: 11,
        range: RangeRule::All,
    }
}

#[test]
fn narrow_scatter_every_estimator_recovers_truth() {
    let s = draw(0.3, 0.05, 0.1, 1e-3, 1.0, 12, 400, 1);
    let (_, all, _) = fit_all(&s, &settings(Method::BinnedMedian)).unwrap();
    for (name, r) in &all {
        let r = r.as_ref().unwrap();
        assert!(
            (r.theta / 0.3 - 1.0).abs() < 0.05,
            "{name}: theta {}",
            r.theta
        );
        assert!(
            (r.eta_c / 0.05 - 1.0).abs() < 0.05,
            "{name}: eta_c {}",
            r.eta_c
        );
        assert!(
            r.theta_interval[0] <= 0.3 * 1.01 && r.theta_interval[1] >= 0.3 * 0.99,
            "{name}: {:?}",
            r.theta_interval
        );
        assert!(
            r.eta_c_interval[0] <= 0.05 * 1.01 && r.eta_c_interval[1] >= 0.05 * 0.99,
            "{name}: {:?}",
            r.eta_c_interval
        );
        assert!(
            r.theta_constrained && r.eta_c_constrained,
            "{name}: {:?}",
            r.notes
        );
    }
}

/// Broad log-normal scatter: the median-based estimators still find Θ, η_c; the mean
/// is e^{s²/2} above the median at every η, so binned-mean finds Θ·e^{s²/2} and the
/// same η_c.
#[test]
fn broad_scatter_mean_exceeds_median_by_lognormal_factor() {
    let sig = 1.0;
    let s = draw(0.3, 0.05, sig, 1e-3, 1.0, 16, 2000, 2);
    let set = FitSettings {
        bootstrap: 20,
        ..settings(Method::BinnedMedian)
    };
    let med = fit_estimator(&s, Method::BinnedMedian, &set).unwrap();
    let mean = fit_estimator(&s, Method::BinnedMean, &set).unwrap();
    let pts = fit_estimator(&s, Method::Points, &set).unwrap();
    assert!((med.theta / 0.3 - 1.0).abs() < 0.05, "{}", med.theta);
    assert!((med.eta_c / 0.05 - 1.0).abs() < 0.1, "{}", med.eta_c);
    assert!((pts.theta / 0.3 - 1.0).abs() < 0.05, "{}", pts.theta);
    let factor = (0.5 * sig * sig).exp();
    assert!(
        (mean.theta / med.theta / factor - 1.0).abs() < 0.06,
        "{} / {} vs {factor}",
        mean.theta,
        med.theta
    );
    assert!(
        (mean.eta_c / med.eta_c - 1.0).abs() < 0.12,
        "{} vs {}",
        mean.eta_c,
        med.eta_c
    );
}

#[test]
fn degenerate_data_is_flagged_or_refused() {
    // All η^s far below η_c: ballistic only, η_c (and Θ) not determined.
    let s = draw(0.3, 0.05, 0.1, 1e-4, 5e-3, 10, 300, 3);
    let r = fit_estimator(&s, Method::BinnedMedian, &settings(Method::BinnedMedian)).unwrap();
    assert!(!r.eta_c_constrained && !r.theta_constrained, "{r:?}");
    assert!(r.notes.iter().any(|n| n.contains("diffusive")));
    // All far above: diffusive only; Θ fine, η_c not.
    let s = draw(0.3, 0.05, 0.1, 0.5, 10.0, 10, 300, 4);
    let r = fit_estimator(&s, Method::BinnedMedian, &settings(Method::BinnedMedian)).unwrap();
    assert!(!r.eta_c_constrained, "{r:?}");
    assert!((r.theta / 0.3 - 1.0).abs() < 0.05);
    // Too few points.
    let s = draw(0.3, 0.05, 0.1, 1e-3, 1.0, 1, 2, 5);
    assert!(fit_all(&s, &settings(Method::Points)).is_err());
    let s = draw(0.3, 0.05, 0.1, 1e-3, 1.0, 1, 5, 5);
    assert!(fit_estimator(&s, Method::BinnedMedian, &settings(Method::BinnedMedian)).is_err());
    // One start time: no interval, flagged.
    let s = draw(0.3, 0.05, 0.1, 1e-3, 1.0, 1, 2000, 6);
    let r = fit_estimator(&s, Method::BinnedMedian, &settings(Method::BinnedMedian)).unwrap();
    assert!(!r.theta_constrained && r.notes.iter().any(|n| n.contains("single start")));
}

#[test]
fn bootstrap_is_seeded_and_thread_independent() {
    let s = draw(0.3, 0.05, 0.5, 1e-3, 1.0, 10, 300, 7);
    let set = settings(Method::BinnedMedian);
    let a = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| fit_estimator(&s, Method::BinnedMedian, &set).unwrap());
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| fit_estimator(&s, Method::BinnedMedian, &set).unwrap());
    assert_eq!(a.theta_interval, b.theta_interval);
    assert_eq!(a.eta_c_interval, b.eta_c_interval);
    let c = fit_estimator(&s, Method::BinnedMedian, &FitSettings { seed: 12, ..set }).unwrap();
    assert_ne!(a.theta_interval, c.theta_interval);
}

/// The protocol's sampling, synthetic: `starts` start times, seven lags doubling from
/// a median η^s of 0.004 (log-normal spread `spread` within a lag), D²min/R² = Eq. 19 ×
/// log-normal scatter 0.3. Above η^s = 0.6 — reached only by the longest lags' upper
/// tails — the planted fall-off multiplies D²min by (0.6/η)² (issue 22: the medians of
/// such bins fall below the trend).
fn protocol_like(fall_off: bool, starts: u32, seed: u64) -> Samples {
    let mut rng = Rng::new(seed);
    let mut out = Samples::default();
    let spread = 0.8;
    for g in 0..starts {
        for lag in 0..7u32 {
            let typical = 0.004 * 2f64.powi(lag as i32);
            for _ in 0..250 {
                let eta = typical * (spread * rng.normal()).exp();
                let mut y = d2min_over_r2(eta, 0.3, 0.05) * (0.3 * rng.normal()).exp();
                if fall_off && eta > 0.6 {
                    y *= (0.6 / eta).powi(2);
                }
                out.push_lag(eta, y, g, 1 << lag);
            }
        }
    }
    out
}

#[test]
fn the_coverage_rule_leaves_out_the_tail_only_the_longest_lag_reaches() {
    let s = protocol_like(true, 12, 21);
    let with = |range: RangeRule, method: Method| FitSettings {
        range,
        bootstrap: 20,
        ..settings(method)
    };
    for method in [Method::BinnedMedian, Method::WeightedMean] {
        let (r, _, range) = fit_all(&s, &with(RangeRule::Coverage, method)).unwrap();
        let name = method.name();
        // A mean of log-normal scatter s = 0.3 is e^{s²/2} above the median.
        let theta = match method {
            Method::WeightedMean => 0.3 * (0.045f64).exp(),
            _ => 0.3,
        };
        assert!(
            (r.theta / theta - 1.0).abs() < 0.05,
            "{name}: Θ {}",
            r.theta
        );
        assert!(
            (r.eta_c / 0.05 - 1.0).abs() < 0.05,
            "{name}: η_c {}",
            r.eta_c
        );
        // The second-longest lag's 95th percentile is 0.128·e^{1.645·0.8} ≈ 0.48: the
        // range ends at the upper edge of that bin (10^-0.2 ≈ 0.63, bins of 0.2 decade),
        // short of the fall-off's bins, and the bins above are reported.
        assert!(range.hi < 0.64 && range.hi > 0.3, "{range:?}");
        assert!(range.lo > 1e-3 && range.lo < 5e-3, "{range:?}");
        assert!(
            range
                .excluded
                .iter()
                .any(|b| b.eta_s > 0.6 && b.reason.contains("lag")),
            "{:?}",
            range.excluded
        );
        let (all, _, _) = fit_all(&s, &with(RangeRule::All, method)).unwrap();
        assert!(
            (all.theta / theta - 1.0).abs() > 0.05 || (all.eta_c / 0.05 - 1.0).abs() > 0.05,
            "{name}: fitting every bin should be pulled off by the fall-off: Θ {} η_c {}",
            all.theta,
            all.eta_c
        );
    }
    // Without the fall-off the rule changes little: it drops data, not signal.
    let clean = protocol_like(false, 12, 22);
    let (r, _, _) = fit_all(&clean, &with(RangeRule::All, Method::BinnedMedian)).unwrap();
    assert!((r.theta / 0.3 - 1.0).abs() < 0.05, "Θ {}", r.theta);
}

#[test]
fn an_explicit_range_is_the_fitted_range() {
    let s = protocol_like(true, 8, 23);
    let set = FitSettings {
        range: RangeRule::Explicit { lo: 1e-3, hi: 0.3 },
        bootstrap: 20,
        ..settings(Method::BinnedMedian)
    };
    let (r, _, range) = fit_all(&s, &set).unwrap();
    assert_eq!((range.lo, range.hi), (1e-3, 0.3));
    let inside = s
        .eta_s
        .iter()
        .filter(|&&e| (1e-3..=0.3).contains(&e))
        .count();
    assert_eq!(range.samples_in, inside);
    assert_eq!(range.samples_in + range.samples_out, s.len());
    assert!(r.curve.iter().all(|b| b.eta_s >= 1e-3 && b.eta_s <= 0.3));
    assert!((r.theta / 0.3 - 1.0).abs() < 0.05, "Θ {}", r.theta);
    for (text, want) in [
        ("coverage", Some(RangeRule::Coverage)),
        ("all", Some(RangeRule::All)),
        (
            " 1e-4, 0.5",
            Some(RangeRule::Explicit { lo: 1e-4, hi: 0.5 }),
        ),
        ("0.5,1e-4", None),
        ("nan,1", None),
        ("0,inf", None),
        ("1e-4", None),
    ] {
        assert_eq!(RangeRule::parse(text).ok(), want, "{text}");
    }
}

#[test]
fn weighted_mean_weights_bins_by_their_standard_error() {
    // Narrow scatter: recovers the truth (mean = Eq. 19 · e^{s²/2}, s = 0.1: 0.5 %).
    let s = draw(0.3, 0.05, 0.1, 1e-3, 1.0, 12, 400, 24);
    let r = fit_estimator(&s, Method::WeightedMean, &settings(Method::WeightedMean)).unwrap();
    assert!((r.theta / 0.3 - 1.0).abs() < 0.05, "Θ {}", r.theta);
    assert!((r.eta_c / 0.05 - 1.0).abs() < 0.05, "η_c {}", r.eta_c);
    assert!(r.curve.iter().all(|b| b.se.is_some_and(|se| se > 0.0)));
    // A bin with a far-off mean but a huge standard error barely moves the fit, where
    // the log fit of bin means (every bin alike) is pulled by it.
    let mut pts = reduce(
        &s.eta_s,
        &s.d2min_over_r2,
        Method::WeightedMean,
        &Binning::default(),
    );
    let k = pts.len() - 2;
    pts[k].d2min_over_r2 *= 3.0;
    pts[k].se = Some(pts[k].d2min_over_r2 * 10.0);
    let w = fit_method(&pts, Method::WeightedMean).unwrap();
    let l = fit_method(&pts, Method::BinnedMean).unwrap();
    assert!((w.theta / 0.3 - 1.0).abs() < 0.03, "weighted Θ {}", w.theta);
    assert!(
        (l.theta / 0.3 - 1.0).abs() > (w.theta / 0.3 - 1.0).abs(),
        "log Θ {} vs weighted {}",
        l.theta,
        w.theta
    );
}

#[test]
fn a_slope_that_rises_across_the_range_leaves_eta_c_undetermined() {
    // Log slope 1 below η^s = 0.01 and 1.6 above: no ballistic-to-diffusive crossover
    // (Eq. 19's slope falls from 2 to 1), which is what the bundled trackpy sample shows.
    let mut rng = Rng::new(31);
    let mut s = Samples::default();
    for g in 0..12 {
        for _ in 0..400 {
            let eta = (1e-3f64.ln() + rng.uniform() * (0.3f64.ln() - 1e-3f64.ln())).exp();
            let y = if eta < 0.01 {
                0.1 * eta
            } else {
                0.1 * 0.01 * (eta / 0.01).powf(1.6)
            };
            s.push(eta, y * (0.2 * rng.normal()).exp(), g);
        }
    }
    let r = fit_estimator(&s, Method::BinnedMedian, &settings(Method::BinnedMedian)).unwrap();
    assert!(!r.eta_c_constrained, "{r:?}");
    assert!(
        r.notes.iter().any(|n| n.contains("no crossover")),
        "{:?}",
        r.notes
    );
    // Eq. 19 itself passes the same test.
    let s = draw(0.3, 0.05, 0.3, 1e-3, 1.0, 12, 400, 32);
    let r = fit_estimator(&s, Method::BinnedMedian, &settings(Method::BinnedMedian)).unwrap();
    assert!(r.eta_c_constrained, "{:?}", r.notes);
}

#[test]
fn open_ranges_and_failed_fits_survive_a_json_round_trip() {
    // serde_json writes ∞ and NaN as null; fit.json must read back (compare, report).
    let s = protocol_like(false, 4, 40);
    let r = range::choose(&s, RangeRule::All, &Binning::default());
    assert_eq!(r.hi, f64::INFINITY);
    let back: FitRange = serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap();
    assert_eq!(back, r);
    let row = SensitivityRow {
        method: Method::Points,
        rc_over_d: 1.25,
        lo: 0.0,
        hi: f64::INFINITY,
        theta: f64::NAN,
        eta_c: 0.05,
        fitted_points: 0,
    };
    let back: SensitivityRow = serde_json::from_str(&serde_json::to_string(&row).unwrap()).unwrap();
    assert!(back.theta.is_nan() && back.hi == f64::INFINITY && back.eta_c == 0.05);
}

#[test]
fn thirds_of_the_start_times_show_a_drift_and_agree_without_one() {
    // Starts 0–3 with Θ = 0.2, 4–7 with 0.3, 8–11 with 0.4 (η_c = 0.05 throughout).
    let mut drift = Samples::default();
    for (k, theta) in [0.2, 0.3, 0.4].iter().enumerate() {
        let part = draw(*theta, 0.05, 0.2, 1e-3, 1.0, 4, 400, 50 + k as u64);
        for i in 0..part.len() {
            let g = part.group[i] + 4 * k as u32;
            drift.push(part.eta_s[i], part.d2min_over_r2[i], g);
        }
    }
    let set = FitSettings {
        bootstrap: 100,
        ..settings(Method::BinnedMedian)
    };
    let range = range::choose(&drift, RangeRule::All, &set.binning);
    let t = by_thirds(&drift, &set, &range);
    assert_eq!(t.len(), 3);
    for (fit, want) in t.iter().zip([0.2, 0.3, 0.4]) {
        assert!(
            (fit.theta / want - 1.0).abs() < 0.05,
            "{}: Θ {}",
            fit.part,
            fit.theta
        );
    }
    assert_eq!((t[0].starts, t[2].starts), ([0, 3], [8, 11]));
    assert!(t[0].theta_interval[1] < t[2].theta_interval[0], "{t:?}");
    // Stationary: every third's interval holds the truth.
    let flat = draw(0.3, 0.05, 0.2, 1e-3, 1.0, 12, 400, 60);
    for fit in by_thirds(
        &flat,
        &set,
        &range::choose(&flat, RangeRule::All, &set.binning),
    ) {
        assert!(
            fit.theta_interval[0] <= 0.3 * 1.01 && fit.theta_interval[1] >= 0.3 * 0.99,
            "{fit:?}"
        );
    }
    // Too few starts for an interval per third.
    let few = draw(0.3, 0.05, 0.2, 1e-3, 1.0, 5, 400, 61);
    assert!(
        by_thirds(
            &few,
            &set,
            &range::choose(&few, RangeRule::All, &set.binning)
        )
        .is_empty()
    );
}
