//! Shear lines followed across consecutive frame pairs: are they transient?
//! (li-granular-pillars Sec. V, Fig. 11 text: "these shear lines are transient in time.
//! As deformation goes on, new shear lines will form elsewhere in the pillar, while the
//! particles in the shear lines formed earlier may not accumulate significant amount of
//! shear strain continuously", and "there must be more of them in larger systems".)
//!
//! Rule. Pair k + 1 follows pair k when it starts at the frame where k ends (pairs
//! that overlap in time, or with a gap between them, are never linked). A line of pair
//! k and a line of the following pair are the same line when they share at least
//! `min_overlap` of the smaller one's grains (by particle id). Each line continues at
//! most one line and is continued by at most one: candidate links are taken by
//! decreasing shared fraction (ties by the lines' order), so a line that splits goes on
//! as its larger part and the rest are births. A *track* is a chain of linked lines;
//! its lifetime is the number of frame pairs it spans. A track alive in the first pair
//! of a run of following pairs, or in the last, is *censored*: its lifetime is at least
//! what is seen, and it is counted apart.
//!
//! Measures, all from the same links:
//! - the lifetime distribution of the uncensored tracks, its mean, and the share that
//!   live one pair;
//! - the continued fraction: of the lines of pairs that have a following pair, the share
//!   that a line of that pair continues;
//! - births per pair: tracks that start in a pair with a predecessor, per such pair;
//! - grain persistence: of the grains in lines at pair k, the share in a line at k + 1,
//!   beside its chance level, the share of k + 1's grains that are in lines. A line
//!   whose grains keep shearing gives a persistence far above chance; the paper's
//!   transient lines give one near it.

/// The lines of one frame pair: each line's grains as sorted particle ids.
#[derive(Debug, Clone, PartialEq)]
pub struct PairLines {
    pub frame: i64,
    pub frame_end: i64,
    /// Grains with a determined J2 in the pair (the chance level's denominator).
    pub grains: usize,
    pub lines: Vec<Vec<i64>>,
}

/// The linking rule's parameter.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LinkOptions {
    /// Least shared fraction of the smaller line's grains that links two lines.
    pub min_overlap: f64,
}

impl Default for LinkOptions {
    fn default() -> Self {
        // A line about 2 D wide moves by a fraction of its width between pairs at the
        // paper's Δt = 8/15 R/v_c; a third of its grains shared is the same band, while
        // two unrelated lines crossing share a few grains at the crossing only.
        LinkOptions { min_overlap: 0.3 }
    }
}

/// What the links say about a run's lines. Lifetimes in frame pairs.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackSummary {
    pub pairs: usize,
    pub lines: usize,
    pub tracks: usize,
    /// Mean lines per pair.
    pub lines_per_pair: f64,
    /// `lifetime_counts[L - 1]`: uncensored tracks that lived L pairs.
    pub lifetime_counts: Vec<usize>,
    pub censored: usize,
    /// Mean lifetime of the uncensored tracks (pairs; NaN without one).
    pub mean_lifetime: f64,
    /// Share of the uncensored tracks that lived one pair (NaN without one).
    pub single_pair_fraction: f64,
    /// Share of the lines, in pairs that have a following pair, continued into it.
    pub continued_fraction: f64,
    /// Tracks born per pair that has a predecessor (NaN without such a pair).
    pub births_per_pair: f64,
    /// Share of pair k's line grains in a line at pair k + 1, and its chance level.
    pub grain_persistence: f64,
    pub grain_chance: f64,
}

/// Each pair's lines' track ids (`track[k][l]` for line l of pair k) and the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct LineTracks {
    pub track: Vec<Vec<usize>>,
    /// Each track's lifetime in pairs, by track id.
    pub lifetime: Vec<usize>,
    pub summary: TrackSummary,
}

/// Shared fraction of the smaller of two sorted id lists.
fn overlap(a: &[i64], b: &[i64]) -> f64 {
    let (mut i, mut j, mut shared) = (0, 0, 0usize);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                shared += 1;
                i += 1;
                j += 1;
            }
        }
    }
    let smaller = a.len().min(b.len());
    if smaller == 0 {
        0.0
    } else {
        shared as f64 / smaller as f64
    }
}

