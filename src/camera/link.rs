//! Linking located grains into trajectories, the Crocker–Grier way as trackpy 0.7 does
//! (`trackpy.link`): frame by frame, each feature of the new frame is linked to at most
//! one particle of the frames before, within `search_range`.
//!
//! Per frame `t`:
//! - The *particles* that may link are those seen last at a frame `f` with
//!   `t − f ≤ memory + 1`: a particle may vanish for up to `memory` frames (frame
//!   numbers, so a frame missing from the data counts as a frame in which every
//!   particle vanished, as in trackpy).
//! - Each particle is looked for at its predicted position: with `predict`, its last
//!   position plus its last displacement per frame times `t − f` (a particle seen once
//!   predicts no motion); without, its last position.
//! - A feature's candidates are the particles within `search_range` of it (distance
//!   ≤ search_range), its [`MAX_CANDIDATES`] nearest at most (trackpy's
//!   `MAX_NEIGHBORS`). The candidate links split into *subnets*: the connected
//!   components of particles and features.
//! - A subnet of at most `subnet_limit` particles is solved exactly: the links that
//!   minimise the sum of the squared link lengths plus `search_range²` for each of its
//!   particles left unlinked (trackpy's cost: a feature left unlinked costs nothing; it
//!   starts a trajectory). A larger subnet is solved greedily, shortest links first,
//!   and counted in the report ([`LinkReport::subnets_greedy`]); trackpy raises
//!   `SubnetOversizeException` there instead.
//! - A feature without a link starts a new trajectory; nothing is linked beyond
//!   `search_range`.
//!
//! The exact solution is an assignment problem, solved with the Hungarian algorithm
//! (O(n³) in the subnet's size, where trackpy's depth-first search can take exponential
//! time on a large subnet); both find the minimum, so they agree except where two
//! assignments cost exactly the same.
//!
//! Candidates come from a cell list of the particles (cells one search range wide,
//! sorted by cell), so a frame costs O(n log n). Subnets are solved in parallel, each
//! on its own; the result does not depend on the number of threads.

use super::Feature;
use crate::error::{Error, Result};
use rayon::prelude::*;

/// trackpy's default largest subnet solved exactly (`Linker.MAX_SUB_NET_SIZE`).
pub const DEFAULT_SUBNET_LIMIT: usize = 30;

/// The most candidate particles a feature keeps, its nearest (trackpy's
/// `Linker.MAX_NEIGHBORS`).
pub const MAX_CANDIDATES: usize = 10;

/// How to link, in trackpy's names.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LinkOptions {
    /// Largest distance a particle may move between frames (from its predicted
    /// position), px.
    pub search_range: f64,
    /// Frames a particle may vanish and come back as the same particle.
    pub memory: usize,
    /// Look for each particle at its last position plus its last displacement per frame.
    pub predict: bool,
    /// Largest subnet (in particles) solved exactly; larger ones are solved greedily.
    pub subnet_limit: usize,
}

impl LinkOptions {
    /// `search_range` px, no memory, prediction on, trackpy's subnet limit.
    pub fn new(search_range: f64) -> Self {
        Self {
            search_range,
            memory: 0,
            predict: true,
            subnet_limit: DEFAULT_SUBNET_LIMIT,
        }
    }
}

impl LinkOptions {
    /// An error naming the first parameter out of its domain.
    pub fn check(&self) -> Result<()> {
        let r = self.search_range;
        if !(r > 0.0 && r.is_finite()) {
            return Err(Error::param(
                "search_range",
                format!("{r} px; must be a finite number > 0"),
            ));
        }
        Ok(())
    }
}

/// What linking did.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct LinkReport {
    pub features: usize,
    /// Frames holding at least one feature.
    pub frames: usize,
    /// Distinct particles (trajectories).
    pub trajectories: usize,
    /// Links made (each joins a feature to its particle's previous feature).
    pub links: usize,
    /// Subnets (connected candidate links, at least one particle and one feature)
    /// solved exactly, one-to-one ones included.
    pub subnets_exact: usize,
    /// Particles in the largest subnet.
    pub largest_subnet: usize,
    /// Subnets above the subnet limit, solved greedily (shortest links first).
    pub subnets_greedy: usize,
    /// Features (of the new frames) in those subnets.
    pub features_greedy: usize,
    /// Trajectories whose last feature is before the last frame.
    pub ended: usize,
    /// Links across one or more frames in which the particle was not seen (memory).
    pub gaps_bridged: usize,
}

/// A particle id per feature (in the input's order) and the report.
#[derive(Debug, Clone, PartialEq)]
pub struct Linked {
    /// Ids 0, 1, 2, … in order of first appearance (frame, then input order).
    pub particle: Vec<i64>,
    pub report: LinkReport,
}

