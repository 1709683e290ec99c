//! Steady-state statistics of a sheared-disk run: block means and errors of the series
//! after the transient (vagberg-sheared-disks Eqs. 16, 19, 20, 25).

use crate::dem::shear::{DurationHistogram, ShearParams, ShearSim, cohort_half};
use crate::error::{Error, Result};
use crate::stages::shear::{SERIES, ShearOptions};
use crate::stats::{SurvivalMean, survival_mean};
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Copy, Serialize)]
pub struct MeanErr {
    pub mean: f64,
    pub err: f64,
}

/// Mean over all blocks and the standard error of the block means.
pub(crate) fn block_stats(blocks: &[f64]) -> MeanErr {
    let n = blocks.len() as f64;
    let mean = blocks.iter().sum::<f64>() / n.max(1.0);
    let var = blocks.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    MeanErr {
        mean,
        err: (var / n.max(1.0)).sqrt(),
    }
}

/// var[θ̇_i/γ̇] of vagberg-sheared-disks Eq. 28, ⟨(θ̇_i/γ̇)²⟩ − ⟨θ̇_i/γ̇⟩² with ⟨…⟩ the
/// average over the disks and the steady window's samples (Eq. 29), from each sample's
/// mean `m` and spread `v` over the disks (the series' two spin columns: the sample's
/// mean square is v + m²). The value is over the whole window, as the paper's is; its
/// error is that of the same quantity block by block. (The mean of the samples' own
/// spreads, which this once reported, misses the samples' scatter of m: O(1/N).)
pub(crate) fn spin_variance(m: &[f64], v: &[f64], blocks: &[std::ops::Range<usize>]) -> MeanErr {
    let eq28 = |r: &std::ops::Range<usize>| {
        let k = r.len() as f64;
        let mean = m[r.clone()].iter().sum::<f64>() / k;
        let square = r.clone().map(|i| v[i] + m[i] * m[i]).sum::<f64>() / k;
        square - mean * mean
    };
    let per_block: Vec<f64> = blocks.iter().map(eq28).collect();
    let whole = match (blocks.first(), blocks.last()) {
        (Some(a), Some(b)) => eq28(&(a.start..b.end)),
        _ => f64::NAN,
    };
    MeanErr {
        mean: whole,
        err: block_stats(&per_block).err,
    }
}

/// The contacts begun in the averaging window, by half (see `cohort_half`): the
/// durations of those that ended, and how long those still open at the end had lasted.
pub(crate) struct Cohort {
    pub ended: [DurationHistogram; 2],
    pub censored: [DurationHistogram; 2],
}

impl Cohort {
    /// The run's cohort, its open contacts censored now.
    pub(crate) fn of(sim: &ShearSim) -> Cohort {
        let mut censored: [DurationHistogram; 2] = Default::default();
        let from = sim.coll.window_start;
        for start in sim.open_contact_starts() {
            if start >= from {
                censored[cohort_half(start)].add(sim.time - start);
            }
        }
        Cohort {
            ended: sim.coll.cohort_ended.clone(),
            censored,
        }
    }

    /// τ_dur by the survival estimator, over the halves `halves`.
    fn tau(&self, halves: &[usize]) -> SurvivalMean {
        let b = DurationHistogram::BINS;
        let add = |f: &dyn Fn(&DurationHistogram, usize) -> f64, hs: &[DurationHistogram; 2]| {
            (0..b)
                .map(|k| halves.iter().map(|&h| f(&hs[h], k)).sum::<f64>())
                .collect::<Vec<f64>>()
        };
        let count = |h: &DurationHistogram, k: usize| h.count[k] as f64;
        let ended: Vec<u64> = add(&count, &self.ended).iter().map(|&v| v as u64).collect();
        let ended_sum = add(&|h, k| h.sum[k], &self.ended);
        let censored: Vec<u64> = add(&count, &self.censored)
            .iter()
            .map(|&v| v as u64)
            .collect();
        let edges: Vec<f64> = (0..=b).map(DurationHistogram::lower_edge).collect();
        survival_mean(&ended, &ended_sum, &censored, &edges)
    }
}

