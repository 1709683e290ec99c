use super::*;

fn f(frame: i64, x: f64, y: f64) -> Feature {
    Feature {
        frame,
        x,
        y,
        ..Feature::default()
    }
}

fn opts(search_range: f64, memory: usize, predict: bool) -> LinkOptions {
    LinkOptions {
        search_range,
        memory,
        predict,
        subnet_limit: DEFAULT_SUBNET_LIMIT,
    }
}

/// Features of `paths` (one per particle: (frame, x, y) points, frames ascending),
/// frame by frame, particles in path order within a frame; with the true path of
/// each feature.
fn features_of(paths: &[Vec<(i64, f64, f64)>]) -> (Vec<Feature>, Vec<usize>) {
    let mut rows: Vec<(i64, usize, Feature)> = paths
        .iter()
        .enumerate()
        .flat_map(|(p, path)| path.iter().map(move |&(t, x, y)| (t, p, f(t, x, y))))
        .collect();
    rows.sort_by_key(|r| (r.0, r.1));
    (
        rows.iter().map(|r| r.2).collect(),
        rows.iter().map(|r| r.1).collect(),
    )
}

/// Particles well apart moving 1 px per frame; A misses `memory` frames, B one
/// more: A keeps its id, B comes back as a new one.
#[test]
fn gaps_up_to_memory_are_bridged_and_one_more_starts_a_new_id() {
    let path = |x0: f64, skip: &[i64]| -> Vec<(i64, f64, f64)> {
        (0..=10)
            .filter(|t| !skip.contains(t))
            .map(|t| (t, x0 + t as f64, 50.0))
            .collect()
    };
    let paths = [
        path(0.0, &[3, 4]),
        path(100.0, &[5, 6, 7]),
        path(200.0, &[]),
    ];
    let (feats, truth) = features_of(&paths);
    for predict in [true, false] {
        let out = link(&feats, &opts(5.0, 2, predict)).unwrap();
        // A = 0, B = 1 then (from frame 8) 3, C = 2.
        let want: Vec<i64> = feats
            .iter()
            .zip(&truth)
            .map(|(ft, &p)| if p == 1 && ft.frame >= 8 { 3 } else { p as i64 })
            .collect();
        assert_eq!(out.particle, want, "predict {predict}");
        let r = &out.report;
        assert_eq!(r.trajectories, 4);
        assert_eq!(r.gaps_bridged, 1);
        assert_eq!(r.ended, 1, "B's first part");
        assert_eq!(r.links, feats.len() - 4);
        assert_eq!(r.frames, 11);
        // With one frame more of memory, B's gap is bridged too.
        let out = link(&feats, &opts(5.0, 3, predict)).unwrap();
        let truth: Vec<i64> = truth.iter().map(|&p| p as i64).collect();
        assert_eq!(out.particle, truth);
        assert_eq!(out.report.gaps_bridged, 2);
        assert_eq!(out.report.ended, 0);
    }
}

/// A frame missing from the data counts: without memory every particle ends there.
#[test]
fn a_missing_frame_is_a_frame_in_which_everything_vanished() {
    let feats = [f(0, 0.0, 0.0), f(1, 1.0, 0.0), f(3, 3.0, 0.0)];
    let out = link(&feats, &opts(5.0, 0, true)).unwrap();
    assert_eq!(out.particle, [0, 0, 1]);
    let out = link(&feats, &opts(5.0, 1, true)).unwrap();
    assert_eq!(out.particle, [0, 0, 0]);
    assert_eq!(out.report.gaps_bridged, 1);
}

/// A particle moving 3 px per frame misses a frame: it is looked for at its last
/// position plus twice its last displacement.
#[test]
fn prediction_spans_a_gap() {
    let feats = [
        f(0, 0.0, 0.0),
        f(1, 1.5, 0.0),
        f(2, 4.5, 0.0),
        f(4, 10.5, 0.0),
    ];
    // Frames 0→1 within 2 px with no velocity yet; 1→2 predicted at 3.0; 2→4 at 10.5.
    let out = link(&feats, &opts(2.0, 1, true)).unwrap();
    assert_eq!(out.particle, [0, 0, 0, 0]);
    let out = link(&feats, &opts(2.0, 1, false)).unwrap();
    assert_eq!(out.particle, [0, 0, 1, 2]);
}

/// Two grains crossing head-on at 4 px per frame: between frames 3 and 4 each new
/// position is 2 px from the other's old one and 4 px from its own. Nearest
/// neighbours (and the exact subnet without prediction) swap them; the prediction
/// keeps them.
#[test]
fn crossing_grains_are_kept_apart_by_the_prediction() {
    let a: Vec<_> = (0..9).map(|t| (t, 4.0 * t as f64, 0.0)).collect();
    let b: Vec<_> = (0..9).map(|t| (t, 30.0 - 4.0 * t as f64, 0.0)).collect();
    let (feats, truth) = features_of(&[a, b]);
    let truth: Vec<i64> = truth.iter().map(|&p| p as i64).collect();
    let out = link(&feats, &opts(5.0, 0, true)).unwrap();
    assert_eq!(out.particle, truth);
    assert_eq!(out.report.trajectories, 2);
    let wrong = link(&feats, &opts(5.0, 0, false)).unwrap();
    assert_ne!(
        wrong.particle, truth,
        "the case must defeat a linker without prediction"
    );
}

