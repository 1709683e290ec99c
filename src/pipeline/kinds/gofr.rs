//! `gofr`: the pair distribution g(r) of one frame of a stage's tracks, around small and
//! around large grains (li-granular-pillars Fig. 2); r over the large-grain diameter D.
//! The command `pillar-pipe gofr` flattens the same options.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// `gofr`'s options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct GofrParams {
    /// The stage whose tracks are read (pipeline files; the command line takes a path).
    #[arg(skip)]
    pub input: String,
    /// Frame (default: the first).
    #[arg(long)]
    pub frame: Option<i64>,
    /// Largest r in units of D; open packings count only centres this far inside.
    #[arg(long, default_value_t = GofrParams::default().r_max)]
    pub r_max: f64,
    /// Bins out to r_max.
    #[arg(long, default_value_t = GofrParams::default().bins)]
    pub bins: usize,
}

impl Default for GofrParams {
    fn default() -> Self {
        GofrParams {
            input: String::new(),
            frame: None,
            r_max: 4.0,
            bins: 80,
        }
    }
}

pub struct Gofr;

impl StageKind for Gofr {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<GofrParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: GofrParams = typed(&s.name, &s.params)?;
        let tracks = ctx.input(s, "input", "tracks")?;
        let (g, frame, d) =
            stages::gofr::run(&tracks, &out.join("gofr.parquet"), p.frame, p.r_max, p.bins)?;
        Ok(Produced {
            outputs: outputs(&[("gofr", "gofr.parquet")]),
            metrics: json!({"frame": frame, "d_large": d, "centres": g.centres, "density": g.density}),
            summary: json!({"frame": frame, "centres": g.centres}),
        })
    }
}
