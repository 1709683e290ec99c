//! `pillar-pipe sizes`: a size scan's flow stress (li-granular-pillars Fig. 10a, b): for
//! each `simulate pillar` run, ⟨σ⟩ over 0.05 ≤ ε ≤ 0.2 in m g μ/D with its error, the
//! mean dissipation ratio κ there (Fig. 10d), W0 and H0 in D; and the fit ⟨σ⟩ = c W0/D
//! through the origin with its 95 % interval; the shape scaling χ = W/W0 at ε = 0.1
//! and 0.2, the contact pressure along the bar (Fig. 10c, `bar_pressure`), the yield
//! point ε_y, σ_y of each curve (Sec. III, [`crate::structure::yielding`]), and the
//! paper's claims as checks across the sizes. Optionally the curves of every run
//! (σ, κ, χ against ε) and the pressure profiles, for overlays.

use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::table::{read_table, write_table};
use polars::prelude::*;
use std::path::{Path, PathBuf};

/// The strain window of the paper's mean flow stress.
pub const WINDOW: (f64, f64) = (0.05, 0.2);

/// One run of the scan.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
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
    /// ⟨P_in⟩ and ⟨P_g-s⟩ over the window (Eqs. 20, 21) in units of m g μ v_c: the
    /// frames' F_bar/(m g μ) = σ W/(m g μ), and κ times it.
    pub p_in: f64,
    pub p_gs: f64,
    /// χ = W/W0 at ε = 0.1 and 0.2 (W: the `width` column, 2 D band at the top bar).
    pub chi: [f64; 2],
    /// The mean bar pressure profile over `bar_pressure::WINDOW` (p in m g μ/D), or why
    /// there is none.
    pub pressure: std::result::Result<(crate::structure::pressure::PressureProfile, usize), String>,
    /// Local stress against distance from the lateral edges over the bar pressure's
    /// window (`structure::edge_stress`, p in m g μ/D, d in D), or why there is none.
    pub edge: std::result::Result<crate::structure::edge_stress::EdgeProfile, String>,
    /// The yield point of σ(ε) over 0 ≤ ε ≤ `WINDOW.1` (σ_y in m g μ/D), or why none.
    pub yielding: crate::structure::yielding::Yield,
    /// Frames of the run: ε, σ (m g μ/D), κ, χ.
    pub curves: [Vec<f64>; 4],
}

/// Bootstrap replicates of the yield point's interval, and their seed.
pub const YIELD_REPLICATES: usize = 200;
pub const YIELD_SEED: u64 = 36;

/// The strains at which χ = W/W0 is compared across sizes.
pub const CHI_AT: [f64; 2] = [0.1, 0.2];

impl SizeRow {
    /// ε_y, σ_y and their intervals: [ε_y, lo, hi, σ_y, lo, hi], NaN where the curve does
    /// not yield.
    pub fn yield_columns(&self) -> [f64; 6] {
        match self.yielding.point() {
            Some(p) => [
                p.eps_y,
                p.eps_interval[0],
                p.eps_interval[1],
                p.sigma_y,
                p.sigma_interval[0],
                p.sigma_interval[1],
            ],
            None => [f64::NAN; 6],
        }
    }

    /// The pressure at the centre of the interface: the mean of the middle 40 % of x/W
    /// (the paper's "saturated values around the centre"), m g μ/D.
    pub fn p_centre(&self) -> f64 {
        match &self.pressure {
            Ok((p, _)) => {
                let mid: Vec<f64> = (0..p.p.len())
                    .filter(|&k| (p.x_over_w[k] - 0.5).abs() < 0.2)
                    .map(|k| p.p[k])
                    .collect();
                mid.iter().sum::<f64>() / mid.len().max(1) as f64
            }
            Err(_) => f64::NAN,
        }
    }
}

