//! `track`: locate and link on frames (a render stage's or a folder), then the linked
//! table to canonical tracks (`pillar-pipe track`, then `ingest`).

use super::Locate;
use super::Stage;
use super::StageKind;
use super::typed;
use crate::camera::{LinkOptions, LocateParams};
use crate::error::{Error, Result};
use crate::pipeline::exec::{Ctx, Produced, outputs, sum};
use crate::stages;
use serde::{Deserialize, Serialize};
use serde_json::{Value as Json, json};
use std::path::Path;

/// A `track` stage: locate + link (`pillar-pipe track`) on a `render` stage's frames or
/// a folder of frames, then the linked table to canonical tracks (`ingest`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackParams {
    pub input: Option<String>,
    pub frames: Option<String>,
    pub diameter: usize,
    pub minmass: f64,
    pub separation: Option<f64>,
    pub noise_size: f64,
    pub percentile: f64,
    pub maxsize: Option<f64>,
    pub smoothing_size: Option<usize>,
    pub threshold: Option<f64>,
    pub invert: bool,
    pub topn: Option<usize>,
    pub max_iterations: usize,
    pub search_range: f64,
    pub memory: usize,
    pub predict: bool,
    pub subnet_limit: usize,
    pub px_per_unit: Option<f64>,
    pub origin_px: Option<[f64; 2]>,
    pub unit: Option<String>,
    pub frame_time: Option<f64>,
    pub radii: Option<[f64; 2]>,
    pub bar_speed: Option<f64>,
}

impl Default for TrackParams {
    fn default() -> Self {
        let l = LocateParams::default();
        let k = LinkOptions::new(0.0);
        TrackParams {
            input: None,
            frames: None,
            diameter: 0,
            minmass: l.minmass,
            separation: l.separation,
            noise_size: l.noise_size,
            percentile: l.percentile,
            maxsize: l.maxsize,
            smoothing_size: l.smoothing_size,
            threshold: l.threshold,
            invert: l.invert,
            topn: l.topn,
            max_iterations: l.max_iterations,
            search_range: 0.0,
            memory: k.memory,
            predict: k.predict,
            subnet_limit: k.subnet_limit,
            px_per_unit: None,
            origin_px: None,
            unit: None,
            frame_time: None,
            radii: None,
            bar_speed: None,
        }
    }
}

impl TrackParams {
    pub fn locate(&self) -> LocateParams {
        LocateParams {
            diameter: self.diameter,
            minmass: self.minmass,
            separation: self.separation,
            noise_size: self.noise_size,
            percentile: self.percentile,
            maxsize: self.maxsize,
            smoothing_size: self.smoothing_size,
            threshold: self.threshold,
            invert: self.invert,
            topn: self.topn,
            max_iterations: self.max_iterations,
        }
    }
    pub fn link(&self) -> LinkOptions {
        LinkOptions {
            memory: self.memory,
            predict: self.predict,
            subnet_limit: self.subnet_limit,
            ..LinkOptions::new(self.search_range)
        }
    }
    /// The first key out of its domain, as the stage would find it, so a pipeline is
    /// refused at load: (key, what is wrong).
    pub fn problem(&self) -> Option<(String, String)> {
        let named = |e: Error| match e {
            Error::Param { name, msg } => (name, msg),
            other => (String::new(), other.to_string()),
        };
        if let Err(e) = self.locate().check() {
            return Some(named(e));
        }
        if let Err(e) = self.link().check() {
            return Some(named(e));
        }
        None
    }
}

pub struct Track;

impl StageKind for Track {
    fn resolve(&self, given: Json) -> std::result::Result<Json, String> {
        super::round_trip::<TrackParams>(given)
    }

    fn check(&self, src: &dyn Locate, st: &mut Stage) -> Result<Vec<Stage>> {
        let p: TrackParams = super::typed_at(src, st)?;
        if let Some((key, m)) = p.problem() {
            return Err(src.err(&format!("{}.{key}", st.name), m));
        }
        check_track_source(src, st, &p)?;
        Ok(Vec::new())
    }

    fn execute(&self, s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
        let q = ctx.quiet;
        let p: TrackParams = typed(&s.name, &s.params)?;
        let frames = match s.files.get("frames") {
            Some(folder) => folder.clone(),
            None => ctx.input(s, "input", "frames")?,
        };
        let linked = out.join("linked.csv");
        let r = stages::track::run(
            std::slice::from_ref(&frames),
            &linked,
            &p.locate(),
            &p.link(),
            q,
        )?;
        // The render's pixel mapping, the keys given here over it.
        let mut o = if frames.join("camera.json").is_file() {
            stages::track::camera_ingest_options(&frames)?
        } else {
            stages::ingest::IngestOptions {
                format: Some(stages::ingest::Format::Trackpy),
                ..Default::default()
            }
        };
        o.px_per_unit = p.px_per_unit.or(o.px_per_unit);
        o.origin_px = p.origin_px.map(|v| (v[0], v[1])).or(o.origin_px);
        o.unit = p.unit.clone().or(o.unit);
        o.frame_time = p.frame_time.or(o.frame_time);
        o.radii = p.radii.map(|v| (v[0], v[1])).or(o.radii);
        o.bar_speed = p.bar_speed.or(o.bar_speed);
        let i = stages::ingest::run(&linked, &out.join("tracks.parquet"), &o)?;
        Ok(Produced {
            outputs: outputs(&[("tracks", "tracks.parquet"), ("linked", "linked.csv")]),
            metrics: json!({
                "features": r.link.features, "trajectories": r.link.trajectories,
                "links": r.link.links, "ended": r.link.ended,
                "n": i.summary.particles_per_frame_max, "frames": i.summary.frames,
            }),
            summary: json!({"track": sum(&r), "ingest": sum(&i)}),
        })
    }
}

/// A track stage reads a render stage's frames (`input`) or a folder (`frames`); a
/// folder without a render's `camera.json` needs the scale and unit to convert pixels.
fn check_track_source(src: &dyn Locate, st: &Stage, p: &TrackParams) -> Result<()> {
    let Some(folder) = st.files.get("frames") else {
        if p.input.is_none() {
            return Err(src.err(
                &st.name,
                "give 'input' (a render stage) or 'frames' (a folder of camera frames)",
            ));
        }
        return Ok(());
    };
    if folder.join("camera.json").is_file() {
        return Ok(());
    }
    for (key, given) in [
        ("px_per_unit", p.px_per_unit.is_some()),
        ("unit", p.unit.is_some()),
    ] {
        if !given {
            return Err(src.err(
                &format!("{}.{key}", st.name),
                format!(
                    "needed: {} holds no camera.json (a render's pixel mapping) to convert the tracked pixels with",
                    folder.display()
                ),
            ));
        }
    }
    Ok(())
}