/// A particle as linking knows it: where and when it was seen last, and its last
/// displacement per frame.
#[derive(Debug, Clone, Copy)]
struct Track {
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    frame: i64,
}

/// One subnet of a frame: its particles (indices into the frame's particles) and
/// features (indices into the frame's features), each in ascending order.
#[derive(Debug, Default)]
struct Subnet {
    sources: Vec<u32>,
    dests: Vec<u32>,
}

/// Link `features` (any order; rows of one frame keep their input order) into
/// trajectories.
pub fn link(features: &[Feature], opt: &LinkOptions) -> Result<Linked> {
    opt.check()?;
    if let Some((i, f, c, v)) = features.iter().enumerate().find_map(|(i, f)| {
        [("x", f.x), ("y", f.y)]
            .into_iter()
            .find(|(_, v)| !v.is_finite())
            .map(|(c, v)| (i, f.frame, c, v))
    }) {
        return Err(Error::param(
            "features",
            format!("row {i} (frame {f}): {c} = {v} is not a finite position"),
        ));
    }
    let n = features.len();
    if u32::try_from(n).is_err() {
        return Err(Error::param(
            "features",
            format!("{n} features; at most {} can be linked at once", u32::MAX),
        ));
    }
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by_key(|&i| features[i as usize].frame);

    let mut report = LinkReport {
        features: n,
        ..LinkReport::default()
    };
    let mut particle = vec![-1i64; n];
    let mut tracks: Vec<Track> = Vec::new();
    // Particles that may still link, by id (ascending: new ids are appended).
    let mut active: Vec<u32> = Vec::new();
    let reach = opt.memory as i128 + 1;
    let mut scratch = Scratch::default();

    for group in order.chunk_by(|&a, &b| features[a as usize].frame == features[b as usize].frame) {
        let t = features[group[0] as usize].frame;
        report.frames += 1;
        active.retain(|&k| t as i128 - tracks[k as usize].frame as i128 <= reach);
        let predicted: Vec<(f64, f64)> = active
            .iter()
            .map(|&k| {
                let p = &tracks[k as usize];
                if opt.predict {
                    let dt = (t as i128 - p.frame as i128) as f64;
                    (p.x + p.vx * dt, p.y + p.vy * dt)
                } else {
                    (p.x, p.y)
                }
            })
            .collect();
        let dests: Vec<(f64, f64)> = group
            .iter()
            .map(|&i| (features[i as usize].x, features[i as usize].y))
            .collect();
        let assigned = scratch.link_frame(&predicted, &dests, opt, &mut report);

        let mut born = Vec::new();
        for (&row, a) in group.iter().zip(&assigned) {
            let f = &features[row as usize];
            match *a {
                Some(s) => {
                    let k = active[s as usize];
                    let p = &mut tracks[k as usize];
                    let dt = t as i128 - p.frame as i128;
                    if dt > 1 {
                        report.gaps_bridged += 1;
                    }
                    p.vx = (f.x - p.x) / dt as f64;
                    p.vy = (f.y - p.y) / dt as f64;
                    (p.x, p.y, p.frame) = (f.x, f.y, t);
                    particle[row as usize] = k as i64;
                    report.links += 1;
                }
                None => {
                    let k = tracks.len() as u32;
                    tracks.push(Track {
                        x: f.x,
                        y: f.y,
                        vx: 0.0,
                        vy: 0.0,
                        frame: t,
                    });
                    particle[row as usize] = k as i64;
                    born.push(k);
                }
            }
        }
        active.extend(born);
    }
    report.trajectories = tracks.len();
    if let Some(&last) = order.last() {
        let last = features[last as usize].frame;
        report.ended = tracks.iter().filter(|p| p.frame < last).count();
    }
    Ok(Linked { particle, report })
}

/// Buffers reused from frame to frame.
#[derive(Default)]
struct Scratch {
    /// Particles by cell: (cell row, cell column, particle).
    cells: Vec<(i64, i64, u32)>,
    /// Candidates of feature j: `cand[cand_at[j]..cand_at[j + 1]]`, (squared distance,
    /// particle), nearest first.
    cand: Vec<(f64, u32)>,
    cand_at: Vec<usize>,
    /// Union–find over particles (0..ns) and features (ns..ns + nd).
    parent: Vec<u32>,
}

