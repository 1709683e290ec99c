//! Stage references: resolving names, data sets of the report, cycles, output types,
//! input files, and the run order.

use super::parse::{RawStage, Source};
use super::schema::{Kind, PipelineSchema};
use crate::error::Result;

use serde_json::Value as Json;
use std::collections::BTreeMap;
use std::path::Path;

pub use super::kinds::{Dataset, Stage};

pub fn build(
    src: &Source,
    schema: &PipelineSchema,
    raw: &[RawStage],
    params: Vec<Json>,
    branches: &[String],
    root: &Path,
) -> Result<Vec<Stage>> {
    let names: Vec<&str> = raw.iter().map(|s| s.name.as_str()).collect();
    let index = |n: &str| names.iter().position(|m| *m == n);
    let mut stages = Vec::new();
    for (s, mut p) in raw.iter().zip(params) {
        let mut st = Stage {
            name: s.name.clone(),
            kind: s.kind,
            branch: s.branch.clone(),
            line: s.line,
            params: Json::Null,
            upstream: BTreeMap::new(),
            datasets: Vec::new(),
            files: BTreeMap::new(),
        };
        for ks in &schema.stage(s.kind).keys {
            let path = format!("{}.{}", s.name, ks.name);
            let Some(v) = p.get_mut(&ks.name) else {
                continue;
            };
            match (ks.ty.as_str(), v.as_str()) {
                ("stage", Some(target)) => {
                    let local = s.branch.as_ref().map(|b| format!("{b}.{target}"));
                    let full = if index(target).is_some() {
                        target.to_string()
                    } else if let Some(l) = local.filter(|l| index(l).is_some()) {
                        l
                    } else {
                        return Err(src.err(
                            &path,
                            format!("no stage '{target}'; stages: {}", names.join(", ")),
                        ));
                    };
                    *v = Json::String(full.clone());
                    st.upstream.insert(ks.name.clone(), full);
                }
                ("path", Some(rel)) => {
                    let abs = root.join(rel);
                    if !abs.is_file() {
                        return Err(src.err(
                            &path,
                            format!(
                                "file not found: {} (paths are relative to the pipeline root {})",
                                abs.display(),
                                root.display()
                            ),
                        ));
                    }
                    // Ingest reads settings beside its input; they shape the output too.
                    if let Some(settings) = s.kind.def().beside(&abs) {
                        st.files.insert(format!("{}.settings", ks.name), settings);
                    }
                    st.files.insert(ks.name.clone(), abs);
                }
                ("folder", Some(rel)) => {
                    let abs = root.join(rel);
                    if !abs.is_dir() {
                        return Err(src.err(
                            &path,
                            format!(
                                "folder not found: {} (paths are relative to the pipeline root {})",
                                abs.display(),
                                root.display()
                            ),
                        ));
                    }
                    st.files.insert(ks.name.clone(), abs);
                }
                ("branches", _) => {
                    for b in v
                        .as_array()
                        .into_iter()
                        .flatten()
                        .filter_map(|b| b.as_str())
                    {
                        let d = dataset(src, schema, raw, &path, b, branches)?;
                        for (role, n) in [
                            ("tracks", &d.tracks),
                            ("kinematics", &d.kinematics),
                            ("fit", &d.fit),
                            ("stress", &d.stress),
                            ("force", &d.force),
                            ("shear", &d.shear),
                            ("sweep", &d.sweep),
                            ("grid", &d.grid),
                        ] {
                            if let Some(n) = n {
                                st.upstream
                                    .insert(format!("datasets.{b}.{role}"), n.clone());
                            }
                        }
                        for n in &d.ramps {
                            st.upstream
                                .insert(format!("datasets.{b}.ramp:{n}"), n.clone());
                        }
                        st.datasets.push(d);
                    }
                }
                _ => {}
            }
        }
        st.params = p;
        match s.table.get("vary") {
            Some(toml::Value::Table(v)) => {
                stages.extend(super::vary::expand(src, schema, &mut st, v)?)
            }
            _ => stages.extend(st.kind.def().check(src, &mut st)?),
        }
        stages.push(st);
    }
    check_cycles(src, &stages)?;
    check_types(src, schema, &stages)?;
    for s in &stages {
        s.kind.def().check_references(src, s, &stages)?;
    }
    Ok(order(stages))
}

