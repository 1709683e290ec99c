//! `fit`: the D²min–η^s study of Li et al. Sec. IV. From tracks it runs the sampling
//! protocol (start times every (2/3) R/v_c, lags {2, 4, …, 128}/15 R/v_c, R_c = 1.25 D);
//! from a `kinematics` table it takes the rows as they are. Then Eq. 19 is fitted with
//! every estimator and the chosen one is reported with bootstrap intervals.

pub use crate::stages::fit::sampling::ETA_S_AT_REST;
pub mod params;
pub mod sampling;

use crate::error::{Error, Result};
use crate::fit::{
    Binning, EstimatorResult, FitRange, FitSettings, Method, RangeRule, SensitivityRow, ThirdFit,
    by_thirds, fit_all_above, json_nonfinite, sensitivity,
};
use crate::io::sink::stream_table;
use crate::io::{atomic_write_str, read_tracks, sha256_file};
use crate::stages::fit::sampling::{ScatterRows, from_kinematics, from_tracks, is_kinematics};
use polars::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// R_c / D of the sensitivity table (the paper's 1.25 and either side).
pub const SENSITIVITY_RC: [f64; 3] = [1.0, 1.25, 1.5];

/// Paper defaults, in units of R/v_c.
pub const START_SPACING: f64 = 2.0 / 3.0;
pub const MIN_STARTS: usize = 8;
/// Fewest neighbours for a D²min sample: with N_i = 2 the four components of J fit the
/// two neighbour vectors exactly, so D²min ≡ 0 (round-off) and carries no information.
pub const MIN_NEIGHBORS_FOR_D2MIN: u32 = 3;
pub fn default_lags() -> Vec<f64> {
    [2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0]
        .iter()
        .map(|l| l / 15.0)
        .collect()
}

#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Large-grain diameter D (length unit); default from the data.
    pub diameter: Option<f64>,
    /// Bar speed v_c (length unit / s); default from the tracks' metadata.
    pub bar_speed: Option<f64>,
    /// Start times in R/v_c after the first frame; default every 2/3 R/v_c.
    pub starts: Option<Vec<f64>>,
    /// Lags in R/v_c; default {2, 4, …, 128}/15.
    pub lags: Option<Vec<f64>>,
    /// R_c in units of D.
    pub rc_over_d: f64,
    pub method: Method,
    pub binning: Binning,
    pub bootstrap: usize,
    pub seed: u64,
    /// Which η^s are fitted (default: the bins the protocol samples evenly).
    pub range: RangeRule,
    /// The scatter table; default `<output stem>.scatter.parquet`.
    pub scatter: Option<PathBuf>,
    pub quiet: bool,
    /// Position noise σ per coordinate per frame (length unit, frames independent) of
    /// the tracks; sets the tracking-noise floor instead of the data's estimate.
    pub position_noise: Option<f64>,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            diameter: None,
            bar_speed: None,
            starts: None,
            lags: None,
            rc_over_d: 1.25,
            method: Method::BinnedMedian,
            binning: Binning::default(),
            bootstrap: 1000,
            seed: 1,
            range: RangeRule::Coverage,
            scatter: None,
            quiet: false,
            position_noise: None,
        }
    }
}

/// How the samples were collected; `compare` refuses fits whose protocols differ.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Protocol {
    /// "tracks" (protocol run here) or "kinematics" (rows as given).
    pub source: String,
    pub diameter: f64,
    pub rc_over_d: f64,
    pub bar_speed: Option<f64>,
    /// R/v_c in the tracks' time unit, when known.
    pub time_scale: Option<f64>,
    pub lags_frames: Vec<i64>,
    /// Lags asked for and obtained (nearest frames), in R/v_c.
    pub lags_requested: Vec<f64>,
    pub lags_used: Vec<f64>,
    pub start_frames: Vec<i64>,
    pub binning: Binning,
}

