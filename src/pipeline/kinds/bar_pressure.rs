//! `bar_pressure`: the contact pressure along the compressing bar of a `simulate`
//! stage's run (li-granular-pillars Fig. 10c), p in m g μ/D against x/W, averaged over
//! the force snapshots in a strain window. The command `pillar-pipe bar-pressure`
//! flattens the same options.

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

/// `bar-pressure`'s options, defined once for the command line and a pipeline.
#[derive(Debug, Clone, Serialize, Deserialize, clap::Args)]
#[serde(deny_unknown_fields, default)]
pub struct BarPressureParams {
    /// The simulate stage read (pipeline files; the command line takes its folder).
    #[arg(skip)]
    pub input: String,
    /// Strain window LO,HI of the snapshots averaged (engineering strain).
    #[arg(long, value_parser = parse_pair, default_value = "0.1,0.2")]
    pub strain: (f64, f64),
    /// Bins across the interface.
    #[arg(long, default_value_t = BarPressureParams::default().bins)]
    pub bins: usize,
}

impl Default for BarPressureParams {
    fn default() -> Self {
        BarPressureParams {
            input: String::new(),
            strain: (0.1, 0.2),
            bins: 10,
        }
    }
}

pub struct BarPressure;

impl StageKind for BarPressure {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<BarPressureParams>(given)
    }

    /// The force snapshots are a pillar simulation's: `input` names a simulate stage.
    fn check_references(&self, src: &dyn Locate, st: &Stage, all: &[Stage]) -> Result<()> {
        super::input_is_simulate(src, st, all, "the bar's forces")
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: BarPressureParams = typed(&s.name, &s.params)?;
        let run = ctx.upstream(s, "input")?.dir.clone();
        let (profile, snapshots) =
            stages::bar_pressure::run(&run, p.strain, p.bins, &out.join("bar_pressure.parquet"))?;
        Ok(Produced {
            outputs: outputs(&[("bar_pressure", "bar_pressure.parquet")]),
            metrics: json!({"snapshots": snapshots, "width": profile.width, "force": profile.force, "contacts": profile.contacts}),
            summary: json!({"snapshots": snapshots, "x_over_w": profile.x_over_w, "p": profile.p}),
        })
    }
}
