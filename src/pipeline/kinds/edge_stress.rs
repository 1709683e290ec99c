//! `edge_stress`: the local stress of a `simulate` stage's grains against their
//! distance from the pillar's nearer lateral edge (li-granular-pillars Sec. V), pooled
//! over the force snapshots in a strain window, with the rate at which it rises
//! (`structure::edge_stress`). The command `pillar-pipe edge-stress` flattens the same
//! options.

use super::Locate;
use super::Stage;
use super::StageKind;
use super::{parse_pair, typed};
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// `edge-stress`' options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct EdgeStressParams {
    /// The simulate stage read (pipeline files; the command line takes its folder).
    #[arg(skip)]
    pub input: String,
    /// Strain window LO,HI of the snapshots pooled (engineering strain).
    #[arg(long, value_parser = parse_pair, default_value = "0.1,0.2")]
    pub strain: (f64, f64),
}

impl Default for EdgeStressParams {
    fn default() -> Self {
        EdgeStressParams {
            input: String::new(),
            strain: stages::bar_pressure::WINDOW,
        }
    }
}

pub struct EdgeStress;

impl StageKind for EdgeStress {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<EdgeStressParams>(given)
    }

    /// The per-grain forces are a pillar simulation's: `input` names a simulate stage.
    fn check_references(&self, src: &dyn Locate, st: &Stage, all: &[Stage]) -> Result<()> {
        super::input_is_simulate(src, st, all, "the grains' contact forces")
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: EdgeStressParams = typed(&s.name, &s.params)?;
        let run = ctx.upstream(s, "input")?.dir.clone();
        let e = stages::edge_stress::run(&run, p.strain, &out.join("edge_stress.parquet"))?;
        Ok(Produced {
            outputs: outputs(&[("edge_stress", "edge_stress.parquet")]),
            metrics: json!({"snapshots": e.snapshots, "rate": e.rate}),
            summary: json!({"snapshots": e.snapshots, "rate": e.rate, "d_over_d": e.d_over_d, "p": e.p}),
        })
    }
}
