//! `sizes`: the size scan of the data sets' pillar runs (li-granular-pillars Sec. V) as
//! a cached stage: the scan's tables and the analyses a report draws (Figs. 2, 9–11),
//! `stages::size_analysis`. A report of two or more pillar runs gets one of its own
//! (`<report>:sizes`, see `kinds/report.rs`); a pipeline may also name one itself.

use super::Locate;
use super::typed;
use super::{Dataset, Stage};
use super::{Kind, StageKind};
use crate::error::Result;
use crate::pipeline::exec::{Ctx, Produced, outputs};
use crate::stages;
use crate::stages::datasets::DatasetInputs;
use crate::stages::size_analysis::{ANALYSIS, TABLES};
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SizesParams {
    /// The branches whose pillar runs (and experiments, for g(r)) are compared.
    pub datasets: Vec<String>,
}

/// The roles of a data set the analyses read: a change elsewhere in the branch (its
/// fit) leaves them cached.
const ROLES: [&str; 3] = ["tracks", "kinematics", "stress"];

pub struct Sizes;

impl StageKind for Sizes {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<SizesParams>(given)
    }

    fn check(&self, _src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        keep_roles(st);
        Ok(Vec::new())
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let _: SizesParams = typed(&s.name, &s.params)?;
        let datasets: Vec<DatasetInputs> =
            s.datasets.iter().map(|d| dataset_inputs(d, ctx)).collect();
        let a = stages::size_analysis::run(&datasets, out)?;
        let mut files = Vec::new();
        if let Some(a) = &a {
            files.push(("analysis", ANALYSIS));
            if a.scan.is_ok() {
                files.extend([
                    ("size_scan", TABLES[0]),
                    ("size_scan_curves", TABLES[1]),
                    ("size_scan_pressure", TABLES[2]),
                ]);
            }
        }
        let runs = a.as_ref().map_or(0, |a| a.names.len());
        Ok(Produced {
            outputs: outputs(&files),
            metrics: json!({"runs": runs, "compared": a.as_ref().is_some_and(|a| a.scan.is_ok())}),
            summary: json!({"runs": a.as_ref().map(|a| &a.names)}),
        })
    }
}

/// Only the data sets' roles the analyses read, in the stage's references and data sets.
fn keep_roles(st: &mut Stage) {
    st.upstream.retain(|k, _| {
        !k.starts_with("datasets.") || ROLES.iter().any(|r| k.ends_with(&format!(".{r}")))
    });
    for d in &mut st.datasets {
        *d = Dataset {
            label: d.label.clone(),
            tracks: d.tracks.clone(),
            kinematics: d.kinematics.clone(),
            stress: d.stress.clone(),
            ..Default::default()
        };
    }
}

/// The size scan of a report's data sets, when two or more are pillar runs: a stage
/// named `<report>:sizes` the report reads (its reference `sizes`).
pub(crate) fn for_report(st: &mut Stage) -> Result<Option<Stage>> {
    if st.datasets.iter().filter(|d| d.stress.is_some()).count() < 2 {
        return Ok(None);
    }
    let labels: Vec<&str> = st.datasets.iter().map(|d| d.label.as_str()).collect();
    let params = Kind::Sizes
        .def()
        .resolve(json!({ "datasets": labels }))
        .map_err(|m| crate::Error::param(&st.name, m))?;
    let mut s = Stage {
        name: format!("{}:sizes", st.name),
        kind: Kind::Sizes,
        branch: st.branch.clone(),
        line: st.line,
        params,
        upstream: st.upstream.clone(),
        datasets: st.datasets.clone(),
        files: BTreeMap::new(),
    };
    keep_roles(&mut s);
    st.upstream.insert("sizes".into(), s.name.clone());
    Ok(Some(s))
}

/// A data set's files from its stages' outputs.
pub(crate) fn dataset_inputs(d: &Dataset, ctx: &Ctx) -> DatasetInputs {
    let dir = |n: &Option<String>| {
        n.as_ref()
            .and_then(|n| ctx.done.get(n))
            .map(|d| d.dir.clone())
    };
    DatasetInputs {
        label: d.label.clone(),
        tracks: ctx.optional(&d.tracks, "tracks"),
        kinematics: ctx.optional(&d.kinematics, "kinematics"),
        fit: ctx.optional(&d.fit, "fit"),
        stress: ctx.optional(&d.stress, "stress_strain"),
        measured_stress: ctx.optional(&d.force, "stress_strain"),
        // The same simulate stage writes the per-grain forces (Fig. 6).
        forces: ctx.optional(&d.stress, "forces"),
        shear: dir(&d.shear),
        sweep: dir(&d.sweep),
        ramps: d
            .ramps
            .iter()
            .filter_map(|n| ctx.done.get(n))
            .map(|d| d.dir.clone())
            .collect(),
        grid: dir(&d.grid),
    }
}
