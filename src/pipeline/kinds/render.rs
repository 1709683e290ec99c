//! `render`: the camera emulator, a stage's tracks to frames (`pillar-pipe render`).

use super::Locate;
use super::Stage;
use super::StageKind;
use super::typed;
use crate::camera::render::{Camera, Profile};
use crate::error::{Error, Result};
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use crate::stages::render::{ImageFormat, RenderOptions};
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

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

pub struct Render;

impl StageKind for Render {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<RenderParams>(given)
    }

    fn check(&self, src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        let p: RenderParams = super::typed_at(src, st)?;
        match p.problem() {
            Some((key, m)) => Err(src.err(&format!("{}.{key}", st.name), m)),
            None => Ok(Vec::new()),
        }
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let q = ctx.quiet;
        let p: RenderParams = typed(&s.name, &s.params)?;
        // A pillar run's tracks: render finds its bars beside them.
        let tracks = ctx.input(s, "input", "tracks")?;
        let r = stages::render::run(&tracks, &out.join("frames"), &p.options(false, q))?;
        Ok(Produced {
            outputs: outputs(&[("frames", "frames")]),
            metrics: json!({"frames": r.frames, "width": r.width, "height": r.height, "grains": r.grains, "bars": r.bars}),
            summary: sum(&r),
        })
    }
}
