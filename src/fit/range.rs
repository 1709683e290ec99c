//! Which η^s the fit of Eq. 19 uses. The protocol of Li et al. Sec. IV (a start every
//! (2/3) R/v_c, lags {2, …, 128}/15 R/v_c) samples η^s evenly only where several lags
//! feed a bin with their typical values. At the top only the longest lag's upper tail
//! reaches — grains of shear zones, a selected minority whose median D²min falls below
//! the trend — and at the bottom only the shortest lag's lower tail, down to round-off
//! of positions that barely moved. Fitting those bins moves Θ by a quarter (issue 22),
//! so by default they are left out, and the figure shows them greyed with the reason.

use super::Samples;
use super::estimate::Binning;
use crate::stats::quantile_sorted;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

/// How the fitted range of η^s is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RangeRule {
    /// Bins the protocol samples evenly (default): η^s within the central
    /// [`LAG_TAIL`]…1 − [`LAG_TAIL`] quantiles of at least [`MIN_LAGS`] lags (one when
    /// the data have a single lag), fed by at least [`MIN_START_FRACTION`] of the start
    /// times.
    Coverage,
    /// Every sample.
    All,
    /// η^s in [lo, hi] as the user gave it.
    Explicit { lo: f64, hi: f64 },
}

impl RangeRule {
    /// `coverage` (the default rule), `all`, or `LO,HI` (0 ≤ LO < HI, dimensionless η^s).
    pub fn parse(text: &str) -> Result<RangeRule, String> {
        match text.trim() {
            "coverage" => return Ok(RangeRule::Coverage),
            "all" => return Ok(RangeRule::All),
            _ => {}
        }
        let bad = || {
            format!("expected 'coverage', 'all' or LO,HI (η^s bounds, 0 ≤ LO < HI), got '{text}'")
        };
        let (a, b) = text.split_once(',').ok_or_else(bad)?;
        let lo: f64 = a.trim().parse().map_err(|_| bad())?;
        let hi: f64 = b.trim().parse().map_err(|_| bad())?;
        if !(lo >= 0.0 && hi > lo && hi.is_finite()) {
            return Err(bad());
        }
        Ok(RangeRule::Explicit { lo, hi })
    }
    pub fn name(&self) -> String {
        match self {
            RangeRule::Coverage => "coverage".into(),
            RangeRule::All => "all".into(),
            RangeRule::Explicit { lo, hi } => format!("{lo:e},{hi:e}"),
        }
    }
}

/// Fraction of each lag's η^s distribution counted as its tail at either end.
pub const LAG_TAIL: f64 = 0.05;
/// Lags whose central η^s range must cover a bin.
pub const MIN_LAGS: usize = 2;
/// Fraction of the start times a bin's points must come from.
pub const MIN_START_FRACTION: f64 = 0.5;

/// A bin left out of the fit, for the figure and fit.json.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ExcludedBin {
    /// Median η^s of the bin's samples.
    pub eta_s: f64,
    /// Median D²min/R² of the bin's samples.
    pub d2min_over_r2: f64,
    pub n: usize,
    pub reason: String,
}

/// The range used, how it was chosen, and what it left out.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FitRange {
    pub rule: RangeRule,
    /// Fitted η^s ∈ [lo, hi] (dimensionless; hi = ∞, `null` in JSON, when open).
    pub lo: f64,
    #[serde(deserialize_with = "super::json_nonfinite::inf")]
    pub hi: f64,
    /// One sentence: the rule in words, with its numbers.
    pub description: String,
    pub samples_in: usize,
    pub samples_out: usize,
    pub excluded: Vec<ExcludedBin>,
}

impl FitRange {
    /// One line for people: the range, how much it keeps, the rule and its reason.
    pub fn summary(&self) -> String {
        format!(
            "η^s in [{:.3e}, {:.3e}], {} of {} samples (rule '{}': {})",
            self.lo,
            self.hi,
            self.samples_in,
            self.samples_in + self.samples_out,
            self.rule.name(),
            self.description
        )
    }
}

