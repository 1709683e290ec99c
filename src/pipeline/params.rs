//! The parameters of each stage kind as typed structs: a validated stage table is
//! deserialised into one of these (filling defaults), serialised back as the resolved
//! parameters recorded in manifests and hashed into cache keys, and turned into the
//! stage function's options. Defaults come from the stages' own option defaults so the
//! CLI and pipelines agree; the schema test checks the schema file documents them.

use super::schema::Kind;
use crate::camera::render::{Camera, Profile};
use crate::camera::{LinkOptions, LocateParams};
use crate::error::{Error, Result};
use crate::kinematics::Convention;
pub use crate::stages::fit::params::FitParams;
use crate::stages::ingest::{Format, IngestOptions};
use crate::stages::kinematics::{KinematicsOptions, LagSpec};
use crate::stages::render::{ImageFormat, RenderOptions};
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

/// `render`'s options, defined once: the command line flattens this struct
/// (`pillar-pipe render --gradient 0.2`) and a pipeline's render stage deserialises it
/// (`gradient = 0.2`). Defaults are `RenderOptions::default()`'s and `Camera`'s.
/// Brightness levels are fractions of the full scale (255 at 8 bit, 65535 at 16 bit);
/// noise is in grey levels of the chosen bit depth; lengths on the image in pixels.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct RenderParams {
    /// The stage whose tracks are drawn (pipeline files; the command line takes a path).
    #[arg(skip)]
    pub input: String,
    /// Pixels per length unit of the tracks (e.g. 31.496 for cm at 80 px/inch).
    #[arg(long)]
    pub px_per_unit: f64,
    /// Render every N-th frame of the tracks.
    #[arg(long, default_value_t = RenderOptions::default().every)]
    pub every: i64,
    /// Frame image format.
    #[arg(long, value_enum, default_value_t = RenderOptions::default().format)]
    pub format: ImageFormat,
    /// Bits per pixel: 8 or 16.
    #[arg(long, default_value_t = Camera::default().bit_depth)]
    pub bit_depth: u8,
    /// Grain brightness profile: flat (uniform disk, soft edge), gaussian (σ = r/2),
    /// dome (lit sphere, brighter centre).
    #[arg(long, value_enum, default_value_t = Camera::default().profile)]
    pub profile: Profile,
    /// Grain brightness above the background, fraction of full scale.
    #[arg(long, default_value_t = Camera::default().grain_level)]
    pub level: f64,
    /// Relative spread of the grains' brightness (each grain keeps its own, from the seed).
    #[arg(long, default_value_t = Camera::default().brightness_spread)]
    pub spread: f64,
    /// Width σ of the grain's own edge before the blur, px (flat and dome profiles; the
    /// imaged edge is √(edge² + blur²) wide, its 10–90 % rise 2.56 times that).
    #[arg(long, default_value_t = Camera::default().edge_px)]
    pub edge: f64,
    /// Dome profile: centre-to-rim contrast, 0 … 1.
    #[arg(long, default_value_t = Camera::default().dome_contrast)]
    pub dome_contrast: f64,
    /// Background brightness, fraction of full scale.
    #[arg(long, default_value_t = Camera::default().background)]
    pub background: f64,
    /// Illumination gradient: fractional change across the frame (0.2: ±10 %).
    #[arg(long, default_value_t = Camera::default().gradient)]
    pub gradient: f64,
    /// Direction in which the illumination rises, degrees (0: to the right, 90: down).
    #[arg(long, default_value_t = Camera::default().gradient_angle_deg)]
    pub gradient_angle: f64,
    /// Relative frame-to-frame flicker of the illumination (standard deviation).
    #[arg(long, default_value_t = Camera::default().flicker)]
    pub flicker: f64,
    /// Gaussian blur σ of the optics, px (0: none).
    #[arg(long, default_value_t = Camera::default().blur_px)]
    pub blur: f64,
    /// Shot noise: photons per pixel at full scale (0: none).
    #[arg(long, default_value_t = Camera::default().photons)]
    pub photons: f64,
    /// Read noise, standard deviation in grey levels.
    #[arg(long, default_value_t = Camera::default().read_noise)]
    pub read_noise: f64,
    /// Seed of the grains' brightness and of every frame's noise.
    #[arg(long, default_value_t = Camera::default().seed)]
    pub seed: u64,
    /// Least distance between the content and the frame's edges, px.
    #[arg(long, default_value_t = RenderOptions::default().margin_px)]
    pub margin: f64,
    /// Frame size WIDTHxHEIGHT in px (a pipeline: [WIDTH, HEIGHT]) [default: the
    /// content plus the margin].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Do not draw a pillar run's bars.
    #[arg(long)]
    pub no_bars: bool,
    /// Bar thickness in the tracks' length unit [default: 2 large-grain diameters].
    #[arg(long)]
    pub bar_thickness: Option<f64>,
    /// Bar brightness above the background, fraction of full scale.
    #[arg(long, default_value_t = RenderOptions::default().bar_level)]
    pub bar_level: f64,
}

