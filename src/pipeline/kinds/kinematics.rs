//! `kinematics`: per-particle velocities, best-fit J, D²min, η^s and J2 within R_c
//! (li-granular-pillars Eqs. 13–18) from a stage's tracks.

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::{Error, Result};
use crate::kinematics::Convention;
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use crate::stages::kinematics::{KinematicsOptions, LagSpec};
use clap::ValueEnum;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KinematicsParams {
    pub input: String,
    pub lags: Vec<i64>,
    pub lag_time: Option<f64>,
    pub rc: Option<f64>,
    pub start: Option<i64>,
    pub every: Option<i64>,
    pub convention: String,
}

impl Default for KinematicsParams {
    fn default() -> Self {
        KinematicsParams {
            input: String::new(),
            lags: vec![1],
            lag_time: None,
            rc: None,
            start: None,
            every: None,
            convention: "paper".into(),
        }
    }
}

impl KinematicsParams {
    pub fn options(&self, quiet: bool) -> Result<KinematicsOptions> {
        Ok(KinematicsOptions {
            lag: match self.lag_time {
                Some(s) => LagSpec::Time(s),
                None => LagSpec::Frames(self.lags.clone()),
            },
            rc: self.rc,
            start: self.start,
            every: self.every,
            convention: Convention::from_str(&self.convention, true)
                .map_err(|e| Error::param("convention", e))?,
            // A pipeline's later stages read every column.
            columns: Default::default(),
            quiet,
        })
    }
}

pub struct Kinematics;

impl StageKind for Kinematics {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<KinematicsParams>(given)
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let q = ctx.quiet;
        let p: KinematicsParams = typed(&s.name, &s.params)?;
        let tracks = ctx.input(s, "input", "tracks")?;
        let r = stages::kinematics::run(&tracks, &out.join("kinematics.parquet"), &p.options(q)?)?;
        Ok(Produced {
            outputs: outputs(&[("kinematics", "kinematics.parquet")]),
            metrics: json!({"frame_pairs": r.frame_pairs, "rows": r.rows}),
            summary: sum(&r),
        })
    }
}
