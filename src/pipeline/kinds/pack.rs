//! `pack`: a jammed bidisperse packing by the protocol of li-granular-pillars Sec. II.A
//! (`pillar-pipe pack`), as canonical tracks of one frame. Simulate stages that name it
//! (`packing_stage`) start from the one cached packing, so a parameter study compares
//! runs of the same grains and packs once.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::dem::pillar::pack::Growth;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// `pack`'s options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct PackParams {
    /// Grains (half small, half large).
    #[arg(long, default_value_t = PackParams::default().n)]
    pub n: usize,
    /// Seed of the initial random positions.
    #[arg(long, default_value_t = PackParams::default().seed)]
    pub seed: u64,
    /// How the box grows between minimisations: `halving` (default) or `secant` (half
    /// the growths, about as many CG iterations).
    #[arg(long, value_enum, default_value_t = PackParams::default().growth)]
    pub growth: Growth,
}

impl Default for PackParams {
    fn default() -> Self {
        PackParams {
            n: 1000,
            seed: 1,
            growth: Growth::Halving,
        }
    }
}

pub struct Pack;

impl StageKind for Pack {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<PackParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: PackParams = typed(&s.name, &s.params)?;
        let r = stages::pack::run(
            &out.join("tracks.parquet"),
            p.n,
            p.seed,
            p.growth,
            false,
            ctx.quiet,
        )?;
        Ok(Produced {
            outputs: outputs(&[("tracks", "tracks.parquet")]),
            metrics: json!({"n": r.n, "phi": r.packing.phi, "elapsed_s": r.elapsed_s}),
            summary: sum(&r),
        })
    }
}
