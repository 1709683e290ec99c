//! `pillar-pipe sizes`: a size scan's flow stress (li-granular-pillars Fig. 10a, b): for
//! each `simulate pillar` run, ⟨σ⟩ over 0.05 ≤ ε ≤ 0.2 in m g μ/D with its error, the
//! mean dissipation ratio κ there (Fig. 10d), W0 and H0 in D; and the fit ⟨σ⟩ = c W0/D
//! through the origin with its 95 % interval.

use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::table::{read_table, write_table};
use polars::prelude::*;
use std::path::{Path, PathBuf};

/// The strain window of the paper's mean flow stress.
pub const WINDOW: (f64, f64) = (0.05, 0.2);

/// One run of the scan.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SizeRow {
    pub run: PathBuf,
    pub n: usize,
    pub w0_over_d: f64,
    pub h0_over_d: f64,
    /// ⟨σ⟩ (m g μ/D) over the window and its standard error (from four blocks of it).
    pub sigma: f64,
    pub sigma_err: f64,
    /// ⟨κ⟩ over the window.
    pub kappa: f64,
}

/// The scan's fit ⟨σ⟩ = c W0/D: c (m g μ/D per D) and its 95 % interval.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SizeFit {
    pub c: f64,
    pub c_interval: [f64; 2],
}

fn row(dir: &Path) -> Result<SizeRow> {
    let mpath = dir.join(crate::stages::manifest::MANIFEST);
    let text = std::fs::read_to_string(&mpath).map_err(|e| Error::io(&mpath, e))?;
    let m: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::input(mpath.display(), format!("not a manifest: {e}")))?;
    if m["command"] != "simulate pillar" {
        return Err(Error::input(
            mpath.display(),
            format!("not a `simulate pillar` run (command {})", m["command"]),
        ));
    }
    let num = |v: &serde_json::Value, key: &str| {
        v.as_f64()
            .ok_or_else(|| Error::input(mpath.display(), format!("no number at {key}")))
    };
    let w0 = num(&m["setup"]["w0_over_d"], "setup.w0_over_d")?;
    let h0 = num(&m["setup"]["h0_over_d"], "setup.h0_over_d")?;
    let n = m["setup"]["n"].as_u64().unwrap_or(0) as usize;
    let table = dir.join("stress_strain.parquet");
    let t = read_table(
        &table,
        &[
            ("strain", Expect::Float),
            ("stress_reduced", Expect::Float),
            ("kappa", Expect::Float),
        ],
    )?;
    let (eps, sig, kap) = (
        t.f64("strain")?,
        t.f64_or_nan("stress_reduced")?,
        t.f64_or_nan("kappa")?,
    );
    let idx: Vec<usize> = (0..eps.len())
        .filter(|&k| eps[k] >= WINDOW.0 && eps[k] <= WINDOW.1 && sig[k].is_finite())
        .collect();
    let reached = eps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if idx.len() < 8 || reached < WINDOW.1 * (1.0 - 1e-6) {
        return Err(Error::input(
            table.display(),
            format!(
                "the run reached ε = {reached:.3} with {} frames in {} ≤ ε ≤ {}: run to ε = 0.2 for the mean flow stress",
                idx.len(),
                WINDOW.0,
                WINDOW.1
            ),
        ));
    }
    let mean = |v: &[usize], c: &[f64]| v.iter().map(|&k| c[k]).sum::<f64>() / v.len() as f64;
    let blocks: Vec<f64> = idx
        .chunks(idx.len().div_ceil(4))
        .map(|b| mean(b, &sig))
        .collect();
    let stats = crate::stages::shear::block_stats(&blocks);
    let kappa_idx: Vec<usize> = idx
        .iter()
        .copied()
        .filter(|&k| kap[k].is_finite())
        .collect();
    Ok(SizeRow {
        run: dir.to_path_buf(),
        n,
        w0_over_d: w0,
        h0_over_d: h0,
        sigma: mean(&idx, &sig),
        sigma_err: stats.err,
        kappa: if kappa_idx.is_empty() {
            f64::NAN
        } else {
            mean(&kappa_idx, &kap)
        },
    })
}

