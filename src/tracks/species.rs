//! The two species of a bidisperse packing from measurements: a threshold on the
//! trackpy `size` of each trajectory (Otsu), and each species' radius from the packing's
//! geometry. Analysis of tracks, used by the trackpy reader.

use super::{LARGE, SMALL};
use crate::error::{Error, Result};
use crate::neighbors::{CellList, Cutoff};

/// Species per row from the per-trajectory median `size`, split into two populations by
/// Otsu's threshold (the split minimising the within-class variance).
pub fn split_by_size(particle: &[i64], size: &[f64]) -> (Vec<i32>, f64, usize, usize) {
    use rayon::prelude::*;
    // Sizes grouped by trajectory (a counting sort), then a median per group.
    let (dense, ids) = super::dense_ids(particle);
    let mut start = vec![0usize; ids.len() + 1];
    for &d in &dense {
        start[d as usize + 1] += 1;
    }
    for k in 0..ids.len() {
        start[k + 1] += start[k];
    }
    let mut fill = start[..ids.len()].to_vec();
    let mut grouped = vec![0.0; size.len()];
    for (&d, &v) in dense.iter().zip(size) {
        grouped[fill[d as usize]] = v;
        fill[d as usize] += 1;
    }
    let mut groups = Vec::with_capacity(ids.len());
    let mut rest = grouped.as_mut_slice();
    for k in 0..ids.len() {
        let (g, r) = rest.split_at_mut(start[k + 1] - start[k]);
        groups.push(g);
        rest = r;
    }
    let med: Vec<f64> = groups
        .into_par_iter()
        .map(crate::stats::median_select)
        .collect();
    let mut vals = med.clone();
    vals.sort_by(f64::total_cmp);
    let threshold = otsu(&vals);
    let large: Vec<bool> = med.iter().map(|&m| m > threshold).collect();
    let n_large = large.iter().filter(|&&l| l).count();
    let species = dense
        .iter()
        .map(|&d| if large[d as usize] { LARGE } else { SMALL })
        .collect();
    (species, threshold, med.len() - n_large, n_large)
}

/// Otsu threshold of sorted values: midpoint of the split with the largest
/// between-class variance.
pub fn otsu(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n < 2 {
        return sorted.first().copied().unwrap_or(0.0);
    }
    let total: f64 = sorted.iter().sum();
    let mut best = (f64::NEG_INFINITY, 0.5 * (sorted[0] + sorted[n - 1]));
    let mut left = 0.0;
    for k in 1..n {
        left += sorted[k - 1];
        if sorted[k] == sorted[k - 1] {
            continue;
        }
        let (w0, w1) = (k as f64, (n - k) as f64);
        let (m0, m1) = (left / w0, (total - left) / w1);
        let between = w0 * w1 * (m0 - m1).powi(2);
        if between > best.0 {
            best = (between, 0.5 * (sorted[k - 1] + sorted[k]));
        }
    }
    best.1
}

/// Radii from geometry: in a dense packing most grains touch their nearest neighbour of
/// the same species, so half the median nearest same-species distance estimates each
/// radius. Uses the frame with the most detections.
pub fn estimate_radii(frame: &[i64], x: &[f64], y: &[f64], species: &[i32]) -> Result<(f64, f64)> {
    // Detections per frame through dense frame indices (a map per row costs more than
    // the whole neighbour search below).
    let (dense, frames) = super::dense_ids(frame);
    let mut counts = vec![0usize; frames.len()];
    for &d in &dense {
        counts[d as usize] += 1;
    }
    let best = (0..frames.len())
        .max_by_key(|&k| (counts[k], std::cmp::Reverse(frames[k])))
        .map(|k| frames[k])
        .unwrap_or(0);
    let idx: Vec<usize> = (0..frame.len()).filter(|&i| frame[i] == best).collect();
    let mut out = [0.0; 2];
    for (k, sp) in [SMALL, LARGE].into_iter().enumerate() {
        let pts: Vec<crate::geom::Vec2> = idx
            .iter()
            .filter(|&&i| species[i] == sp)
            .map(|&i| crate::geom::Vec2::new(x[i], y[i]))
            .collect();
        if pts.len() < 2 {
            return Err(Error::Other(format!(
                "cannot estimate the radius of species {sp}: fewer than 2 grains; pass --radii SMALL,LARGE"
            )));
        }
        // Search radius: a few mean spacings of this species.
        let (xmin, xmax) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.x), a.1.max(p.x)));
        let (ymin, ymax) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.y), a.1.max(p.y)));
        let spacing = (((xmax - xmin) * (ymax - ymin)).max(1e-300) / pts.len() as f64).sqrt();
        let cl = CellList::new(&pts, 3.0 * spacing, Cutoff::Strict, None)?;
        let mut nn: Vec<f64> = pts
            .iter()
            .enumerate()
            .filter_map(|(i, &p)| {
                let mut best = f64::INFINITY;
                cl.for_each_within(p, |j, d| {
                    if j != i {
                        best = best.min(d.norm());
                    }
                });
                best.is_finite().then_some(best)
            })
            .collect();
        nn.sort_by(f64::total_cmp);
        out[k] = 0.5 * crate::stats::median_sorted(&nn);
    }
    Ok((out[0], out[1]))
}
