//! The binned estimators' bootstrap without re-binning. A replicate draws start times
//! with replacement; its binned curve is that of the samples of the drawn starts, each
//! start counted as often as it was drawn. Sorting once per bin (by η^s and by D²min)
//! and keeping each start's count and sums per bin, a replicate's medians and quantiles
//! are order statistics of a weighted list (one pass per bin) and its means are weighted
//! sums: O(samples) per replicate instead of a sort of every resampled sample
//! (O(n log n) plus the copy). Medians and quantiles equal the re-binned ones bit for bit;
//! means agree to rounding (sums in another order).

use super::estimate::{BinPoint, Binning, Method, NODES};

/// One bin's samples, sorted two ways, with each start's share.
struct PreBin {
    /// (η^s, start) sorted by η^s.
    eta: Vec<(f64, u32)>,
    /// (D²min/R², start) sorted by D²min/R².
    y: Vec<(f64, u32)>,
    /// Per start (dense index): samples, Σ y, Σ y².
    count: Vec<u32>,
    sum: Vec<f64>,
    sum2: Vec<f64>,
}

/// Samples binned once for the bootstrap of one binned estimator.
pub struct Prebinned {
    method: Method,
    min_count: usize,
    bins: Vec<PreBin>,
}

impl Prebinned {
    /// `group` holds dense start indices below `n_groups`; (η, y) are positive and
    /// finite (as `reduce` receives them).
    pub fn new(
        eta: &[f64],
        y: &[f64],
        group: &[u32],
        n_groups: usize,
        method: Method,
        b: &Binning,
    ) -> Self {
        let mut keyed: Vec<(i64, usize)> = eta
            .iter()
            .enumerate()
            .map(|(k, e)| ((e.log10() * b.bins_per_decade).floor() as i64, k))
            .collect();
        keyed.sort_unstable_by_key(|&(key, k)| (key, k));
        let mut bins = Vec::new();
        let mut s = 0;
        while s < keyed.len() {
            let mut e = s;
            while e < keyed.len() && keyed[e].0 == keyed[s].0 {
                e += 1;
            }
            let idx = &keyed[s..e];
            let mut pe: Vec<(f64, u32)> = idx.iter().map(|&(_, k)| (eta[k], group[k])).collect();
            let mut py: Vec<(f64, u32)> = idx.iter().map(|&(_, k)| (y[k], group[k])).collect();
            pe.sort_by(|a, b| a.0.total_cmp(&b.0));
            py.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (mut count, mut sum, mut sum2) = (
                vec![0u32; n_groups],
                vec![0.0; n_groups],
                vec![0.0; n_groups],
            );
            for &(v, g) in &py {
                count[g as usize] += 1;
                sum[g as usize] += v;
                sum2[g as usize] += v * v;
            }
            bins.push(PreBin {
                eta: pe,
                y: py,
                count,
                sum,
                sum2,
            });
            s = e;
        }
        Prebinned {
            method,
            min_count: b.min_count,
            bins,
        }
    }

    /// The binned curve of a replicate that drew start g `weight[g]` times.
    pub fn reduce(&self, weight: &[u32]) -> Vec<BinPoint> {
        let mut out = Vec::with_capacity(self.bins.len());
        for bin in &self.bins {
            let n: u64 = bin
                .count
                .iter()
                .zip(weight)
                .map(|(&c, &w)| c as u64 * w as u64)
                .sum();
            if n < self.min_count as u64 || n == 0 {
                continue;
            }
            let eta_s = weighted_median(&bin.eta, weight, n);
            let is_mean = matches!(self.method, Method::BinnedMean | Method::WeightedMean);
            let (stat, se, nodes) = if is_mean {
                let (mut s1, mut s2) = (0.0, 0.0);
                for ((&w, a), b) in weight.iter().zip(&bin.sum).zip(&bin.sum2) {
                    s1 += w as f64 * a;
                    s2 += w as f64 * b;
                }
                let nf = n as f64;
                let mean = s1 / nf;
                let var = ((s2 - nf * mean * mean) / (nf - 1.0).max(1.0)).max(0.0);
                let se = (var / nf).sqrt().max(1e-9 * mean.abs());
                let nodes = weighted_quantiles(&bin.eta, weight, n);
                (mean, Some(se), Some(nodes))
            } else {
                (weighted_median(&bin.y, weight, n), None, None)
            };
            out.push(BinPoint {
                eta_s,
                d2min_over_r2: stat,
                n: n as usize,
                se,
                nodes,
            });
        }
        out
    }
}