/// Two grains 5 px apart in a row, speeding up to 8 px per frame (a compressed
/// pillar's edge): without prediction the front grain's old position is nearer to
/// the rear grain's new one.
#[test]
fn grains_moving_fast_the_same_way_are_followed_with_prediction() {
    let steps = [1.0, 3.0, 5.0, 7.0, 8.0, 8.0, 8.0];
    let mut x = 0.0;
    let mut xs = vec![0.0];
    for s in steps {
        x += s;
        xs.push(x);
    }
    let a: Vec<_> = xs
        .iter()
        .enumerate()
        .map(|(t, &x)| (t as i64, x, 0.0))
        .collect();
    let b: Vec<_> = xs
        .iter()
        .enumerate()
        .map(|(t, &x)| (t as i64, x + 5.0, 0.0))
        .collect();
    let (feats, truth) = features_of(&[a, b]);
    let truth: Vec<i64> = truth.iter().map(|&p| p as i64).collect();
    let out = link(&feats, &opts(6.0, 0, true)).unwrap();
    assert_eq!(out.particle, truth);
    let wrong = link(&feats, &opts(6.0, 0, false)).unwrap();
    assert_ne!(wrong.particle, truth);
}

/// Particles at 0 and 4, features at 2.5 and 7 (search range 5): shortest link
/// first takes 4 → 2.5 and strands the particle at 0; the exact subnet links both.
/// Above the subnet limit the greedy answer is used and counted.
#[test]
fn exact_subnet_beats_nearest_neighbour_and_greedy_is_counted() {
    let feats = [
        f(0, 0.0, 0.0),
        f(0, 4.0, 0.0),
        f(1, 2.5, 0.0),
        f(1, 7.0, 0.0),
    ];
    let exact = link(&feats, &opts(5.0, 0, false)).unwrap();
    assert_eq!(exact.particle, [0, 1, 0, 1]);
    assert_eq!(exact.report.subnets_exact, 1);
    assert_eq!(exact.report.largest_subnet, 2);
    assert_eq!(exact.report.subnets_greedy, 0);
    let greedy = link(
        &feats,
        &LinkOptions {
            subnet_limit: 1,
            ..opts(5.0, 0, false)
        },
    )
    .unwrap();
    assert_eq!(greedy.particle, [0, 1, 1, 2]);
    let r = &greedy.report;
    assert_eq!(
        (r.subnets_exact, r.subnets_greedy, r.features_greedy),
        (0, 1, 2)
    );
    assert_eq!((r.links, r.trajectories, r.ended), (1, 3, 1));
}

/// A feature with nothing within the search range starts a trajectory, however
/// close it is to the range; one at the range links.
#[test]
fn nothing_is_linked_beyond_the_search_range() {
    let out = link(&[f(0, 0.0, 0.0), f(1, 5.001, 0.0)], &opts(5.0, 0, true)).unwrap();
    assert_eq!(out.particle, [0, 1]);
    assert_eq!(out.report.links, 0);
    let out = link(&[f(0, 0.0, 0.0), f(1, 3.0, 4.0)], &opts(5.0, 0, true)).unwrap();
    assert_eq!(out.particle, [0, 0]);
    // Two features near one particle: the nearer links, the other starts anew
    // rather than being forced onto another particle 6 px away.
    let feats = [
        f(0, 0.0, 0.0),
        f(0, 10.0, 0.0),
        f(1, 1.0, 0.0),
        f(1, 4.0, 0.0),
    ];
    let out = link(&feats, &opts(5.0, 0, false)).unwrap();
    assert_eq!(out.particle, [0, 1, 0, 2]);
    assert_eq!(out.report.ended, 1);
}

