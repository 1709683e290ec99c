//! `pillar-pipe` command line: parse, validate, call a stage, print its report.

mod cli_bench;
mod cli_camera;
mod cli_camera_render;
mod cli_force;
mod cli_runs;
mod cli_sim;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use cli_runs::{RunsCmd, run_pipeline, runs};
use pillar_pipe::kinematics::Convention;
use pillar_pipe::stages::ingest::{self, Format, IngestOptions};
use pillar_pipe::stages::kinematics::{self as kin, KinematicsOptions, LagSpec};
use pillar_pipe::structure::ShearLineOptions;
use std::path::PathBuf;

// Large tables allocate and free hundreds of MB; glibc returns each to the kernel and
// faults it in again page by page, mimalloc keeps and reuses it.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

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
    IngestForce(cli_force::IngestForceArgs),
    /// Per-particle J, η, η^s, J2, D²min and velocity between frames t and t+Δt
    /// (Li et al. Eqs. 13–18); writes the `kinematics` table.
    Kinematics {
        /// Canonical tracks (CSV or Parquet, e.g. from `ingest`).
        tracks: PathBuf,
        /// Output table; default <stem>.kinematics.parquet beside the input.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Lag Δt in frames.
        #[arg(long, conflicts_with_all = ["lag_time", "lags"])]
        lag: Option<i64>,
        /// Lag Δt in seconds (nearest whole number of frames).
        #[arg(long, conflicts_with = "lags")]
        lag_time: Option<f64>,
        /// Several lags in frames, e.g. 2,4,8,16.
        #[arg(long, value_delimiter = ',')]
        lags: Option<Vec<i64>>,
        /// Neighbour cutoff R_c in length units (default 1.25 D).
        #[arg(long)]
        rc: Option<f64>,
        /// Only this start frame.
        #[arg(long)]
        start: Option<i64>,
        /// Step between start frames (default: the lag).
        #[arg(long)]
        every: Option<i64>,
        /// `ovito` reproduces OVITO's Atomic Strain numbers (≤ cutoff, D²min not ÷ N_i).
        #[arg(long, value_enum, default_value = "paper")]
        convention: Convention,
        /// Write only these columns (and frame, frame_end, particle), e.g. d2min, or
        /// eta_s,d2min,valid for `fit`: the same numbers, a smaller file, a faster run
        /// [default: all]
        #[arg(long, value_delimiter = ',')]
        columns: Option<Vec<String>>,
        #[arg(long)]
        quiet: bool,
        #[arg(long)]
        json: bool,
        /// Also print where the wall time went (read + hash, compute, compute ‖ write, write).
        #[arg(long)]
        timings: bool,
    },
    /// Fit the D²min–η^s crossover (Li et al. Eq. 19) with every estimator; writes
    /// fit.json and the scatter table.
    Fit {
        /// Canonical tracks (runs the Sec. IV protocol) or a `kinematics` table (fits its rows).
        input: PathBuf,
        #[arg(short, long, default_value = "fit.json")]
        output: PathBuf,
        /// Large-grain diameter D (length unit); default from the data.
        #[arg(long)]
        diameter: Option<f64>,
        /// Bar speed v_c (length unit/s); default from the tracks' metadata.
        #[arg(long)]
        bar_speed: Option<f64>,
        /// Start times in R/v_c (default every 2/3).
        #[arg(long, value_delimiter = ',')]
        starts: Option<Vec<f64>>,
        /// Lags in R/v_c (default 2/15, 4/15, ..., 128/15).
        #[arg(long, value_delimiter = ',')]
        lags: Option<Vec<f64>>,
        /// R_c in units of D.
        #[arg(long, default_value_t = 1.25)]
        rc_over_d: f64,
        #[arg(long, value_enum, default_value = "binned-median")]
        method: pillar_pipe::fit::Method,
        #[arg(long, default_value_t = 5.0)]
        bins_per_decade: f64,
        #[arg(long, default_value_t = 10)]
        min_bin_count: usize,
        /// Bootstrap replicates over start times.
        #[arg(long, default_value_t = 1000)]
        bootstrap: usize,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Fitted η^s (dimensionless): `coverage` (bins the protocol samples evenly:
        /// inside the central 90 % of η^s of at least two lags, from at least half the
        /// start times), `all`, or LO,HI.
        #[arg(long, default_value = "coverage", value_parser = pillar_pipe::fit::RangeRule::parse)]
        eta_range: pillar_pipe::fit::RangeRule,
        /// Position noise σ per coordinate per frame of the tracks (length unit, frames
        /// independent): sets the tracking-noise floor of D²min/R² instead of the data's
        /// estimate; under the default range rule bins within 3 floors are left out.
        #[arg(long, value_name = "SIGMA")]
        position_noise: Option<f64>,
        /// Scatter table (default <output stem>.scatter.parquet).
        #[arg(long)]
        scatter: Option<PathBuf>,
        #[arg(long)]
        quiet: bool,
    },
    /// Two fits side by side (experiment vs simulation); refuses fits made differently.
    Compare {
        a: PathBuf,
        b: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// The main job: the bundled experiment sample through ingest, kinematics and fit.
    Quickstart {
        /// Input trackpy/canonical tracks (default: the bundled sample).
        #[arg(long)]
        input: Option<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "runs/quickstart")]
        out: PathBuf,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[arg(long, default_value_t = 1000)]
        bootstrap: usize,
        #[arg(long)]
        quiet: bool,
    },
    /// Run the bundled DEM (pillar; sheared disks).
    Simulate {
        #[command(subcommand)]
        what: cli_sim::SimulateCmd,
    },
    /// Grid of sheared-disk runs (φ × Q × γ̇), `--jobs` at a time, with one summary table.
    Sweep(cli_sim::SweepArgs),
    /// Generate a jammed bidisperse packing (li-granular-pillars Sec. II.A).
    Pack(cli_sim::PackArgs),
    /// Locate grains in camera frames (PNG/TIFF, 8/16 bit) as trackpy's `locate`
    /// does (Crocker–Grier: band-pass, local maxima, centroid refinement), frames in
    /// parallel; writes trackpy's columns (y, x, mass, size, ecc, signal, raw_mass,
    /// ep, frame) in pixels.
    Locate(cli_camera::LocateArgs),
    /// Link located grains (trackpy's feature columns, px) into trajectories the
    /// trackpy way (search range in px, memory in frames, prediction from each grain's
    /// last displacement); writes the features with a particle column.
    Link(cli_camera::LinkArgs),
    /// Locate and link in one command: camera frames → trackpy's linked table
    /// (`pillar-pipe ingest` reads it). trackpy's locate and link options, px and
    /// frames.
    Track(cli_camera::TrackArgs),
    /// Camera emulator: render tracks into grey-scale frames (PNG/TIFF) with ground truth.
    Render(cli_camera_render::RenderArgs),
    /// Run a pipeline file (pipelines/*.toml): cached stages, recorded under RUNS_DIR/<id>/.
    Run {
        pipeline: PathBuf,
        /// Override a key, STAGE.KEY=VALUE; STAGE is a stage name or a kind (all stages of it).
        #[arg(long = "set", value_name = "STAGE.KEY=VALUE")]
        set: Vec<String>,
        /// Recompute this stage (name, kind or `all`) and everything downstream of it.
        #[arg(long, value_name = "STAGE")]
        force: Vec<String>,
        #[arg(long)]
        quiet: bool,
        #[arg(long, default_value = "runs")]
        runs_dir: PathBuf,
        /// Validate the pipeline and show which stages are cached; run nothing.
        #[arg(long)]
        dry_run: bool,
        /// Check cached outputs' SHA-256 before using them (by default only their sizes).
        #[arg(long)]
        verify: bool,
        /// Stages computed at once by the local executor (independent stages, e.g. a
        /// sweep's grid points); default: the machine's cores. 1 runs them one by one.
        #[arg(long, short = 'j', value_parser = clap::value_parser!(u64).range(1..))]
        jobs: Option<u64>,
        #[command(flatten)]
        exec: cli_runs::ExecutorArgs,
    },
    /// One task of a Slurm job array submitted by `run`/`sweep --executor slurm`.
    #[command(hide = true)]
    SlurmJob {
        spec: PathBuf,
    },
    /// Tracked pipeline runs: list, show, compare.
    Runs {
        #[command(subcommand)]
        what: RunsCmd,
        #[arg(long, global = true, default_value = "runs")]
        runs_dir: PathBuf,
    },
    /// Benchmarks of the hot paths against a reference measured in the same run.
    Bench {
        #[command(subcommand)]
        what: cli_bench::BenchCmd,
    },
    /// Write tracks (or a simulation run's) as extended XYZ or a LAMMPS text dump for
    /// OVITO, ASE or LAMMPS: one snapshot per frame, id, species, position (z = 0),
    /// radius, and with --kinematics every column of a kinematics table (D²min, η^s,
    /// J2, velocity, …) on the particles of the frame each pair starts at (NaN where a
    /// particle has none). Periodic and Lees–Edwards boxes are written as cells (the
    /// offset as the tilt xy); open frames get their bounding box (LAMMPS) or no cell
    /// (extxyz). Lengths in the table's unit.
    Export {
        /// Tracks (canonical CSV/Parquet) or a `simulate` run's directory.
        input: PathBuf,
        /// A kinematics table of these tracks (`pillar-pipe kinematics`).
        #[arg(long)]
        kinematics: Option<PathBuf>,
        /// extxyz or lammps-dump; default: from the output's extension (.xyz/.extxyz,
        /// .dump/.lammpstrj).
        #[arg(long, value_enum)]
        format: Option<pillar_pipe::io::export::Format>,
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Pair distribution g(r) of one frame, around small and around large grains
    /// (li-granular-pillars Fig. 2); r in units of the large-grain diameter D.
    Gofr {
        /// Tracks (canonical CSV/Parquet, e.g. from ingest, simulate or pack).
        input: PathBuf,
        /// Output table (.parquet or .csv).
        #[arg(short, long)]
        output: PathBuf,
        /// Frame (default: the first).
        #[arg(long)]
        frame: Option<i64>,
        /// Largest r in units of D; open packings count only centres this far inside.
        #[arg(long, default_value_t = 4.0)]
        r_max: f64,
        #[arg(long, default_value_t = 80)]
        bins: usize,
    },
    /// A pillar's outline at a frame (li-granular-pillars Fig. 9), in units of its
    /// initial width W0: outermost grain edges in slabs one D thick. With --against,
    /// also how far it is from another pillar's outline rescaled the same way.
    Outline {
        /// Tracks of a pillar.
        input: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        /// Frame (default: the last).
        #[arg(long)]
        frame: Option<i64>,
        /// Another pillar's tracks to compare with (e.g. another size).
        #[arg(long)]
        against: Option<PathBuf>,
        /// Its frame (default: the last).
        #[arg(long)]
        against_frame: Option<i64>,
    },
    /// Transient shear lines (li-granular-pillars Fig. 11) in one frame pair of a
    /// `kinematics` table: grains with J2 above THRESHOLD x the mean J2, linked at
    /// 1.25 D, measured by the principal axes of their centres. Writes one row per line:
    /// angle to the compression axis y in degrees (0-90), width and length in units of
    /// the large-grain diameter D, centre in the table's length unit, mean J2 in
    /// 1/time. Method: docs/shear-lines.md.
    ShearLines {
        /// A `kinematics` table (from `pillar-pipe kinematics`: frame, frame_end, x, y, j2).
        kinematics: PathBuf,
        /// Output table (.csv or .parquet); default <stem>.shear_lines.csv beside the input.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Start frame of the pair (default: the first).
        #[arg(long)]
        frame: Option<i64>,
        /// Lag of the pair in frames, frame_end - frame (default: the smallest there).
        #[arg(long)]
        lag_frames: Option<i64>,
        /// A grain is high when J2 > THRESHOLD x J2_ref, the mean J2 of the pair's grains
        /// below their 99th percentile (dimensionless).
        #[arg(long, default_value_t = ShearLineOptions::default().threshold)]
        threshold: f64,
        /// Fewest grains in a line.
        #[arg(long, default_value_t = ShearLineOptions::default().min_grains)]
        min_grains: usize,
        /// Least length of a line, in D.
        #[arg(long, default_value_t = ShearLineOptions::default().min_length_over_d)]
        min_length: f64,
        /// Least elongation of a line (length / width).
        #[arg(long, default_value_t = ShearLineOptions::default().min_elongation)]
        min_elongation: f64,
        /// Large-grain diameter D in the table's length unit (default: the table's sidecar).
        #[arg(long)]
        diameter: Option<f64>,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// A pillar size scan's flow stress (li-granular-pillars Fig. 10a, b): per
    /// `simulate pillar` run ⟨σ⟩ over 0.05 ≤ ε ≤ 0.2 (m g μ/D) and κ, against W0; the
    /// fit ⟨σ⟩ = c W0/D through the origin with its 95 % interval; the yield point ε_y,
    /// σ_y of each σ(ε) (Sec. III; docs/size-scan.md), "not reached" for a curve still
    /// rising at ε = 0.2.
    Sizes {
        /// `simulate pillar` output directories (run each to ε ≥ 0.2).
        #[arg(required = true)]
        runs: Vec<PathBuf>,
        /// One row per run: N, W0/D, ⟨σ⟩ and its error (m g μ/D), ⟨κ⟩, χ = W/W0 at
        /// ε = 0.1 and 0.2, the bar pressure at the interface's centre (m g μ/D), ε_y and
        /// σ_y (m g μ/D) with their 95 % intervals (NaN where not reached).
        #[arg(short, long)]
        output: PathBuf,
        /// Also every run's frames: ε, σ (m g μ/D), κ, χ (Figs. 10a, 10d, shape scaling).
        #[arg(long)]
        curves: Option<PathBuf>,
        /// Also every run's bar pressure profile p (m g μ/D) against x/W (Fig. 10c).
        #[arg(long)]
        pressure: Option<PathBuf>,
    },
    /// Contact pressure along the compressing bar of a `simulate pillar` run
    /// (li-granular-pillars Fig. 10c): p in m g μ/D against x/W (W the span of the
    /// grains touching the bar), averaged over the force snapshots in a strain window.
    BarPressure {
        /// A `simulate pillar` output directory.
        run: PathBuf,
        /// Strain window LO,HI of the snapshots averaged (engineering strain).
        #[arg(long, value_parser = parse_pair, default_value = "0.1,0.2")]
        strain: (f64, f64),
        /// Bins across the interface.
        #[arg(long, default_value_t = 10)]
        bins: usize,
        /// x_over_w, p table (CSV or Parquet by extension).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Ground-truth tracks: a bidisperse packing mapped by a known affine transform.
    Synth {
        #[arg(short, long)]
        output: PathBuf,
        /// Number of particles (about).
        #[arg(long, default_value_t = 1000)]
        n: usize,
        /// Affine map F = [[f11, f12], [f21, f22]] as f11,f12,f21,f22.
        #[arg(long, value_delimiter = ',', default_value = "1,0.05,0,0.98")]
        affine: Vec<f64>,
        /// Non-affine Gaussian displacement per axis, in D.
        #[arg(long, default_value_t = 0.0)]
        noise: f64,
        #[arg(long, default_value_t = 1)]
        seed: u64,
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
    pillar_pipe::interrupt::install();
    pillar_pipe::io::table::quiet_guarded_panics();
    // A file-size limit (`ulimit -f`) exceeded while writing should be a write error,
    // which removes the partial output and says why, not a SIGXFSZ kill that leaves it.
    // SAFETY: no thread runs yet, and SIG_IGN installs no handler code.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        if let Some(signal) = interrupted(&e) {
            eprintln!("stopped: {e:#}");
            eprintln!("continue with: {}", resume_command(std::env::args()));
            std::process::exit(pillar_pipe::interrupt::exit_code(signal));
        }
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// The signal, where the error is a run stopped by SIGINT or SIGTERM.
fn interrupted(e: &anyhow::Error) -> Option<i32> {
    e.chain().find_map(|c| match c.downcast_ref() {
        Some(pillar_pipe::error::Error::Interrupted { signal, .. }) => Some(*signal),
        _ => None,
    })
}

/// The command that continues a stopped one: `simulate … -o DIR` becomes
/// `simulate … --resume DIR` (the options must stay those of the run); `run` and
/// `sweep` continue when typed again.
fn resume_command(args: impl Iterator<Item = String>) -> String {
    let args: Vec<String> = args.collect();
    let simulate = args.get(1).is_some_and(|a| a == "simulate");
    let mut out = vec!["pillar-pipe".to_string()];
    let mut it = args.iter().skip(1);
    while let Some(a) = it.next() {
        let dir = if !simulate {
            None
        } else if a == "-o" || a == "--output" {
            it.next().cloned()
        } else if let Some(d) = a.strip_prefix("--output=") {
            Some(d.to_string())
        } else {
            a.strip_prefix("-o")
                .filter(|d| !d.is_empty() && !a.starts_with("--"))
                .map(str::to_string)
        };
        match dir {
            Some(d) => out.extend(["--resume".to_string(), d]),
            None => out.push(a.clone()),
        }
    }
    out.iter()
        .map(|a| shell_quote(a))
        .collect::<Vec<_>>()
        .join(" ")
}

fn shell_quote(a: &str) -> String {
    let plain = !a.is_empty()
        && a.chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-./=,:+@%".contains(c));
    if plain {
        a.to_string()
    } else {
        format!("'{}'", a.replace('\'', "'\\''"))
    }
}

fn run(cli: Cli) -> Result<()> {
    pillar_pipe::dem::backend::simd::cap_from_env().map_err(anyhow::Error::msg)?;
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
                if let Some(f) = &rep.settings_file {
                    println!("settings      from {f}");
                }
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
        Cmd::Kinematics {
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
        } => {
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
        }
        Cmd::Fit {
            input,
            output,
            diameter,
            bar_speed,
            starts,
            lags,
            rc_over_d,
            method,
            bins_per_decade,
            min_bin_count,
            bootstrap,
            seed,
            eta_range,
            position_noise,
            scatter,
            quiet,
        } => {
            use pillar_pipe::stages::fit;
            let opt = fit::FitOptions {
                diameter,
                bar_speed,
                starts,
                lags,
                rc_over_d,
                method,
                binning: pillar_pipe::fit::Binning {
                    bins_per_decade,
                    min_count: min_bin_count,
                },
                bootstrap,
                seed,
                range: eta_range,
                scatter,
                quiet,
                position_noise,
            };
            let rep = fit::run(&input, &output, &opt)
                .with_context(|| format!("fit {}", input.display()))?;
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
        }
        Cmd::Compare { a, b, json } => {
            let c = pillar_pipe::stages::compare::run(&a, &b)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&c)?);
            } else {
                print!("{c}");
            }
        }
        Cmd::Quickstart {
            input,
            out,
            seed,
            bootstrap,
            quiet,
        } => {
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
        }
        Cmd::Run {
            pipeline,
            set,
            force,
            quiet,
            runs_dir,
            dry_run,
            verify,
            jobs,
            exec,
        } => run_pipeline(pillar_pipe::pipeline::RunOptions {
            pipeline,
            sets: set,
            force,
            quiet,
            runs_dir,
            dry_run,
            verify,
            executor: exec.executor.clone(),
            slurm: exec.slurm(),
            jobs: jobs.map(|j| j as usize),
        })?,
        Cmd::SlurmJob { spec } => {
            std::process::exit(pillar_pipe::pipeline::slurm::job::main(&spec));
        }
        Cmd::Runs { what, runs_dir } => runs(what, &runs_dir)?,
        Cmd::Bench { what } => cli_bench::bench(what)?,
        Cmd::Simulate { what } => cli_sim::simulate(what)?,
        Cmd::Pack(a) => cli_sim::pack(a)?,
        Cmd::IngestForce(a) => cli_force::ingest_force(a)?,
        Cmd::Locate(a) => cli_camera::locate(a)?,
        Cmd::Link(a) => cli_camera::link(a)?,
        Cmd::Track(a) => cli_camera::track(a)?,
        Cmd::Render(a) => cli_camera_render::run(a)?,
        Cmd::Sweep(a) => cli_sim::sweep(a)?,
        Cmd::Export {
            input,
            kinematics,
            format,
            output,
        } => {
            use pillar_pipe::io::export::Format;
            let ext = output
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase());
            let format = match (format, ext.as_deref()) {
                (Some(f), _) => f,
                (None, Some("xyz" | "extxyz")) => Format::Extxyz,
                (None, Some("dump" | "lammpstrj")) => Format::LammpsDump,
                _ => anyhow::bail!(
                    "{}: cannot tell the format from the extension; pass --format extxyz or --format lammps-dump (or name the file .xyz or .dump)",
                    output.display()
                ),
            };
            let r =
                pillar_pipe::stages::export::run(&input, kinematics.as_deref(), format, &output)
                    .with_context(|| format!("export of {}", input.display()))?;
            println!(
                "wrote       {}: {} frames, {} rows; properties: id, species, pos, radius{}{}",
                r.output.display(),
                r.frames,
                r.particles,
                if r.properties.is_empty() {
                    String::new()
                } else {
                    format!(", {}", r.properties.join(", "))
                },
                if r.skipped.is_empty() {
                    String::new()
                } else {
                    format!(" (left out: {})", r.skipped.join("; "))
                }
            );
        }
        Cmd::Gofr {
            input,
            output,
            frame,
            r_max,
            bins,
        } => {
            let (g, f, d) = pillar_pipe::stages::gofr::run(&input, &output, frame, r_max, bins)
                .with_context(|| format!("g(r) of {}", input.display()))?;
            let peak = |v: &[f64]| {
                g.r.iter()
                    .zip(v)
                    .filter(|(_, x)| x.is_finite())
                    .max_by(|a, b| a.1.total_cmp(b.1))
                    .map(|(r, x)| format!("{:.3} D (g = {x:.2})", r / d))
                    .unwrap_or_else(|| "none".into())
            };
            println!(
                "g(r)        frame {f}: {} centres counted ({} small, {} large) of density {:.4} per unit²; first peak around small {}, around large {}",
                g.centres[0],
                g.centres[1],
                g.centres[2],
                g.density,
                peak(&g.g_small),
                peak(&g.g_large)
            );
            println!("wrote       {}", output.display());
        }
        Cmd::ShearLines {
            kinematics,
            output,
            frame,
            lag_frames,
            threshold,
            min_grains,
            min_length,
            min_elongation,
            diameter,
            json,
        } => {
            use pillar_pipe::stages::shear_lines as sl;
            let output = output.unwrap_or_else(|| sl::default_output(&kinematics));
            let opt = sl::ShearLinesOptions {
                frame,
                lag_frames,
                diameter,
                detect: ShearLineOptions {
                    threshold,
                    min_grains,
                    min_length_over_d: min_length,
                    min_elongation,
                    ..ShearLineOptions::default()
                },
            };
            let rep = sl::run(&kinematics, &output, &opt)
                .with_context(|| format!("shear lines of {}", kinematics.display()))?;
            if json {
                println!("{}", serde_json::to_string_pretty(&rep)?);
            } else {
                println!("{rep}");
                println!("wrote       {}", output.display());
            }
        }
        Cmd::Sizes {
            runs,
            output,
            curves,
            pressure,
        } => {
            let out = pillar_pipe::stages::sizes::SizeOutputs {
                table: output.clone(),
                curves,
                pressure,
            };
            let scan = pillar_pipe::stages::sizes::run(&runs, &out).context("size scan")?;
            let (rows, fit) = (&scan.rows, &scan.fit);
            for r in rows {
                println!(
                    "size        N = {:6}  W0 = {:6.2} D  <sigma> = {:.3} ± {:.3} m g mu/D  kappa = {:.3}  ({})",
                    r.n,
                    r.w0_over_d,
                    r.sigma,
                    r.sigma_err,
                    r.kappa,
                    r.run.display()
                );
            }
            match fit {
                Some(f) => println!(
                    "fit         <sigma> = c W0/D, c = {:.4} [{:.4}, {:.4}] (95 %) m g mu/D per D",
                    f.c, f.c_interval[0], f.c_interval[1]
                ),
                None => println!("fit         needs two runs or more"),
            }
            for r in rows {
                match &r.yielding {
                    pillar_pipe::structure::yielding::Yield::Reached(p) => println!(
                        "yield       N = {:6}  eps_y = {:.4} [{:.4}, {:.4}]  sigma_y = {:.3} [{:.3}, {:.3}] m g mu/D  sigma_y/W0 = {:.4}",
                        r.n,
                        p.eps_y,
                        p.eps_interval[0],
                        p.eps_interval[1],
                        p.sigma_y,
                        p.sigma_interval[0],
                        p.sigma_interval[1],
                        p.sigma_y / r.w0_over_d
                    ),
                    pillar_pipe::structure::yielding::Yield::NotReached(why) => {
                        println!("yield       N = {:6}  not reached: {why}", r.n)
                    }
                }
            }
            for r in rows {
                println!(
                    "shape       N = {:6}  chi = W/W0: {:.3} at eps = 0.1, {:.3} at 0.2",
                    r.n, r.chi[0], r.chi[1]
                );
                match &r.pressure {
                    Ok((_, snaps)) => println!(
                        "pressure    N = {:6}  p at the centre = {:.3} m g mu/D ({snaps} snapshots, 0.1 <= eps <= 0.2), p/W0 = {:.4}",
                        r.n,
                        r.p_centre(),
                        r.p_centre() / r.w0_over_d
                    ),
                    Err(e) => println!("warning     N = {}: no bar pressure: {e}", r.n),
                }
            }
            if let Some(c) = &scan.checks {
                let verdict = |ok: bool| if ok { "holds" } else { "does NOT hold" };
                println!(
                    "check       <sigma>/W0 equal across sizes within 10 %: spread {:.1} % ({})",
                    100.0 * c.sigma_over_w0_spread,
                    verdict(c.sigma_over_w0_spread <= 0.10)
                );
                match c.sigma_y_over_w0_spread {
                    Some(s) => println!(
                        "check       sigma_y/W0 equal across sizes within 10 %: spread {:.1} % ({})",
                        100.0 * s,
                        verdict(s <= 0.10)
                    ),
                    None => println!(
                        "check       sigma_y/W0 equal across sizes within 10 %: not made (a run does not yield)"
                    ),
                }
                println!(
                    "check       kappa equal across sizes within 0.03: spread {:.3} ({})",
                    c.kappa_spread,
                    verdict(c.kappa_spread <= 0.03)
                );
                for (k, at) in pillar_pipe::stages::sizes::CHI_AT.iter().enumerate() {
                    println!(
                        "check       W/W0 at eps = {at} equal across sizes within 5 %: spread {:.1} % ({})",
                        100.0 * c.chi_spread[k],
                        verdict(c.chi_spread[k] <= 0.05)
                    );
                }
            }
            println!("wrote       {}", output.display());
            for p in [&out.curves, &out.pressure].into_iter().flatten() {
                println!("wrote       {}", p.display());
            }
        }
        Cmd::BarPressure {
            run,
            strain,
            bins,
            output,
        } => {
            let (p, snaps) = pillar_pipe::stages::bar_pressure::run(&run, strain, bins, &output)
                .context("bar pressure")?;
            println!(
                "pressure    {snaps} snapshots at {} <= eps <= {}: W = {:.2} D, bar force {:.3} m g mu, {} grains touching",
                strain.0, strain.1, p.width, p.force, p.contacts
            );
            for (x, v) in p.x_over_w.iter().zip(&p.p) {
                println!("  x/W = {x:.2}   p = {v:.3} m g mu/D");
            }
            println!("wrote       {}", output.display());
        }
        Cmd::Outline {
            input,
            output,
            frame,
            against,
            against_frame,
        } => {
            let other = against.as_deref().map(|p| (p, against_frame));
            let (a, distance) = pillar_pipe::stages::outline::run(&input, frame, other, &output)
                .with_context(|| format!("outline of {}", input.display()))?;
            let hw = a.outline.half_width();
            let widest = hw.iter().fold(0.0f64, |m, &w| m.max(2.0 * w));
            println!(
                "outline     frame {}: {} slabs, height {:.3} W0, widest {:.3} W0 (W0 = {:.4})",
                a.frame,
                hw.len(),
                a.outline.height() / a.w0,
                widest / a.w0,
                a.w0
            );
            if let Some(d) = distance {
                println!("shape       rms distance of the rescaled half-widths: {d:.4} W0");
            }
            println!("wrote       {}", output.display());
        }
        Cmd::Synth {
            output,
            n,
            affine,
            noise,
            seed,
        } => {
            use pillar_pipe::geom::Mat2;
            use pillar_pipe::synth::{bidisperse_packing, two_frame_tracks};
            if affine.len() != 4 {
                anyhow::bail!(
                    "--affine needs 4 numbers f11,f12,f21,f22, got {}",
                    affine.len()
                );
            }
            let f = Mat2::new(affine[0], affine[1], affine[2], affine[3]);
            let p = bidisperse_packing(n, 1.0, 0.1, seed);
            let mut t = two_frame_tracks(&p, f, noise, seed);
            t.meta.provenance.tool = pillar_pipe::stages::TOOL.into();
            t.meta.provenance.tool_version = pillar_pipe::stages::VERSION.into();
            t.meta.provenance.source = "synth".into();
            t.meta.provenance.parameters =
                serde_json::json!({"n": n, "affine": affine, "noise": noise, "seed": seed});
            pillar_pipe::io::write_tracks(&t, &output)?;
            let s = pillar_pipe::kinematics::strain_from_j(&f, Convention::Paper);
            println!(
                "synth         {} particles, 2 frames -> {}\nexact         J = {affine:?}, eta_s = {:.6e}, eta_m = {:.6e}, D2min = 0 without noise",
                p.pos.len(),
                output.display(),
                s.eta_s,
                s.eta_m
            );
        }
    }
    Ok(())
}
