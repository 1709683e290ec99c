//! `shear_lines`: the transient shear lines (li-granular-pillars Fig. 11) of one frame
//! pair of a stage's kinematics: grains with J2 above `threshold` times the mean,
//! linked at 1.25 D, measured by the principal axes of their centres
//! (docs/shear-lines.md). The command `pillar-pipe shear-lines` flattens the same
//! options.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use crate::structure::ShearLineOptions;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// `shear-lines`' options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct ShearLinesParams {
    /// The kinematics stage read (pipeline files; the command line takes a path).
    #[arg(skip)]
    pub input: String,
    /// Start frame of the pair (default: the first).
    #[arg(long)]
    pub frame: Option<i64>,
    /// Lag of the pair in frames, frame_end - frame (default: the smallest there).
    #[arg(long)]
    pub lag_frames: Option<i64>,
    /// A grain is high when J2 > THRESHOLD x J2_ref, the mean J2 of the pair's grains
    /// below their 99th percentile (dimensionless).
    #[arg(long, default_value_t = ShearLineOptions::default().threshold)]
    pub threshold: f64,
    /// Fewest grains in a line.
    #[arg(long, default_value_t = ShearLineOptions::default().min_grains)]
    pub min_grains: usize,
    /// Least length of a line, in D.
    #[arg(long, default_value_t = ShearLineOptions::default().min_length_over_d)]
    pub min_length: f64,
    /// Least elongation of a line (length / width).
    #[arg(long, default_value_t = ShearLineOptions::default().min_elongation)]
    pub min_elongation: f64,
    /// Large-grain diameter D in the table's length unit (default: the table's sidecar).
    #[arg(long)]
    pub diameter: Option<f64>,
}

impl Default for ShearLinesParams {
    fn default() -> Self {
        let d = ShearLineOptions::default();
        ShearLinesParams {
            input: String::new(),
            frame: None,
            lag_frames: None,
            threshold: d.threshold,
            min_grains: d.min_grains,
            min_length: d.min_length_over_d,
            min_elongation: d.min_elongation,
            diameter: None,
        }
    }
}

impl ShearLinesParams {
    pub fn options(&self) -> stages::shear_lines::ShearLinesOptions {
        stages::shear_lines::ShearLinesOptions {
            frame: self.frame,
            lag_frames: self.lag_frames,
            diameter: self.diameter,
            detect: detect_options(
                self.threshold,
                self.min_grains,
                self.min_length,
                self.min_elongation,
            ),
        }
    }
}

/// The detection's options from the keys `shear_lines` and `shear_line_tracks` share.
pub(crate) fn detect_options(
    threshold: f64,
    min_grains: usize,
    min_length: f64,
    min_elongation: f64,
) -> ShearLineOptions {
    ShearLineOptions {
        threshold,
        min_grains,
        min_length_over_d: min_length,
        min_elongation,
        ..ShearLineOptions::default()
    }
}

pub struct ShearLines;

impl StageKind for ShearLines {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<ShearLinesParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: ShearLinesParams = typed(&s.name, &s.params)?;
        let kin = ctx.input(s, "input", "kinematics")?;
        let r = stages::shear_lines::run(&kin, &out.join("shear_lines.parquet"), &p.options())?;
        Ok(Produced {
            outputs: outputs(&[("shear_lines", "shear_lines.parquet")]),
            metrics: json!({"frame": r.frame, "frame_end": r.frame_end, "lines": r.result.lines.len()}),
            summary: sum(&r),
        })
    }
}
