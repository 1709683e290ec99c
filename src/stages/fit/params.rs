//! `fit`'s options as a user writes them, defined once: the command line flattens this
//! struct (`pillar-pipe fit --bootstrap 200`), a pipeline's fit stage deserialises it
//! (`bootstrap = 200`), and the resolved values are what a manifest records and a cache
//! key hashes. The defaults are `FitOptions::default()`'s, named once here for both.

use super::FitOptions;
use crate::error::{Error, Result};
use crate::fit::{Binning, Method, RangeRule};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct FitParams {
    /// The stage whose output is fitted (pipeline files; the command line takes a path).
    #[arg(skip)]
    pub input: String,
    /// Large-grain diameter D (length unit); default from the data.
    #[arg(long)]
    pub diameter: Option<f64>,
    /// Bar speed v_c (length unit/s); default from the tracks' metadata.
    #[arg(long)]
    pub bar_speed: Option<f64>,
    /// Start times in R/v_c (default every 2/3).
    #[arg(long, value_delimiter = ',')]
    pub starts: Option<Vec<f64>>,
    /// Lags in R/v_c (default 2/15, 4/15, ..., 128/15).
    #[arg(long, value_delimiter = ',')]
    pub lags: Option<Vec<f64>>,
    /// R_c in units of D.
    #[arg(long, default_value_t = FitOptions::default().rc_over_d)]
    pub rc_over_d: f64,
    #[arg(long, value_enum, default_value_t = FitOptions::default().method)]
    pub method: Method,
    #[arg(long, default_value_t = FitOptions::default().binning.bins_per_decade)]
    pub bins_per_decade: f64,
    #[arg(long, default_value_t = FitOptions::default().binning.min_count)]
    pub min_bin_count: usize,
    /// Bootstrap replicates over start times.
    #[arg(long, default_value_t = FitOptions::default().bootstrap)]
    pub bootstrap: usize,
    #[arg(long, default_value_t = FitOptions::default().seed)]
    pub seed: u64,
    /// Fitted η^s (dimensionless): `coverage` (bins the protocol samples evenly:
    /// inside the central 90 % of η^s of at least two lags, from at least half the
    /// start times), `all`, or LO,HI.
    #[arg(long, default_value_t = FitOptions::default().range.name(), value_parser = range_rule)]
    pub eta_range: String,
    /// Position noise σ per coordinate per frame of the tracks (length unit, frames
    /// independent): sets the tracking-noise floor of D²min/R² instead of the data's
    /// estimate; under the default range rule bins within 3 floors are left out.
    #[arg(long, value_name = "SIGMA")]
    pub position_noise: Option<f64>,
}

/// The command line checks `--eta-range` as it parses, so its error names the flag.
fn range_rule(text: &str) -> std::result::Result<String, String> {
    RangeRule::parse(text).map(|_| text.to_string())
}

impl Default for FitParams {
    fn default() -> Self {
        let d = FitOptions::default();
        FitParams {
            input: String::new(),
            diameter: d.diameter,
            bar_speed: d.bar_speed,
            starts: d.starts,
            lags: d.lags,
            rc_over_d: d.rc_over_d,
            method: d.method,
            bins_per_decade: d.binning.bins_per_decade,
            min_bin_count: d.binning.min_count,
            bootstrap: d.bootstrap,
            seed: d.seed,
            eta_range: d.range.name(),
            position_noise: d.position_noise,
        }
    }
}

impl FitParams {
    /// The stage's options; `stage` names the key in errors (`fit.eta_range`).
    pub fn options(&self, stage: &str, quiet: bool) -> Result<FitOptions> {
        let range = RangeRule::parse(&self.eta_range)
            .map_err(|e| Error::param(format!("{stage}.eta_range"), e))?;
        Ok(FitOptions {
            diameter: self.diameter,
            bar_speed: self.bar_speed,
            starts: self.starts.clone(),
            lags: self.lags.clone(),
            rc_over_d: self.rc_over_d,
            method: self.method,
            binning: Binning {
                bins_per_decade: self.bins_per_decade,
                min_count: self.min_bin_count,
            },
            bootstrap: self.bootstrap,
            seed: self.seed,
            range,
            scatter: None,
            quiet,
            position_noise: self.position_noise,
        })
    }
}
