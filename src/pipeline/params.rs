//! The parameters of each stage kind as typed structs: a validated stage table is
//! deserialised into one of these (filling defaults), serialised back as the resolved
//! parameters recorded in manifests and hashed into cache keys, and turned into the
//! stage function's options. Defaults come from the stages' own option defaults so the
//! CLI and pipelines agree; the schema test checks the schema file documents them.

use super::schema::Kind;
use crate::camera::render::Profile;
use crate::camera::{LinkOptions, LocateParams};
use crate::error::{Error, Result};
use crate::fit::{Binning, Method};
use crate::kinematics::Convention;
use crate::stages::fit::FitOptions;
use crate::stages::ingest::{Format, IngestOptions};
use crate::stages::kinematics::{KinematicsOptions, LagSpec};
use crate::stages::render::RenderOptions;
use crate::stages::shear::ShearOptions;
use crate::stages::simulate::SimulateOptions;
use clap::ValueEnum;
use serde::{Deserialize, Serialize, de::DeserializeOwned};
use serde_json::Value as Json;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IngestParams {
    pub input: String,
    pub format: String,
    pub px_per_unit: Option<f64>,
    pub unit: Option<String>,
    pub frame_time: Option<f64>,
    pub radii: Option<[f64; 2]>,
    pub origin_px: Option<[f64; 2]>,
    pub bar_speed: Option<f64>,
    pub keep_detached: bool,
    /// A force-sensor CSV (`ingest-force`) read beside the tracks.
    pub force: Option<String>,
}

impl Default for IngestParams {
    fn default() -> Self {
        IngestParams {
            input: String::new(),
            format: "auto".into(),
            px_per_unit: None,
            unit: None,
            frame_time: None,
            radii: None,
            origin_px: None,
            bar_speed: None,
            keep_detached: false,
            force: None,
        }
    }
}

impl IngestParams {
    pub fn options(&self) -> Result<IngestOptions> {
        Ok(IngestOptions {
            format: Some(
                Format::from_str(&self.format, true).map_err(|e| Error::param("format", e))?,
            ),
            px_per_unit: self.px_per_unit,
            unit: self.unit.clone(),
            frame_time: self.frame_time,
            radii: self.radii.map(|r| (r[0], r[1])),
            origin_px: self.origin_px.map(|r| (r[0], r[1])),
            bar_speed: self.bar_speed,
            keep_detached: self.keep_detached,
        })
    }
}

/// A `render` stage: the camera emulator (`pillar-pipe render`) on an upstream
/// stage's tracks; the camera settings users vary, the rest at `Camera`'s defaults.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderParams {
    pub input: String,
    pub px_per_unit: f64,
    pub every: i64,
    pub bit_depth: u8,
    pub profile: Profile,
    pub blur: f64,
    pub read_noise: f64,
    pub photons: f64,
    pub seed: u64,
}

impl Default for RenderParams {
    fn default() -> Self {
        let o = RenderOptions::default();
        RenderParams {
            input: String::new(),
            px_per_unit: 0.0,
            every: o.every,
            bit_depth: o.camera.bit_depth,
            profile: o.camera.profile,
            blur: o.camera.blur_px,
            read_noise: o.camera.read_noise,
            photons: o.camera.photons,
            seed: o.camera.seed,
        }
    }
}

impl RenderParams {
    pub fn options(&self, quiet: bool) -> RenderOptions {
        let d = RenderOptions::default();
        RenderOptions {
            px_per_unit: self.px_per_unit,
            every: self.every,
            camera: crate::camera::render::Camera {
                bit_depth: self.bit_depth,
                profile: self.profile,
                blur_px: self.blur,
                read_noise: self.read_noise,
                photons: self.photons,
                seed: self.seed,
                ..d.camera.clone()
            },
            quiet,
            ..d
        }
    }
}

impl RenderParams {
    /// The first camera setting out of its domain, as the render would find it, so a
    /// pipeline is refused at load: (key, what is wrong).
    pub fn problem(&self) -> Option<(String, String)> {
        let cam = crate::camera::render::Camera {
            width: 1,
            height: 1,
            ..self.options(true).camera
        };
        match cam.validate() {
            Ok(()) => None,
            // The command's option names (bit-depth) are the keys (bit_depth).
            Err(Error::Param { name, msg }) => Some((name.replace('-', "_"), msg)),
            Err(e) => Some((String::new(), e.to_string())),
        }
    }
}

