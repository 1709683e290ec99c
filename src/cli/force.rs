//! `pillar-pipe ingest-force`: argument types and printing only; the work is in
//! `pillar_pipe::stages::force`.

use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::stages::force::{self, ForceOptions};
use std::path::PathBuf;

/// A force sensor's CSV → bar_forces and stress_strain tables (li-granular-pillars
/// Fig. 4a); units: --help.
///
/// Reads a force sensor's CSV (time and/or bar displacement, and the force on the top
/// bar) into the `bar_forces` table the simulator writes (time s, forces N, bar faces cm,
/// the bottom bar at y = 0), and its stress–strain curve with the simulator's definitions
/// (li-granular-pillars Sec. III): ε = ΔH/H0, σ = F_bar / W (N/m) and σ in m g μ / D.
///
/// Units come from the header (`time [s]`, `force [mN]`), from `# key = value` comment
/// lines above it, from `ingest.toml` (or `<stem>.ingest.toml`) beside the file, or from
/// these flags (flags first, then comments, then ingest.toml). Format: docs/ingest.md
/// ("Force sensor").
#[derive(Args, Debug)]
pub struct IngestForceArgs {
    /// The sensor's CSV (comma, tab or semicolon separated).
    pub input: PathBuf,
    /// bar_forces table (.parquet or .csv); default <stem>.bar_forces.parquet beside the input.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// stress_strain table (.parquet or .csv); default <stem>.stress_strain.parquet beside the input.
    #[arg(long)]
    pub stress_strain: Option<PathBuf>,
    /// Unit of the force columns: N, mN, kN, uN, gf, kgf, lbf or dyn.
    #[arg(long)]
    pub force_unit: Option<String>,
    /// Unit of the time column: s, ms, us, min or h.
    #[arg(long)]
    pub time_unit: Option<String>,
    /// Length unit of the displacement column, --height, --width, --grain-size and
    /// --bar-speed: m, cm, mm, um or in.
    #[arg(long)]
    pub unit: Option<String>,
    /// Bar speed v_c in length unit per second: bar travel = v_c × time (or time =
    /// travel / v_c), and P_in = F_bar v_c.
    #[arg(long)]
    pub bar_speed: Option<f64>,
    /// Initial pillar height H0 (bar separation at time 0), length unit: ε = travel / H0.
    #[arg(long)]
    pub height: Option<f64>,
    /// Pillar width W at the top edge, length unit: σ = F_bar / W (or --tracks).
    #[arg(long)]
    pub width: Option<f64>,
    /// Large-grain diameter D, length unit, for σ in m g μ / D [default: 0.635 cm, the paper's].
    #[arg(long)]
    pub grain_size: Option<f64>,
    /// Large-grain mass m in kg, for σ in m g μ / D [default: 0.80e-3, the paper's].
    #[arg(long)]
    pub grain_mass: Option<f64>,
    /// Grain–substrate friction μ, for σ in m g μ / D [default: 0.23, the paper's].
    #[arg(long)]
    pub mu: Option<f64>,
    /// The experiment's tracks (canonical, e.g. from `ingest`: y = 0 at the bottom bar
    /// face, frame times in s): W measured per frame as the simulator does (grains within
    /// 2 D of the top bar), interpolated to the sensor's times, instead of one --width.
    #[arg(long)]
    pub tracks: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn ingest_force(a: IngestForceArgs) -> Result<()> {
    let (bar_default, ss_default) = force::default_outputs(&a.input);
    let bar = a.output.unwrap_or(bar_default);
    let ss = a.stress_strain.unwrap_or(ss_default);
    let opt = ForceOptions {
        force_unit: a.force_unit,
        time_unit: a.time_unit,
        unit: a.unit,
        bar_speed: a.bar_speed,
        height: a.height,
        width: a.width,
        grain_size: a.grain_size,
        grain_mass: a.grain_mass,
        mu: a.mu,
        tracks: a.tracks,
        width_over_tracks: false,
    };
    let rep = force::run(&a.input, &bar, &ss, &opt)
        .with_context(|| format!("ingest-force {}", a.input.display()))?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rep)?);
        return Ok(());
    }
    println!("ingested {} ({} rows)", rep.input, rep.rows);
    println!("bar_forces    -> {}", rep.bar_forces);
    println!("stress_strain -> {}", rep.stress_strain);
    if let Some(f) = &rep.settings_file {
        println!("settings      from {f}");
    }
    println!(
        "max strain {:.4}, max stress {:.4} N/m = {:.3} m g mu / D",
        rep.max_strain, rep.max_stress, rep.max_stress_reduced
    );
    for w in &rep.warnings {
        println!("warning: {w}");
    }
    Ok(())
}