/// Links the lines of `pairs` (in time order) by the rule of the module.
pub fn link(pairs: &[PairLines], opt: &LinkOptions) -> LineTracks {
    let follows = |k: usize| k > 0 && pairs[k].frame == pairs[k - 1].frame_end;
    let mut track: Vec<Vec<usize>> = Vec::with_capacity(pairs.len());
    let mut lifetime: Vec<usize> = Vec::new();
    let mut born_at: Vec<usize> = Vec::new();
    let (mut continued, mut could_continue) = (0usize, 0usize);
    let (mut persist_sum, mut chance_sum, mut persist_n) = (0.0, 0.0, 0usize);
    let mut births = 0usize;
    for (k, p) in pairs.iter().enumerate() {
        let mut ids = vec![usize::MAX; p.lines.len()];
        if follows(k) {
            let prev = &pairs[k - 1];
            let mut cand: Vec<(f64, usize, usize)> = Vec::new();
            for (a, la) in prev.lines.iter().enumerate() {
                for (b, lb) in p.lines.iter().enumerate() {
                    let f = overlap(la, lb);
                    if f >= opt.min_overlap && f > 0.0 {
                        cand.push((f, a, b));
                    }
                }
            }
            cand.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
            let mut used_prev = vec![false; prev.lines.len()];
            for (_, a, b) in cand {
                if !used_prev[a] && ids[b] == usize::MAX {
                    used_prev[a] = true;
                    ids[b] = track[k - 1][a];
                    lifetime[ids[b]] += 1;
                }
            }
            could_continue += prev.lines.len();
            continued += used_prev.iter().filter(|&&u| u).count();
            // Grain persistence from the previous pair's line grains into this pair's.
            let here: std::collections::HashSet<i64> = p.lines.iter().flatten().copied().collect();
            let before: Vec<i64> = prev.lines.iter().flatten().copied().collect();
            if !before.is_empty() && p.grains > 0 {
                let kept = before.iter().filter(|g| here.contains(g)).count();
                persist_sum += kept as f64 / before.len() as f64;
                chance_sum += here.len() as f64 / p.grains as f64;
                persist_n += 1;
            }
        }
        for id in ids.iter_mut().filter(|id| **id == usize::MAX) {
            *id = lifetime.len();
            lifetime.push(1);
            born_at.push(k);
            if follows(k) {
                births += 1;
            }
        }
        track.push(ids);
    }
    // A track is censored when it is alive where the chain of following pairs begins
    // or ends: its first pair has no predecessor, or its last pair no successor.
    let chain_start = |k: usize| !follows(k);
    let chain_end = |k: usize| k + 1 >= pairs.len() || !follows(k + 1);
    let mut lifetime_counts: Vec<usize> = Vec::new();
    let mut censored = 0;
    for (t, &life) in lifetime.iter().enumerate() {
        let (first, last) = (born_at[t], born_at[t] + life - 1);
        if chain_start(first) || chain_end(last) {
            censored += 1;
        } else {
            if lifetime_counts.len() < life {
                lifetime_counts.resize(life, 0);
            }
            lifetime_counts[life - 1] += 1;
        }
    }
    let complete: usize = lifetime_counts.iter().sum();
    let ratio = |a: f64, b: usize| if b == 0 { f64::NAN } else { a / b as f64 };
    let lines: usize = pairs.iter().map(|p| p.lines.len()).sum();
    let with_predecessor = (0..pairs.len()).filter(|&k| follows(k)).count();
    let summary = TrackSummary {
        pairs: pairs.len(),
        lines,
        tracks: lifetime.len(),
        lines_per_pair: ratio(lines as f64, pairs.len()),
        mean_lifetime: ratio(
            lifetime_counts
                .iter()
                .enumerate()
                .map(|(l, &c)| ((l + 1) * c) as f64)
                .sum(),
            complete,
        ),
        single_pair_fraction: ratio(
            lifetime_counts.first().copied().unwrap_or(0) as f64,
            complete,
        ),
        lifetime_counts,
        censored,
        continued_fraction: ratio(continued as f64, could_continue),
        births_per_pair: ratio(births as f64, with_predecessor),
        grain_persistence: ratio(persist_sum, persist_n),
        grain_chance: ratio(chance_sum, persist_n),
    };
    LineTracks {
        track,
        lifetime,
        summary,
    }
}

