//! `vary`: a stage run at several values of its keys (a parameter study, li-granular-
//! pillars Sec. II.C). Each point becomes a stage of the same kind with those values,
//! resolved as a hand-written one would be, so it has the same cache key (a grown study
//! reuses its finished points, and under Slurm they run as any stages do); the declared
//! stage becomes a `grid` that gathers them.

use super::kinds::{Kind, Stage};
use super::parse::Source;
use super::schema::{self, PipelineSchema};
use crate::error::Result;
use serde_json::{Value as Json, json};
use std::collections::BTreeMap;

/// Kinds a study cannot vary: those that gather other stages.
const NOT_VARIED: [Kind; 4] = [Kind::Report, Kind::Sweep, Kind::Sizes, Kind::Grid];

/// The points of `st` by its `vary` table (validated: equal, non-empty lists), each
/// checked as its kind checks a stage; `st` becomes their grid.
pub fn expand(
    src: &Source,
    schema: &PipelineSchema,
    st: &mut Stage,
    vary: &toml::Table,
) -> Result<Vec<Stage>> {
    let at = format!("{}.vary", st.name);
    if NOT_VARIED.contains(&st.kind) {
        return Err(src.err(
            &at,
            format!(
                "a {} stage gathers other stages; vary the stages it reads instead",
                st.kind.name()
            ),
        ));
    }
    // (key path, values) in the table's order (toml tables keep it sorted by name).
    let mut keys: Vec<(Vec<String>, Vec<Json>)> = Vec::new();
    for (k, v) in vary {
        let path: Vec<String> = k.split('.').map(str::to_string).collect();
        let spec = schema.key(st.kind, &path[0]).ok_or_else(|| {
            src.err(
                &format!("{at}.{k}"),
                format!("not a key of a {} stage", st.kind.name()),
            )
        })?;
        let ok_type = match (spec.ty.as_str(), path.len()) {
            ("float{}", 2) => true,
            ("stage" | "path" | "folder" | "branches" | "vary" | "float{}", _) => false,
            (_, 1) => spec.name != "kind",
            _ => false,
        };
        if !ok_type {
            return Err(src.err(
                &format!("{at}.{k}"),
                format!(
                    "cannot be varied: give a plain key of the stage{}",
                    if spec.ty == "float{}" {
                        format!(" or an entry of its table as \"{}.NAME\"", spec.name)
                    } else {
                        String::new()
                    }
                ),
            ));
        }
        let toml::Value::Array(list) = v else {
            return Err(src.err(&format!("{at}.{k}"), "expected an array of values"));
        };
        let mut values = Vec::new();
        for (i, x) in list.iter().enumerate() {
            let checked = if path.len() == 2 {
                match x {
                    toml::Value::Integer(n) => toml::Value::Float(*n as f64),
                    toml::Value::Float(f) if f.is_finite() => x.clone(),
                    other => {
                        return Err(src.err(
                            &format!("{at}.{k}"),
                            format!("value {}: expected a number, found {other}", i + 1),
                        ));
                    }
                }
            } else {
                schema::check(spec, x)
                    .map_err(|m| src.err(&format!("{at}.{k}"), format!("value {}: {m}", i + 1)))?
            };
            values.push(schema::to_json(&checked));
        }
        keys.push((path, values));
    }
    let n = keys[0].1.len();
    let mut points = Vec::new();
    let mut upstream = BTreeMap::new();
    for i in 0..n {
        let mut given = st.params.clone();
        let mut label = Vec::new();
        for (path, values) in &keys {
            let v = values[i].clone();
            label.push(format!("{}={}", path.join("."), v));
            match path.as_slice() {
                [k] => given[k] = v,
                [table, entry] => {
                    if !given[table].is_object() {
                        given[table] = json!({});
                    }
                    given[table][entry] = v;
                }
                // Paths of one or two parts only pass the type check above.
                _ => return Err(src.err(&at, format!("'{}' is not a key", path.join(".")))),
            }
        }
        let params = st
            .kind
            .def()
            .resolve(given)
            .map_err(|m| src.err(&at, format!("point {}: {m}", i + 1)))?;
        let mut point = Stage {
            name: format!("{}:{}", st.name, label.join(",")),
            kind: st.kind,
            branch: st.branch.clone(),
            line: st.line,
            params,
            upstream: st.upstream.clone(),
            datasets: st.datasets.clone(),
            files: st.files.clone(),
        };
        let more = st.kind.def().check(src, &mut point)?;
        if !more.is_empty() {
            return Err(src.err(&at, "this kind's stages expand into stages of their own"));
        }
        upstream.insert(format!("point:{i:04}"), point.name.clone());
        points.push(point);
    }
    let varied: serde_json::Map<String, Json> = keys
        .iter()
        .map(|(p, v)| (p.join("."), Json::Array(v.clone())))
        .collect();
    *st = Stage {
        name: st.name.clone(),
        kind: Kind::Grid,
        branch: st.branch.clone(),
        line: st.line,
        params: Kind::Grid
            .def()
            .resolve(json!({"of": st.kind.name(), "vary": varied}))
            .map_err(|m| src.err(&at, m))?,
        upstream,
        datasets: Vec::new(),
        files: BTreeMap::new(),
    };
    Ok(points)
}