/// A `track` stage: locate + link (`pillar-pipe track`) on a `render` stage's frames or
/// a folder of frames, then the linked table to canonical tracks (`ingest`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackParams {
    pub input: Option<String>,
    pub frames: Option<String>,
    pub diameter: usize,
    pub minmass: f64,
    pub separation: Option<f64>,
    pub noise_size: f64,
    pub percentile: f64,
    pub search_range: f64,
    pub memory: usize,
    pub predict: bool,
    pub px_per_unit: Option<f64>,
    pub origin_px: Option<[f64; 2]>,
    pub unit: Option<String>,
    pub frame_time: Option<f64>,
    pub radii: Option<[f64; 2]>,
    pub bar_speed: Option<f64>,
}

impl Default for TrackParams {
    fn default() -> Self {
        let l = LocateParams::default();
        let k = LinkOptions::new(0.0);
        TrackParams {
            input: None,
            frames: None,
            diameter: 0,
            minmass: l.minmass,
            separation: l.separation,
            noise_size: l.noise_size,
            percentile: l.percentile,
            search_range: 0.0,
            memory: k.memory,
            predict: k.predict,
            px_per_unit: None,
            origin_px: None,
            unit: None,
            frame_time: None,
            radii: None,
            bar_speed: None,
        }
    }
}