/// The paper's size-independence claims (li-granular-pillars Sec. V) as numbers: the
/// relative spread (max − min over the mean) across the runs of ⟨σ⟩/W0, of σ_y/W0 (the
/// abstract's "the yield stress of the pillars increases linearly with pillar size") and
/// of χ at `CHI_AT`, and the absolute spread of ⟨κ⟩. The tolerances: 10 %, 10 %,
/// 5 %, 0.03.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ScanChecks {
    pub sigma_over_w0_spread: f64,
    /// None when a run does not yield (the check cannot be made).
    pub sigma_y_over_w0_spread: Option<f64>,
    pub chi_spread: [f64; 2],
    pub kappa_spread: f64,
    /// Exponents of ⟨P_in⟩ against W0 (Eq. 20: P_in ∝ W0²) and of ⟨P_g-s⟩ against N
    /// (Sec. V: P_g-s = κ P_in ∝ N); None where the powers are not positive.
    pub p_in_exponent: Option<crate::stats::PowerLaw>,
    pub p_gs_exponent: Option<crate::stats::PowerLaw>,
    /// Relative spread of the rates at which the local stress rises from the lateral
    /// edges (Sec. V: "very close for different-sized pillars"); None where a run has
    /// no force snapshots in the window.
    pub edge_rate_spread: Option<f64>,
}

/// The tolerance each claim is judged by (the issue's), the one place they are stated.
pub struct Tolerances {
    /// Relative spread of ⟨σ⟩/W0 and of σ_y/W0.
    pub sigma_over_w0: f64,
    pub sigma_y_over_w0: f64,
    /// Absolute spread of ⟨κ⟩.
    pub kappa: f64,
    /// Relative spread of χ at each strain of `CHI_AT`.
    pub chi: f64,
    /// Largest distance of a run's median front angle from 45° (Fig. 5a), degrees.
    pub front_deg: f64,
    /// Largest distance of the powers' exponents from the paper's 2 (P_in against W0)
    /// and 1 (P_g-s against N). From σ/W0 equal within 10 % over a factor 2 in W0, the
    /// exponent of P_in = σ W v_c may be off by ln 1.1/ln 2 ≈ 0.14 with χ equal too.
    pub exponent: f64,
    /// Relative spread of the edge stress's rate of rise.
    pub edge_rate: f64,
}

pub const TOLERANCES: Tolerances = Tolerances {
    sigma_over_w0: 0.10,
    sigma_y_over_w0: 0.10,
    kappa: 0.03,
    chi: 0.05,
    front_deg: 10.0,
    exponent: 0.2,
    edge_rate: 0.15,
};

impl ScanChecks {
    pub fn sigma_holds(&self) -> bool {
        self.sigma_over_w0_spread <= TOLERANCES.sigma_over_w0
    }
    /// None when the check cannot be made (a run does not yield).
    pub fn sigma_y_holds(&self) -> Option<bool> {
        self.sigma_y_over_w0_spread
            .map(|s| s <= TOLERANCES.sigma_y_over_w0)
    }
    pub fn kappa_holds(&self) -> bool {
        self.kappa_spread <= TOLERANCES.kappa
    }
    /// P_in ∝ W0² within the tolerance (None: not measurable).
    pub fn p_in_holds(&self) -> Option<bool> {
        self.p_in_exponent
            .map(|p| (p.exponent - 2.0).abs() <= TOLERANCES.exponent)
    }
    /// P_g-s ∝ N within the tolerance (None: not measurable).
    pub fn p_gs_holds(&self) -> Option<bool> {
        self.p_gs_exponent
            .map(|p| (p.exponent - 1.0).abs() <= TOLERANCES.exponent)
    }
    /// The edge stress rises at one rate at every size (None: not measurable).
    pub fn edge_rate_holds(&self) -> Option<bool> {
        self.edge_rate_spread.map(|s| s <= TOLERANCES.edge_rate)
    }
    /// At the `k`-th strain of `CHI_AT`.
    pub fn chi_holds(&self, k: usize) -> bool {
        self.chi_spread[k] <= TOLERANCES.chi
    }
}

/// The relative spread of a claim's values across runs (`stats::relative_spread`).
fn spread(v: &[f64]) -> f64 {
    crate::stats::relative_spread(v)
}

/// χ at strain `at` by linear interpolation between frames (NaN beyond the run).
fn interpolate(eps: &[f64], v: &[f64], at: f64) -> f64 {
    (1..eps.len())
        .find(|&k| eps[k - 1] <= at && eps[k] >= at)
        .map_or(f64::NAN, |k| {
            let t = if eps[k] > eps[k - 1] {
                (at - eps[k - 1]) / (eps[k] - eps[k - 1])
            } else {
                0.0
            };
            v[k - 1] + t * (v[k] - v[k - 1])
        })
}

