//! The binned estimators' bootstrap without re-binning. A replicate draws start times
//! with replacement; its binned curve is that of the samples of the drawn starts, each
//! start counted as often as it was drawn. Sorting once per bin (by η^s and by D²min)
//! and keeping each start's count and sums per bin, a replicate's medians and quantiles
//! are order statistics of a weighted list (one pass per bin) and its means are weighted
//! sums: O(samples) per replicate instead of a sort of every resampled sample
//! (O(n log n) plus the copy). Medians and quantiles equal the re-binned ones bit for bit;
//! means agree to rounding (sums in another order). Each sorted list also keeps every
//! start's running count at every [`STRIDE`]-th entry, so an order statistic is found by
//! bisecting those marks and scanning at most one stride: a thousand replicates of a
//! 4 M-sample fit no longer walk half of every bin each.

use super::estimate::{BinPoint, Binning, Method, NODES};
use rayon::prelude::*;

/// Entries between the marks of a [`Sorted`] list.
const STRIDE: usize = 128;

/// Values with their starts in ascending order, with each start's count of the entries
/// before every `STRIDE`-th one.
struct Sorted {
    v: Vec<(f64, u32)>,
    /// `marks[c * n_groups + g]`: entries of start g among the first `c * STRIDE`.
    marks: Vec<u32>,
    n_groups: usize,
}

impl Sorted {
    fn new(mut v: Vec<(f64, u32)>, n_groups: usize) -> Self {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut marks = Vec::with_capacity((v.len() / STRIDE + 1) * n_groups);
        let mut count = vec![0u32; n_groups];
        for (i, &(_, g)) in v.iter().enumerate() {
            if i % STRIDE == 0 {
                marks.extend_from_slice(&count);
            }
            count[g as usize] += 1;
        }
        Sorted { v, marks, n_groups }
    }

    /// Entries, each start counted `weight[start]` times, before mark `c`.
    fn seen_at(&self, c: usize, weight: &[u32]) -> u64 {
        self.marks[c * self.n_groups..(c + 1) * self.n_groups]
            .iter()
            .zip(weight)
            .map(|(&m, &w)| m as u64 * w as u64)
            .sum()
    }

    /// The k-th (0-based) value of the list with each entry repeated weight[start]
    /// times (NaN past its end): the last mark at most k, then a scan from there. The
    /// same entry as scanning from the start, which cannot stop before that mark.
    fn order_stat(&self, weight: &[u32], k: u64) -> f64 {
        let marks = self.marks.len() / self.n_groups.max(1);
        // Mark 0 sees nothing (≤ k); find the last mark c with seen_at(c) ≤ k.
        let (mut lo, mut hi) = (0usize, marks);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if self.seen_at(mid, weight) <= k {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut seen = if marks == 0 {
            0
        } else {
            self.seen_at(lo, weight)
        };
        for &(x, g) in &self.v[lo * STRIDE..] {
            seen += weight[g as usize] as u64;
            if seen > k {
                return x;
            }
        }
        f64::NAN
    }
}

/// One bin's samples, sorted two ways, with each start's share.
struct PreBin {
    /// (η^s, start) sorted by η^s.
    eta: Sorted,
    /// (D²min/R², start) sorted by D²min/R².
    y: Sorted,
    /// Per start (dense index): samples, Σ y, Σ y².
    count: Vec<u32>,
    sum: Vec<f64>,
    sum2: Vec<f64>,
}

/// Samples binned once for the bootstrap of one binned estimator (the bins are shared
/// by every binned estimator: see [`Prebinned::for_method`]).
pub struct Prebinned {
    method: Method,
    min_count: usize,
    bins: std::sync::Arc<Vec<PreBin>>,
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
        // Keys unique (k is): any sort gives this order.
        keyed.par_sort_unstable_by_key(|&(key, k)| (key, k));
        let mut ranges = Vec::new();
        let mut s = 0;
        while s < keyed.len() {
            let mut e = s;
            while e < keyed.len() && keyed[e].0 == keyed[s].0 {
                e += 1;
            }
            ranges.push(s..e);
            s = e;
        }
        // Bins apart, each on its own thread: the same bins.
        let bins: Vec<PreBin> = ranges
            .into_par_iter()
            .map(|r| {
                let idx = &keyed[r];
                let pe: Vec<(f64, u32)> = idx.iter().map(|&(_, k)| (eta[k], group[k])).collect();
                let py = Sorted::new(
                    idx.iter().map(|&(_, k)| (y[k], group[k])).collect(),
                    n_groups,
                );
                let (mut count, mut sum, mut sum2) = (
                    vec![0u32; n_groups],
                    vec![0.0; n_groups],
                    vec![0.0; n_groups],
                );
                for &(v, g) in &py.v {
                    count[g as usize] += 1;
                    sum[g as usize] += v;
                    sum2[g as usize] += v * v;
                }
                PreBin {
                    eta: Sorted::new(pe, n_groups),
                    y: py,
                    count,
                    sum,
                    sum2,
                }
            })
            .collect();
        Prebinned {
            method,
            min_count: b.min_count,
            bins: std::sync::Arc::new(bins),
        }
    }

    /// The same samples for another binned estimator, without binning them again.
    pub fn for_method(&self, method: Method) -> Prebinned {
        Prebinned {
            method,
            min_count: self.min_count,
            bins: self.bins.clone(),
        }
    }

    /// The binned curve of a replicate that drew start g `weight[g]` times.
    pub fn reduce(&self, weight: &[u32]) -> Vec<BinPoint> {
        let mut out = Vec::with_capacity(self.bins.len());
        for bin in self.bins.iter() {
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

/// As `stats::median_sorted` of the expanded list (n entries).
fn weighted_median(v: &Sorted, weight: &[u32], n: u64) -> f64 {
    if n % 2 == 1 {
        v.order_stat(weight, n / 2)
    } else {
        0.5 * (v.order_stat(weight, n / 2 - 1) + v.order_stat(weight, n / 2))
    }
}

/// `stats::quantile_sorted` of the expanded list (n entries) at the NODES quantile
/// nodes (k + ½)/NODES.
fn weighted_quantiles(v: &Sorted, weight: &[u32], n: u64) -> [f64; NODES] {
    std::array::from_fn(|k| {
        let h = ((k as f64 + 0.5) / NODES as f64) * (n - 1) as f64;
        let (a, b) = (
            v.order_stat(weight, h.floor() as u64),
            v.order_stat(weight, h.ceil() as u64),
        );
        a + (h - h.floor()) * (b - a)
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
