//! `compare`: two fits' parameters side by side, with whether their intervals agree.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::Value as Json;
use std::path::Path;

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompareParams {
    pub a: String,
    pub b: String,
}

pub struct Compare;

impl StageKind for Compare {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<CompareParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let _: CompareParams = typed(&s.name, &s.params)?;
        let (a, b) = (ctx.input(s, "a", "fit")?, ctx.input(s, "b", "fit")?);
        let c = stages::compare::run(&a, &b)?;
        stages::compare::write(&c, &out.join("compare.json"))?;
        let agree: serde_json::Map<String, Json> = c
            .params
            .iter()
            .map(|p| (format!("{}_agree", p.name), Json::Bool(p.agree)))
            .collect();
        Ok(Produced {
            outputs: outputs(&[("compare", "compare.json")]),
            metrics: Json::Object(agree),
            summary: sum(&c),
        })
    }
}
