//! Storage order of the sheared disks. Shear and diffusion scatter grains that started
//! side by side in memory, and at N = 65,536 the pair loop then waits on cache misses;
//! every [`RESORT_EVERY`] steps the grains are put back in cell order (by their position
//! in the primary cell), carrying each contact's history to the pair's new indices.
//! The schedule depends on the step count only, so a resumed run re-sorts exactly where
//! an uninterrupted one does.

use crate::dem::base::verlet::PairList;
use crate::dem::shear::ShearSim;

/// Steps between re-sorts (a sort costs about as much as a few steps at any N).
pub const RESORT_EVERY: u64 = 1000;

impl ShearSim {
    /// Put the grains in cell order (rows of cells of side 2 d_s, then columns, then
    /// id) and rebuild the pair list, keeping every contact's history. Returns whether
    /// the order changed.
    pub fn resort(&mut self) -> bool {
        let n = self.g.len();
        let cell = 2.0;
        let keys: Vec<(i64, i64, i64)> = (0..n)
            .map(|i| {
                let (x, y) = self.wrapped(i);
                ((y / cell) as i64, (x / cell) as i64, self.g.id[i])
            })
            .collect();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_unstable_by_key(|&i| keys[i]);
        if order.iter().enumerate().all(|(k, &i)| k == i) {
            return false;
        }
        // The contacts' histories under the new indices, as a half list (j > i, rows
        // ascending) the build below carries them from, pair by pair, as any build
        // carries the previous list's.
        let mut new_of = vec![0u32; n];
        for (k, &i) in order.iter().enumerate() {
            new_of[i] = k as u32;
        }
        self.list = remapped_history(&mut self.list, &new_of);
        self.g.permute(&order);
        self.pred.inv_m.clear();
        self.pred.inv_i.clear();
        for v in [&mut self.fx, &mut self.fy, &mut self.tq] {
            *v = order.iter().map(|&i| v[i]).collect();
        }
        let builds = self.list.builds;
        // On the steps' threads where they run (the same list for any number).
        let team = self.lent_team();
        self.list.spare.team = team.clone();
        let b = self.boundary();
        let g = &self.g;
        let mut build = || self.list.build(&g.x, &g.y, &g.radius, b);
        match team.as_deref() {
            Some(t) => t.uncounted(build),
            None => build(),
        }
        self.list.spare.team = None;
        self.list.builds = builds + 1;
        true
    }
}

/// The pairs of `list` that hold a tangential spring, under the new indices `new_of`
/// (old index → new), as a half list in CSR form (partners ascending) with those
/// springs: what a build needs to carry each contact's history to the new order (a
/// row-by-row merge, no hashing). Its skin and build count are `list`'s, its
/// buffers `list`'s spares.
fn remapped_history(list: &mut PairList, new_of: &[u32]) -> PairList {
    let n = new_of.len();
    let rows = n.min(list.start.len().saturating_sub(1));
    let mut out = PairList::new(list.skin);
    out.builds = list.builds;
    out.spare = std::mem::take(&mut list.spare);
    let list = &*list;
    // Counted by row, placed, then each row (a few pairs) sorted.
    let held = || {
        (0..rows).flat_map(move |i| {
            (list.start[i] as usize..list.start[i + 1] as usize)
                .filter(|&k| list.shear[k] != 0.0)
                .map(move |k| {
                    let (a, b) = (new_of[i], new_of[list.j[k] as usize]);
                    (a.min(b), a.max(b), list.shear[k])
                })
        })
    };
    out.start = vec![0; n + 1];
    for (a, _, _) in held() {
        out.start[a as usize + 1] += 1;
    }
    for a in 0..n {
        out.start[a + 1] += out.start[a];
    }
    let total = out.start[n] as usize;
    let mut next: Vec<u32> = out.start[..n].to_vec();
    let mut row = vec![(0u32, 0.0f64); total];
    for (a, b, h) in held() {
        let at = &mut next[a as usize];
        row[*at as usize] = (b, h);
        *at += 1;
    }
    for a in 0..n {
        // One entry per pair: a half list holds each pair once.
        row[out.start[a] as usize..out.start[a + 1] as usize].sort_unstable_by_key(|e| e.0);
    }
    out.j = row.iter().map(|e| e.0).collect();
    out.shear = row.iter().map(|e| e.1).collect();
    out
}
