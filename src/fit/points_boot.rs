//! The `points` estimator's bootstrap without copying the drawn samples. A replicate
//! draws start times with replacement; its log-space cost at trial η_c is the variance
//! of the log residuals of the drawn starts' samples, each start counted as often as it
//! was drawn. With the residuals' sums Σr and Σr² kept per start, that cost is a
//! weighted sum over starts: the grid scan that brackets η_c (29 nodes) is computed once
//! for all replicates, and each of Brent's evaluations passes only over the samples of
//! the starts drawn (about 63 % of them) without building the resampled list. The result
//! equals `fit_method` on the resampled samples to rounding (sums in another order).

use super::estimate::{GRID_STEPS, LN_4, PointFit, grid_node, refine};
use super::model::{ln_shape_of_ln, residual_sums, residual_sums_pair};
use argmin::core::CostFunction;
use rayon::prelude::*;
use std::cell::RefCell;

/// Samples grouped by start, in log space, with the grid scan's per-start sums.
pub struct PointsBoot {
    /// Start g's samples are `offsets[g]..offsets[g + 1]`.
    offsets: Vec<usize>,
    ln_eta: Vec<f64>,
    ln_y: Vec<f64>,
    /// `grid[k][g]`: (Σr, Σr²) of start g at grid node k, r shifted by `shift(node k)`.
    grid: Vec<Vec<(f64, f64)>>,
}

impl PointsBoot {
    /// `group` holds dense start indices below `n_groups`; (η, y) positive and finite.
    pub fn new(eta: &[f64], y: &[f64], group: &[u32], n_groups: usize) -> Self {
        let mut offsets = vec![0usize; n_groups + 1];
        for &g in group {
            offsets[g as usize + 1] += 1;
        }
        for g in 0..n_groups {
            offsets[g + 1] += offsets[g];
        }
        let mut next = offsets.clone();
        let (mut ln_eta, mut ln_y) = (vec![0.0; eta.len()], vec![0.0; eta.len()]);
        for k in 0..eta.len() {
            let at = &mut next[group[k] as usize];
            ln_eta[*at] = eta[k].ln();
            ln_y[*at] = y[k].ln();
            *at += 1;
        }
        let mut b = PointsBoot {
            offsets,
            ln_eta,
            ln_y,
            grid: Vec::new(),
        };
        b.grid = (0..=GRID_STEPS)
            .into_par_iter()
            .map(|k| {
                let (l, shift) = (grid_node(k), b.shift(grid_node(k)));
                (0..n_groups).map(|g| b.sums(g, l, shift)).collect()
            })
            .collect();
        b
    }

    /// A constant subtracted from every residual against cancellation in Σr² − (Σr)²/n:
    /// the first sample's residual.
    fn shift(&self, ln_eta_c: f64) -> f64 {
        match (self.ln_y.first(), self.ln_eta.first()) {
            (Some(ly), Some(le)) => ly - LN_4 - ln_eta_c - ln_shape_of_ln(le - ln_eta_c),
            _ => 0.0,
        }
    }

    /// (Σr, Σr²) over start g's samples, r = ln y − ln model(Θ = 1) − shift.
    fn sums(&self, g: usize, ln_eta_c: f64, shift: f64) -> (f64, f64) {
        let r = self.offsets[g]..self.offsets[g + 1];
        residual_sums(
            &self.ln_y[r.clone()],
            &self.ln_eta[r],
            ln_eta_c,
            |ly, shape| ly - LN_4 - ln_eta_c - shape - shift,
        )
    }

    /// Variance of the log residuals from weighted per-start sums (f64::MAX where not
    /// finite), as `LogCost::profile`.
    fn cost_of(s1: f64, s2: f64, n: f64) -> f64 {
        let c = (s2 - s1 * s1 / n) / n;
        if c.is_finite() { c.max(0.0) } else { f64::MAX }
    }

    /// The weighted (Σr, Σr²) at ln η_c over the drawn starts.
    fn weighted_sums(&self, weight: &[u32], ln_eta_c: f64, shift: f64) -> (f64, f64) {
        // The drawn starts two at a time (their sums interleave), added in start order.
        let drawn: Vec<usize> = (0..weight.len()).filter(|&g| weight[g] > 0).collect();
        let (mut s1, mut s2) = (0.0, 0.0);
        for pair in drawn.chunks(2) {
            let of = |g: usize| {
                let r = self.offsets[g]..self.offsets[g + 1];
                (&self.ln_y[r.clone()], &self.ln_eta[r])
            };
            let second = pair.get(1).map_or((&[][..], &[][..]), |&g| of(g));
            let sums = residual_sums_pair([of(pair[0]), second], ln_eta_c, |ly, shape| {
                ly - LN_4 - ln_eta_c - shape - shift
            });
            for (&g, (a, b)) in pair.iter().zip(sums) {
                let w = weight[g] as f64;
                s1 += w * a;
                s2 += w * b;
            }
        }
        (s1, s2)
    }

