//! `pillar-pipe shear-lines`: the transient shear lines (li-granular-pillars Fig. 11) of
//! one frame pair of a `kinematics` table, one row per line
//! (`data_schema/shear_lines.schema.json`). The method and its definitions are
//! `structure::shear_lines`'; this reads, selects the pair and writes.

use crate::error::{Error, Result};
use crate::geom::Vec2;
use crate::io::csvdiag::Expect;
use crate::io::table::{Table, read_table, write_table};
use crate::io::{sha256_file, sidecar_path, write_with_sidecar};
use crate::structure::{ShearLine, ShearLineOptions, ShearLines, shear_lines};
use polars::prelude::*;
use serde::Serialize;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Columns the detection reads from the kinematics table.
const REQUIRED: [&str; 5] = ["frame", "frame_end", "x", "y", "j2"];

#[derive(Debug, Clone, Default)]
pub struct ShearLinesOptions {
    /// Start frame of the pair (default: the first).
    pub frame: Option<i64>,
    /// frame_end − frame (default: the smallest at the chosen start frame).
    pub lag_frames: Option<i64>,
    /// Large-grain diameter D (length unit); default: the table's sidecar `d_large`.
    pub diameter: Option<f64>,
    pub detect: ShearLineOptions,
}

#[derive(Debug, Clone, Serialize)]
pub struct ShearLinesReport {
    pub input: String,
    pub output: String,
    pub frame: i64,
    pub frame_end: i64,
    /// Δt of the pair (`time_unit`), NaN without a `dt` column.
    pub dt: f64,
    /// D in `length_unit`.
    pub d_large: f64,
    pub length_unit: String,
    pub time_unit: String,
    /// Frame pairs in the table.
    pub pairs: usize,
    pub options: ShearLineOptions,
    pub result: ShearLines,
}

impl std::fmt::Display for ShearLinesReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.result.summary;
        writeln!(
            f,
            "shear lines {}: frames {} -> {} (dt = {} {}; {} pairs in the table), D = {} {}",
            self.input,
            self.frame,
            self.frame_end,
            self.dt,
            self.time_unit,
            self.pairs,
            self.d_large,
            self.length_unit
        )?;
        writeln!(
            f,
            "grains      {} with J2, {} above {} x J2_ref = {:.4e} per {} (J2_ref: mean below the 99th percentile)",
            s.determined, s.high, self.options.threshold, s.j2_ref, self.time_unit
        )?;
        if s.lines == 0 {
            write!(f, "lines       none; {} compact clusters", s.compact)?;
        } else {
            write!(
                f,
                "lines       {}: median angle {:.1} deg to the compression axis y, median width {:.2} D, median length {:.1} D; {} compact clusters",
                s.lines, s.median_angle_deg, s.median_width_d, s.median_length_d, s.compact
            )?;
        }
        for l in &self.result.lines {
            write!(
                f,
                "\nline {:<6} {:4} grains at ({:.3}, {:.3}): {:5.1} deg, width {:.2} D, length {:.1} D, J2 {:.1} x J2_ref",
                l.id, l.n_grains, l.x, l.y, l.angle_deg, l.width_d, l.length_d, l.j2_contrast
            )?;
        }
        Ok(())
    }
}

/// Default output beside the input: `name.kinematics.parquet` → `name.shear_lines.csv`.
pub fn default_output(input: &Path) -> PathBuf {
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "kinematics".into());
    let stem = stem
        .strip_suffix(".kinematics")
        .unwrap_or(&stem)
        .to_string();
    input.with_file_name(format!("{stem}.shear_lines.csv"))
}

/// A kinematics table, or an error naming the file and what it lacks.
pub(crate) fn read_kinematics(input: &Path) -> Result<Table> {
    let expect = [
        ("frame", Expect::Int),
        ("frame_end", Expect::Int),
        ("x", Expect::Float),
        ("y", Expect::Float),
        ("j2", Expect::Float),
    ];
    let t = read_table(input, &expect)?;
    if !t.has("j2") && t.has("radius") {
        return Err(Error::input(
            &t.file,
            "has no column 'j2': this is a tracks table, not a kinematics table; run \
             `pillar-pipe kinematics` on it and pass its output",
        ));
    }
    t.require(&REQUIRED)?;
    Ok(t)
}

