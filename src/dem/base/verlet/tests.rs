use super::*;
use crate::dem::backend::team::Team;
use crate::rng::Rng;

/// `n` bidisperse disks (radii 0.5 and 0.7) scattered over a `side` × `side` square,
/// some unwrapped by up to two boxes (as sheared positions are).
fn disks(n: usize, side: f64, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = Rng::new(seed);
    let mut v = |k: f64| (rng.uniform() * (1.0 + 2.0 * k) - k) * side;
    let (x, y): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|i| {
            if i % 7 == 0 {
                (v(2.0), v(2.0))
            } else {
                (v(0.0), v(0.0))
            }
        })
        .unzip();
    let r = (0..n).map(|i| if i % 2 == 0 { 0.5 } else { 0.7 }).collect();
    (x, y, r)
}

/// Every pair i < j closer than R_i + R_j + skin at its nearest image, by testing all.
fn brute(x: &[f64], y: &[f64], r: &[f64], skin: f64, b: Boundary) -> Vec<(u32, u32)> {
    let d = b.image();
    let mut pairs = Vec::new();
    for i in 0..x.len() {
        for j in i + 1..x.len() {
            let (dx, dy) = d.of(x[i] - x[j], y[i] - y[j]);
            let c = r[i] + r[j] + skin;
            if dx * dx + dy * dy < c * c {
                pairs.push((i as u32, j as u32));
            }
        }
    }
    pairs
}

fn pairs_of(l: &PairList) -> Vec<(u32, u32)> {
    (0..l.start.len() - 1)
        .flat_map(|i| (l.start[i]..l.start[i + 1]).map(move |k| (i as u32, k)))
        .map(|(i, k)| (i, l.j[k as usize]))
        .collect()
}

/// A list built in `parts` parts, listed last part first (as threads may finish).
fn built_in_parts(
    l: &mut PairList,
    (x, y, r): (&[f64], &[f64], &[f64]),
    b: Boundary,
    parts: usize,
) {
    let plan = l.begin_build(x, y, r, b, parts);
    for k in (0..plan.parts()).rev() {
        l.list_part(&plan, k, x, y, r);
    }
    l.finish_build(plan, x, y);
}

const BOUNDARIES: [Boundary; 4] = [
    Boundary::Open,
    Boundary::Periodic { lx: 24.0, ly: 24.0 },
    Boundary::LeesEdwards {
        lx: 24.0,
        ly: 24.0,
        offset: 3.7,
    },
    Boundary::LeesEdwards {
        lx: 24.0,
        ly: 24.0,
        offset: -61.3,
    },
];

#[test]
fn every_split_lists_exactly_the_pairs_in_reach() {
    let (x, y, r) = disks(500, 24.0, 5);
    for b in BOUNDARIES {
        let want = brute(&x, &y, &r, 0.2, b);
        assert!(
            want.len() > 300,
            "{b:?}: a dense enough test ({})",
            want.len()
        );
        for parts in [1, 2, 3, 7] {
            let mut l = PairList::new(0.2);
            built_in_parts(&mut l, (&x, &y, &r), b, parts);
            assert_eq!(pairs_of(&l), want, "{b:?}, {parts} parts");
            // Each grain's partners ascending, as the kernels and the history need.
            assert!((0..500).all(|i| {
                l.j[l.start[i] as usize..l.start[i + 1] as usize]
                    .windows(2)
                    .all(|w| w[0] < w[1])
            }));
        }
    }
}

#[test]
fn a_rebuild_in_parts_keeps_the_springs_of_surviving_pairs() {
    let (mut x, y, r) = disks(400, 24.0, 8);
    for b in BOUNDARIES {
        for parts in [1, 2, 5] {
            let mut l = PairList::new(0.2);
            l.build(&x, &y, &r, b);
            // A spring per pair that names the pair.
            let spring = |i: u32, j: u32| f64::from(i) * 1000.0 + f64::from(j);
            let before = pairs_of(&l);
            for (k, &(i, j)) in before.iter().enumerate() {
                l.shear[k] = spring(i, j);
            }
            x.iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v += 0.3 * ((i % 5) as f64 - 2.0));
            built_in_parts(&mut l, (&x, &y, &r), b, parts);
            let after = pairs_of(&l);
            let (mut kept, mut fresh) = (0, 0);
            for (k, &(i, j)) in after.iter().enumerate() {
                if before.binary_search(&(i, j)).is_ok() {
                    assert_eq!(
                        l.shear[k],
                        spring(i, j),
                        "{b:?}: pair ({i}, {j}) kept its spring"
                    );
                    kept += 1;
                } else {
                    assert_eq!(
                        l.shear[k], 0.0,
                        "{b:?}: new pair ({i}, {j}) starts unloaded"
                    );
                    fresh += 1;
                }
            }
            assert!(
                kept > 100 && fresh > 10,
                "{b:?}: both kinds met ({kept}, {fresh})"
            );
            assert_eq!(l.builds, 2);
            assert_eq!((&l.x_ref, &l.y_ref), (&x, &y));
            x.iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v -= 0.3 * ((i % 5) as f64 - 2.0));
        }
    }
}

#[test]
fn a_team_builds_the_list_one_thread_builds() {
    let (x, y, r) = disks(600, 24.0, 2);
    let b = BOUNDARIES[2];
    let mut one = PairList::new(0.2);
    let mut team = PairList::new(0.2);
    team.spare.team = Some(std::sync::Arc::new(Team::new(3, "list-test")));
    for _ in 0..3 {
        one.build(&x, &y, &r, b);
        team.build(&x, &y, &r, b);
        assert_eq!(one, team);
    }
}

#[test]
#[should_panic(expected = "every part listed")]
fn a_build_with_a_part_not_listed_is_refused() {
    let (x, y, r) = disks(100, 24.0, 1);
    let mut l = PairList::new(0.2);
    let plan = l.begin_build(&x, &y, &r, Boundary::Open, 2);
    l.list_part(&plan, 0, &x, &y, &r);
    l.finish_build(plan, &x, &y);
}

/// A Lees–Edwards offset far beyond any real strain (a corrupt checkpoint) put a
/// shifted row's column at i64's end, and the merged column range overflowed into an
/// index out of bounds (found by `fuzz_shear_checkpoint`): the build must go through.
#[test]
fn an_absurd_lees_edwards_offset_builds_a_list() {
    let (x, y, r) = disks(300, 24.0, 4);
    for offset in [1e300, -1e300, 9.3e18, -9.3e18] {
        let b = Boundary::LeesEdwards {
            lx: 24.0,
            ly: 24.0,
            offset,
        };
        for parts in [1, 3] {
            let mut l = PairList::new(0.2);
            built_in_parts(&mut l, (&x, &y, &r), b, parts);
            assert_eq!(l.start.len(), 301, "offset {offset}");
        }
    }
}
