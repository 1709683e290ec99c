//! `pillar-pipe locate` (and the locate options `track` shares): argument types and
//! printing only; the work is in `pillar_pipe::stages::locate` and `camera`.

use anyhow::Result;
use clap::Args;
use pillar_pipe::camera::LocateParams;
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