/// Steady-state means with block errors (Eqs. 16, 19, 20, 25).
pub(crate) fn summarize(
    cols: &[Vec<f64>],
    p: &ShearParams,
    n: usize,
    opt: &ShearOptions,
    cohort: &Cohort,
) -> Result<BTreeMap<String, MeanErr>> {
    let col = |name: &str| {
        &cols[SERIES
            .iter()
            .position(|s| *s == name)
            .expect("series column")]
    };
    let strain = col("strain");
    let first = strain
        .iter()
        .position(|&g| g >= opt.transient * opt.strain)
        .unwrap_or(0);
    let m = strain.len() - first;
    if m < 2 * opt.blocks {
        return Err(Error::param(
            "strain",
            format!(
                "only {m} samples after the transient for {} blocks; run longer or sample more often",
                opt.blocks
            ),
        ));
    }
    let bl = m / opt.blocks;
    let ranges: Vec<std::ops::Range<usize>> = (0..opt.blocks)
        .map(|b| first + b * bl..first + (b + 1) * bl)
        .collect();
    let mean_in =
        |c: &[f64], r: &std::ops::Range<usize>| c[r.clone()].iter().sum::<f64>() / r.len() as f64;
    let per_block = |f: &dyn Fn(&std::ops::Range<usize>) -> f64| -> MeanErr {
        block_stats(&ranges.iter().map(f).collect::<Vec<_>>())
    };
    let (kd, rate) = (1.0 / p.q, p.rate);
    let mut s = BTreeMap::new();
    for (key, c) in [
        ("p", "p"),
        ("sigma", "sigma"),
        ("p_el", "p_el"),
        ("sigma_el", "sigma_el"),
        ("z", "z"),
        ("theta_dot_over_gamma_dot", "theta_dot_over_gamma_dot"),
    ] {
        s.insert(key.to_string(), per_block(&|r| mean_in(col(c), r)));
    }
    s.insert(
        "theta_dot_over_gamma_dot_var".into(),
        spin_variance(
            col("theta_dot_over_gamma_dot"),
            col("theta_dot_over_gamma_dot_var"),
            &ranges,
        ),
    );
    s.insert(
        "mu".into(),
        per_block(&|r| mean_in(col("sigma"), r) / mean_in(col("p"), r)),
    );
    // Eqs. 35–37: R_v = ⟨δv_x²⟩/⟨v_y²⟩, O(1) when homogeneous, large in shear bands.
    s.insert(
        "r_v".into(),
        per_block(&|r| mean_in(col("dvx2"), r) / mean_in(col("vy2"), r)),
    );
    s.insert(
        "mu_el".into(),
        per_block(&|r| mean_in(col("sigma_el"), r) / mean_in(col("p_el"), r)),
    );
    for (k, c) in [
        ("b_p", "p"),
        ("b_sigma", "sigma"),
        ("b_p_el", "p_el"),
        ("b_sigma_el", "sigma_el"),
    ] {
        s.insert(k.into(), per_block(&|r| mean_in(col(c), r) / (rate * rate)));
    }
    for (k, c) in [
        ("eta_p", "p"),
        ("eta_sigma", "sigma"),
        ("eta_p_el", "p_el"),
        ("eta_sigma_el", "sigma_el"),
    ] {
        s.insert(k.into(), per_block(&|r| mean_in(col(c), r) / (kd * rate)));
    }
    let (begun, tsum, time, ended) = (
        col("collisions_begun"),
        col("contact_time_ended"),
        col("time"),
        col("collisions_ended"),
    );
    // Contacts per particle begun per τ_e, and mean duration, from block differences.
    let nu = |r: &std::ops::Range<usize>| {
        (begun[r.end - 1] - begun[r.start]) / (n as f64 * (time[r.end - 1] - time[r.start]))
    };
    // Collision statistics need the whole window as one piece: a block shorter than a
    // contact's life would only see the short ones. Blocks give the error bar.
    let whole = first..strain.len();
    let with_whole = |f: &dyn Fn(&std::ops::Range<usize>) -> f64| -> MeanErr {
        MeanErr {
            mean: f(&whole),
            err: per_block(f).err,
        }
    };
    s.insert("nu_coll".into(), with_whole(&nu));
    // The biased estimate, for comparison: the mean duration of the contacts that
    // ended in the window (contacts still open at its end, the longer ones, are left
    // out).
    let tau_ended = |r: &std::ops::Range<usize>| {
        (tsum[r.end - 1] - tsum[r.start]) / (ended[r.end - 1] - ended[r.start]).max(1.0)
    };
    s.insert("tau_dur_ended_only".into(), with_whole(&tau_ended));
    // τ_dur: the contacts begun in the window followed to its end, those still open
    // censored (Kaplan–Meier); the error from its two halves' difference.
    let all = cohort.tau(&[0, 1]);
    let (a, b) = (cohort.tau(&[0]), cohort.tau(&[1]));
    let tau = MeanErr {
        mean: all.mean,
        err: 0.5 * (a.mean - b.mean).abs(),
    };
    s.insert("tau_dur".into(), tau);
    let total = (all.events + all.censored).max(1) as f64;
    s.insert(
        "tau_dur_censored_fraction".into(),
        MeanErr {
            mean: all.censored as f64 / total,
            err: 0.0,
        },
    );
    s.insert(
        "tau_dur_unobserved_tail".into(),
        MeanErr {
            mean: all.tail,
            err: 0.0,
        },
    );
    let nu = with_whole(&nu);
    s.insert(
        "two_tau_dur_nu_coll".into(),
        MeanErr {
            mean: 2.0 * tau.mean * nu.mean,
            err: 2.0 * ((tau.err * nu.mean).powi(2) + (tau.mean * nu.err).powi(2)).sqrt(),
        },
    );
    Ok(s)
}

