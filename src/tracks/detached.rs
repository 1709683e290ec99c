//! Detections that are not part of the packing: tracker artefacts such as bar corners,
//! which sit apart from every grain. A trajectory is "detached" when, in most of its
//! frames, it has fewer than 2 detections within 1.25 D (the paper's R_c).

use super::Tracks;
use crate::neighbors::{CellList, Cutoff};
use std::collections::{BTreeMap, BTreeSet};

/// Particle ids of detached trajectories.
pub fn detached_trajectories(t: &Tracks) -> BTreeSet<i64> {
    let Some(d) = t.large_diameter() else {
        return BTreeSet::new();
    };
    let rc = 1.25 * d;
    let mut lonely: BTreeMap<i64, (usize, usize)> = BTreeMap::new();
    for (f, r) in t.frame_ranges() {
        let v = t.view(f, r);
        let pos: Vec<_> = (0..v.len()).map(|i| v.pos(i)).collect();
        let Ok(cl) = CellList::new(&pos, rc, Cutoff::Strict, v.simbox) else {
            continue;
        };
        for (i, &p) in pos.iter().enumerate() {
            let mut n = 0;
            cl.for_each_within(p, |j, _| n += usize::from(j != i));
            let e = lonely.entry(v.particle[i]).or_default();
            e.0 += usize::from(n < 2);
            e.1 += 1;
        }
    }
    lonely
        .into_iter()
        .filter(|(_, (l, n))| 2 * l > *n)
        .map(|(p, _)| p)
        .collect()
}

/// Remove every row of the given trajectories.
pub fn drop_trajectories(t: &mut Tracks, ids: &BTreeSet<i64>) {
    let keep: Vec<usize> = (0..t.len())
        .filter(|&r| !ids.contains(&t.particle[r]))
        .collect();
    t.permute(&keep);
}
