//! CLI wiring for the camera emulator: `render`.

use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::camera::render::{Camera, Profile};
use pillar_pipe::stages::render::{self, ImageFormat, RenderOptions};
use std::path::PathBuf;

/// Brightness levels are fractions of the full scale (255 at 8 bit, 65535 at 16 bit);
/// noise is in grey levels of the chosen bit depth; lengths on the image in pixels.
#[derive(Args)]
#[command(
    after_help = "Units: positions, radii and --bar-thickness in the tracks' length unit, mapped by --px-per-unit (x → column, y up → rows down); --edge, --blur, --margin, --size in px; --level, --background, --bar-level as fractions of full scale (255 or 65535); --read-noise in grey levels; --photons per pixel at full scale. Writes frame_00000.png … (or .tif), ground_truth.csv (frame, particle, species, x_px, y_px, radius_px, x, y, radius; pixel centres on whole numbers) and camera.json (settings, seed, pixel mapping, frame interval, input SHA-256)."
)]
pub struct RenderArgs {
    /// Tracks: any table `ingest` reads (canonical .tracks.parquet/.csv, a LAMMPS dump,
    /// trackpy CSV), or a `simulate pillar` run folder (its bars are drawn too).
    pub tracks: PathBuf,
    /// Output folder: frame_00000.png …, ground_truth.csv, camera.json.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Pixels per length unit of the tracks (e.g. 31.496 for cm at 80 px/inch).
    #[arg(long)]
    pub px_per_unit: f64,
    /// Render every N-th frame of the tracks.
    #[arg(long, default_value_t = 1)]
    pub every: i64,
    /// Frame image format.
    #[arg(long, value_enum, default_value = "png")]
    pub format: ImageFormat,
    /// Bits per pixel: 8 or 16.
    #[arg(long, default_value_t = Camera::default().bit_depth)]
    pub bit_depth: u8,
    /// Grain brightness profile: flat (uniform disk, soft edge), gaussian (σ = r/2),
    /// dome (lit sphere, brighter centre).
    #[arg(long, value_enum, default_value = "flat")]
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
    #[arg(long, default_value_t = 20.0)]
    pub margin: f64,
    /// Frame size WIDTHxHEIGHT in px [default: the content plus the margin].
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Do not draw a pillar run's bars.
    #[arg(long)]
    pub no_bars: bool,
    /// Bar thickness in the tracks' length unit [default: 2 large-grain diameters].
    #[arg(long)]
    pub bar_thickness: Option<f64>,
    /// Bar brightness above the background, fraction of full scale.
    #[arg(long, default_value_t = 0.25)]
    pub bar_level: f64,
    /// Replace an earlier render in the output folder.
    #[arg(long)]
    pub overwrite: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

fn parse_size(s: &str) -> Result<(usize, usize), String> {
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

pub fn run(a: RenderArgs) -> Result<()> {
    let (width, height) = a.size.unwrap_or((0, 0));
    let opt = RenderOptions {
        px_per_unit: a.px_per_unit,
        every: a.every,
        format: a.format,
        camera: Camera {
            width,
            height,
            bit_depth: a.bit_depth,
            profile: a.profile,
            grain_level: a.level,
            brightness_spread: a.spread,
            edge_px: a.edge,
            dome_contrast: a.dome_contrast,
            background: a.background,
            gradient: a.gradient,
            gradient_angle_deg: a.gradient_angle,
            flicker: a.flicker,
            blur_px: a.blur,
            photons: a.photons,
            read_noise: a.read_noise,
            seed: a.seed,
        },
        margin_px: a.margin,
        bars: !a.no_bars,
        bar_thickness: a.bar_thickness,
        bar_level: a.bar_level,
        overwrite: a.overwrite,
        quiet: a.quiet,
    };
    let rep = render::run(&a.tracks, &a.output, &opt)
        .with_context(|| format!("render {} into {}", a.tracks.display(), a.output.display()))?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rep)?);
        return Ok(());
    }
    for w in &rep.warnings {
        eprintln!("warning: {w}");
    }
    println!(
        "render      {} frames of {} × {} px ({} grains{}) into {} in {:.2} s",
        rep.frames,
        rep.width,
        rep.height,
        rep.grains,
        if rep.bars { ", bars" } else { "" },
        rep.output.display(),
        rep.elapsed_s
    );
    Ok(())
}