/// The exact solution's cost (Σ d² + r² per unlinked particle) is the least over
/// every matching within the range, on random subnets; greedy is never cheaper.
#[test]
fn exact_subnets_reach_the_brute_force_minimum() {
    fn best(s: usize, cost: &[Vec<Option<f64>>], taken: &mut Vec<bool>, r2: f64) -> f64 {
        if s == cost.len() {
            return 0.0;
        }
        let mut b = r2 + best(s + 1, cost, taken, r2);
        for (j, c) in cost[s].iter().enumerate() {
            if let Some(c) = c
                && !taken[j]
            {
                taken[j] = true;
                b = b.min(c + best(s + 1, cost, taken, r2));
                taken[j] = false;
            }
        }
        b
    }
    let mut rng = crate::rng::Rng::new(7);
    let r = 4.0;
    for case in 0..300 {
        let ns = 1 + rng.below(7);
        let nd = 1 + rng.below(7);
        let mut feats = Vec::new();
        for _ in 0..ns {
            feats.push(f(0, 10.0 * rng.uniform(), 6.0 * rng.uniform()));
        }
        for _ in 0..nd {
            feats.push(f(1, 10.0 * rng.uniform(), 6.0 * rng.uniform()));
        }
        let d2 = |a: &Feature, b: &Feature| (a.x - b.x).powi(2) + (a.y - b.y).powi(2);
        let cost: Vec<Vec<Option<f64>>> = feats[..ns]
            .iter()
            .map(|s| {
                feats[ns..]
                    .iter()
                    .map(|d| Some(d2(s, d)).filter(|&c| c <= r * r))
                    .collect()
            })
            .collect();
        let want = best(0, &cost, &mut vec![false; nd], r * r);
        let cost_of = |l: &Linked| {
            let mut c = 0.0;
            for s in 0..ns {
                match (ns..ns + nd).find(|&j| l.particle[j] == l.particle[s]) {
                    Some(j) => c += d2(&feats[s], &feats[j]),
                    None => c += r * r,
                }
            }
            c
        };
        let exact = link(&feats, &opts(r, 0, false)).unwrap();
        assert!(
            (cost_of(&exact) - want).abs() < 1e-9,
            "case {case}: {} vs brute force {want}",
            cost_of(&exact)
        );
        let greedy = link(
            &feats,
            &LinkOptions {
                subnet_limit: 0,
                ..opts(r, 0, false)
            },
        )
        .unwrap();
        assert!(cost_of(&greedy) >= want - 1e-9, "case {case}");
    }
}

/// A lattice of 1000 grains 18 px apart, jittered by `noise` px per frame, drifting
/// apart, 1 % of them missing from each frame.
pub(crate) fn movie(frames: i64, noise: f64, seed: u64) -> Vec<Feature> {
    let mut rng = crate::rng::Rng::new(seed);
    let base: Vec<(f64, f64)> = (0..1000)
        .map(|i| {
            (
                20.0 + 18.0 * (i % 40) as f64 + 9.0 * ((i / 40) % 2) as f64,
                20.0 + 15.6 * (i / 40) as f64,
            )
        })
        .collect();
    let mut out = Vec::new();
    for t in 0..frames {
        for &(x, y) in &base {
            if rng.uniform() < 0.01 {
                continue;
            }
            out.push(f(
                t,
                x + noise * rng.normal() + 0.05 * t as f64 * (x / 100.0),
                y + noise * rng.normal() - 0.1 * t as f64 * (y / 100.0),
            ));
        }
    }
    out
}

#[test]
fn the_result_does_not_depend_on_the_thread_count() {
    // Noisy enough for subnets of many particles.
    let feats = movie(40, 2.0, 3);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                link(
                    &feats,
                    &LinkOptions {
                        search_range: 12.0,
                        memory: 2,
                        predict: true,
                        subnet_limit: 4,
                    },
                )
                .unwrap()
            })
    };
    let one = run(1);
    assert!(one.report.largest_subnet > 4, "{:?}", one.report);
    assert!(one.report.subnets_greedy > 0 && one.report.subnets_exact > 1000);
    assert!(one.report.gaps_bridged > 0);
    assert_eq!(one, run(4));
}

/// Rows of different frames in any order: each feature gets the same id.
#[test]
fn input_order_across_frames_does_not_matter() {
    let feats = movie(6, 0.5, 5);
    let opt = opts(6.0, 1, true);
    let want = link(&feats, &opt).unwrap();
    // Frames in reverse, rows of a frame in their order.
    let mut idx: Vec<usize> = (0..feats.len()).collect();
    idx.sort_by_key(|&i| std::cmp::Reverse(feats[i].frame));
    let shuffled: Vec<Feature> = idx.iter().map(|&i| feats[i]).collect();
    let got = link(&shuffled, &opt).unwrap();
    for (k, &i) in idx.iter().enumerate() {
        assert_eq!(got.particle[k], want.particle[i]);
    }
    assert_eq!(got.report, want.report);
    // Ids count up in order of first appearance.
    let mut next = 0;
    for &p in &want.particle {
        assert!(p <= next);
        next = next.max(p + 1);
    }
}

#[test]
fn bad_parameters_and_positions_are_refused_by_name() {
    for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = link(&[f(0, 0.0, 0.0)], &opts(r, 0, true)).unwrap_err();
        assert!(
            matches!(&e, Error::Param { name, .. } if name == "search_range"),
            "{e}"
        );
    }
    let feats = [f(0, 0.0, 0.0), f(1, 1.0, 0.0), f(1, 2.0, f64::NAN)];
    let e = link(&feats, &opts(5.0, 0, true)).unwrap_err().to_string();
    assert!(
        e.contains("row 2") && e.contains("frame 1") && e.contains("y = NaN"),
        "{e}"
    );
    let empty = link(&[], &opts(5.0, 0, true)).unwrap();
    assert!(empty.particle.is_empty());
    assert_eq!(empty.report, LinkReport::default());
}
