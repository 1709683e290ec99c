//! Running one stage into a directory: its parameters become the stage function's
//! options, its references become the upstream stages' output files, and what it wrote
//! is described by output names and key metrics.

use super::cache::StageRecord;
use super::params::{
    CompareParams, FitParams, IngestParams, KinematicsParams, RampParams, RenderParams,
    ReportParams, SweepParams, TrackParams, typed,
};
use super::{Kind, Pipeline, Stage};
use crate::error::{Error, Result};
use crate::stages;
use serde_json::{Value as Json, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A finished stage: its record and where it lies.
#[derive(Debug, Clone)]
pub struct Done {
    pub record: StageRecord,
    pub dir: PathBuf,
}

impl Done {
    pub fn output(&self, name: &str) -> Option<PathBuf> {
        self.record.outputs.get(name).map(|r| self.dir.join(r))
    }
}

pub struct Ctx<'a> {
    pub pipeline: &'a Pipeline,
    pub done: &'a BTreeMap<String, Done>,
    pub quiet: bool,
    pub run_id: &'a str,
    /// The stage's cache directory (its final name; the stage writes elsewhere).
    pub dir: &'a Path,
}

/// What the stage produced: output files (relative), metrics, its report.
pub struct Produced {
    pub outputs: BTreeMap<String, String>,
    pub metrics: Json,
    pub summary: Json,
}

fn outputs(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

impl Ctx<'_> {
    fn upstream(&self, s: &Stage, key: &str) -> Result<&Done> {
        let name = s
            .upstream
            .get(key)
            .ok_or_else(|| Error::param(format!("{}.{key}", s.name), "no upstream stage"))?;
        self.done
            .get(name)
            .ok_or_else(|| Error::Other(format!("{name} has not run")))
    }

    /// The named output of the stage `key` refers to.
    fn input(&self, s: &Stage, key: &str, output: &str) -> Result<PathBuf> {
        self.upstream(s, key)?.output(output).ok_or_else(|| {
            Error::Other(format!(
                "{}: upstream stage {} has no '{output}' output",
                s.name, s.upstream[key]
            ))
        })
    }

    fn optional(&self, name: &Option<String>, output: &str) -> Option<PathBuf> {
        name.as_ref()
            .and_then(|n| self.done.get(n))
            .and_then(|d| d.output(output))
    }
}