/// Weighted least squares through the origin, weights 1/err²; the interval from the
/// residual scatter (so it also holds when the per-run errors understate the spread),
/// 95 % with Student's t for n − 1 degrees of freedom.
pub fn fit_through_origin(x: &[f64], y: &[f64], err: &[f64]) -> Option<SizeFit> {
    let w: Vec<f64> = err.iter().map(|e| 1.0 / (e * e).max(1e-300)).collect();
    let sxx: f64 = (0..x.len()).map(|k| w[k] * x[k] * x[k]).sum();
    let sxy: f64 = (0..x.len()).map(|k| w[k] * x[k] * y[k]).sum();
    if x.len() < 2 || !(sxx > 0.0) {
        return None;
    }
    let c = sxy / sxx;
    let dof = (x.len() - 1) as f64;
    let chi2: f64 = (0..x.len()).map(|k| w[k] * (y[k] - c * x[k]).powi(2)).sum();
    let se = (chi2 / dof / sxx).sqrt().max((1.0 / sxx).sqrt());
    let t = match x.len() - 1 {
        1 => 12.71,
        2 => 4.30,
        3 => 3.18,
        4 => 2.78,
        5 => 2.57,
        6..=9 => 2.36,
        _ => 2.1,
    };
    Some(SizeFit {
        c,
        c_interval: [c - t * se, c + t * se],
    })
}

/// The scan of the runs in `dirs`, written to `output` (Parquet or CSV).
pub fn run(dirs: &[PathBuf], output: &Path) -> Result<(Vec<SizeRow>, Option<SizeFit>)> {
    let mut rows = dirs.iter().map(|d| row(d)).collect::<Result<Vec<_>>>()?;
    rows.sort_by(|a, b| a.w0_over_d.total_cmp(&b.w0_over_d));
    let col = |f: &dyn Fn(&SizeRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let fit = fit_through_origin(
        &col(&|r| r.w0_over_d),
        &col(&|r| r.sigma),
        &col(&|r| r.sigma_err),
    );
    let mut df = DataFrame::new(
        rows.len(),
        vec![
            Column::new(
                "n".into(),
                rows.iter().map(|r| r.n as i64).collect::<Vec<i64>>(),
            ),
            Column::new("w0_over_d".into(), col(&|r| r.w0_over_d)),
            Column::new("h0_over_d".into(), col(&|r| r.h0_over_d)),
            Column::new("sigma_mean".into(), col(&|r| r.sigma)),
            Column::new("sigma_err".into(), col(&|r| r.sigma_err)),
            Column::new("kappa_mean".into(), col(&|r| r.kappa)),
        ],
    )
    .map_err(|e| Error::polars("the size-scan table", e))?;
    write_table(&mut df, output)?;
    Ok((rows, fit))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_through_the_origin_is_recovered_with_an_honest_interval() {
        let x = [10.0, 20.0, 40.0];
        let y = [5.0, 10.1, 19.9];
        let f = fit_through_origin(&x, &y, &[0.1, 0.1, 0.1]).unwrap();
        assert!((f.c - 0.4983).abs() < 1e-3, "{}", f.c);
        assert!(
            f.c_interval[0] < 0.5 && f.c_interval[1] > 0.5,
            "{:?}",
            f.c_interval
        );
        // Scatter far beyond the stated errors widens the interval.
        let g = fit_through_origin(&x, &[5.0, 12.0, 18.0], &[0.1, 0.1, 0.1]).unwrap();
        assert!(g.c_interval[1] - g.c_interval[0] > 10.0 * (f.c_interval[1] - f.c_interval[0]));
        assert!(fit_through_origin(&[1.0], &[1.0], &[1.0]).is_none());
    }
}