pub fn run(input: &Path, output: &Path, opt: &ShearLinesOptions) -> Result<ShearLinesReport> {
    let t = read_kinematics(input)?;
    let file = t.file.clone();
    let (frame, frame_end) = (t.i64("frame")?, t.i64("frame_end")?);
    let pairs: BTreeSet<(i64, i64)> = frame
        .iter()
        .copied()
        .zip(frame_end.iter().copied())
        .collect();
    let (fa, fb) = pairs
        .iter()
        .copied()
        .find(|&(a, b)| {
            opt.frame.is_none_or(|f| f == a) && opt.lag_frames.is_none_or(|l| b - a == l)
        })
        .ok_or_else(|| no_pair(&file, opt, &pairs))?;
    let meta: Option<serde_json::Value> = std::fs::read_to_string(sidecar_path(input))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok());
    let side = |k: &str| {
        meta.as_ref()
            .and_then(|m| m[k].as_str())
            .map(str::to_string)
    };
    let d = diameter(input, &file, meta.as_ref(), opt.diameter)?;
    let rows: Vec<usize> = (0..frame.len())
        .filter(|&i| frame[i] == fa && frame_end[i] == fb)
        .collect();
    let (x, y, j2) = (t.f64("x")?, t.f64("y")?, t.f64_or_nan("j2")?);
    let pos: Vec<Vec2> = rows.iter().map(|&i| Vec2::new(x[i], y[i])).collect();
    let j2: Vec<f64> = rows.iter().map(|&i| j2[i]).collect();
    let dt = if t.has("dt") {
        t.f64_or_nan("dt")?[rows[0]]
    } else {
        f64::NAN
    };
    let result = shear_lines(&pos, &j2, d, &opt.detect)?;
    let rep = ShearLinesReport {
        input: file.clone(),
        output: output.display().to_string(),
        frame: fa,
        frame_end: fb,
        dt,
        d_large: d,
        length_unit: side("length_unit").unwrap_or_else(|| "length".into()),
        time_unit: side("time_unit").unwrap_or_else(|| "time".into()),
        pairs: pairs.len(),
        options: opt.detect,
        result,
    };
    let sidecar = serde_json::json!({
        "table": "shear_lines",
        "length_unit": rep.length_unit,
        "time_unit": rep.time_unit,
        "d_large": d,
        "frame": fa, "frame_end": fb, "dt": dt,
        "summary": rep.result.summary,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": file, "source_sha256": sha256_file(input)?,
            "parameters": {"frame": opt.frame, "lag_frames": opt.lag_frames, "diameter": opt.diameter, "detect": opt.detect},
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    let mut df = lines_dataframe(&rep)?;
    write_with_sidecar(output, &sidecar, || write_table(&mut df, output))?;
    Ok(rep)
}

/// D from `--diameter`, else the kinematics sidecar's `d_large`.
pub(crate) fn diameter(
    input: &Path,
    file: &str,
    meta: Option<&serde_json::Value>,
    given: Option<f64>,
) -> Result<f64> {
    match (given, meta.and_then(|m| m["d_large"].as_f64())) {
        (Some(d), _) | (None, Some(d)) => Ok(d),
        (None, None) => Err(Error::param(
            "diameter",
            format!(
                "{file}: no large-grain diameter D in a sidecar ({}); pass --diameter D",
                sidecar_path(input).display()
            ),
        )),
    }
}

/// The error for a pair that is not in the table, naming the pairs that are.
fn no_pair(file: &str, opt: &ShearLinesOptions, pairs: &BTreeSet<(i64, i64)>) -> Error {
    let asked = match (opt.frame, opt.lag_frames) {
        (Some(f), Some(l)) => format!("no frame {f} with lag {l}"),
        (Some(f), None) => format!("no frame {f}"),
        (None, Some(l)) => format!("no frame pair with lag {l}"),
        (None, None) => "no rows".into(),
    };
    let shown: Vec<String> = pairs
        .iter()
        .take(12)
        .map(|(a, b)| format!("{a}->{b}"))
        .collect();
    let more = if pairs.len() > 12 { ", ..." } else { "" };
    Error::param(
        if opt.frame.is_some() {
            "frame"
        } else {
            "lag-frames"
        },
        format!(
            "{file}: {asked}; its {} frame pairs (frame->frame_end) are {}{more}",
            pairs.len(),
            shown.join(", ")
        ),
    )
}

/// One row per line, in the schema's column order.
fn lines_dataframe(rep: &ShearLinesReport) -> Result<DataFrame> {
    let rows: Vec<(i64, i64, &ShearLine)> = rep
        .result
        .lines
        .iter()
        .map(|l| (rep.frame, rep.frame_end, l))
        .collect();
    lines_table(&rows)
}

/// One row per (frame, frame_end, line), in the schema's column order.
pub(crate) fn lines_table(rows: &[(i64, i64, &ShearLine)]) -> Result<DataFrame> {
    let n = rows.len();
    let f = |g: fn(&ShearLine) -> f64| -> Vec<f64> { rows.iter().map(|r| g(r.2)).collect() };
    let i =
        |g: fn(&ShearLine) -> usize| -> Vec<i64> { rows.iter().map(|r| g(r.2) as i64).collect() };
    DataFrame::new(
        n,
        vec![
            Column::new(
                "frame".into(),
                rows.iter().map(|r| r.0).collect::<Vec<i64>>(),
            ),
            Column::new(
                "frame_end".into(),
                rows.iter().map(|r| r.1).collect::<Vec<i64>>(),
            ),
            Column::new("line".into(), i(|l| l.id)),
            Column::new("n_grains".into(), i(|l| l.n_grains)),
            Column::new("x".into(), f(|l| l.x)),
            Column::new("y".into(), f(|l| l.y)),
            Column::new("angle_deg".into(), f(|l| l.angle_deg)),
            Column::new("direction_deg".into(), f(|l| l.direction_deg)),
            Column::new("width_d".into(), f(|l| l.width_d)),
            Column::new("length_d".into(), f(|l| l.length_d)),
            Column::new("elongation".into(), f(|l| l.elongation)),
            Column::new("j2_mean".into(), f(|l| l.j2_mean)),
            Column::new("j2_contrast".into(), f(|l| l.j2_contrast)),
        ],
    )
    .map_err(|e| Error::polars("the shear-lines table", e))
}