pub fn execute(s: &Stage, ctx: &Ctx, out: &Path) -> Result<Produced> {
    let q = ctx.quiet;
    match s.kind {
        Kind::Ingest => {
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
        Kind::Render => {
            let p: RenderParams = typed(&s.name, &s.params)?;
            // A pillar run's tracks: render finds its bars beside them.
            let tracks = ctx.input(s, "input", "tracks")?;
            let r = stages::render::run(&tracks, &out.join("frames"), &p.options(false, q))?;
            Ok(Produced {
                outputs: outputs(&[("frames", "frames")]),
                metrics: json!({"frames": r.frames, "width": r.width, "height": r.height, "grains": r.grains, "bars": r.bars}),
                summary: sum(&r),
            })
        }
        Kind::Track => {
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
        Kind::Simulate => {
            let mut o: stages::simulate::SimulateOptions = typed(&s.name, &s.params)?;
            o.packing = match &o.packing_stage {
                Some(_) => Some(ctx.input(s, "packing_stage", "tracks")?),
                None => s.files.get("packing").cloned(),
            };
            o.quiet = q;
            let r = simulate_resumable(out, ctx.dir, &mut o)?;
            let rel: BTreeMap<String, String> = r
                .tables
                .iter()
                .map(|(k, p)| {
                    let p = p
                        .file_name()
                        .map(std::path::PathBuf::from)
                        .unwrap_or_else(|| p.clone());
                    (k.clone(), p.display().to_string())
                })
                .collect();
            if !rel.contains_key("tracks") {
                return Err(Error::Other(format!(
                    "simulate reported no tracks table (tables: {:?})",
                    rel.keys().collect::<Vec<_>>()
                )));
            }
            Ok(Produced {
                outputs: rel,
                metrics: json!({"n": r.n, "frames": r.frames, "steps": r.steps, "mean_flow_stress": r.mean_flow_stress}),
                summary: sum(&r),
            })
        }
        Kind::Kinematics => {
            let p: KinematicsParams = typed(&s.name, &s.params)?;
            let tracks = ctx.input(s, "input", "tracks")?;
            let r =
                stages::kinematics::run(&tracks, &out.join("kinematics.parquet"), &p.options(q)?)?;
            Ok(Produced {
                outputs: outputs(&[("kinematics", "kinematics.parquet")]),
                metrics: json!({"frame_pairs": r.frame_pairs, "rows": r.rows}),
                summary: sum(&r),
            })
        }
        Kind::Fit => {
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
        Kind::Compare => {
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
        Kind::Shear => {
            let mut o: stages::shear::ShearOptions = typed(&s.name, &s.params)?;
            o.quiet = q;
            let summary = shear_resumable(out, ctx.dir, &mut o)?;
            let mean = |k: &str| summary.get(k).and_then(|v| v.get("mean")).cloned();
            Ok(Produced {
                outputs: tables_in(out)?,
                metrics: json!({
                    "n": o.n, "phi": o.phi, "q": o.q, "rate": o.rate, "model": o.model,
                    "p": mean("p"), "z": mean("z"), "mu": mean("mu"),
                }),
                summary: json!({"summary": "summary.json"}),
            })
        }
        Kind::Ramp => {
            let p: RampParams = typed(&s.name, &s.params)?;
            let mut o = p.options();
            o.quiet = q;
            if p.from.is_some() {
                o.from_state = Some(ctx.input(s, "from", "state")?);
            }
            let summary = shear_resumable(out, ctx.dir, &mut o)?;
            Ok(Produced {
                outputs: tables_in(out)?,
                metrics: json!({
                    "n": p.n, "phi": p.phi, "q": p.q, "model": p.model, "ramp": p.ramp,
                    "kappa_tilde": p.kappa, "rate_start": p.rate, "rate_end": summary.get("rate_end"),
                    "windows": summary.get("windows"), "strain": summary.get("strain"),
                }),
                summary: json!({"summary": "summary.json"}),
            })
        }
        Kind::Sweep => {
            let p: SweepParams = typed(&s.name, &s.params)?;
            let grid = p.grid();
            let mut summaries = Vec::new();
            let mut dirs = Vec::new();
            for &point in &grid {
                let name = super::graph::point_name(&s.name, point);
                let done = ctx
                    .done
                    .get(&name)
                    .ok_or_else(|| Error::Other(format!("{name} has not run")))?;
                dirs.push((point, done.dir.clone()));
                let f = done.dir.join("summary.json");
                let text = std::fs::read_to_string(&f).map_err(|e| Error::io(&f, e))?;
                summaries.push(
                    serde_json::from_str(&text)
                        .map_err(|e| Error::input(f.display(), e.to_string()))?,
                );
            }
            let points: Vec<_> = grid.iter().copied().zip(summaries).collect();
            let base = p.point(grid[0]);
            let r = stages::sweep::write_outputs(out, &grid, &points, &base)?;
            stages::sweep::write_contacts(out, &dirs)?;
            Ok(Produced {
                outputs: outputs(&[
                    ("sweep", stages::sweep::TABLE),
                    ("grid", stages::sweep::GRID),
                    ("angles", stages::sweep::ANGLES),
                    ("contacts", stages::sweep::CONTACTS),
                ]),
                metrics: json!({"points": r.runs, "model": p.model, "n": p.n}),
                summary: json!({"points": r.runs}),
            })
        }
        Kind::Report => {
            let p: ReportParams = typed(&s.name, &s.params)?;
            let datasets = s
                .datasets
                .iter()
                .map(|d| stages::report::DatasetInputs {
                    label: d.label.clone(),
                    tracks: ctx.optional(&d.tracks, "tracks"),
                    kinematics: ctx.optional(&d.kinematics, "kinematics"),
                    fit: ctx.optional(&d.fit, "fit"),
                    stress: ctx.optional(&d.stress, "stress_strain"),
                    measured_stress: ctx.optional(&d.force, "stress_strain"),
                    // The same simulate stage writes the per-grain forces (Fig. 6).
                    forces: ctx.optional(&d.stress, "forces"),
                    shear: d
                        .shear
                        .as_ref()
                        .and_then(|n| ctx.done.get(n))
                        .map(|d| d.dir.clone()),
                    sweep: d
                        .sweep
                        .as_ref()
                        .and_then(|n| ctx.done.get(n))
                        .map(|d| d.dir.clone()),
                    ramps: d
                        .ramps
                        .iter()
                        .filter_map(|n| ctx.done.get(n))
                        .map(|d| d.dir.clone())
                        .collect(),
                })
                .collect();
            let opt = stages::report::ReportOptions {
                title: p.title.unwrap_or_else(|| ctx.pipeline.title.clone()),
                datasets,
                map_stages: p.map_stages,
                provenance: provenance(s, ctx),
            };
            let r = stages::report::run(out, &opt)?;
            let mut outs = outputs(&[("html", "report.html"), ("figures", "figures")]);
            // The sweeps' classification tables and the size scan's tables, copied into
            // the run beside the report.
            for e in std::fs::read_dir(out)
                .map_err(|e| Error::io(out, e))?
                .flatten()
            {
                let name = e.file_name().to_string_lossy().into_owned();
                if name.starts_with("classification_") || name.starts_with("size_scan") {
                    outs.insert(name.replace('.', "_"), name);
                }
            }
            Ok(Produced {
                outputs: outs,
                metrics: json!({"figures": r.figures.len()}),
                summary: json!({"sections": r.sections}),
            })
        }
    }
}

/// A sheared-disk run's outputs by name: each table (`series`, `ramp`, `tracks`, …),
/// each JSON record (`summary`, `manifest`) in `out`, and a ramp's final `state`;
/// sidecars (`x.meta.json`) go with their tables.
fn tables_in(out: &Path) -> Result<BTreeMap<String, String>> {
    let mut outs = BTreeMap::new();
    for e in std::fs::read_dir(out)
        .map_err(|e| Error::io(out, e))?
        .flatten()
    {
        let name = e.file_name().to_string_lossy().into_owned();
        let key = name
            .strip_suffix(".parquet")
            .or_else(|| name.strip_suffix(".json").filter(|n| !n.contains('.')))
            .or_else(|| (name == stages::shear::STATE).then_some("state"));
        if let Some(k) = key {
            outs.insert(k.to_string(), name.clone());
        }
    }
    Ok(outs)
}

/// What the report prints under "Provenance": the stages it depends on with their
/// parameters, cache keys and input hashes, the pipeline file and the run that made it.
fn provenance(s: &Stage, ctx: &Ctx) -> Json {
    let mut todo: Vec<&str> = s.upstream.values().map(String::as_str).collect();
    let mut stages = serde_json::Map::new();
    while let Some(n) = todo.pop() {
        let (Some(st), Some(d)) = (ctx.pipeline.stage(n), ctx.done.get(n)) else {
            continue;
        };
        if stages.contains_key(n) {
            continue;
        }
        todo.extend(st.upstream.values().map(String::as_str));
        stages.insert(
            n.to_string(),
            json!({"kind": d.record.kind, "cache_key": d.record.key, "parameters": st.params, "input_sha256": d.record.files}),
        );
    }
    json!({
        "pipeline": ctx.pipeline.name,
        "pipeline_file": ctx.pipeline.file.display().to_string(),
        "pipeline_sha256": ctx.pipeline.sha256,
        "computed_in_run": ctx.run_id,
        "tool": format!("{} {}", stages::TOOL, stages::VERSION),
        "stages": stages,
    })
}

fn sum<T: serde::Serialize>(r: &T) -> Json {
    serde_json::to_value(r).unwrap_or(Json::Null)
}

/// A `shear` or `ramp` stage's run, resumable like a simulate stage's
/// (`simulate_resumable`): it works in `.work-shear-<hash>/` (`.work-ramp-<hash>/`)
/// beside the cache, from its checkpoint when one is there; the files then move into
/// `out`. Returns `summary.json`'s top level (a ramp's: its rates, windows, strain).
fn shear_resumable(
    out: &Path,
    stage_dir: &Path,
    o: &mut stages::shear::ShearOptions,
) -> Result<serde_json::Map<String, Json>> {
    let work = work_dir(stage_dir);
    let finished = work.join(stages::manifest::MANIFEST).exists();
    o.resume = !finished && work.join("checkpoint.bin").exists();
    if !finished && !o.resume && work.exists() {
        std::fs::remove_dir_all(&work).map_err(|e| Error::io(&work, e))?;
    }
    if !finished {
        stages::shear::run(&work, o)?;
    }
    move_files(&work, out)?;
    let _ = std::fs::remove_dir_all(&work);
    stages::shear::relocate_records(out)?;
    let f = out.join("summary.json");
    if !f.exists() {
        return Ok(Default::default());
    }
    let text = std::fs::read_to_string(&f).map_err(|e| Error::io(&f, e))?;
    let v: Json =
        serde_json::from_str(&text).map_err(|e| Error::input(f.display(), e.to_string()))?;
    Ok(v.as_object().cloned().unwrap_or_default())
}

/// `.work-<name>` beside the stage's cache directory `<name>`: named by the stage's
/// key, so only the holder of the stage's lock uses it, and not swept with the
/// stage's temporary directory.
fn work_dir(stage_dir: &Path) -> PathBuf {
    let cache = stage_dir.parent().unwrap_or(stage_dir);
    let name = stage_dir
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    cache.join(format!(".work-{name}"))
}

/// Move every plain file (tables, sidecars, manifest) of `from` into `to`.
fn move_files(from: &Path, to: &Path) -> Result<()> {
    for e in std::fs::read_dir(from)
        .map_err(|e| Error::io(from, e))?
        .flatten()
    {
        if e.path().is_file() {
            let dest = to.join(e.file_name());
            std::fs::rename(e.path(), &dest).map_err(|err| Error::io(&dest, err))?;
        }
    }
    Ok(())
}

/// Run a simulation so that a killed pipeline resumes it: the work happens in a
/// directory beside the cache named after the stage's (`.work-simulate-<hash>` for
/// `simulate-<hash>`, so the stage's key, which covers its options, the packing and
/// the tool build, names it, and the stage's lock covers it; not swept with the stage's
/// temporary directory), with checkpoints; a rerun continues from the last one, and the
/// finished tables are then moved into the stage's `out`.
fn simulate_resumable(
    out: &Path,
    stage_dir: &Path,
    o: &mut stages::simulate::SimulateOptions,
) -> Result<stages::simulate::SimulateReport> {
    let work = work_dir(stage_dir);
    let finished = work.join(stages::simulate::MANIFEST).exists();
    o.resume = !finished && work.join("checkpoint.bin").exists();
    if !finished && !o.resume && work.exists() {
        std::fs::remove_dir_all(&work).map_err(|e| Error::io(&work, e))?;
    }
    let report = if finished {
        let text = std::fs::read_to_string(work.join(stages::simulate::MANIFEST))
            .map_err(|e| Error::io(&work, e))?;
        let m: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| Error::input(work.display(), e.to_string()))?;
        serde_json::from_value(m["report"].clone())
            .map_err(|e| Error::input(work.display(), e.to_string()))?
    } else {
        stages::simulate::run(&work, o)?
    };
    move_files(&work, out)?;
    let _ = std::fs::remove_dir_all(&work);
    let mut report = report;
    report.out = out.to_path_buf();
    for p in report.tables.values_mut() {
        if let Some(name) = p.file_name() {
            *p = out.join(name);
        }
    }
    Ok(report)
}