/// The k-th (0-based) value of the list with each entry repeated weight[start] times.
fn order_stat(v: &[(f64, u32)], weight: &[u32], k: u64) -> f64 {
    let mut seen = 0u64;
    for &(x, g) in v {
        seen += weight[g as usize] as u64;
        if seen > k {
            return x;
        }
    }
    f64::NAN
}

/// As `stats::median_sorted` of the expanded list (n entries).
fn weighted_median(v: &[(f64, u32)], weight: &[u32], n: u64) -> f64 {
    if n % 2 == 1 {
        order_stat(v, weight, n / 2)
    } else {
        0.5 * (order_stat(v, weight, n / 2 - 1) + order_stat(v, weight, n / 2))
    }
}

/// `stats::quantile_sorted` of the expanded list (n entries) at the NODES quantile
/// nodes (k + ½)/NODES, in one pass: the order statistics they need ascend.
fn weighted_quantiles(v: &[(f64, u32)], weight: &[u32], n: u64) -> [f64; NODES] {
    let h: [f64; NODES] =
        std::array::from_fn(|k| ((k as f64 + 0.5) / NODES as f64) * (n - 1) as f64);
    let mut want = [0u64; 2 * NODES];
    for k in 0..NODES {
        want[2 * k] = h[k].floor() as u64;
        want[2 * k + 1] = h[k].ceil() as u64;
    }
    let mut got = [f64::NAN; 2 * NODES];
    let (mut next, mut seen) = (0, 0u64);
    for &(x, g) in v {
        seen += weight[g as usize] as u64;
        while next < want.len() && seen > want[next] {
            got[next] = x;
            next += 1;
        }
        if next == want.len() {
            break;
        }
    }
    std::array::from_fn(|k| {
        let (a, b) = (got[2 * k], got[2 * k + 1]);
        a + (h[k] - h[k].floor()) * (b - a)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::reduce;
    use crate::rng::Rng;

    /// A replicate's curve from the pre-binned samples equals re-binning the expanded
    /// samples: medians and quantiles bit for bit, means to rounding.
    #[test]
    fn prebinned_replicates_equal_rebinned_ones() {
        let mut rng = Rng::new(5);
        let (mut eta, mut y, mut group) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..6000 {
            let e = (1e-4f64.ln() + rng.uniform() * (1.0f64.ln() - 1e-4f64.ln())).exp();
            eta.push(e);
            y.push(e * (0.7 * rng.normal()).exp());
            group.push((k % 13) as u32);
        }
        let b = Binning::default();
        for method in [
            Method::BinnedMedian,
            Method::BinnedMean,
            Method::WeightedMean,
        ] {
            let pre = Prebinned::new(&eta, &y, &group, 13, method, &b);
            for rep in 0..5 {
                let mut w = vec![0u32; 13];
                for _ in 0..13 {
                    w[rng.below(13)] += 1;
                }
                if rep == 0 {
                    w = vec![1; 13];
                }
                let (mut be, mut by) = (Vec::new(), Vec::new());
                for (g, &m) in w.iter().enumerate() {
                    for _ in 0..m {
                        for k in 0..eta.len() {
                            if group[k] as usize == g {
                                be.push(eta[k]);
                                by.push(y[k]);
                            }
                        }
                    }
                }
                let want = reduce(&be, &by, method, &b);
                let got = pre.reduce(&w);
                assert_eq!(want.len(), got.len(), "{method:?}");
                for (a, c) in want.iter().zip(&got) {
                    assert_eq!((a.eta_s, a.n), (c.eta_s, c.n), "{method:?}");
                    assert_eq!(a.nodes, c.nodes, "{method:?}");
                    if method == Method::BinnedMedian {
                        assert_eq!(a.d2min_over_r2, c.d2min_over_r2);
                    } else {
                        let rel = (a.d2min_over_r2 / c.d2min_over_r2 - 1.0).abs();
                        assert!(rel < 1e-12, "{method:?} mean {rel}");
                        let (sa, sc) = (a.se.unwrap(), c.se.unwrap());
                        assert!((sa / sc - 1.0).abs() < 1e-6, "{method:?} se {sa} {sc}");
                    }
                }
            }
        }
    }
}
