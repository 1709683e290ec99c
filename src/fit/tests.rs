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
    }
}

#[test]
fn narrow_scatter_every_estimator_recovers_truth() {
    let s = draw(0.3, 0.05, 0.1, 1e-3, 1.0, 12, 400, 1);
    let (_, all) = fit_all(&s, &settings(Method::BinnedMedian)).unwrap();
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
