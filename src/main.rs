//! `pillar-pipe` command line: parse, validate, call a stage, print its report.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use pillar_pipe::stages::ingest::{self, Format, IngestOptions};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "pillar-pipe",
    version,
    about = "Deformation analysis and DEM simulation of 2D granular packings (granular pillars, sheared disks)"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Read trajectories (trackpy CSV, LAMMPS dump, canonical CSV/Parquet) into the
    /// canonical tracks table and print a summary.
    Ingest {
        input: PathBuf,
        /// Output table (.parquet, or .csv); default: <input stem>.tracks.parquet beside the input.
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[arg(long, value_enum, default_value = "auto")]
        format: Format,
        /// Pixels per length unit (trackpy input).
        #[arg(long)]
        px_per_unit: Option<f64>,
        /// Length unit name (cm, mm, ...); `--unit px` keeps trackpy pixels.
        #[arg(long)]
        unit: Option<String>,
        /// Frames per second.
        #[arg(long, conflicts_with = "frame_time")]
        fps: Option<f64>,
        /// Seconds per frame.
        #[arg(long)]
        frame_time: Option<f64>,
        /// Radii SMALL,LARGE in the length unit.
        #[arg(long, value_parser = parse_pair)]
        radii: Option<(f64, f64)>,
        /// Origin X,Y in pixels (trackpy): the canonical (0, 0), e.g. the bottom bar face.
        #[arg(long, value_parser = parse_pair)]
        origin_px: Option<(f64, f64)>,
        /// Bar speed v_c in length unit per second, recorded for the fit stage.
        #[arg(long)]
        bar_speed: Option<f64>,
        /// Keep trackpy trajectories detached from the packing (bar-corner artefacts).
        #[arg(long)]
        keep_detached: bool,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
}

fn parse_pair(s: &str) -> std::result::Result<(f64, f64), String> {
    let v: Vec<&str> = s.split(',').collect();
    if v.len() != 2 {
        return Err(format!("expected two numbers A,B, got '{s}'"));
    }
    let a = v[0]
        .trim()
        .parse::<f64>()
        .map_err(|e| format!("'{}': {e}", v[0]))?;
    let b = v[1]
        .trim()
        .parse::<f64>()
        .map_err(|e| format!("'{}': {e}", v[1]))?;
    Ok((a, b))
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Ingest {
            input,
            output,
            format,
            px_per_unit,
            unit,
            fps,
            frame_time,
            radii,
            origin_px,
            bar_speed,
            keep_detached,
            json,
        } => {
            let frame_time = match (fps, frame_time) {
                (Some(f), _) if f > 0.0 => Some(1.0 / f),
                (Some(f), _) => anyhow::bail!("--fps {f} must be > 0"),
                (None, t) => t,
            };
            let output = output.unwrap_or_else(|| ingest::default_output(&input));
            let opt = IngestOptions {
                format: Some(format),
                px_per_unit,
                unit,
                frame_time,
                radii,
                origin_px,
                bar_speed,
                keep_detached,
            };
            let rep = ingest::run(&input, &output, &opt)
                .with_context(|| format!("ingest {}", input.display()))?;
            if json {
                println!("{}", serde_json::to_string_pretty(&rep)?);
            } else {
                println!(
                    "ingested {} ({:?}) -> {}",
                    rep.input, rep.format, rep.output
                );
                println!("{}", rep.summary);
                if let Some(s) = &rep.species_split {
                    println!(
                        "split         trackpy size > {:.3} px is large: {} small / {} large trajectories; radii {}",
                        s.size_threshold_px,
                        s.small_trajectories,
                        s.large_trajectories,
                        s.radii_source
                    );
                }
                for w in &rep.warnings {
                    println!("warning: {w}");
                }
            }
        }
    }
    Ok(())
}
