//! The command line: one `Args` struct per command in the module of its family, and
//! the dispatch. Commands parse, call one library function and print its report; the
//! work is in `pillar_pipe`.

pub mod analysis;
pub mod bench;
pub mod camera;
pub mod export;
pub mod force;
pub mod render;
pub mod runs;
pub mod sim;
pub mod structure;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "pillar-pipe",
    version,
    about = "Deformation analysis and DEM simulation of 2D granular packings (granular pillars, sheared disks)"
)]
pub struct Cli {
    #[command(subcommand)]
    pub cmd: Cmd,
}

#[derive(Subcommand)]
pub enum Cmd {
    Ingest(analysis::IngestArgs),
    IngestForce(force::IngestForceArgs),
    Kinematics(analysis::KinematicsArgs),
    Fit(analysis::FitArgs),
    Compare(analysis::CompareArgs),
    Quickstart(analysis::QuickstartArgs),
    /// Run the bundled DEM (pillar; sheared disks).
    Simulate {
        #[command(subcommand)]
        what: sim::SimulateCmd,
    },
    /// Grid of sheared-disk runs (φ × Q × γ̇), `--jobs` at a time, with one summary table.
    Sweep(sim::SweepArgs),
    /// Generate a jammed bidisperse packing (li-granular-pillars Sec. II.A).
    Pack(sim::PackArgs),
    /// Locate grains in camera frames (PNG/TIFF, 8/16 bit) as trackpy's `locate`
    /// does (Crocker–Grier: band-pass, local maxima, centroid refinement), frames in
    /// parallel; writes trackpy's columns (y, x, mass, size, ecc, signal, raw_mass,
    /// ep, frame) in pixels.
    Locate(camera::LocateArgs),
    /// Link located grains (trackpy's feature columns, px) into trajectories the
    /// trackpy way (search range in px, memory in frames, prediction from each grain's
    /// last displacement); writes the features with a particle column.
    Link(camera::LinkArgs),
    /// Locate and link in one command: camera frames → trackpy's linked table
    /// (`pillar-pipe ingest` reads it). trackpy's locate and link options, px and
    /// frames.
    Track(camera::TrackArgs),
    /// Camera emulator: render tracks into grey-scale frames (PNG/TIFF) with ground truth.
    Render(render::RenderArgs),
    Run(runs::RunArgs),
    /// One task of a Slurm job array submitted by `run`/`sweep --executor slurm`.
    #[command(hide = true)]
    SlurmJob {
        spec: PathBuf,
    },
    /// Tracked pipeline runs: list, show, compare.
    Runs {
        #[command(subcommand)]
        what: runs::RunsCmd,
        #[arg(long, global = true, default_value = "runs")]
        runs_dir: PathBuf,
    },
    /// Benchmarks of the hot paths against a reference measured in the same run.
    Bench {
        #[command(subcommand)]
        what: bench::BenchCmd,
    },
    Export(export::ExportArgs),
    Gofr(structure::GofrArgs),
    Outline(structure::OutlineArgs),
    ShearLines(structure::ShearLinesArgs),
    Sizes(structure::SizesArgs),
    BarPressure(structure::BarPressureArgs),
    Synth(export::SynthArgs),
}

/// Runs one parsed command.
pub fn dispatch(cmd: Cmd) -> Result<()> {
    pillar_pipe::dem::backend::simd::cap_from_env().map_err(anyhow::Error::msg)?;
    match cmd {
        Cmd::Ingest(a) => analysis::ingest(a),
        Cmd::IngestForce(a) => force::ingest_force(a),
        Cmd::Kinematics(a) => analysis::kinematics(a),
        Cmd::Fit(a) => analysis::fit(a),
        Cmd::Compare(a) => analysis::compare(a),
        Cmd::Quickstart(a) => analysis::quickstart(a),
        Cmd::Simulate { what } => sim::simulate(what),
        Cmd::Sweep(a) => sim::sweep(a),
        Cmd::Pack(a) => sim::pack(a),
        Cmd::Locate(a) => camera::locate(a),
        Cmd::Link(a) => camera::link(a),
        Cmd::Track(a) => camera::track(a),
        Cmd::Render(a) => render::run(a),
        Cmd::Run(a) => runs::run(a),
        Cmd::SlurmJob { spec } => {
            std::process::exit(pillar_pipe::pipeline::slurm::job::main(&spec));
        }
        Cmd::Runs { what, runs_dir } => runs::runs(what, &runs_dir),
        Cmd::Bench { what } => bench::bench(what),
        Cmd::Export(a) => export::export(a),
        Cmd::Gofr(a) => structure::gofr(a),
        Cmd::Outline(a) => structure::outline(a),
        Cmd::ShearLines(a) => structure::shear_lines(a),
        Cmd::Sizes(a) => structure::sizes(a),
        Cmd::BarPressure(a) => structure::bar_pressure(a),
        Cmd::Synth(a) => export::synth(a),
    }
}

/// `A,B` as two numbers (`--origin-px 165.98,850`, `--strain 0.1,0.2`).
pub fn parse_pair(s: &str) -> std::result::Result<(f64, f64), String> {
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
