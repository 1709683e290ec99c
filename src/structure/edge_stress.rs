//! Local stress against distance from the pillar's lateral edges (li-granular-pillars
//! Sec. V: the grains of the interior "experience larger inter-particle contact forces,
//! resulting in larger local stress in the interior region of the pillar. The rate of
//! increase for local stress as a function of distance to the lateral edges of the
//! pillars is found to be very close for different-sized pillars").
//!
//! - *Local stress* of grain i: the mean normal stress of its Love–Weber tensor over its
//!   own disk, σ_i = (1/(π R_i²)) Σ_c (R_i n_c) ⊗ F_c, whose half trace is
//!   p_i = Σ_c F_n,c / (2π R_i): the sum of its normal contact forces (the simulator's
//!   `f_n`) over 2π R_i. The lever arm is taken as R_i (overlaps are small). With forces
//!   in m g μ and lengths in D, p_i is in m g μ/D, the unit of the flow stress.
//! - *Distance to the edge* d_i: the pillar cut into slabs one D thick as its outline is
//!   (`Outline`); in grain i's slab, the smaller of x_i − left and right − x_i, the
//!   slab's outermost grain edges. So d_i ≥ R_i; in D.
//! - The bars' layers are left out: grains whose centres lie within `BAR_LAYER_D` of the
//!   lowest or the highest grain edge carry the bar's force into the pillar, not the
//!   bulk's stress.
//! - *Profile*: the mean p_i in bins of d one D wide, pooled over snapshots; the *rate*
//!   is the least-squares slope of the bins' means against their centres over
//!   d ≤ `FIT_D`, each bin weighted by its grains (m g μ/D per D).

use crate::geom::Vec2;
use crate::structure::Outline;

/// Layers at the bars left out, in D.
pub const BAR_LAYER_D: f64 = 2.0;
/// The rate is fitted over d ≤ this (D): within the half-width of the smallest
/// pillars the paper compares (N = 1000: W0 ≈ 20 D, so W/2 ≈ 15 D at ε ≥ 0.1), where
/// the stress still rises at every size.
pub const FIT_D: f64 = 6.0;

/// Accumulates snapshots of one run into a profile on bins one D wide.
#[derive(Debug, Clone, Default)]
pub struct EdgeStress {
    sum: Vec<f64>,
    count: Vec<usize>,
    pub snapshots: usize,
}

/// The mean local stress against distance from the nearer lateral edge.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EdgeProfile {
    /// Bin centres (D) and the mean p (m g μ/D; NaN where a bin is empty).
    pub d_over_d: Vec<f64>,
    pub p: Vec<f64>,
    pub grains: Vec<usize>,
    /// The rate dp/dd over d ≤ `FIT_D` (m g μ/D per D); NaN with fewer than two bins.
    pub rate: f64,
    pub snapshots: usize,
}

impl EdgeStress {
    /// Adds one snapshot: centres and radii in D, each grain's normal contact force sum
    /// `f_n` in m g μ (non-finite entries are skipped).
    pub fn add(&mut self, pos: &[Vec2], radius: &[f64], f_n: &[f64]) {
        let o = Outline::of(pos, radius, 1.0);
        let top = pos
            .iter()
            .zip(radius)
            .map(|(p, r)| p.y + r)
            .fold(f64::NEG_INFINITY, f64::max);
        // Slab index (from the lowest grain edge) to the outline's row, which skips
        // empty slabs.
        let mut row = Vec::new();
        for (k, y) in o.y.iter().enumerate() {
            let slab = (y - o.y0 - 0.5).round() as usize;
            row.resize(slab + 1, None);
            row[slab] = Some(k);
        }
        for i in 0..pos.len() {
            let (p, r, f) = (pos[i], radius[i], f_n[i]);
            if !(p.is_finite() && r > 0.0 && f.is_finite()) {
                continue;
            }
            if p.y - o.y0 < BAR_LAYER_D || top - p.y < BAR_LAYER_D {
                continue;
            }
            let slab = (p.y - o.y0).floor().max(0.0) as usize;
            let Some(&Some(k)) = row.get(slab) else {
                continue;
            };
            let d = (p.x - o.left[k]).min(o.right[k] - p.x).max(0.0);
            let b = d.floor() as usize;
            if b >= self.sum.len() {
                self.sum.resize(b + 1, 0.0);
                self.count.resize(b + 1, 0);
            }
            self.sum[b] += f / (2.0 * std::f64::consts::PI * r);
            self.count[b] += 1;
        }
        self.snapshots += 1;
    }