/// The collision-angle statistics of the steady window (vagberg-sheared-disks Eq. 27,
/// Figs. 8–9, 18–19) from the making and breaking counts (`ANGLE_BINS` bins of 3.6°):
/// - `p_theta_90`, `p_theta_minus_90`: P(ϑ) per degree of both histograms together (the
///   paper's P combines initiation and breaking), averaged over the two bins that meet
///   at +90° (bins 74, 75) or −90° (bins 24, 25); error from the counts (Poisson);
/// - `making_approaching_fraction`: the making events with |ϑ| > 90° (grains driven into
///   each other; bins 0–24 and 75–99), and `breaking_separating_fraction`: the breaking
///   events with |ϑ| < 90° (bins 25–74), each with its binomial error. The paper's
///   geometry makes both 1; anything else measures how far a contact opens or closes
///   within one time step.
///
/// Quantities that have no events are left out.
pub(crate) fn collision_angle_stats(making: &[u64], breaking: &[u64]) -> BTreeMap<String, MeanErr> {
    use crate::dem::shear::{ANGLE_BIN_DEG, ANGLE_BINS_AT_90, ANGLE_BINS_AT_MINUS_90};
    let mut s = BTreeMap::new();
    let total = (making.iter().sum::<u64>() + breaking.iter().sum::<u64>()) as f64;
    if total > 0.0 {
        for (key, bins) in [
            ("p_theta_90", ANGLE_BINS_AT_90),
            ("p_theta_minus_90", ANGLE_BINS_AT_MINUS_90),
        ] {
            let c: u64 = bins.iter().map(|&k| making[k] + breaking[k]).sum();
            let norm = bins.len() as f64 * total * ANGLE_BIN_DEG;
            s.insert(
                key.to_string(),
                MeanErr {
                    mean: c as f64 / norm,
                    err: (c as f64).sqrt() / norm,
                },
            );
        }
    }
    let fraction = |h: &[u64], keep: &dyn Fn(usize) -> bool| {
        let n = h.iter().sum::<u64>() as f64;
        (n > 0.0).then(|| {
            let k: u64 = (0..h.len()).filter(|&b| keep(b)).map(|b| h[b]).sum();
            let f = k as f64 / n;
            MeanErr {
                mean: f,
                err: (f * (1.0 - f) / n).sqrt(),
            }
        })
    };
    let outward = |b: usize| b >= ANGLE_BINS_AT_MINUS_90[1] && b <= ANGLE_BINS_AT_90[0];
    if let Some(f) = fraction(making, &|b| !outward(b)) {
        s.insert("making_approaching_fraction".into(), f);
    }
    if let Some(f) = fraction(breaking, &outward) {
        s.insert("breaking_separating_fraction".into(), f);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. 28 by hand: every disk spins at 1 in one sample and at 3 in the next (each
    /// sample's own spread 0), so ⟨x²⟩ = 5, ⟨x⟩² = 4 and var = 1; the mean of the
    /// samples' spreads would say 0. With spreads 0.5 in every sample, var = 1.5.
    #[test]
    fn the_spin_variance_is_eq_28_over_disks_and_samples() {
        let m = [1.0, 3.0, 1.0, 3.0];
        let blocks = [0..2, 2..4];
        let v = spin_variance(&m, &[0.0; 4], &blocks);
        assert_eq!((v.mean, v.err), (1.0, 0.0));
        let v = spin_variance(&m, &[0.5; 4], &blocks);
        assert!((v.mean - 1.5).abs() < 1e-15, "{v:?}");
        // Blocks that differ give an error from their spread: blocks (1, 1) and (1, 3).
        let v = spin_variance(&[1.0, 1.0, 1.0, 3.0], &[0.0; 4], &blocks);
        // Whole window: ⟨x²⟩ = 3, ⟨x⟩² = 2.25; blocks 0 and 1 give 0 and 1.
        assert!(
            (v.mean - 0.75).abs() < 1e-15 && (v.err - 0.5).abs() < 1e-15,
            "{v:?}"
        );
    }
}
