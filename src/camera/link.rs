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
mod tests;