impl Scratch {
    /// The particle (index into `sources`) each feature of `dests` links to.
    fn link_frame(
        &mut self,
        sources: &[(f64, f64)],
        dests: &[(f64, f64)],
        opt: &LinkOptions,
        report: &mut LinkReport,
    ) -> Vec<Option<u32>> {
        let r = opt.search_range;
        let r2 = r * r;
        let (ns, nd) = (sources.len(), dests.len());
        let mut assigned = vec![None; nd];
        if ns == 0 {
            return assigned;
        }
        // Cells one search range wide: a feature's candidates lie in the 3 × 3 cells
        // around its own. (`as` saturates: absurd coordinates share a cell, which costs
        // time, never a candidate.)
        let cell = |v: f64| (v / r).floor() as i64;
        self.cells.clear();
        self.cells.extend(
            sources
                .iter()
                .enumerate()
                .map(|(s, &(x, y))| (cell(y), cell(x), s as u32)),
        );
        self.cells.sort_unstable();
        self.cand.clear();
        self.cand_at.clear();
        self.cand_at.push(0);
        for &(x, y) in dests {
            let (cy, cx) = (cell(y), cell(x));
            let start = self.cand.len();
            for row in [cy.saturating_sub(1), cy, cy.saturating_add(1)] {
                let lo = (row, cx.saturating_sub(1), 0);
                let hi = (row, cx.saturating_add(1), u32::MAX);
                let a = self.cells.partition_point(|c| *c < lo);
                for &(_, _, s) in self.cells[a..].iter().take_while(|c| **c <= hi) {
                    let (sx, sy) = sources[s as usize];
                    let d2 = (sx - x) * (sx - x) + (sy - y) * (sy - y);
                    if d2 <= r2 {
                        self.cand.push((d2, s));
                    }
                }
            }
            let c = &mut self.cand[start..];
            c.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            // A row saturated at the end of i64 is visited twice; its particles once.
            let mut keep = 0;
            for i in 0..c.len() {
                if keep == 0 || c[i] != c[keep - 1] {
                    c[keep] = c[i];
                    keep += 1;
                }
            }
            let keep = keep.min(MAX_CANDIDATES);
            self.cand.truncate(start + keep);
            self.cand_at.push(self.cand.len());
        }

        // Subnets: connected components of particles and features.
        self.parent.clear();
        self.parent.extend(0..(ns + nd) as u32);
        for j in 0..nd {
            for c in self.cand_at[j]..self.cand_at[j + 1] {
                let s = self.cand[c].1;
                union(&mut self.parent, s, (ns + j) as u32);
            }
        }
        // Numbered in the order of their first feature; particles in ascending order.
        let mut id_of_root = vec![u32::MAX; ns + nd];
        let mut subnets: Vec<Subnet> = Vec::new();
        for j in 0..nd {
            if self.cand_at[j] == self.cand_at[j + 1] {
                continue; // no candidate: a new particle
            }
            let root = find(&mut self.parent, (ns + j) as u32) as usize;
            if id_of_root[root] == u32::MAX {
                id_of_root[root] = subnets.len() as u32;
                subnets.push(Subnet::default());
            }
            subnets[id_of_root[root] as usize].dests.push(j as u32);
        }
        for s in 0..ns {
            let root = find(&mut self.parent, s as u32) as usize;
            // A particle without candidates is its own root, with no subnet: lost.
            if id_of_root[root] != u32::MAX {
                subnets[id_of_root[root] as usize].sources.push(s as u32);
            }
        }

        let cand = &self.cand;
        let cand_at = &self.cand_at;
        let mut nontrivial = Vec::new();
        for sn in subnets {
            report.largest_subnet = report.largest_subnet.max(sn.sources.len());
            if sn.sources.len() == 1 && sn.dests.len() == 1 {
                assigned[sn.dests[0] as usize] = Some(sn.sources[0]);
                report.subnets_exact += 1;
            } else if sn.sources.len() <= opt.subnet_limit {
                report.subnets_exact += 1;
                nontrivial.push((sn, true));
            } else {
                report.subnets_greedy += 1;
                report.features_greedy += sn.dests.len();
                nontrivial.push((sn, false));
            }
        }
        let solved: Vec<Vec<(u32, u32)>> = nontrivial
            .par_iter()
            .with_min_len(4)
            .map(|(sn, exact)| {
                let edges = |j: u32| {
                    cand[cand_at[j as usize]..cand_at[j as usize + 1]]
                        .iter()
                        .map(move |&(d2, s)| (d2, s))
                };
                if *exact {
                    solve_exact(sn, edges, r2)
                } else {
                    solve_greedy(sn, edges)
                }
            })
            .collect();
        for links in solved {
            for (s, j) in links {
                assigned[j as usize] = Some(s);
            }
        }
        assigned
    }
}