struct Bin {
    key: i64,
    etas: Vec<f64>,
    ys: Vec<f64>,
    starts: BTreeSet<u32>,
}

fn bins(s: &Samples, b: &Binning) -> Vec<Bin> {
    let mut map: BTreeMap<i64, Bin> = BTreeMap::new();
    for k in 0..s.len() {
        let (e, y) = (s.eta_s[k], s.d2min_over_r2[k]);
        if !(e > 0.0 && y > 0.0 && e.is_finite() && y.is_finite()) {
            continue;
        }
        let key = (e.log10() * b.bins_per_decade).floor() as i64;
        let bin = map.entry(key).or_insert_with(|| Bin {
            key,
            etas: Vec::new(),
            ys: Vec::new(),
            starts: BTreeSet::new(),
        });
        bin.etas.push(e);
        bin.ys.push(y);
        bin.starts.insert(s.group[k]);
    }
    map.into_values().collect()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    quantile_sorted(v, 0.5)
}

/// Choose the fitted range of `s` by `rule`, binned as the fit bins.
pub fn choose(s: &Samples, rule: RangeRule, b: &Binning) -> FitRange {
    choose_above(s, rule, b, None)
}

/// [`choose`] with a tracking-noise floor of D²min/R²: under the coverage rule, bins
/// whose median D²min/R² is at most `NOISE_FACTOR` floors are left out too (an explicit
/// range or `all` is taken as given).
pub fn choose_above(
    s: &Samples,
    rule: RangeRule,
    b: &Binning,
    noise_floor: Option<f64>,
) -> FitRange {
    let edge = |key: i64| 10f64.powf(key as f64 / b.bins_per_decade);
    let mut all = bins(s, b);
    let (lo, hi, description, reasons): (f64, f64, String, Vec<Option<String>>) = match rule {
        RangeRule::All => (
            0.0,
            f64::INFINITY,
            "every sample".into(),
            vec![None; all.len()],
        ),
        RangeRule::Explicit { lo, hi } => {
            let reasons = all
                .iter()
                .map(|bin| {
                    let m = median(&mut bin.etas.clone());
                    (!(lo..=hi).contains(&m))
                        .then(|| format!("outside --eta-range [{lo:e}, {hi:e}]"))
                })
                .collect();
            (lo, hi, format!("η^s in [{lo:e}, {hi:e}] as given"), reasons)
        }
        RangeRule::Coverage => {
            let (lo, hi, mut description, mut reasons) = coverage(s, &all, b);
            if let Some(f) = noise_floor.filter(|f| *f > 0.0) {
                let limit = super::noise::NOISE_FACTOR * f;
                let mut noisy = 0;
                for (bin, r) in all.iter().zip(reasons.iter_mut()) {
                    let m = median(&mut bin.ys.clone());
                    if r.is_none() && m <= limit {
                        *r = Some(format!(
                            "tracking noise: median D²min/R² {m:.2e} ≤ {} × the noise floor {f:.2e}",
                            super::noise::NOISE_FACTOR
                        ));
                        noisy += 1;
                    }
                }
                if noisy > 0 {
                    description.push_str(&format!(
                        "; {noisy} bin(s) within {}× the tracking-noise floor {f:.2e} left out",
                        super::noise::NOISE_FACTOR
                    ));
                }
            }
            (lo, hi, description, reasons)
        }
    };
    let excluded = all
        .iter_mut()
        .zip(&reasons)
        .filter_map(|(bin, r)| {
            r.as_ref().map(|r| ExcludedBin {
                eta_s: median(&mut bin.etas),
                d2min_over_r2: median(&mut bin.ys),
                n: bin.ys.len(),
                reason: r.clone(),
            })
        })
        .collect();
    // Kept bins are contiguous for the coverage rule: the range runs from the lower edge
    // of the first to the upper edge of the last.
    let (lo, hi) = match rule {
        RangeRule::Coverage => {
            let kept: Vec<i64> = all
                .iter()
                .zip(&reasons)
                .filter(|(_, r)| r.is_none())
                .map(|(bin, _)| bin.key)
                .collect();
            match (kept.first(), kept.last()) {
                (Some(&a), Some(&z)) => (edge(a), edge(z + 1)),
                _ => (lo, hi),
            }
        }
        _ => (lo, hi),
    };
    let samples_in = s.eta_s.iter().filter(|&&e| e >= lo && e <= hi).count();
    FitRange {
        rule,
        lo,
        hi,
        description,
        samples_in,
        samples_out: s.len() - samples_in,
        excluded,
    }
}

