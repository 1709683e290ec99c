//! The analysis commands a user runs in order: `ingest`, `kinematics`, `fit`,
//! `compare`, and `quickstart` (the first three on the bundled sample).

use super::parse_pair;
use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::kinematics::Convention;
use pillar_pipe::stages::fit::params::FitParams;
use pillar_pipe::stages::ingest::{self, Format, IngestOptions};
use pillar_pipe::stages::kinematics::{self as kin, KinematicsOptions, LagSpec};
use std::path::PathBuf;

/// Read trajectories (trackpy CSV, LAMMPS dump, canonical CSV/Parquet) into the
/// canonical tracks table and print a summary.
#[derive(Args)]
pub struct IngestArgs {
    pub input: PathBuf,
    /// Output table (.parquet, or .csv); default: <input stem>.tracks.parquet beside the input.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[arg(long, value_enum, default_value = "auto")]
    pub format: Format,
    /// Pixels per length unit (trackpy input).
    #[arg(long)]
    pub px_per_unit: Option<f64>,
    /// Length unit name (cm, mm, ...); `--unit px` keeps trackpy pixels.
    #[arg(long)]
    pub unit: Option<String>,
    /// Frames per second.
    #[arg(long, conflicts_with = "frame_time")]
    pub fps: Option<f64>,
    /// Seconds per frame.
    #[arg(long)]
    pub frame_time: Option<f64>,
    /// Radii SMALL,LARGE in the length unit.
    #[arg(long, value_parser = parse_pair)]
    pub radii: Option<(f64, f64)>,
    /// Origin X,Y in pixels (trackpy): the canonical (0, 0), e.g. the bottom bar face.
    #[arg(long, value_parser = parse_pair)]
    pub origin_px: Option<(f64, f64)>,
    /// Bar speed v_c in length unit per second, recorded for the fit stage.
    #[arg(long)]
    pub bar_speed: Option<f64>,
    /// Keep trackpy trajectories detached from the packing (bar-corner artefacts).
    #[arg(long)]
    pub keep_detached: bool,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn ingest(args: IngestArgs) -> Result<()> {
    let IngestArgs {
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
    } = args;
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
        if let Some(f) = &rep.settings_file {
            println!("settings      from {f}");
        }
        println!("{}", rep.summary);
        if let Some(s) = &rep.species_split {
            println!(
                "split         trackpy size > {:.3} px is large: {} small / {} large trajectories; radii {}",
                s.size_threshold_px, s.small_trajectories, s.large_trajectories, s.radii_source
            );
        }
        for w in &rep.warnings {
            println!("warning: {w}");
        }
    }
    Ok(())
}

/// Per-particle J, η, η^s, J2, D²min and velocity between frames t and t+Δt
/// (Li et al. Eqs. 13–18); writes the `kinematics` table.
#[derive(Args)]
pub struct KinematicsArgs {
    /// Canonical tracks (CSV or Parquet, e.g. from `ingest`).
    pub tracks: PathBuf,
    /// Output table; default <stem>.kinematics.parquet beside the input.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Lag Δt in frames.
    #[arg(long, conflicts_with_all = ["lag_time", "lags"])]
    pub lag: Option<i64>,
    /// Lag Δt in seconds (nearest whole number of frames).
    #[arg(long, conflicts_with = "lags")]
    pub lag_time: Option<f64>,
    /// Several lags in frames, e.g. 2,4,8,16.
    #[arg(long, value_delimiter = ',')]
    pub lags: Option<Vec<i64>>,
    /// Neighbour cutoff R_c in length units (default 1.25 D).
    #[arg(long)]
    pub rc: Option<f64>,
    /// Only this start frame.
    #[arg(long)]
    pub start: Option<i64>,
    /// Step between start frames (default: the lag).
    #[arg(long)]
    pub every: Option<i64>,
    /// `ovito` reproduces OVITO's Atomic Strain numbers (≤ cutoff, D²min not ÷ N_i).
    #[arg(long, value_enum, default_value = "paper")]
    pub convention: Convention,
    /// Write only these columns (and frame, frame_end, particle), e.g. d2min, or
    /// eta_s,d2min,valid for `fit`: the same numbers, a smaller file, a faster run
    /// [default: all]
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    #[arg(long)]
    pub quiet: bool,
    #[arg(long)]
    pub json: bool,
    /// Also print where the wall time went (read + hash, compute, compute ‖ write, write).
    #[arg(long)]
    pub timings: bool,
}