/// A branch's stages by role, each role an output type of the schema (`tracks`,
/// `kinematics`, …), so a new kind that writes tracks serves as a data set's tracks.
fn dataset(
    src: &Source,
    schema: &PipelineSchema,
    raw: &[RawStage],
    path: &str,
    b: &str,
    branches: &[String],
) -> Result<Dataset> {
    if !branches.iter().any(|x| x == b) {
        return Err(src.err(
            path,
            format!("no branch '{b}'; branches: {}", branches.join(", ")),
        ));
    }
    // A stage with `vary` is a grid of points.
    let output = |s: &RawStage| {
        if s.table.contains_key("vary") {
            "grid"
        } else {
            schema.stage(s.kind).output.as_str()
        }
    };
    let all = |out: &str| -> Vec<&RawStage> {
        raw.iter()
            .filter(|s| s.branch.as_deref() == Some(b) && output(s) == out)
            .collect()
    };
    let of = |out: &str, role: &str| -> Result<Option<&RawStage>> {
        let v = all(out);
        if v.len() > 1 {
            let n: Vec<&str> = v.iter().map(|s| s.name.as_str()).collect();
            return Err(src.err(
                path,
                format!(
                    "branch '{b}' has {} {role} stages ({}); a report shows one per data set",
                    v.len(),
                    n.join(", ")
                ),
            ));
        }
        Ok(v.first().copied())
    };
    let tracks = of("tracks", "tracks (ingest, simulate or track)")?;
    Ok(Dataset {
        label: b.to_string(),
        tracks: tracks.map(|s| s.name.clone()),
        kinematics: of("kinematics", "kinematics")?.map(|s| s.name.clone()),
        fit: of("fit", "fit")?.map(|s| s.name.clone()),
        // A simulate stage's stress–strain, or an ingest stage's from a force sensor
        // (absent without one: the report then finds no table).
        stress: tracks
            .filter(|s| s.kind == Kind::Simulate)
            .map(|s| s.name.clone()),
        // An experiment's force sensor, where its ingest stage has one (Fig. 4a).
        force: raw
            .iter()
            .find(|s| {
                s.branch.as_deref() == Some(b)
                    && s.kind == Kind::Ingest
                    && s.table.get("force").is_some()
            })
            .map(|s| s.name.clone()),
        shear: of("shear_run", "shear")?.map(|s| s.name.clone()),
        sweep: of("sweep", "sweep")?.map(|s| s.name.clone()),
        ramps: all("shear_ramp").iter().map(|s| s.name.clone()).collect(),
        grid: of("grid", "grid (a stage with `vary`)")?.map(|s| s.name.clone()),
    })
}

/// A reference cycle, reported at the key that closes it.
fn check_cycles(src: &Source, stages: &[Stage]) -> Result<()> {
    let idx: BTreeMap<&str, usize> = stages
        .iter()
        .enumerate()
        .map(|(i, s)| (s.name.as_str(), i))
        .collect();
    // 0 unvisited, 1 on the current path, 2 done.
    let mut state = vec![0u8; stages.len()];
    fn visit(
        i: usize,
        stages: &[Stage],
        idx: &BTreeMap<&str, usize>,
        state: &mut [u8],
        path: &mut Vec<usize>,
    ) -> Option<(usize, String, Vec<usize>)> {
        state[i] = 1;
        path.push(i);
        for (key, up) in &stages[i].upstream {
            let j = idx[up.as_str()];
            if state[j] == 1 {
                let start = path.iter().position(|&p| p == j).unwrap_or(0);
                return Some((i, key.clone(), path[start..].to_vec()));
            }
            if state[j] == 0
                && let Some(c) = visit(j, stages, idx, state, path)
            {
                return Some(c);
            }
        }
        path.pop();
        state[i] = 2;
        None
    }
    for i in 0..stages.len() {
        if state[i] == 0
            && let Some((at, key, cycle)) = visit(i, stages, &idx, &mut state, &mut Vec::new())
        {
            let mut chain: Vec<&str> = cycle.iter().map(|&k| stages[k].name.as_str()).collect();
            chain.push(chain[0]);
            // Upstream edges point against the data flow; show the chain as references.
            return Err(src.err(
                &format!("{}.{key}", stages[at].name),
                format!(
                    "reference cycle: {} (each refers to the next)",
                    chain.join(" -> ")
                ),
            ));
        }
    }
    Ok(())
}

fn check_types(src: &Source, schema: &PipelineSchema, stages: &[Stage]) -> Result<()> {
    for s in stages {
        for ks in schema.stage(s.kind).keys.iter().filter(|k| k.ty == "stage") {
            let Some(up) = s.upstream.get(&ks.name) else {
                continue;
            };
            let u = stages.iter().find(|x| &x.name == up).expect("resolved");
            let out = &schema.stage(u.kind).output;
            let accepts = ks.accepts.clone().unwrap_or_default();
            if !accepts.contains(out) {
                return Err(src.err(
                    &format!("{}.{}", s.name, ks.name),
                    format!(
                        "'{up}' is a {} stage and produces {out}; '{}' takes {}",
                        u.kind.name(),
                        ks.name,
                        accepts.join(" or ")
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Topological order; among stages ready at once, file order.
fn order(mut stages: Vec<Stage>) -> Vec<Stage> {
    stages.sort_by_key(|s| s.line);
    let mut done: Vec<String> = Vec::new();
    let mut out = Vec::new();
    while !stages.is_empty() {
        let k = stages
            .iter()
            .position(|s| s.upstream.values().all(|u| done.contains(u)))
            .expect("acyclic");
        let s = stages.remove(k);
        done.push(s.name.clone());
        out.push(s);
    }
    out
}