    /// The profile of the snapshots added.
    pub fn profile(&self) -> EdgeProfile {
        let n = self.sum.len();
        let p: Vec<f64> = (0..n)
            .map(|b| {
                if self.count[b] > 0 {
                    self.sum[b] / self.count[b] as f64
                } else {
                    f64::NAN
                }
            })
            .collect();
        let d: Vec<f64> = (0..n).map(|b| b as f64 + 0.5).collect();
        let fit: Vec<usize> = (0..n)
            .filter(|&b| d[b] <= FIT_D && self.count[b] > 0)
            .collect();
        let rate = if fit.len() >= 2 {
            let w = |b: usize| self.count[b] as f64;
            let sw: f64 = fit.iter().map(|&b| w(b)).sum();
            let dm = fit.iter().map(|&b| w(b) * d[b]).sum::<f64>() / sw;
            let pm = fit.iter().map(|&b| w(b) * p[b]).sum::<f64>() / sw;
            let sxx: f64 = fit.iter().map(|&b| w(b) * (d[b] - dm).powi(2)).sum();
            let sxy: f64 = fit.iter().map(|&b| w(b) * (d[b] - dm) * (p[b] - pm)).sum();
            sxy / sxx
        } else {
            f64::NAN
        };
        EdgeProfile {
            d_over_d: d,
            p,
            grains: self.count.clone(),
            rate,
            snapshots: self.snapshots,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rectangular block of grains on a square lattice (spacing 1 D, radius 0.5 D)
    /// whose contact-force sum rises linearly from the edges, f = 2π R · c · d, so
    /// p = c d exactly: the profile's bins read c × their grains' distances and the rate
    /// is c; grains in the bar layers, however loaded, change nothing.
    #[test]
    fn a_linear_stress_rise_reads_its_rate() {
        let (nx, ny) = (30, 40);
        let c = 0.7;
        let mut pos = Vec::new();
        let mut f = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let p = Vec2::new(i as f64 + 0.5, j as f64 + 0.5);
                let d = p.x.min(nx as f64 - p.x);
                pos.push(p);
                let bar = (j as f64) < BAR_LAYER_D || (ny - j) as f64 <= BAR_LAYER_D;
                f.push(if bar {
                    1e6
                } else {
                    2.0 * std::f64::consts::PI * 0.5 * c * d
                });
            }
        }
        let r = vec![0.5; pos.len()];
        let mut acc = EdgeStress::default();
        acc.add(&pos, &r, &f);
        acc.add(&pos, &r, &f);
        let prof = acc.profile();
        assert_eq!(prof.snapshots, 2);
        // Grain centres at d = 0.5, 1.5, ...: bin b holds d = b + 0.5.
        for b in 0..10 {
            assert!((prof.p[b] - c * (b as f64 + 0.5)).abs() < 1e-12, "{prof:?}");
        }
        // Two columns per bin, 36 rows away from the bars, two snapshots.
        assert_eq!(prof.grains[0], 2 * 2 * (ny - 4));
        assert!((prof.rate - c).abs() < 1e-12, "{}", prof.rate);
    }

    /// The edges follow the outline: in a pillar wider at the bottom than at the top,
    /// d is measured in each grain's own slab.
    #[test]
    fn distances_are_to_the_slab_edges() {
        let mut pos = Vec::new();
        for j in 0..20 {
            let w = if j < 10 { 20 } else { 10 };
            for i in 0..w {
                pos.push(Vec2::new(i as f64 + 0.5, j as f64 + 0.5));
            }
        }
        let r = vec![0.5; pos.len()];
        // f such that p = d when d is measured in the grain's own slab.
        let f: Vec<f64> = pos
            .iter()
            .map(|p| {
                let w = if p.y < 10.0 { 20.0 } else { 10.0 };
                std::f64::consts::PI * p.x.min(w - p.x)
            })
            .collect();
        let mut acc = EdgeStress::default();
        acc.add(&pos, &r, &f);
        let prof = acc.profile();
        for (b, p) in prof.p.iter().enumerate() {
            assert!((p - (b as f64 + 0.5)).abs() < 1e-12, "bin {b}: {p}");
        }
        assert_eq!(prof.p.len(), 10);
        // Non-finite inputs are skipped, not counted.
        let mut bad = f.clone();
        bad[45] = f64::NAN;
        let mut acc2 = EdgeStress::default();
        acc2.add(&pos, &r, &bad);
        let total: usize = acc2.profile().grains.iter().sum();
        assert_eq!(total + 1, prof.grains.iter().sum::<usize>());
    }
}
