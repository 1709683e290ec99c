//! `ingest`: a track file (trackpy, LAMMPS, canonical) to canonical tracks, with the
//! experiment's force sensor beside it when given (`force`, read as `ingest-force` does).

use super::Stage;
use super::StageKind;
use super::typed;
use crate::error::{Error, Result};
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use crate::stages::ingest::{Format, IngestOptions};
use clap::ValueEnum;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IngestParams {
    pub input: String,
    pub format: String,
    pub px_per_unit: Option<f64>,
    pub unit: Option<String>,
    pub frame_time: Option<f64>,
    pub radii: Option<[f64; 2]>,
    pub origin_px: Option<[f64; 2]>,
    pub bar_speed: Option<f64>,
    pub keep_detached: bool,
    /// A force-sensor CSV (`ingest-force`) read beside the tracks.
    pub force: Option<String>,
}

impl Default for IngestParams {
    fn default() -> Self {
        IngestParams {
            input: String::new(),
            format: "auto".into(),
            px_per_unit: None,
            unit: None,
            frame_time: None,
            radii: None,
            origin_px: None,
            bar_speed: None,
            keep_detached: false,
            force: None,
        }
    }
}

impl IngestParams {
    pub fn options(&self) -> Result<IngestOptions> {
        Ok(IngestOptions {
            format: Some(
                Format::from_str(&self.format, true).map_err(|e| Error::param("format", e))?,
            ),
            px_per_unit: self.px_per_unit,
            unit: self.unit.clone(),
            frame_time: self.frame_time,
            radii: self.radii.map(|r| (r[0], r[1])),
            origin_px: self.origin_px.map(|r| (r[0], r[1])),
            bar_speed: self.bar_speed,
            keep_detached: self.keep_detached,
        })
    }
}

pub struct Ingest;

impl StageKind for Ingest {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<IngestParams>(given)
    }

    /// The settings read beside the input (`ingest.toml`) shape the tracks too.
    fn beside(&self, path: &Path) -> Option<PathBuf> {
        stages::ingest::settings_path(path)
    }

    fn execute(&self, s: &Stage, _ctx: &Ctx, out: &Path) -> Result<Produced> {
        let p: IngestParams = typed(&s.name, &s.params)?;
        let r = stages::ingest::run(
            &s.files["input"],
            &out.join("tracks.parquet"),
            &p.options()?,
        )?;
        let mut files = vec![("tracks", "tracks.parquet")];
        let mut metrics =
            json!({"n": r.summary.particles_per_frame_max, "frames": r.summary.frames});
        // The experiment's force sensor (Fig. 4a), read as `ingest-force` does.
        if let Some(force) = s.files.get("force") {
            // W per frame from the tracks just written, unless the sensor's settings
            // give one W.
            let opt = stages::force::ForceOptions {
                unit: p.unit.clone(),
                bar_speed: p.bar_speed,
                tracks: Some(out.join("tracks.parquet")),
                width_over_tracks: true,
                ..Default::default()
            };
            let f = stages::force::run(
                force,
                &out.join("bar_forces.parquet"),
                &out.join("stress_strain.parquet"),
                &opt,
            )?;
            files.extend([
                ("bar_forces", "bar_forces.parquet"),
                ("stress_strain", "stress_strain.parquet"),
            ]);
            metrics["force_rows"] = json!(f.rows);
            metrics["max_stress_reduced"] = json!(f.max_stress_reduced);
        }
        Ok(Produced {
            outputs: outputs(&files),
            metrics,
            summary: sum(&r),
        })
    }
}