    /// The points fit of the replicate that drew start g `weight[g]` times; None with
    /// fewer than three samples (as `fit_method` refuses).
    pub fn fit(&self, weight: &[u32]) -> Option<PointFit> {
        let n: f64 = weight
            .iter()
            .enumerate()
            .map(|(g, &w)| w as f64 * (self.offsets[g + 1] - self.offsets[g]) as f64)
            .sum();
        if n < 3.0 {
            return None;
        }
        let grid: Vec<(f64, f64)> = self
            .grid
            .iter()
            .map(|per| {
                let (mut s1, mut s2) = (0.0, 0.0);
                for (&w, &(a, b)) in weight.iter().zip(per) {
                    s1 += w as f64 * a;
                    s2 += w as f64 * b;
                }
                (s1, s2)
            })
            .collect();
        let best = grid
            .iter()
            .enumerate()
            .map(|(k, &(s1, s2))| (k, Self::cost_of(s1, s2, n)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(0, |(k, _)| k);
        // The best node's sums are the grid's (the terms of undrawn starts there are
        // zeros, which leave a sum as it is), and refine asks again for the cost at
        // the node and at Brent's answer, which then asks once more: each is a pass
        // over most samples, so every evaluation is kept.
        let seen = Evaluated(RefCell::new(vec![(grid_node(best).to_bits(), grid[best])]));
        let sums = |l: f64| {
            seen.get_or(l, || {
                let shift = self.shift(l);
                self.weighted_sums(weight, l, shift)
            })
        };
        let profile = |l: f64| {
            let (s1, s2) = sums(l);
            Self::cost_of(s1, s2, n)
        };
        let cost = Replicate { profile: &profile };
        let (ln_ec, iterations) = refine(cost, best, profile).ok()?;
        let shift = self.shift(ln_ec);
        let (s1, s2) = sums(ln_ec);
        // Θ closed form: the mean log residual; the cost at it is the variance.
        let ln_th = s1 / n + shift;
        Some(PointFit {
            theta: ln_th.exp(),
            eta_c: ln_ec.exp(),
            cost: Self::cost_of(s1, s2, n),
            iterations,
        })
    }
}

/// One replicate's weighted sums at each ln η_c evaluated so far.
struct Evaluated(RefCell<Vec<(u64, (f64, f64))>>);

impl Evaluated {
    fn get_or(&self, l: f64, compute: impl FnOnce() -> (f64, f64)) -> (f64, f64) {
        let key = l.to_bits();
        if let Some(&(_, v)) = self.0.borrow().iter().find(|(k, _)| *k == key) {
            return v;
        }
        let v = compute();
        self.0.borrow_mut().push((key, v));
        v
    }
}

/// One replicate's profile cost for argmin.
struct Replicate<'a> {
    profile: &'a dyn Fn(f64) -> f64,
}

impl CostFunction for Replicate<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, l: &f64) -> std::result::Result<f64, argmin::core::Error> {
        Ok((self.profile)(*l))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{Method, d2min_over_r2, fit_method, reduce};
    use crate::rng::Rng;

    /// Every replicate's fit equals `fit_method` on the resampled, concatenated samples
    /// (the old path) to rounding, for replicates that draw some starts several times
    /// and others not at all.
    #[test]
    fn replicate_fits_equal_fits_of_the_resampled_samples() {
        let mut rng = Rng::new(5);
        let (starts, per) = (12usize, 300usize);
        let (mut eta, mut y, mut group) = (Vec::new(), Vec::new(), Vec::new());
        for g in 0..starts {
            for _ in 0..per {
                let e = 0.002 * (2.5 * rng.normal()).exp();
                eta.push(e);
                y.push(d2min_over_r2(e, 0.3, 0.05) * (0.5 * rng.normal()).exp());
                group.push(g as u32);
            }
        }
        let boot = PointsBoot::new(&eta, &y, &group, starts);
        for rep in 0..6 {
            let mut weight = vec![0u32; starts];
            for _ in 0..starts {
                weight[rng.below(starts)] += 1;
            }
            if rep == 0 {
                weight = vec![1; starts];
            }
            let (mut be, mut by) = (Vec::new(), Vec::new());
            for (g, &w) in weight.iter().enumerate() {
                for _ in 0..w {
                    for k in g * per..(g + 1) * per {
                        be.push(eta[k]);
                        by.push(y[k]);
                    }
                }
            }
            let want = fit_method(
                &reduce(&be, &by, Method::Points, &Default::default()),
                Method::Points,
            )
            .unwrap();
            let got = boot.fit(&weight).unwrap();
            let rel = |a: f64, b: f64| ((a - b) / b).abs();
            assert!(
                rel(got.theta, want.theta) < 1e-7,
                "rep {rep}: Θ {} vs {}",
                got.theta,
                want.theta
            );
            assert!(
                rel(got.eta_c, want.eta_c) < 1e-7,
                "rep {rep}: η_c {} vs {}",
                got.eta_c,
                want.eta_c
            );
            assert!(
                rel(got.cost, want.cost) < 1e-9,
                "rep {rep}: cost {} vs {}",
                got.cost,
                want.cost
            );
        }
        assert!(boot.fit(&vec![0; starts]).is_none(), "no samples drawn");
    }
}
