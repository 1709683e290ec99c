//! Storage order of the sheared disks. Shear and diffusion scatter grains that started
//! side by side in memory, and at N = 65,536 the pair loop then waits on cache misses;
//! every [`RESORT_EVERY`] steps the grains are put back in cell order (by their position
//! in the primary cell), carrying each contact's history to the pair's new indices.
//! The schedule depends on the step count only, so a resumed run re-sorts exactly where
//! an uninterrupted one does.

use crate::dem::base::verlet::PairList;
use crate::dem::shear::ShearSim;
use std::collections::HashMap;

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
        // History of every pair slot that holds some, under the new indices.
        let mut new_of = vec![0u32; n];
        for (k, &i) in order.iter().enumerate() {
            new_of[i] = k as u32;
        }
        let l = &self.list;
        let mut history: HashMap<(u32, u32), f64> = HashMap::new();
        for i in 0..n.min(l.start.len().saturating_sub(1)) {
            for k in l.start[i] as usize..l.start[i + 1] as usize {
                if l.shear[k] != 0.0 {
                    let (a, b) = (new_of[i], new_of[l.j[k] as usize]);
                    history.insert((a.min(b), a.max(b)), l.shear[k]);
                }
            }
        }
        self.g.permute(&order);
        self.pred.inv_m.clear();
        self.pred.inv_i.clear();
        for v in [&mut self.fx, &mut self.fy, &mut self.tq] {
            *v = order.iter().map(|&i| v[i]).collect();
        }
        let builds = self.list.builds;
        let mut list = PairList::new(self.list.skin);
        list.build(&self.g.x, &self.g.y, &self.g.radius, self.boundary());
        for i in 0..n {
            for k in list.start[i] as usize..list.start[i + 1] as usize {
                if let Some(&h) = history.get(&(i as u32, list.j[k])) {
                    list.shear[k] = h;
                }
            }
        }
        list.builds = builds + 1;
        self.list = list;
        true
    }
}
