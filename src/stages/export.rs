//! `pillar-pipe export`: a tracks table (or a simulation run's) as extended XYZ or a
//! LAMMPS text dump for OVITO, ASE or LAMMPS, with a kinematics table's columns (D²min,
//! η^s, J2, …, li-granular-pillars Eqs. 13–18) attached to the particles of the frame
//! each pair starts at, so a viewer can colour grains by them.

use crate::error::{Error, Result};
use crate::io::export::{Cell, Format, Snapshot, write_extxyz, write_lammps_dump};
use crate::io::table::read_table;
use crate::io::{atomic_write, read_tracks, sha256_file};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Kinematics columns that are keys or already written as particle fields.
const NOT_PROPERTIES: [&str; 9] = [
    "frame",
    "frame_end",
    "particle",
    "x",
    "y",
    "species",
    "vx",
    "vy",
    "status",
];

#[derive(Debug, Clone, serde::Serialize)]
pub struct ExportReport {
    pub output: PathBuf,
    pub frames: usize,
    pub particles: usize,
    /// The per-particle properties written beside id, species, position and radius.
    pub properties: Vec<String>,
    /// Kinematics columns left out (not numbers), with why.
    pub skipped: Vec<String>,
}

/// The tracks table behind `input`: the table itself, or a run directory's
/// `tracks.parquet`.
pub fn tracks_of(input: &Path) -> Result<PathBuf> {
    if input.is_dir() {
        let t = input.join("tracks.parquet");
        if !t.is_file() {
            return Err(Error::input(
                input.display(),
                "a directory given as tracks holds no tracks.parquet (a `simulate` run's directory does)",
            ));
        }
        return Ok(t);
    }
    Ok(input.to_path_buf())
}

/// Kinematics rows by (start frame, particle), its property columns and velocity.
struct Kin {
    row: HashMap<(i64, i64), usize>,
    props: Vec<(String, Vec<f64>)>,
    velocity: Option<(Vec<f64>, Vec<f64>)>,
    skipped: Vec<String>,
}

fn read_kinematics(path: &Path) -> Result<Kin> {
    let t = read_table(path, &[])?;
    t.require(&["frame", "particle"])?;
    let (frame, particle) = (t.i64("frame")?, t.i64("particle")?);
    let mut row = HashMap::with_capacity(frame.len());
    for (i, k) in frame.iter().zip(&particle).enumerate() {
        if row.insert((*k.0, *k.1), i).is_some() {
            return Err(Error::input(
                path.display(),
                format!(
                    "row {}: frame {} particle {} appears twice; a kinematics table holds one row per (frame, particle)",
                    i + 1,
                    k.0,
                    k.1
                ),
            ));
        }
    }
    let (mut props, mut skipped) = (Vec::new(), Vec::new());
    for c in t.columns() {
        if NOT_PROPERTIES.contains(&c.as_str()) {
            continue;
        }
        match t.f64_or_nan(&c) {
            Ok(v) => props.push((c, v)),
            Err(e) => skipped.push(format!("{c} ({e})")),
        }
    }
    let cols = t.columns();
    let velocity = if cols.iter().any(|c| c == "vx") && cols.iter().any(|c| c == "vy") {
        Some((t.f64_or_nan("vx")?, t.f64_or_nan("vy")?))
    } else {
        None
    };
    Ok(Kin {
        row,
        props,
        velocity,
        skipped,
    })
}

/// Write every frame of `input` (tracks, or a run directory) to `output` in `format`,
/// with `kinematics`' columns where given; `output` and its `.meta.json` sidecar are
/// written under temporary names and renamed into place.
pub fn run(
    input: &Path,
    kinematics: Option<&Path>,
    format: Format,
    output: &Path,
) -> Result<ExportReport> {
    let tracks_path = tracks_of(input)?;
    let (t, _) = read_tracks(&tracks_path)?;
    let kin = kinematics.map(read_kinematics).transpose()?;
    let boxes: HashMap<i64, Cell> = t
        .meta
        .boxes
        .iter()
        .map(|b| {
            (
                b.frame,
                Cell {
                    lo: (b.x_lo, b.y_lo),
                    l: (b.lx, b.ly),
                    // The same lattice with the tilt in [−L_x/2, L_x/2], as LAMMPS
                    // requires of a dump (the offset γL grows without bound).
                    xy: if b.periodic_x && b.lx > 0.0 {
                        b.xy - b.lx * (b.xy / b.lx).round()
                    } else {
                        b.xy
                    },
                    periodic: (b.periodic_x, b.periodic_y),
                },
            )
        })
        .collect();
    let names: Vec<String> = kin
        .as_ref()
        .map(|k| k.props.iter().map(|p| p.0.clone()).collect())
        .unwrap_or_default();
    let ranges = t.frame_ranges();
    let write = |f: &mut std::fs::File| -> Result<()> {
        let mut w = std::io::BufWriter::new(f);
        let io = |e: std::io::Error| Error::io(output, e);
        for (frame, r) in &ranges {
            let (frame, r) = (*frame, r.clone());
            let particle = &t.particle[r.clone()];
            let species = t.species.as_ref().map(|s| &s[r.clone()]);
            let time = t.time.as_ref().map(|s| s[r.start]);
            let (props, velocity) = match &kin {
                Some(k) => {
                    let rows: Vec<Option<usize>> = particle
                        .iter()
                        .map(|p| k.row.get(&(frame, *p)).copied())
                        .collect();
                    let pick = |col: &[f64]| -> Vec<f64> {
                        rows.iter()
                            .map(|r| r.map_or(f64::NAN, |i| col[i]))
                            .collect()
                    };
                    let props: Vec<(String, Vec<f64>)> =
                        k.props.iter().map(|(n, c)| (n.clone(), pick(c))).collect();
                    let vel = k.velocity.as_ref().map(|(a, b)| (pick(a), pick(b)));
                    (props, vel)
                }
                None => (Vec::new(), None),
            };
            let s = Snapshot {
                frame,
                time,
                cell: boxes.get(&frame).copied(),
                id: particle,
                x: &t.x[r.clone()],
                y: &t.y[r.clone()],
                radius: &t.radius[r],
                species,
                velocity: velocity.as_ref().map(|(a, b)| (&a[..], &b[..])),
                props: &props,
            };
            match format {
                Format::Extxyz => write_extxyz(&mut w, &s),
                Format::LammpsDump => write_lammps_dump(&mut w, &s),
            }
            .map_err(io)?;
        }
        std::io::Write::flush(&mut w).map_err(io)
    };
    let sidecar = serde_json::json!({
        "file": output.file_name().map(|n| n.to_string_lossy().into_owned()),
        "format": format,
        "length_unit": t.meta.length_unit, "time_unit": t.meta.time_unit,
        "properties": names,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": tracks_path.display().to_string(), "source_sha256": sha256_file(&tracks_path)?,
            "kinematics": kinematics.map(|k| k.display().to_string()),
            "kinematics_sha256": kinematics.map(sha256_file).transpose()?,
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    crate::io::write_with_sidecar(output, &sidecar, || atomic_write(output, write))?;
    Ok(ExportReport {
        output: output.to_path_buf(),
        frames: ranges.len(),
        particles: t.particle.len(),
        properties: names,
        skipped: kin.map(|k| k.skipped).unwrap_or_default(),
    })
}
