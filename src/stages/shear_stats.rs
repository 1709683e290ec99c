//! Steady-state statistics of a sheared-disk run: block means and errors of the series
//! after the transient (vagberg-sheared-disks Eqs. 16, 19, 20, 25).

use super::shear::{SERIES, ShearOptions};
use crate::dem::shear::ShearParams;
use crate::error::{Error, Result};
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

/// Steady-state means with block errors (Eqs. 16, 19, 20, 25).
pub(crate) fn summarize(
    cols: &[Vec<f64>],
    p: &ShearParams,
    n: usize,
    opt: &ShearOptions,
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
        (
            "theta_dot_over_gamma_dot_var",
            "theta_dot_over_gamma_dot_var",
        ),
    ] {
        s.insert(key.to_string(), per_block(&|r| mean_in(col(c), r)));
    }
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
    // τ_dur: mean duration of the contacts that ended in the block.
    let tau = |r: &std::ops::Range<usize>| {
        (tsum[r.end - 1] - tsum[r.start]) / (ended[r.end - 1] - ended[r.start]).max(1.0)
    };
    s.insert("tau_dur".into(), with_whole(&tau));
    s.insert(
        "two_tau_dur_nu_coll".into(),
        with_whole(&|r| 2.0 * tau(r) * nu(r)),
    );
    Ok(s)
}