/// `fit.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitReport {
    // An undetermined number is NaN, written as `null`.
    #[serde(deserialize_with = "json_nonfinite::nan")]
    pub theta: f64,
    #[serde(deserialize_with = "json_nonfinite::nan")]
    pub eta_c: f64,
    #[serde(deserialize_with = "json_nonfinite::nan_pair")]
    pub theta_interval: [f64; 2],
    #[serde(deserialize_with = "json_nonfinite::nan_pair")]
    pub eta_c_interval: [f64; 2],
    pub theta_constrained: bool,
    pub eta_c_constrained: bool,
    pub method: Method,
    pub n_points: usize,
    pub n_starts: usize,
    #[serde(deserialize_with = "json_nonfinite::nan")]
    pub residual_rms: f64,
    pub notes: Vec<String>,
    /// The fitted η^s range, the rule that chose it and the bins it left out (absent in
    /// fits made before the rule existed: those fitted every bin).
    #[serde(default)]
    pub range: Option<FitRange>,
    /// Every estimator's Θ, η_c with the range's upper end at 0.2, 0.5, 1 and ∞ (point
    /// fits, no bootstrap): the spread behind the headline number.
    #[serde(default)]
    pub sensitivity: Vec<SensitivityRow>,
    /// The chosen estimator on the first, middle and last third of the start times
    /// (empty with fewer than six starts): is the crossover stationary?
    #[serde(default)]
    pub stationarity: Vec<ThirdFit>,
    /// Every estimator's result, or its error.
    pub estimators: BTreeMap<String, serde_json::Value>,
    /// The tracking-noise floor of D²min/R², each way it was estimated, and which one
    /// the range rule used (absent in fits made before it existed).
    #[serde(default)]
    pub noise: Option<NoiseReport>,
    pub protocol: Protocol,
    pub bootstrap: usize,
    pub seed: u64,
    pub input: String,
    pub input_sha256: String,
    pub scatter: String,
    pub tool: String,
    pub tool_version: String,
    pub elapsed_s: f64,
    pub warnings: Vec<String>,
}

/// Tracking noise (see `fit::noise`): floors of D²min/R² from the data and from the
/// user's σ, the displacement noise they mean, and the floor the range rule used.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct NoiseReport {
    /// The floor the range rule used (D²min/R²), and why: `position_noise` (given),
    /// `data` (measured tracks), or `none` (a simulation, or no floor seen).
    pub floor: Option<f64>,
    pub source: String,
    /// From the data: the two shortest lags' median D²min/R² extrapolated to zero lag,
    /// and the displacement noise per coordinate it means (length unit).
    pub data_floor: Option<f64>,
    pub data_displacement_noise: Option<f64>,
    /// From `--position-noise` σ (length unit): its floor, 8σ²(1 − 1/N)/R².
    pub position_noise: Option<f64>,
    pub position_noise_floor: Option<f64>,
    /// From trackpy's median `ep` (length unit, carried by ingest) taken as σ: its
    /// floor. Reported, never used: trackpy's estimate can be far off (tested on the
    /// bundled sample).
    #[serde(default)]
    pub trackpy_ep: Option<f64>,
    #[serde(default)]
    pub trackpy_ep_floor: Option<f64>,
    /// Neighbours per particle assumed in (1 − 1/N).
    pub neighbours: f64,
    /// Bins the floor left out.
    pub bins_left_out: usize,
}

impl NoiseReport {
    fn of(
        samples: &crate::fit::Samples,
        r: f64,
        measured: bool,
        sigma: Option<f64>,
        ep: Option<f64>,
    ) -> Self {
        use crate::fit::noise::{TYPICAL_NEIGHBOURS, data_floor, floor_of, s_of_floor};
        let n = TYPICAL_NEIGHBOURS;
        let data = data_floor(samples);
        let user = sigma.map(|s| floor_of(2.0 * s * s, n, r));
        let (floor, source) = match (user, data) {
            (Some(f), _) => (Some(f), "position_noise"),
            (None, Some(f)) if measured => (Some(f), "data"),
            _ => (None, "none"),
        };
        NoiseReport {
            floor,
            source: source.into(),
            data_floor: data,
            data_displacement_noise: data.map(|f| s_of_floor(f, n, r)),
            position_noise: sigma,
            position_noise_floor: user,
            trackpy_ep: ep,
            trackpy_ep_floor: ep.map(|e| floor_of(2.0 * e * e, n, r)),
            neighbours: n,
            bins_left_out: 0,
        }
    }

    /// One line for people.
    pub fn summary(&self) -> String {
        let data = match (self.data_floor, self.data_displacement_noise) {
            (Some(f), Some(s)) => {
                format!("data {f:.2e} (displacement noise {s:.3} per coordinate)")
            }
            _ => "data: none seen".into(),
        };
        let mut user = match (self.position_noise, self.position_noise_floor) {
            (Some(s), Some(f)) => format!("; --position-noise {s} → {f:.2e}"),
            _ => String::new(),
        };
        if let (Some(e), Some(f)) = (self.trackpy_ep, self.trackpy_ep_floor) {
            user.push_str(&format!("; trackpy ep {e:.2e} → {f:.2e} (not used)"));
        }
        match self.floor {
            Some(f) => format!(
                "floor {f:.2e} of D²min/R² ({}), {} bin(s) left out; {data}{user}",
                self.source, self.bins_left_out
            ),
            None => format!("no floor applied ({}); {data}{user}", self.source),
        }
    }
}

