//! `shear_line_tracks`: the shear lines of every frame pair of a stage's kinematics,
//! linked across consecutive pairs (li-granular-pillars Sec. V: transient lines;
//! `structure::line_tracks`, docs/shear-lines.md). The command `pillar-pipe
//! shear-line-tracks` flattens the same options.

use super::Stage;
use super::StageKind;
use super::shear_lines::detect_options;
use super::typed;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use crate::structure::ShearLineOptions;
use crate::structure::line_tracks::LinkOptions;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// `shear-line-tracks`' options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct ShearLineTracksParams {
    /// The kinematics stage read (pipeline files; the command line takes a path).
    #[arg(skip)]
    pub input: String,
    /// Least shared fraction (0-1] of the smaller line's grains that links two lines.
    #[arg(long, default_value_t = LinkOptions::default().min_overlap)]
    pub min_overlap: f64,
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

impl Default for ShearLineTracksParams {
    fn default() -> Self {
        let d = ShearLineOptions::default();
        ShearLineTracksParams {
            input: String::new(),
            min_overlap: LinkOptions::default().min_overlap,
            threshold: d.threshold,
            min_grains: d.min_grains,
            min_length: d.min_length_over_d,
            min_elongation: d.min_elongation,
            diameter: None,
        }
    }
}

impl ShearLineTracksParams {
    pub fn options(&self) -> stages::line_tracks::TracksOptions {
        stages::line_tracks::TracksOptions {
            diameter: self.diameter,
            detect: detect_options(
                self.threshold,
                self.min_grains,
                self.min_length,
                self.min_elongation,
            ),
            link: LinkOptions {
                min_overlap: self.min_overlap,
            },
        }
    }
}

pub struct ShearLineTracks;

impl StageKind for ShearLineTracks {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<ShearLineTracksParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: ShearLineTracksParams = typed(&s.name, &s.params)?;
        let kin = ctx.input(s, "input", "kinematics")?;
        let file = out.join("shear_line_tracks.parquet");
        let r = stages::line_tracks::run(&kin, &file, &p.options())?;
        let t = &r.summary;
        Ok(Produced {
            outputs: outputs(&[("shear_line_tracks", "shear_line_tracks.parquet")]),
            metrics: json!({"pairs": t.pairs, "lines": t.lines, "tracks": t.tracks,
                "mean_lifetime_pairs": t.mean_lifetime, "grain_persistence": t.grain_persistence}),
            summary: sum(&r),
        })
    }
}