fn find(parent: &mut [u32], mut a: u32) -> u32 {
    while parent[a as usize] != a {
        let up = parent[parent[a as usize] as usize];
        parent[a as usize] = up;
        a = up;
    }
    a
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // The smaller root wins: the forest does not depend on anything but the order
        // of the unions, which is fixed.
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

/// The links (particle, feature) of `sn` that minimise Σ d² over the links plus r² per
/// particle left unlinked. `edges(j)`: feature j's candidates (d², particle).
///
/// An assignment of the particles (rows) to the features and to one "unlinked" column
/// per particle (cost r² for any particle), solved with the Hungarian algorithm
/// (shortest augmenting paths with potentials; rows ≤ columns).
fn solve_exact<I>(sn: &Subnet, edges: impl Fn(u32) -> I, r2: f64) -> Vec<(u32, u32)>
where
    I: Iterator<Item = (f64, u32)>,
{
    let (ns, nd) = (sn.sources.len(), sn.dests.len());
    let m = nd + ns;
    // Dense cost matrix, rows = particles, columns = features then the unlinked
    // columns; absent links cost infinity.
    let mut cost = vec![f64::INFINITY; ns * m];
    for (jl, &j) in sn.dests.iter().enumerate() {
        for (d2, s) in edges(j) {
            let sl = sn
                .sources
                .binary_search(&s)
                .expect("candidate in its subnet");
            cost[sl * m + jl] = d2;
        }
    }
    for sl in 0..ns {
        cost[sl * m + nd..(sl + 1) * m].fill(r2);
    }
    let col_of_row = hungarian(ns, m, &cost);
    col_of_row
        .into_iter()
        .enumerate()
        .filter(|&(_, c)| c < nd)
        .map(|(sl, c)| (sn.sources[sl], sn.dests[c]))
        .collect()
}

/// Minimum-cost assignment of `n` rows to distinct columns of `m ≥ n` (cost row-major,
/// every row with a finite choice among any n columns left): the column of each row.
fn hungarian(n: usize, m: usize, cost: &[f64]) -> Vec<usize> {
    // 1-based, column 0 the virtual start (e-maxx's formulation).
    let mut u = vec![0.0f64; n + 1];
    let mut v = vec![0.0f64; m + 1];
    let mut row_of = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    let mut minv = vec![0.0f64; m + 1];
    let mut used = vec![false; m + 1];
    for i in 1..=n {
        row_of[0] = i;
        let mut j0 = 0;
        minv.fill(f64::INFINITY);
        used.fill(false);
        loop {
            used[j0] = true;
            let i0 = row_of[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0;
            let row = &cost[(i0 - 1) * m..i0 * m];
            for j in 1..=m {
                if used[j] {
                    continue;
                }
                let cur = row[j - 1] - u[i0] - v[j];
                if cur < minv[j] {
                    minv[j] = cur;
                    way[j] = j0;
                }
                if minv[j] < delta {
                    delta = minv[j];
                    j1 = j;
                }
            }
            debug_assert!(delta.is_finite(), "an unlinked column is always free");
            for j in 0..=m {
                if used[j] {
                    u[row_of[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if row_of[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            row_of[j0] = row_of[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut col_of_row = vec![usize::MAX; n];
    for j in 1..=m {
        if row_of[j] != 0 {
            col_of_row[row_of[j] - 1] = j - 1;
        }
    }
    col_of_row
}

/// Shortest candidate links first, each taken when its particle and feature are both
/// free; ties broken by particle, then feature.
fn solve_greedy<I>(sn: &Subnet, edges: impl Fn(u32) -> I) -> Vec<(u32, u32)>
where
    I: Iterator<Item = (f64, u32)>,
{
    let mut all: Vec<(f64, u32, u32)> = sn
        .dests
        .iter()
        .flat_map(|&j| edges(j).map(move |(d2, s)| (d2, s, j)))
        .collect();
    all.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut s_taken = std::collections::HashSet::new();
    let mut d_taken = std::collections::HashSet::new();
    let mut out = Vec::new();
    for (_, s, j) in all {
        if !s_taken.contains(&s) && !d_taken.contains(&j) {
            s_taken.insert(s);
            d_taken.insert(j);
            out.push((s, j));
        }
    }
    out
}

#[cfg(test)]
mod tests {
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

    /// `cargo test --release --lib camera::link::tests::timing -- --ignored --nocapture`:
    /// the time to link 40 frames of 1000 grains (best of 5).
    #[test]
    #[ignore]
    fn timing() {
        let feats = movie(40, 0.5, 1);
        for (r, limit) in [(8.0, DEFAULT_SUBNET_LIMIT), (12.0, DEFAULT_SUBNET_LIMIT)] {
            let opt = LinkOptions {
                memory: 3,
                subnet_limit: limit,
                ..LinkOptions::new(r)
            };
            let mut best = f64::INFINITY;
            let mut rep = None;
            for _ in 0..5 {
                let t0 = std::time::Instant::now();
                let out = link(&feats, &opt).unwrap();
                best = best.min(t0.elapsed().as_secs_f64());
                rep = Some(out.report);
            }
            eprintln!(
                "{} features, search_range {r}: {:.2} ms on {} threads; {:?}",
                feats.len(),
                best * 1e3,
                rayon::current_num_threads(),
                rep.unwrap()
            );
        }
    }
}