impl std::fmt::Display for FitReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let value = |x: f64, iv: [f64; 2], ok: bool| {
            let v = with_interval(x, iv, ok);
            if ok { v } else { format!("{v} by these data") }
        };
        writeln!(
            f,
            "fit           Eq. 19 by {}, {} points from {} starts",
            self.method.name(),
            self.n_points,
            self.n_starts
        )?;
        writeln!(
            f,
            "Theta         {}",
            value(self.theta, self.theta_interval, self.theta_constrained)
        )?;
        writeln!(
            f,
            "eta_c         {}",
            value(self.eta_c, self.eta_c_interval, self.eta_c_constrained)
        )?;
        if let Some(r) = &self.range {
            writeln!(
                f,
                "range         {}; {} bins left out",
                r.summary(),
                r.excluded.len()
            )?;
        }
        if let Some(n) = &self.noise {
            writeln!(f, "noise         {}", n.summary())?;
        }
        writeln!(
            f,
            "              (95% bootstrap over start times, {} replicates, seed {})",
            self.bootstrap, self.seed
        )?;
        for (name, v) in &self.estimators {
            let shown = |key: &str| {
                let ok = v
                    .get(format!("{key}_constrained"))
                    .and_then(|b| b.as_bool())
                    .unwrap_or(true);
                match v.get(key).and_then(|x| x.as_f64()) {
                    Some(x) if ok => num(x),
                    Some(_) => "not constrained".into(),
                    None => "?".into(),
                }
            };
            match (v.get("theta"), v.get("eta_c")) {
                (Some(_), Some(_)) => writeln!(
                    f,
                    "  {name:14} Theta {}  eta_c {}",
                    shown("theta"),
                    shown("eta_c")
                )?,
                _ => writeln!(
                    f,
                    "  {name:14} failed: {}",
                    v.get("error").and_then(|e| e.as_str()).unwrap_or("?")
                )?,
            }
        }
        let spread = |get: fn(&SensitivityRow) -> f64| {
            let v: Vec<f64> = self
                .sensitivity
                .iter()
                .map(get)
                .filter(|x| x.is_finite())
                .collect();
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (lo, hi)
        };
        if !self.sensitivity.is_empty() {
            let ((t0, t1), (e0, e1)) = (spread(|r| r.theta), spread(|r| r.eta_c));
            let mut rcs: Vec<f64> = self.sensitivity.iter().map(|r| r.rc_over_d).collect();
            rcs.sort_by(f64::total_cmp);
            rcs.dedup();
            writeln!(
                f,
                "sensitivity   Theta {}–{}, eta_c {}–{} over {} estimators × upper eta_s {{0.2, 0.5, 1, all}} × R_c {:?} D (point fits; fit.json 'sensitivity')",
                num(t0),
                num(t1),
                num(e0),
                num(e1),
                Method::ALL.len(),
                rcs
            )?;
        }
        if !self.stationarity.is_empty() {
            let parts: Vec<String> = self
                .stationarity
                .iter()
                .map(|t| {
                    format!(
                        "{}: Theta {}, eta_c {}",
                        t.part,
                        with_interval(t.theta, t.theta_interval, t.theta_constrained),
                        with_interval(t.eta_c, t.eta_c_interval, t.eta_c_constrained)
                    )
                })
                .collect();
            writeln!(f, "thirds        {}", parts.join("; "))?;
        }
        for n in &self.notes {
            writeln!(f, "note: {n}")?;
        }
        write!(
            f,
            "lags          {:?} frames = {:.3?} R/v_c",
            self.protocol.lags_frames, self.protocol.lags_used
        )
    }
}

/// `x [lo, hi]`, or "not constrained" where the data do not determine x: an
/// undetermined parameter is never shown as a number.
pub fn with_interval(x: f64, iv: [f64; 2], ok: bool) -> String {
    if ok {
        format!("{} [{}, {}]", num(x), num(iv[0]), num(iv[1]))
    } else {
        "not constrained".to_string()
    }
}

/// Four significant digits, scientific outside [1e-3, 1e4).
pub fn num(x: f64) -> String {
    if x == 0.0 || (x.abs() >= 1e-3 && x.abs() < 1e4) {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}

/// Default scatter path: `fit.json` → `fit.scatter.parquet`.
pub fn scatter_path(output: &Path) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "fit".into());
    output.with_file_name(format!("{stem}.scatter.parquet"))
}