/// `WIDTHxHEIGHT` in px, each a whole number above 0.
fn parse_size(s: &str) -> std::result::Result<(usize, usize), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}': expected WIDTHxHEIGHT, e.g. 640x480"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<usize>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("'{v}': expected a whole number of pixels > 0"))
    };
    Ok((p(w)?, p(h)?))
}

impl Default for RenderParams {
    fn default() -> Self {
        let o = RenderOptions::default();
        let c = &o.camera;
        RenderParams {
            input: String::new(),
            // No default scale: a pipeline must give it (0 is refused at load).
            px_per_unit: 0.0,
            every: o.every,
            format: o.format,
            bit_depth: c.bit_depth,
            profile: c.profile,
            level: c.grain_level,
            spread: c.brightness_spread,
            edge: c.edge_px,
            dome_contrast: c.dome_contrast,
            background: c.background,
            gradient: c.gradient,
            gradient_angle: c.gradient_angle_deg,
            flicker: c.flicker,
            blur: c.blur_px,
            photons: c.photons,
            read_noise: c.read_noise,
            seed: c.seed,
            margin: o.margin_px,
            size: None,
            no_bars: !o.bars,
            bar_thickness: o.bar_thickness,
            bar_level: o.bar_level,
        }
    }
}

impl RenderParams {
    /// The render's options; `overwrite` and `quiet` say how the command runs.
    pub fn options(&self, overwrite: bool, quiet: bool) -> RenderOptions {
        let (width, height) = self.size.unwrap_or((0, 0));
        RenderOptions {
            px_per_unit: self.px_per_unit,
            every: self.every,
            format: self.format,
            camera: Camera {
                width,
                height,
                bit_depth: self.bit_depth,
                profile: self.profile,
                grain_level: self.level,
                brightness_spread: self.spread,
                edge_px: self.edge,
                dome_contrast: self.dome_contrast,
                background: self.background,
                gradient: self.gradient,
                gradient_angle_deg: self.gradient_angle,
                flicker: self.flicker,
                blur_px: self.blur,
                photons: self.photons,
                read_noise: self.read_noise,
                seed: self.seed,
            },
            margin_px: self.margin,
            bars: !self.no_bars,
            bar_thickness: self.bar_thickness,
            bar_level: self.bar_level,
            overwrite,
            quiet,
        }
    }
}

impl RenderParams {
    /// The first camera setting out of its domain, as the render would find it, so a
    /// pipeline is refused at load: (key, what is wrong).
    pub fn problem(&self) -> Option<(String, String)> {
        let cam = Camera {
            width: 1,
            height: 1,
            ..self.options(false, true).camera
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
    pub maxsize: Option<f64>,
    pub smoothing_size: Option<usize>,
    pub threshold: Option<f64>,
    pub invert: bool,
    pub topn: Option<usize>,
    pub max_iterations: usize,
    pub search_range: f64,
    pub memory: usize,
    pub predict: bool,
    pub subnet_limit: usize,
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
            maxsize: l.maxsize,
            smoothing_size: l.smoothing_size,
            threshold: l.threshold,
            invert: l.invert,
            topn: l.topn,
            max_iterations: l.max_iterations,
            search_range: 0.0,
            memory: k.memory,
            predict: k.predict,
            subnet_limit: k.subnet_limit,
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
            maxsize: self.maxsize,
            smoothing_size: self.smoothing_size,
            threshold: self.threshold,
            invert: self.invert,
            topn: self.topn,
            max_iterations: self.max_iterations,
        }
    }
    pub fn link(&self) -> LinkOptions {
        LinkOptions {
            memory: self.memory,
            predict: self.predict,
            subnet_limit: self.subnet_limit,
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