/// The scan's fit ⟨σ⟩ = c W0/D: c (m g μ/D per D) and its 95 % interval.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct SizeFit {
    pub c: f64,
    pub c_interval: [f64; 2],
}

/// One `simulate pillar` run's row: ⟨σ⟩ and κ over `WINDOW`, χ, the yield point and the
/// bar pressure (the run must reach ε = `WINDOW.1`).
pub fn row(dir: &Path) -> Result<SizeRow> {
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
            ("width", Expect::Float),
        ],
    )?;
    // D in the width column's unit (cm), from the manifest's H0 in cm and in D.
    let d_cm = num(&m["h0_cm"], "h0_cm")? / h0;
    let (eps, sig, kap, width) = (
        t.f64("strain")?,
        t.f64_or_nan("stress_reduced")?,
        t.f64_or_nan("kappa")?,
        t.f64("width")?,
    );
    let w_start = width.first().copied().unwrap_or(f64::NAN);
    let chi: Vec<f64> = width.iter().map(|w| w / w_start).collect();
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
    let yielding =
        crate::structure::yielding::yield_point(&eps, &sig, WINDOW.1, YIELD_REPLICATES, YIELD_SEED);
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
    let p_in: Vec<f64> = (0..eps.len()).map(|k| sig[k] * width[k] / d_cm).collect();
    let p_gs: Vec<f64> = (0..eps.len()).map(|k| kap[k] * p_in[k]).collect();
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
        p_in: mean(&idx, &p_in),
        p_gs: if kappa_idx.is_empty() {
            f64::NAN
        } else {
            mean(&kappa_idx, &p_gs)
        },
        chi: CHI_AT.map(|at| interpolate(&eps, &chi, at)),
        pressure: super::bar_pressure::run_profile(
            dir,
            super::bar_pressure::WINDOW,
            super::bar_pressure::BINS,
        )
        .map_err(|e| e.to_string()),
        edge: super::edge_stress::run_profile(dir, super::bar_pressure::WINDOW)
            .map_err(|e| e.to_string()),
        yielding,
        curves: [eps, sig, kap, chi],
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
    let t = crate::stats::t_95(x.len() - 1);
    Some(SizeFit {
        c,
        c_interval: [c - t * se, c + t * se],
    })
}

/// Where the scan writes: the one-row-per-run table, and optionally every run's curves
/// against ε and every run's pressure profile (Parquet or CSV by extension).
#[derive(Debug, Clone, Default)]
pub struct SizeOutputs {
    pub table: PathBuf,
    pub curves: Option<PathBuf>,
    pub pressure: Option<PathBuf>,
}

/// What the scan found.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct SizeScan {
    pub rows: Vec<SizeRow>,
    pub fit: Option<SizeFit>,
    /// None with fewer than two runs.
    pub checks: Option<ScanChecks>,
}

/// The scan of the runs in `dirs`, written where `out` says.
pub fn run(dirs: &[PathBuf], out: &SizeOutputs) -> Result<SizeScan> {
    let scan = scan(dirs)?;
    write(&scan, out)?;
    Ok(scan)
}

