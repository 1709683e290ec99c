//! `fit`: the D²min–η^s crossover (li-granular-pillars Eq. 19) on a stage's kinematics
//! or tracks (the Sec. IV protocol).

use super::Stage;
use super::typed;
use super::{Kind, StageKind};
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs};
use crate::stages;
use crate::stages::fit::params::FitParams;
use serde_json::{Value as Json, json};
use std::path::Path;

pub struct Fit;

impl StageKind for Fit {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<FitParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let q = ctx.quiet;
        let p: FitParams = typed(&s.name, &s.params)?;
        let up = ctx.upstream(s, "input")?;
        let what = if up.record.kind == Kind::Kinematics.name() {
            "kinematics"
        } else {
            "tracks"
        };
        let input = ctx.input(s, "input", what)?;
        let r = stages::fit::run(&input, &out.join("fit.json"), &p.options(&s.name, q)?)?;
        Ok(Produced {
            outputs: outputs(&[("fit", "fit.json"), ("scatter", "fit.scatter.parquet")]),
            metrics: json!({
                "theta": r.theta, "theta_interval": r.theta_interval, "theta_constrained": r.theta_constrained,
                "eta_c": r.eta_c, "eta_c_interval": r.eta_c_interval, "eta_c_constrained": r.eta_c_constrained,
                "method": r.method.name(), "n_points": r.n_points, "n_starts": r.n_starts,
            }),
            summary: json!({"fit": "fit.json", "warnings": r.warnings, "notes": r.notes}),
        })
    }
}
