//! `pack`: a jammed bidisperse packing by the protocol of li-granular-pillars Sec. II.A
//! (`pillar-pipe pack`), as canonical tracks of one frame. Simulate stages that name it
//! (`packing_stage`) start from the one cached packing, so a parameter study compares
//! runs of the same grains and packs once.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use serde_json::{Value as Json, json};
use std::path::Path;

pub use crate::stages::pack::PackParams;

pub struct Pack;

impl StageKind for Pack {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<PackParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: PackParams = typed(&s.name, &s.params)?;
        let r = stages::pack::run(&out.join("tracks.parquet"), &p, false, ctx.quiet)?;
        Ok(Produced {
            outputs: outputs(&[("tracks", "tracks.parquet")]),
            metrics: json!({"n": r.n, "phi": r.packing.phi, "elapsed_s": r.elapsed_s}),
            summary: sum(&r),
        })
    }
}