/// The scan of the runs in `dirs`, ordered by W0, without writing anything.
pub fn scan(dirs: &[PathBuf]) -> Result<SizeScan> {
    let mut rows = dirs.iter().map(|d| row(d)).collect::<Result<Vec<_>>>()?;
    rows.sort_by(|a, b| a.w0_over_d.total_cmp(&b.w0_over_d));
    let col = |f: &dyn Fn(&SizeRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let fit = fit_through_origin(
        &col(&|r| r.w0_over_d),
        &col(&|r| r.sigma),
        &col(&|r| r.sigma_err),
    );
    let checks = checks(&rows);
    Ok(SizeScan { rows, fit, checks })
}

/// The claims across the runs (None with fewer than two).
fn checks(rows: &[SizeRow]) -> Option<ScanChecks> {
    let col = |f: &dyn Fn(&SizeRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    (rows.len() >= 2).then(|| ScanChecks {
        sigma_over_w0_spread: spread(&col(&|r| r.sigma / r.w0_over_d)),
        sigma_y_over_w0_spread: rows
            .iter()
            .map(|r| r.yielding.point().map(|p| p.sigma_y / r.w0_over_d))
            .collect::<Option<Vec<f64>>>()
            .map(|v| spread(&v)),
        chi_spread: [0, 1].map(|k| spread(&col(&|r| r.chi[k]))),
        kappa_spread: {
            let k = col(&|r| r.kappa);
            k.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - k.iter().copied().fold(f64::INFINITY, f64::min)
        },
        p_in_exponent: crate::stats::power_law(&col(&|r| r.w0_over_d), &col(&|r| r.p_in)),
        p_gs_exponent: crate::stats::power_law(&col(&|r| r.n as f64), &col(&|r| r.p_gs)),
        edge_rate_spread: rows
            .iter()
            .map(|r| {
                r.edge
                    .as_ref()
                    .ok()
                    .map(|e| e.rate)
                    .filter(|v| v.is_finite())
            })
            .collect::<Option<Vec<f64>>>()
            .map(|v| spread(&v)),
    })
}

/// The scan's tables where `out` says.
pub fn write(scan: &SizeScan, out: &SizeOutputs) -> Result<()> {
    let rows = &scan.rows;
    let col = |f: &dyn Fn(&SizeRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
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
            Column::new("p_in_mean".into(), col(&|r| r.p_in)),
            Column::new("p_gs_mean".into(), col(&|r| r.p_gs)),
            Column::new(
                "edge_rate".into(),
                col(&|r| r.edge.as_ref().map_or(f64::NAN, |e| e.rate)),
            ),
            Column::new("chi_at_0_1".into(), col(&|r| r.chi[0])),
            Column::new("chi_at_0_2".into(), col(&|r| r.chi[1])),
            Column::new("p_centre".into(), col(&|r| r.p_centre())),
            Column::new("eps_y".into(), col(&|r| r.yield_columns()[0])),
            Column::new("eps_y_lo".into(), col(&|r| r.yield_columns()[1])),
            Column::new("eps_y_hi".into(), col(&|r| r.yield_columns()[2])),
            Column::new("sigma_y".into(), col(&|r| r.yield_columns()[3])),
            Column::new("sigma_y_lo".into(), col(&|r| r.yield_columns()[4])),
            Column::new("sigma_y_hi".into(), col(&|r| r.yield_columns()[5])),
        ],
    )
    .map_err(|e| Error::polars("the size-scan table", e))?;
    write_table(&mut df, &out.table)?;
    if let Some(path) = &out.curves {
        write_long(
            rows,
            path,
            &["strain", "stress_reduced", "kappa", "chi"],
            |r| r.curves.to_vec(),
        )?;
    }
    if let Some(path) = &out.pressure {
        write_long(rows, path, &["x_over_w", "p"], |r| match &r.pressure {
            Ok((p, _)) => vec![p.x_over_w.clone(), p.p.clone()],
            Err(_) => vec![Vec::new(), Vec::new()],
        })?;
    }
    Ok(())
}

/// One table of per-run columns stacked, each row labelled with its run's N and W0/D.
fn write_long(
    rows: &[SizeRow],
    path: &Path,
    names: &[&str],
    cols: impl Fn(&SizeRow) -> Vec<Vec<f64>>,
) -> Result<()> {
    let (mut n, mut w0) = (Vec::new(), Vec::new());
    let mut data: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for r in rows {
        let c = cols(r);
        let len = c.first().map_or(0, Vec::len);
        n.extend(std::iter::repeat_n(r.n as i64, len));
        w0.extend(std::iter::repeat_n(r.w0_over_d, len));
        for (d, v) in data.iter_mut().zip(c) {
            d.extend(v);
        }
    }
    let mut columns = vec![
        Column::new("n".into(), n),
        Column::new("w0_over_d".into(), w0),
    ];
    columns.extend(
        names
            .iter()
            .zip(data)
            .map(|(name, v)| Column::new((*name).into(), v)),
    );
    let height = columns[0].len();
    let mut df = DataFrame::new(height, columns)
        .map_err(|e| Error::polars(format!("{}: building", path.display()), e))?;
    write_table(&mut df, path)
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

    /// The σ_y/W0 check: the spread of σ_y/W0 when every run yields (proportional σ_y
    /// holds, a σ_y growing faster than W0 does not), none when one run does not.
    #[test]
    fn the_yield_check_spreads_sigma_y_over_w0() {
        use crate::structure::yielding::{Yield, YieldPoint};
        let row = |w0: f64, sigma_y: Option<f64>| SizeRow {
            run: PathBuf::new(),
            n: 0,
            w0_over_d: w0,
            h0_over_d: 2.0 * w0,
            sigma: 0.7 * w0,
            sigma_err: 0.1,
            kappa: 0.7,
            p_in: 0.7 * w0 * 1.5 * w0,
            p_gs: 0.7 * 0.7 * w0 * 1.5 * w0,
            chi: [1.4, 1.8],
            pressure: Err(String::new()),
            edge: Err(String::new()),
            yielding: match sigma_y {
                Some(s) => Yield::Reached(YieldPoint {
                    eps_y: 0.02,
                    eps_interval: [0.01, 0.03],
                    sigma_y: s,
                    sigma_interval: [s - 1.0, s + 1.0],
                    modulus: s / 0.02,
                    hardening: 0.0,
                    replicates: 0,
                    replicates_yielded: 0,
                }),
                None => Yield::NotReached("still rising".into()),
            },
            curves: Default::default(),
        };
        let c = checks(&[row(10.0, Some(6.0)), row(20.0, Some(12.6))]).unwrap();
        let s = c.sigma_y_over_w0_spread.unwrap();
        assert!((s - 0.03 / 0.615).abs() < 1e-9, "{s}");
        let c = checks(&[row(10.0, Some(5.0)), row(20.0, Some(14.0))]).unwrap();
        assert!(c.sigma_y_over_w0_spread.unwrap() > 0.3);
        assert_eq!(c.sigma_over_w0_spread, 0.0);
        let c = checks(&[row(10.0, Some(6.0)), row(20.0, None)]).unwrap();
        assert!(c.sigma_y_over_w0_spread.is_none());
        assert!(checks(&[row(10.0, Some(6.0))]).is_none());
        // The CSV columns: the point and its intervals, NaN when not reached.
        assert_eq!(
            row(10.0, Some(6.0)).yield_columns(),
            [0.02, 0.01, 0.03, 6.0, 5.0, 7.0]
        );
        assert!(row(10.0, None).yield_columns().iter().all(|v| v.is_nan()));
        // The powers: P_in = σ W ∝ W0² and, with n ∝ W0², P_g-s ∝ N.
        let mut rows: Vec<SizeRow> = [10.0, 20.0, 40.0].map(|w| row(w, None)).to_vec();
        for r in &mut rows {
            r.n = (10.0 * r.w0_over_d * r.w0_over_d) as usize;
        }
        let c = checks(&rows).unwrap();
        assert!((c.p_in_exponent.unwrap().exponent - 2.0).abs() < 1e-12);
        assert!((c.p_gs_exponent.unwrap().exponent - 1.0).abs() < 1e-12);
        assert_eq!((c.p_in_holds(), c.p_gs_holds()), (Some(true), Some(true)));
        // A flow stress independent of size gives P_in ∝ W0 and fails the check.
        for r in &mut rows {
            r.p_in /= r.w0_over_d;
            r.p_gs /= r.w0_over_d;
        }
        let c = checks(&rows).unwrap();
        assert_eq!((c.p_in_holds(), c.p_gs_holds()), (Some(false), Some(false)));
    }

    #[test]
    fn spread_and_interpolation() {
        assert!((spread(&[0.9, 1.0, 1.1]) - 0.2).abs() < 1e-12);
        let eps = [0.0, 0.08, 0.12, 0.2];
        let chi = [1.0, 1.2, 1.4, 1.6];
        assert!((interpolate(&eps, &chi, 0.1) - 1.3).abs() < 1e-12);
        assert_eq!(interpolate(&eps, &chi, 0.2), 1.6);
        assert!(interpolate(&eps, &chi, 0.3).is_nan(), "beyond the run");
    }
}
