//! Grouping rows by particle id without a map per row: ids → dense indices in
//! ascending id order, and the rows of each id as a compressed (CSR) list.

/// Rows grouped by particle: `rows[start[k]..start[k + 1]]` are the rows of `ids[k]`,
/// in their original order.
pub struct ByParticle {
    pub ids: Vec<i64>,
    pub start: Vec<usize>,
    pub rows: Vec<usize>,
}

impl ByParticle {
    pub fn new(particle: &[i64]) -> ByParticle {
        let (dense, ids) = dense_ids(particle);
        let mut start = vec![0usize; ids.len() + 1];
        for &d in &dense {
            start[d as usize + 1] += 1;
        }
        for k in 0..ids.len() {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        let mut rows = vec![0usize; particle.len()];
        for (r, &d) in dense.iter().enumerate() {
            rows[fill[d as usize]] = r;
            fill[d as usize] += 1;
        }
        ByParticle { ids, start, rows }
    }
    pub fn len(&self) -> usize {
        self.ids.len()
    }
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }
    pub fn rows_of(&self, k: usize) -> &[usize] {
        &self.rows[self.start[k]..self.start[k + 1]]
    }
}

/// Per-row dense index of its id (ids numbered in ascending order) and the ids.
pub fn dense_ids(particle: &[i64]) -> (Vec<u32>, Vec<i64>) {
    let (Some(&lo), Some(&hi)) = (particle.iter().min(), particle.iter().max()) else {
        return (Vec::new(), Vec::new());
    };
    let range = (hi as i128 - lo as i128) as u128 + 1;
    if range <= 4 * particle.len() as u128 + 1024 {
        // Compact ids (trackpy, LAMMPS): a lookup table over the id range.
        let mut slot = vec![u32::MAX; range as usize];
        for &p in particle {
            slot[(p - lo) as usize] = 0;
        }
        let mut ids = Vec::new();
        for (k, s) in slot.iter_mut().enumerate() {
            if *s == 0 {
                *s = ids.len() as u32;
                ids.push(lo + k as i64);
            }
        }
        let dense = particle.iter().map(|&p| slot[(p - lo) as usize]).collect();
        (dense, ids)
    } else {
        let mut ids: Vec<i64> = particle.to_vec();
        ids.sort_unstable();
        ids.dedup();
        let dense = particle
            .iter()
            .map(|p| ids.binary_search(p).expect("present") as u32)
            .collect();
        (dense, ids)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_rows_in_order_for_compact_and_sparse_ids() {
        for ids in [
            vec![5i64, 3, 5, 9, 3, 5],
            vec![5_000_000_000, -7, 5_000_000_000, 1, -7, 5_000_000_000],
        ] {
            let g = ByParticle::new(&ids);
            let mut sorted = ids.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(g.ids, sorted);
            for k in 0..g.len() {
                let want: Vec<usize> = (0..ids.len()).filter(|&r| ids[r] == g.ids[k]).collect();
                assert_eq!(g.rows_of(k), want.as_slice());
            }
        }
    }
}