/// Particle ids of each line of a pair, from the lines' member indices into `particle`.
pub fn line_ids(lines: &[super::ShearLine], particle: &[i64]) -> Vec<Vec<i64>> {
    lines
        .iter()
        .map(|l| {
            let mut v: Vec<i64> = l.members.iter().map(|&i| particle[i]).collect();
            v.sort_unstable();
            v
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Per track id, the pairs (indices) it lives in.
    fn pairs_of(tracks: &LineTracks) -> HashMap<usize, Vec<usize>> {
        let mut m: HashMap<usize, Vec<usize>> = HashMap::new();
        for (k, ids) in tracks.track.iter().enumerate() {
            for &t in ids {
                m.entry(t).or_default().push(k);
            }
        }
        m
    }

    fn pair(frame: i64, lines: Vec<Vec<i64>>) -> PairLines {
        PairLines {
            frame,
            frame_end: frame + 1,
            grains: 1000,
            lines,
        }
    }

    /// Line A lives in pairs 1–3 of 0–5, sliding by one grain per pair; B lives in pair 2
    /// only; C is alive at the start (censored); D at the end (censored).
    #[test]
    fn planted_tracks_have_their_lifetimes_and_censoring() {
        let a = |s: i64| (100 + s..120 + s).collect::<Vec<i64>>();
        let b: Vec<i64> = (500..520).collect();
        let c: Vec<i64> = (700..720).collect();
        let d: Vec<i64> = (900..920).collect();
        let pairs = vec![
            pair(0, vec![c.clone()]),
            pair(1, vec![a(0), c.clone()]),
            pair(2, vec![a(1), b.clone()]),
            pair(3, vec![a(2)]),
            pair(4, vec![]),
            pair(5, vec![d.clone()]),
        ];
        let t = link(&pairs, &LinkOptions::default());
        let by = pairs_of(&t);
        let life = |k: usize, l: usize| by[&t.track[k][l]].clone();
        assert_eq!(life(1, 0), vec![1, 2, 3], "A slides one grain a pair");
        assert_eq!(life(2, 1), vec![2], "B lives one pair");
        assert_eq!(life(0, 0), vec![0, 1], "C from the start");
        assert_eq!(life(5, 0), vec![5], "D at the end");
        let s = &t.summary;
        assert_eq!((s.tracks, s.censored), (4, 2));
        assert_eq!(s.lifetime_counts, vec![1, 0, 1]);
        assert_eq!(s.mean_lifetime, 2.0);
        assert_eq!(s.single_pair_fraction, 0.5);
        // Births in pairs 1–5 (each has a predecessor): A, B, D.
        assert_eq!(s.births_per_pair, 3.0 / 5.0);
        // Lines of pairs 0–4 that could go on: 1 + 2 + 2 + 1 + 0 = 6; continued: C, A, A.
        assert_eq!(s.continued_fraction, 3.0 / 6.0);
        assert_eq!(s.lines, 7);
    }

    /// Below the overlap threshold, or across a gap in the frames, nothing links.
    #[test]
    fn lines_that_move_away_or_pairs_apart_do_not_link() {
        let a: Vec<i64> = (0..20).collect();
        let moved: Vec<i64> = (15..35).collect(); // 5 of 20 shared: 0.25 < 0.3
        let t = link(
            &[pair(0, vec![a.clone()]), pair(1, vec![moved])],
            &LinkOptions::default(),
        );
        assert_ne!(t.track[0][0], t.track[1][0]);
        let gap = link(
            &[pair(0, vec![a.clone()]), pair(2, vec![a.clone()])],
            &LinkOptions::default(),
        );
        assert_ne!(gap.track[0][0], gap.track[1][0], "frames 1 -> 2 missing");
        // Two censored tracks, so nothing uncensored to average.
        assert!(gap.summary.mean_lifetime.is_nan());
        assert!(gap.summary.births_per_pair.is_nan());
    }

    /// A line that splits goes on as the part that shares the most; the other is born.
    #[test]
    fn a_split_line_continues_as_its_larger_share() {
        let a: Vec<i64> = (0..30).collect();
        let big: Vec<i64> = (0..20).collect();
        let small: Vec<i64> = (25..35).collect();
        let t = link(
            &[pair(0, vec![a]), pair(1, vec![small, big])],
            &LinkOptions::default(),
        );
        // Both share ≥ 0.3 of the smaller: small 5/10, big 20/20 → big wins.
        assert_eq!(t.track[1][1], t.track[0][0]);
        assert_ne!(t.track[1][0], t.track[0][0]);
    }

    /// Grain persistence: the same grains in lines again give 1; fresh grains 0; chance
    /// is the share of grains in lines.
    #[test]
    fn grain_persistence_against_chance() {
        let a: Vec<i64> = (0..50).collect();
        let b: Vec<i64> = (100..150).collect();
        let same = link(
            &[pair(0, vec![a.clone()]), pair(1, vec![a.clone()])],
            &LinkOptions::default(),
        );
        assert_eq!(same.summary.grain_persistence, 1.0);
        assert_eq!(same.summary.grain_chance, 50.0 / 1000.0);
        let fresh = link(
            &[pair(0, vec![a]), pair(1, vec![b])],
            &LinkOptions::default(),
        );
        assert_eq!(fresh.summary.grain_persistence, 0.0);
    }

    #[test]
    fn overlap_is_of_the_smaller() {
        assert_eq!(overlap(&[1, 2, 3, 4], &[3, 4]), 1.0);
        assert_eq!(overlap(&[1, 2], &[3, 4]), 0.0);
        assert_eq!(overlap(&[], &[3, 4]), 0.0);
    }
}
