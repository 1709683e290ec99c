//! `pillar-pipe locate`, `link` and `track` (the two in one): argument types and
//! printing only; the work is in `pillar_pipe::stages::{locate, link, track}` and
//! `camera`.

use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::camera::link::DEFAULT_SUBNET_LIMIT;
use pillar_pipe::camera::{LinkOptions, LinkReport, LocateParams};
use pillar_pipe::stages::locate as stage;
use std::path::PathBuf;

/// trackpy's `locate` parameters, with its names (dashes for underscores) and defaults.
/// Lengths in pixels, brightness in the frames' grey levels (0–255 or 0–65535).
#[derive(Args, Debug, Clone)]
pub struct LocateOptions {
    /// Feature diameter, px, odd (trackpy's `diameter`): the centroid and the
    /// characterisation use the disk of radius diameter/2 around each maximum.
    #[arg(long)]
    pub diameter: usize,
    /// Smallest integrated band-passed brightness kept, grey levels × px
    /// (trackpy's `minmass`; default 0). Look at the `mass` column of a first run.
    #[arg(long, default_value_t = 0.0)]
    pub minmass: f64,
    /// Largest radius of gyration kept, px (trackpy's `maxsize`).
    #[arg(long)]
    pub maxsize: Option<f64>,
    /// Smallest distance between two grains, px (default diameter + 1); of two
    /// closer ones the dimmer is dropped.
    #[arg(long)]
    pub separation: Option<f64>,
    /// σ of the Gaussian noise filter, px (trackpy's `noise_size`).
    #[arg(long, default_value_t = 1.0)]
    pub noise_size: f64,
    /// Side of the boxcar background filter, px, odd (default diameter).
    #[arg(long)]
    pub smoothing_size: Option<usize>,
    /// Band-passed values below this are zeroed, grey levels (default 1).
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Dark grains on a bright background.
    #[arg(long)]
    pub invert: bool,
    /// A maximum must be brighter than this percentile of the non-zero band-passed
    /// pixels.
    #[arg(long, default_value_t = 64.0)]
    pub percentile: f64,
    /// Keep only the N brightest grains of each frame.
    #[arg(long)]
    pub topn: Option<usize>,
    /// Centroid refinement steps at most.
    #[arg(long, default_value_t = 10)]
    pub max_iterations: usize,
}

impl LocateOptions {
    pub fn params(&self) -> LocateParams {
        LocateParams {
            diameter: self.diameter,
            minmass: self.minmass,
            maxsize: self.maxsize,
            separation: self.separation,
            noise_size: self.noise_size,
            smoothing_size: self.smoothing_size,
            threshold: self.threshold,
            invert: self.invert,
            percentile: self.percentile,
            topn: self.topn,
            max_iterations: self.max_iterations,
        }
    }
}

#[derive(Args, Debug)]
pub struct LocateArgs {
    /// Frames: folders of PNG/TIFF files, patterns (`movie/img_*.tif`) or files, 8 or
    /// 16 bit grey; numbered 0, 1, … in natural order (img2 before img10).
    #[arg(required = true)]
    pub frames: Vec<PathBuf>,
    /// Output CSV in trackpy's columns; default features.csv beside the frames.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub locate: LocateOptions,
    /// Print the run's record as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    #[arg(long)]
    pub quiet: bool,
}

/// trackpy's `link` parameters.
#[derive(Args, Debug, Clone)]
pub struct LinkOptionsArgs {
    /// Largest distance a grain moves between frames, from where it is predicted, px.
    #[arg(long, value_name = "PX")]
    pub search_range: f64,
    /// Frames a grain may vanish and come back as the same particle.
    #[arg(long, value_name = "FRAMES", default_value_t = 0)]
    pub memory: usize,
    /// Look for each grain at its last position, not at its last position plus its
    /// last displacement per frame (trackpy's default linker).
    #[arg(long)]
    pub no_predict: bool,
    /// Largest subnet (grains competing for the same features) solved exactly; larger
    /// ones are linked greedily, shortest links first, and reported.
    #[arg(long, value_name = "PARTICLES", default_value_t = DEFAULT_SUBNET_LIMIT)]
    pub subnet_limit: usize,
}

