//! CLI wiring for the camera emulator: `render`.

use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::pipeline::params::RenderParams;
use pillar_pipe::stages::render;
use std::path::PathBuf;

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
    /// The camera, the same struct (names, defaults) as a pipeline's render stage.
    #[command(flatten)]
    pub params: RenderParams,
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

pub fn run(a: RenderArgs) -> Result<()> {
    let opt = a.params.options(a.overwrite, a.quiet);
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