pub fn kinematics(args: KinematicsArgs) -> Result<()> {
    let KinematicsArgs {
        tracks,
        output,
        lag,
        lag_time,
        lags,
        rc,
        start,
        every,
        convention,
        columns,
        quiet,
        json,
        timings,
    } = args;
    let lag = match (lag, lag_time, lags) {
        (Some(l), _, _) => LagSpec::Frames(vec![l]),
        (_, Some(s), _) => LagSpec::Time(s),
        (_, _, Some(v)) => LagSpec::Frames(v),
        _ => {
            anyhow::bail!("give the lag: --lag FRAMES, --lag-time SECONDS or --lags 2,4,8")
        }
    };
    let output = output.unwrap_or_else(|| kin::default_output(&tracks));
    let columns = match columns {
        Some(c) => pillar_pipe::io::kinematics_io::Selection::of(&c)?,
        None => Default::default(),
    };
    let opt = KinematicsOptions {
        lag,
        rc,
        start,
        every,
        convention,
        columns,
        quiet,
    };
    let rep = kin::run(&tracks, &output, &opt)
        .with_context(|| format!("kinematics {}", tracks.display()))?;
    if json {
        println!("{}", serde_json::to_string_pretty(&rep)?);
    } else {
        println!("{rep}");
        if timings {
            println!(
                "{}",
                pillar_pipe::stages::timing::format_phases(&rep.timings)
            );
        }
        for w in &rep.warnings {
            println!("warning: {w}");
        }
    }
    Ok(())
}

/// Fit the D²min–η^s crossover (Li et al. Eq. 19) with every estimator; writes
/// fit.json and the scatter table.
#[derive(Args)]
pub struct FitArgs {
    /// Canonical tracks (runs the Sec. IV protocol) or a `kinematics` table (fits its rows).
    pub input: PathBuf,
    #[arg(short, long, default_value = "fit.json")]
    pub output: PathBuf,
    /// The fit's options, the same struct (names, defaults) as a pipeline's fit stage.
    #[command(flatten)]
    pub params: FitParams,
    /// Scatter table (default <output stem>.scatter.parquet).
    #[arg(long)]
    pub scatter: Option<PathBuf>,
    #[arg(long)]
    pub quiet: bool,
}

pub fn fit(args: FitArgs) -> Result<()> {
    use pillar_pipe::stages::fit;
    let FitArgs {
        input,
        output,
        params,
        scatter,
        quiet,
    } = args;
    let opt = fit::FitOptions {
        scatter,
        ..params.options("fit", quiet)?
    };
    let rep =
        fit::run(&input, &output, &opt).with_context(|| format!("fit {}", input.display()))?;
    println!("{rep}");
    for w in &rep.warnings {
        println!("warning: {w}");
    }
    println!(
        "wrote         {} and {} ({:.2} s)",
        output.display(),
        rep.scatter,
        rep.elapsed_s
    );
    Ok(())
}

/// Two fits side by side (experiment vs simulation); refuses fits made differently.
#[derive(Args)]
pub struct CompareArgs {
    pub a: PathBuf,
    pub b: PathBuf,
    #[arg(long)]
    pub json: bool,
}

pub fn compare(args: CompareArgs) -> Result<()> {
    let CompareArgs { a, b, json } = args;
    let c = pillar_pipe::stages::compare::run(&a, &b)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&c)?);
    } else {
        print!("{c}");
    }
    Ok(())
}

/// The main job: the bundled experiment sample through ingest, kinematics and fit.
#[derive(Args)]
pub struct QuickstartArgs {
    /// Input trackpy/canonical tracks (default: the bundled sample).
    #[arg(long)]
    pub input: Option<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "runs/quickstart")]
    pub out: PathBuf,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[arg(long, default_value_t = 1000)]
    pub bootstrap: usize,
    #[arg(long)]
    pub quiet: bool,
}

pub fn quickstart(args: QuickstartArgs) -> Result<()> {
    let QuickstartArgs {
        input,
        out,
        seed,
        bootstrap,
        quiet,
    } = args;
    use pillar_pipe::stages::quickstart;
    let input = input.unwrap_or_else(quickstart::bundled_sample);
    let rep = quickstart::run(&input, &out, seed, bootstrap, quiet)
        .with_context(|| format!("quickstart on {}", input.display()))?;
    println!("== ingest\n{}", rep.ingest.summary);
    for w in &rep.ingest.warnings {
        println!("warning: {w}");
    }
    println!("\n== kinematics\n{}", rep.kinematics);
    println!("\n== fit\n{}", rep.fit);
    for w in &rep.fit.warnings {
        println!("warning: {w}");
    }
    println!(
        "\nwrote {}/{{tracks.parquet, kinematics.parquet, fit.json, fit.scatter.parquet, manifest.json}} in {:.1} s",
        rep.out, rep.elapsed_s
    );
    Ok(())
}
