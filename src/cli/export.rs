//! Tables out and in for other tools: `export` (OVITO, ASE, LAMMPS) and `synth`
//! (tracks under a known affine map, the ground truth the kinematics are tested on).

use anyhow::{Context, Result};
use clap::Args;
use pillar_pipe::kinematics::Convention;
use std::path::PathBuf;

/// Write tracks (or a simulation run's) as extended XYZ or a LAMMPS text dump for
/// OVITO, ASE or LAMMPS: one snapshot per frame, id, species, position (z = 0),
/// radius, and with --kinematics every column of a kinematics table (D²min, η^s,
/// J2, velocity, …) on the particles of the frame each pair starts at (NaN where a
/// particle has none). Periodic and Lees–Edwards boxes are written as cells (the
/// offset as the tilt xy); open frames get their bounding box (LAMMPS) or no cell
/// (extxyz). Lengths in the table's unit.
#[derive(Args)]
pub struct ExportArgs {
    /// Tracks (canonical CSV/Parquet) or a `simulate` run's directory.
    pub input: PathBuf,
    /// A kinematics table of these tracks (`pillar-pipe kinematics`).
    #[arg(long)]
    pub kinematics: Option<PathBuf>,
    /// extxyz or lammps-dump; default: from the output's extension (.xyz/.extxyz,
    /// .dump/.lammpstrj).
    #[arg(long, value_enum)]
    pub format: Option<pillar_pipe::io::export::Format>,
    #[arg(short, long)]
    pub output: PathBuf,
}

pub fn export(args: ExportArgs) -> Result<()> {
    let ExportArgs {
        input,
        kinematics,
        format,
        output,
    } = args;
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
    let r = pillar_pipe::stages::export::run(&input, kinematics.as_deref(), format, &output)
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
    Ok(())
}

/// Ground-truth tracks: a bidisperse packing mapped by a known affine transform.
#[derive(Args)]
pub struct SynthArgs {
    #[arg(short, long)]
    pub output: PathBuf,
    /// Number of particles (about).
    #[arg(long, default_value_t = 1000)]
    pub n: usize,
    /// Affine map F = [[f11, f12], [f21, f22]] as f11,f12,f21,f22.
    #[arg(long, value_delimiter = ',', default_value = "1,0.05,0,0.98")]
    pub affine: Vec<f64>,
    /// Non-affine Gaussian displacement per axis, in D.
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn synth(args: SynthArgs) -> Result<()> {
    let SynthArgs {
        output,
        n,
        affine,
        noise,
        seed,
    } = args;
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
    Ok(())
}