impl LinkOptionsArgs {
    pub fn options(&self) -> LinkOptions {
        LinkOptions {
            search_range: self.search_range,
            memory: self.memory,
            predict: !self.no_predict,
            subnet_limit: self.subnet_limit,
        }
    }
}

#[derive(Args)]
pub struct LinkArgs {
    /// Located grains: CSV (or Parquet) in trackpy's columns, positions in px; x, y and
    /// frame are required.
    pub features: PathBuf,
    /// Output CSV: the features in trackpy's columns plus `particle` (read by `ingest`).
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub link: LinkOptionsArgs,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct TrackArgs {
    /// Frames: folders of PNG/TIFF files, patterns (`movie/img_*.tif`) or files, 8 or
    /// 16 bit grey; numbered 0, 1, … in natural order.
    #[arg(required = true)]
    pub frames: Vec<PathBuf>,
    /// Output CSV: trackpy's linked columns (y, x, mass, size, ecc, signal, raw_mass,
    /// ep, frame, particle), px; `pillar-pipe ingest` reads it.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub locate: LocateOptions,
    #[command(flatten)]
    pub link: LinkOptionsArgs,
    /// Print the run's record as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    #[arg(long)]
    pub quiet: bool,
}

fn print_link(r: &LinkReport, warnings: &[String]) {
    eprintln!(
        "features      {} in {} frames; {} trajectories ({} ended before the last frame)",
        r.features, r.frames, r.trajectories, r.ended
    );
    eprintln!(
        "links         {} ({} across gaps bridged by memory)",
        r.links, r.gaps_bridged
    );
    eprintln!(
        "subnets       {} solved exactly (the largest of {} particles); {} solved greedily ({} features)",
        r.subnets_exact, r.largest_subnet, r.subnets_greedy, r.features_greedy
    );
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

pub fn link(a: LinkArgs) -> Result<()> {
    let opt = a.link.options();
    let run = pillar_pipe::stages::link::run(&a.features, &a.output, &opt)
        .with_context(|| format!("link {}", a.features.display()))?;
    eprintln!("linked {} -> {}", run.input, run.output);
    print_link(&run.report, &run.warnings);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&run)?);
    }
    Ok(())
}

pub fn track(a: TrackArgs) -> Result<()> {
    let run = pillar_pipe::stages::track::run(
        &a.frames,
        &a.output,
        &a.locate.params(),
        &a.link.options(),
        a.quiet,
    )?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&run)?);
    }
    if !a.quiet {
        let r = &run.locate.report;
        eprintln!(
            "located {} grains in {} frames ({}×{} px, {} bit; {}–{} per frame) → {}",
            r.features,
            r.frames,
            r.width,
            r.height,
            r.bit_depth,
            r.per_frame_min,
            r.per_frame_max,
            run.output
        );
        print_link(&run.link, &run.warnings);
    } else {
        for w in &run.warnings {
            eprintln!("warning: {w}");
        }
    }
    Ok(())
}

pub fn locate(a: LocateArgs) -> Result<()> {
    let out = a
        .output
        .clone()
        .unwrap_or_else(|| stage::default_output(&a.frames));
    let run = stage::run(&a.frames, &out, &a.locate.params(), a.quiet)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&run)?);
    } else {
        let r = &run.report;
        eprintln!(
            "located {} grains in {} frames ({}×{} px, {} bit; {}–{} per frame) → {}",
            r.features,
            r.frames,
            r.width,
            r.height,
            r.bit_depth,
            r.per_frame_min,
            r.per_frame_max,
            run.output
        );
    }
    Ok(())
}
