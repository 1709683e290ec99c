//! `outline`: a pillar's outline at a frame of a stage's tracks (li-granular-pillars
//! Fig. 9), lengths over its initial width W0; with `against`, the rms distance to
//! another pillar's outline rescaled the same way. The command `pillar-pipe outline`
//! flattens the same options.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// `outline`'s options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Default, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct OutlineParams {
    /// The stage whose tracks are read (pipeline files; the command line takes a path).
    #[arg(skip)]
    pub input: String,
    /// Frame (default: the last).
    #[arg(long)]
    pub frame: Option<i64>,
    /// Another pillar to compare with (e.g. another size): a stage in a pipeline, its
    /// tracks' path on the command line (`--against`).
    #[arg(skip)]
    pub against: Option<String>,
    /// Its frame (default: the last).
    #[arg(long)]
    pub against_frame: Option<i64>,
}

pub struct Outline;

impl StageKind for Outline {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<OutlineParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: OutlineParams = typed(&s.name, &s.params)?;
        let tracks = ctx.input(s, "input", "tracks")?;
        let other = match &p.against {
            Some(_) => Some(ctx.input(s, "against", "tracks")?),
            None => None,
        };
        let (a, distance) = stages::outline::run(
            &tracks,
            p.frame,
            other.as_deref().map(|o| (o, p.against_frame)),
            &out.join("outline.parquet"),
        )?;
        Ok(Produced {
            outputs: outputs(&[("outline", "outline.parquet")]),
            metrics: json!({"frame": a.frame, "w0": a.w0, "height_over_w0": a.outline.height() / a.w0, "distance": distance}),
            summary: json!({"frame": a.frame, "w0": a.w0, "distance": distance}),
        })
    }
}