pub fn run(input: &Path, output: &Path, opt: &FitOptions) -> Result<FitReport> {
    let t0 = std::time::Instant::now();
    if opt.bootstrap < 10 {
        return Err(Error::param(
            "bootstrap",
            format!(
                "{} replicates: need at least 10 for an interval",
                opt.bootstrap
            ),
        ));
    }
    if !(opt.rc_over_d > 0.0) {
        return Err(Error::param("rc", "R_c must be > 0"));
    }
    let mut warnings = Vec::new();
    // Tracks are read once: the sensitivity table reruns the protocol on them.
    let tracks = if is_kinematics(input)? {
        None
    } else {
        let (t, w) = read_tracks(input)?;
        warnings.extend(w);
        Some(t)
    };
    let (samples, rows, protocol) = match &tracks {
        None => from_kinematics(input, opt, &mut warnings)?,
        Some(t) => from_tracks(input, t, opt, &mut warnings)?,
    };
    let settings = FitSettings {
        method: opt.method,
        binning: opt.binning,
        bootstrap: opt.bootstrap,
        seed: opt.seed,
        range: opt.range,
    };
    // Measured positions carry tracking noise; simulated ones do not.
    let measured = tracks.as_ref().is_some_and(|t| {
        !matches!(
            t.meta.provenance.source_format.as_str(),
            "simulation" | "generated"
        )
    });
    let ep = tracks.as_ref().and_then(|t| t.meta.position_error_ep);
    let mut noise = NoiseReport::of(
        &samples,
        0.5 * protocol.diameter,
        measured,
        opt.position_noise,
        ep,
    );
    let (chosen, all, range) = fit_all_above(&samples, &settings, noise.floor)
        .map_err(|e| Error::Other(format!("{}: {e}", input.display())))?;
    noise.bins_left_out = range
        .excluded
        .iter()
        .filter(|b| b.reason.starts_with("tracking noise"))
        .count();
    let stationarity = by_thirds(&samples, &settings, &range);
    let mut sensitivity = sensitivity(&samples, opt.rc_over_d, range.lo, &opt.binning);
    if let Some(t) = &tracks {
        // The neighbourhood radius is the paper's choice too (Sec. IV); from tracks the
        // protocol can be rerun with the others.
        for rc in SENSITIVITY_RC {
            if (rc - opt.rc_over_d).abs() < 1e-9 {
                continue;
            }
            let o = FitOptions {
                rc_over_d: rc,
                quiet: true,
                ..opt.clone()
            };
            let (other, _, _) = from_tracks(input, t, &o, &mut Vec::new())?;
            sensitivity.extend(crate::fit::sensitivity(&other, rc, range.lo, &opt.binning));
        }
    }
    let scatter = opt.scatter.clone().unwrap_or_else(|| scatter_path(output));
    write_scatter(&scatter, &rows)?;
    let estimators = all
        .into_iter()
        .map(|(k, v)| {
            let j = match v {
                Ok(r) => serde_json::to_value(r).expect("json"),
                Err(e) => serde_json::json!({ "error": e }),
            };
            (k, j)
        })
        .collect();
    let EstimatorResult {
        theta,
        eta_c,
        theta_interval,
        eta_c_interval,
        theta_constrained,
        eta_c_constrained,
        notes,
        residual_rms,
        ..
    } = chosen;
    let rep = FitReport {
        theta,
        eta_c,
        theta_interval,
        eta_c_interval,
        theta_constrained,
        eta_c_constrained,
        method: opt.method,
        n_points: samples.len(),
        n_starts: protocol.start_frames.len(),
        residual_rms,
        notes,
        range: Some(range),
        sensitivity,
        stationarity,
        estimators,
        noise: Some(noise),
        protocol,
        bootstrap: opt.bootstrap,
        seed: opt.seed,
        input: input.display().to_string(),
        input_sha256: sha256_file(input)?,
        scatter: scatter.display().to_string(),
        tool: crate::stages::TOOL.into(),
        tool_version: crate::stages::VERSION.into(),
        elapsed_s: t0.elapsed().as_secs_f64(),
        warnings,
    };
    atomic_write_str(output, &serde_json::to_string_pretty(&rep).expect("json"))?;
    Ok(rep)
}

fn write_scatter(path: &Path, r: &ScatterRows) -> Result<()> {
    let n = r.start.len();
    let df = DataFrame::new(
        n,
        vec![
            Column::new("frame".into(), &r.start),
            Column::new("frame_end".into(), &r.end),
            Column::new("particle".into(), &r.particle),
            Column::new("species".into(), &r.species),
            Column::new("eta_s".into(), &r.eta_s),
            Column::new("d2min_over_r2".into(), &r.y),
        ],
    )
    .map_err(|e| Error::polars("scatter table", e))?;
    let schema = df.schema().as_ref().clone();
    stream_table(path, &schema, |sink| sink.write(&df)).map(|_| ())
}

/// Read a `fit.json`.
pub fn read_fit(path: &Path) -> Result<FitReport> {
    // Bytes, not a string: serde_json then places invalid UTF-8 at its line and column.
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    serde_json::from_slice(&text)
        .map_err(|e| Error::input(path.display(), format!("not a pillar-pipe fit.json: {e}")))
}