/// The coverage rule: (lo, hi, description, a reason per bin it leaves out).
fn coverage(s: &Samples, all: &[Bin], b: &Binning) -> (f64, f64, String, Vec<Option<String>>) {
    let mut by_lag: BTreeMap<u32, Vec<f64>> = BTreeMap::new();
    for k in 0..s.len() {
        if s.eta_s[k] > 0.0 && s.eta_s[k].is_finite() {
            by_lag.entry(s.lag[k]).or_default().push(s.eta_s[k]);
        }
    }
    let central: Vec<(f64, f64)> = by_lag
        .values_mut()
        .map(|v| {
            v.sort_by(f64::total_cmp);
            (
                quantile_sorted(v, LAG_TAIL),
                quantile_sorted(v, 1.0 - LAG_TAIL),
            )
        })
        .collect();
    let need_lags = MIN_LAGS.min(central.len()).max(1);
    let starts: BTreeSet<u32> = s.group.iter().copied().collect();
    let need_starts = ((MIN_START_FRACTION * starts.len() as f64).ceil() as usize).max(1);
    let ok: Vec<Option<String>> = all
        .iter()
        .map(|bin| {
            let mut etas = bin.etas.clone();
            let m = median(&mut etas);
            let lags = central
                .iter()
                .filter(|(a, z)| (*a..=*z).contains(&m))
                .count();
            if bin.ys.len() < b.min_count {
                Some(format!("fewer than {} samples", b.min_count))
            } else if lags < need_lags {
                Some(format!(
                    "inside the central {:.0} % of only {lags} lag(s) (need {need_lags})",
                    100.0 * (1.0 - 2.0 * LAG_TAIL)
                ))
            } else if bin.starts.len() < need_starts {
                Some(format!(
                    "samples from {} of {} start times (need {need_starts})",
                    bin.starts.len(),
                    starts.len()
                ))
            } else {
                None
            }
        })
        .collect();
    // The longest run of consecutive kept bins: a kept bin cut off from it by a left-out
    // one is left out too, so the fitted range is one interval.
    let (mut best, mut run) = ((0, 0), (0, 0));
    for (i, r) in ok.iter().enumerate() {
        let contiguous = i > 0 && all[i].key == all[i - 1].key + 1 && ok[i - 1].is_none();
        if r.is_none() {
            run = if contiguous {
                (run.0, i + 1)
            } else {
                (i, i + 1)
            };
            if run.1 - run.0 > best.1 - best.0 {
                best = run;
            }
        }
    }
    let reasons = ok
        .into_iter()
        .enumerate()
        .map(|(i, r)| match r {
            None if !(best.0..best.1).contains(&i) => {
                Some("separated from the main range by a left-out bin".into())
            }
            r => r,
        })
        .collect();
    let description = format!(
        "bins inside the central {:.0} % of η^s of at least {need_lags} of {} lags and fed by at least {need_starts} of {} start times",
        100.0 * (1.0 - 2.0 * LAG_TAIL),
        central.len(),
        starts.len()
    );
    (0.0, f64::INFINITY, description, reasons)
}