impl TrackParams {
    pub fn locate(&self) -> LocateParams {
        LocateParams {
            diameter: self.diameter,
            minmass: self.minmass,
            separation: self.separation,
            noise_size: self.noise_size,
            percentile: self.percentile,
            ..LocateParams::default()
        }
    }
    pub fn link(&self) -> LinkOptions {
        LinkOptions {
            memory: self.memory,
            predict: self.predict,
            ..LinkOptions::new(self.search_range)
        }
    }
    /// The first key out of its domain, as the stage would find it, so a pipeline is
    /// refused at load: (key, what is wrong).
    pub fn problem(&self) -> Option<(String, String)> {
        let named = |e: Error| match e {
            Error::Param { name, msg } => (name, msg),
            other => (String::new(), other.to_string()),
        };
        if let Err(e) = self.locate().check() {
            return Some(named(e));
        }
        if let Err(e) = self.link().check() {
            return Some(named(e));
        }
        None
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KinematicsParams {
    pub input: String,
    pub lags: Vec<i64>,
    pub lag_time: Option<f64>,
    pub rc: Option<f64>,
    pub start: Option<i64>,
    pub every: Option<i64>,
    pub convention: String,
}

impl Default for KinematicsParams {
    fn default() -> Self {
        KinematicsParams {
            input: String::new(),
            lags: vec![1],
            lag_time: None,
            rc: None,
            start: None,
            every: None,
            convention: "paper".into(),
        }
    }
}

impl KinematicsParams {
    pub fn options(&self, quiet: bool) -> Result<KinematicsOptions> {
        Ok(KinematicsOptions {
            lag: match self.lag_time {
                Some(s) => LagSpec::Time(s),
                None => LagSpec::Frames(self.lags.clone()),
            },
            rc: self.rc,
            start: self.start,
            every: self.every,
            convention: Convention::from_str(&self.convention, true)
                .map_err(|e| Error::param("convention", e))?,
            // A pipeline's later stages read every column.
            columns: Default::default(),
            quiet,
        })
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FitParams {
    pub input: String,
    pub diameter: Option<f64>,
    pub bar_speed: Option<f64>,
    pub starts: Option<Vec<f64>>,
    pub lags: Option<Vec<f64>>,
    pub rc_over_d: f64,
    pub method: Method,
    pub bins_per_decade: f64,
    pub min_bin_count: usize,
    pub bootstrap: usize,
    pub seed: u64,
    /// `coverage`, `all` or `LO,HI` (see `fit --eta-range`).
    pub eta_range: String,
    /// Position noise σ per coordinate per frame (length unit; see `fit --position-noise`).
    pub position_noise: Option<f64>,
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
    pub fn options(&self, stage: &str, quiet: bool) -> Result<FitOptions> {
        let range = crate::fit::RangeRule::parse(&self.eta_range)
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

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompareParams {
    pub a: String,
    pub b: String,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReportParams {
    pub datasets: Vec<String>,
    pub title: Option<String>,
    pub map_stages: usize,
}

impl Default for ReportParams {
    fn default() -> Self {
        ReportParams {
            datasets: Vec::new(),
            title: None,
            map_stages: 3,
        }
    }
}

/// A `sweep` stage: the grid (every combination of `phi`, `q` and `rate`) and what its
/// runs share; each grid point runs as a `shear` stage of its own (see `graph`), so
/// these are `ShearOptions` less the per-point keys and the ramp (a ramp is one run).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SweepParams {
    pub phi: Vec<f64>,
    pub q: Vec<f64>,
    pub rate: Vec<f64>,
    pub n: usize,
    pub model: crate::dem::shear::Dissipation,
    pub strain: f64,
    pub dt: Option<f64>,
    pub seed: u64,
    pub output_every: Option<u64>,
    pub sample_every: u64,
    pub transient: f64,
    pub blocks: usize,
    pub checkpoint_every: u64,
    pub checkpoint_interval: f64,
}

impl Default for SweepParams {
    fn default() -> Self {
        let d = ShearOptions::default();
        SweepParams {
            phi: Vec::new(),
            q: Vec::new(),
            rate: Vec::new(),
            n: d.n,
            model: d.model,
            strain: d.strain,
            dt: d.dt,
            seed: d.seed,
            output_every: d.output_every,
            sample_every: d.sample_every,
            transient: d.transient,
            blocks: d.blocks,
            checkpoint_every: d.checkpoint_every,
            checkpoint_interval: d.checkpoint_interval,
        }
    }
}

impl SweepParams {
    /// The grid points (φ, Q, γ̇) in table order (φ outermost), duplicates dropped.
    pub fn grid(&self) -> Vec<(f64, f64, f64)> {
        let mut g: Vec<(f64, f64, f64)> = Vec::new();
        for &phi in &self.phi {
            for &q in &self.q {
                for &rate in &self.rate {
                    if !g.contains(&(phi, q, rate)) {
                        g.push((phi, q, rate));
                    }
                }
            }
        }
        g
    }

    /// The options of the run at one grid point: exactly what a `shear` stage with the
    /// same keys would run, so both share one cache entry.
    pub fn point(&self, (phi, q, rate): (f64, f64, f64)) -> ShearOptions {
        ShearOptions {
            n: self.n,
            phi,
            q,
            rate,
            model: self.model,
            strain: self.strain,
            dt: self.dt,
            seed: self.seed,
            output_every: self.output_every,
            sample_every: self.sample_every,
            transient: self.transient,
            blocks: self.blocks,
            checkpoint_every: self.checkpoint_every,
            checkpoint_interval: self.checkpoint_interval,
            ..ShearOptions::default()
        }
    }
}

/// A `ramp` stage: one strain-rate ramp (vagberg-sheared-disks Eqs. 38–41), γ̇ τ_e from
/// `rate` to `rate_end` by 10^{±κ̃} every τ_e. `ShearOptions` less what only a steady
/// run reads (its strain, transient and blocks: a ramp's length is set by its rates
/// and κ̃, and it has no steady window), the ramp keys required where the command
/// line has them optional.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RampParams {
    /// `up` or `down` (the command's `--ramp`).
    pub ramp: String,
    /// Final γ̇ τ_e (`--rate-end`).
    pub rate_end: f64,
    /// κ̃ = κ τ_e / ln 10 (Eq. 39).
    pub kappa: f64,
    /// Averaging window of `ramp.parquet` (τ_e; the paper: 10³).
    pub window: f64,
    /// A `ramp` stage whose final state this ramp starts from (a cycle), else random
    /// positions.
    pub from: Option<String>,
    pub n: usize,
    pub phi: f64,
    pub q: f64,
    /// Initial γ̇ τ_e.
    pub rate: f64,
    pub model: crate::dem::shear::Dissipation,
    pub dt: Option<f64>,
    pub seed: u64,
    pub output_every: Option<u64>,
    pub sample_every: u64,
    pub checkpoint_every: u64,
    pub checkpoint_interval: f64,
}

impl Default for RampParams {
    fn default() -> Self {
        let d = ShearOptions::default();
        RampParams {
            ramp: String::new(),
            rate_end: 0.0,
            kappa: d.kappa,
            window: d.window,
            from: None,
            n: d.n,
            phi: d.phi,
            q: d.q,
            rate: d.rate,
            model: d.model,
            dt: d.dt,
            seed: d.seed,
            output_every: d.output_every,
            sample_every: d.sample_every,
            checkpoint_every: d.checkpoint_every,
            checkpoint_interval: d.checkpoint_interval,
        }
    }
}

impl RampParams {
    /// The options `simulate shear --ramp` runs with.
    pub fn options(&self) -> ShearOptions {
        ShearOptions {
            n: self.n,
            phi: self.phi,
            q: self.q,
            rate: self.rate,
            model: self.model,
            dt: self.dt,
            seed: self.seed,
            output_every: self.output_every,
            sample_every: self.sample_every,
            ramp: Some(self.ramp.clone()),
            kappa: self.kappa,
            rate_end: Some(self.rate_end),
            window: self.window,
            checkpoint_every: self.checkpoint_every,
            checkpoint_interval: self.checkpoint_interval,
            ..ShearOptions::default()
        }
    }
}

/// Options of `ShearOptions` that only a ramp reads: a `shear` stage is a steady run,
/// a ramp is a `ramp` stage.
pub const RAMP_ONLY: [&str; 4] = ["ramp", "kappa", "rate_end", "window"];

/// How a run behaves, not what it computes: `--quiet`, and resuming (a pipeline stage
/// always starts in a fresh directory).
const SIMULATE_RUN_ONLY: [&str; 2] = ["quiet", "resume"];

fn round_trip<T: Serialize + DeserializeOwned>(given: Json) -> std::result::Result<Json, String> {
    let t: T = serde_json::from_value(given).map_err(|e| e.to_string())?;
    Ok(serde_json::to_value(t).expect("json"))
}

/// Fill defaults: the stage table (validated, `kind` removed) → every key's value.
pub fn resolve(kind: Kind, given: Json) -> std::result::Result<Json, String> {
    let mut v = match kind {
        Kind::Ingest => round_trip::<IngestParams>(given),
        Kind::Simulate => round_trip::<SimulateOptions>(given),
        Kind::Kinematics => round_trip::<KinematicsParams>(given),
        Kind::Fit => round_trip::<FitParams>(given),
        Kind::Compare => round_trip::<CompareParams>(given),
        Kind::Report => round_trip::<ReportParams>(given),
        Kind::Shear => round_trip::<ShearOptions>(given),
        Kind::Sweep => round_trip::<SweepParams>(given),
        Kind::Ramp => round_trip::<RampParams>(given),
        Kind::Render => round_trip::<RenderParams>(given),
        Kind::Track => round_trip::<TrackParams>(given),
    }?;
    if kind == Kind::Shear
        && let Some(o) = v.as_object_mut()
    {
        for k in RAMP_ONLY {
            o.remove(k);
        }
    }
    if matches!(kind, Kind::Simulate | Kind::Shear)
        && let Some(o) = v.as_object_mut()
    {
        for k in SIMULATE_RUN_ONLY {
            o.remove(k);
        }
    }
    Ok(v)
}

/// Every key of a kind with its Rust default (what the schema file must document).
pub fn rust_defaults(kind: Kind) -> Json {
    resolve(kind, Json::Object(Default::default())).expect("defaults deserialise")
}

/// Typed parameters back from resolved JSON (always succeeds for resolved values).
pub fn typed<T: DeserializeOwned>(stage: &str, params: &Json) -> Result<T> {
    let mut p = params.clone();
    if let Some(o) = p.as_object_mut() {
        o.remove("kind");
    }
    serde_json::from_value(p).map_err(|e| Error::param(stage, e.to_string()))
}
