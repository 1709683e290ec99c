//! Text views of tracked runs: `runs list`, `runs show`, `runs compare`.

use super::runs::RunManifest;
use crate::stages::fit::num;
use serde_json::Value as Json;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A plain-text table with aligned columns.
pub fn table(header: &[String], rows: &[Vec<String>]) -> String {
    let n = header.len();
    let mut w = vec![0usize; n];
    for r in std::iter::once(header).chain(rows.iter().map(|r| r.as_slice())) {
        for (k, c) in r.iter().enumerate().take(n) {
            w[k] = w[k].max(c.chars().count());
        }
    }
    let line = |r: &[String]| {
        let cells: Vec<String> = (0..n)
            .map(|k| {
                let c = r.get(k).map_or("", |s| s.as_str());
                format!("{c}{}", " ".repeat(w[k] - c.chars().count()))
            })
            .collect();
        cells.join("  ").trim_end().to_string() + "\n"
    };
    let mut out = line(header);
    out += &line(&w.iter().map(|&k| "-".repeat(k)).collect::<Vec<_>>());
    for r in rows {
        out += &line(r);
    }
    out
}

fn value(v: &Json) -> String {
    match v {
        Json::Null => "-".into(),
        Json::String(s) => s.clone(),
        Json::Number(x) if x.is_f64() => num(x.as_f64().unwrap_or(f64::NAN)),
        other => other.to_string(),
    }
}

/// Metrics flattened to `stage.metric` → text; a metric `x` with `x_interval` and
/// `x_constrained` siblings reads "x [lo, hi]", flagged when not constrained.
pub fn metric_rows(m: &RunManifest) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for (stage, obj) in &m.metrics {
        let Some(o) = obj.as_object() else { continue };
        for (k, v) in o {
            if k.ends_with("_interval") || k.ends_with("_constrained") {
                continue;
            }
            let mut s = value(v);
            if let Some(Json::Array(iv)) = o.get(&format!("{k}_interval")) {
                let b: Vec<String> = iv.iter().map(value).collect();
                s = format!("{s} [{}]", b.join(", "));
            }
            if o.get(&format!("{k}_constrained")) == Some(&Json::Bool(false)) {
                s += " (not constrained)";
            }
            out.insert(format!("{stage}.{k}"), s);
        }
    }
    out
}

/// Parameters flattened to `stage.key` → text.
pub fn parameter_rows(m: &RunManifest) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for (stage, p) in &m.parameters {
        for (k, v) in p.as_object().into_iter().flatten() {
            out.insert(format!("{stage}.{k}"), value(v));
        }
    }
    out
}

pub fn cache_counts(m: &RunManifest) -> (usize, usize) {
    let cached = m.stages.iter().filter(|s| s.cached).count();
    (m.stages.len() - cached, cached)
}

pub fn list_text(runs: &[RunManifest]) -> String {
    let header = [
        "run",
        "pipeline",
        "status",
        "computed",
        "cached",
        "time",
        "overrides",
    ]
    .map(String::from);
    let rows: Vec<Vec<String>> = runs
        .iter()
        .map(|m| {
            let (c, h) = cache_counts(m);
            vec![
                m.run_id.clone(),
                m.pipeline.name.clone(),
                m.status.clone(),
                c.to_string(),
                h.to_string(),
                format!("{:.1} s", m.elapsed_s),
                m.overrides.join(" "),
            ]
        })
        .collect();
    table(&header, &rows)
}

/// Metrics, then the parameters that differ, one column per run.
pub fn compare_text(runs: &[RunManifest]) -> String {
    let mut header = vec!["".to_string()];
    header.extend(runs.iter().map(|m| m.run_id.clone()));
    let rows_of = |f: &dyn Fn(&RunManifest) -> BTreeMap<String, String>, all: bool| {
        let maps: Vec<BTreeMap<String, String>> = runs.iter().map(f).collect();
        let keys: BTreeSet<&String> = maps.iter().flat_map(|m| m.keys()).collect();
        keys.into_iter()
            .map(|k| {
                let vals: Vec<String> = maps
                    .iter()
                    .map(|m| m.get(k).cloned().unwrap_or_else(|| "-".into()))
                    .collect();
                (k.clone(), vals)
            })
            .filter(|(_, v)| all || v.iter().any(|x| x != &v[0]))
            .map(|(k, v)| std::iter::once(k).chain(v).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    let mut rows = vec![
        std::iter::once("pipeline".to_string())
            .chain(runs.iter().map(|m| m.pipeline.name.clone()))
            .collect(),
        std::iter::once("status".to_string())
            .chain(runs.iter().map(|m| m.status.clone()))
            .collect(),
        std::iter::once("computed/cached".to_string())
            .chain(runs.iter().map(|m| {
                let (c, h) = cache_counts(m);
                format!("{c}/{h}")
            }))
            .collect(),
    ];
    rows.extend(rows_of(&metric_rows, true));
    let mut out = String::from("metrics\n");
    out += &table(&header, &rows);
    let changed = rows_of(&parameter_rows, false);
    out += "\nchanged parameters\n";
    if changed.is_empty() {
        out += "(none)\n";
    } else {
        out += &table(&header, &changed);
    }
    out
}

pub fn show_text(m: &RunManifest, runs_dir: &Path) -> String {
    let mut s = format!("run        {} ({})\n", m.run_id, m.status);
    s += &format!(
        "pipeline   {} ({}, sha256 {})\n",
        m.pipeline.name,
        m.pipeline.file,
        &m.pipeline.sha256[..12.min(m.pipeline.sha256.len())]
    );
    s += &format!(
        "started    {} for {:.1} s, {} {}\n",
        m.started, m.elapsed_s, m.tool, m.tool_version
    );
    if !m.overrides.is_empty() {
        s += &format!("overrides  {}\n", m.overrides.join(" "));
    }
    if let (Some(st), Some(e)) = (&m.failed_stage, &m.error) {
        s += &format!("failed     {st}: {e}\n");
    }
    s += "\n";
    let rows: Vec<Vec<String>> = m
        .stages
        .iter()
        .map(|st| {
            vec![
                st.name.clone(),
                st.kind.clone(),
                match (st.cached, st.verified.as_str(), &st.slurm) {
                    (_, _, Some(j)) => {
                        let on = if j.node.is_empty() {
                            String::new()
                        } else {
                            format!(" on {}", j.node)
                        };
                        format!("{}, Slurm job {}{on}", j.state, j.job)
                    }
                    (false, _, _) => "computed".into(),
                    // Manifests from before outputs were verified record nothing.
                    (true, "", _) => "cached".into(),
                    (true, how, _) => format!("cached ({how} checked)"),
                },
                format!(
                    "{:.2} s",
                    if st.cached {
                        st.compute_s
                    } else {
                        st.elapsed_s
                    }
                ),
                runs_dir.join(&st.dir).display().to_string(),
            ]
        })
        .collect();
    s += &table(
        &["stage", "kind", "", "compute time", "output"].map(String::from),
        &rows,
    );
    let logs: Vec<String> = m
        .stages
        .iter()
        .filter_map(|st| {
            let j = st.slurm.as_ref()?;
            Some(format!(
                "log        {} {}\n",
                st.name,
                runs_dir.join(&j.log).display()
            ))
        })
        .collect();
    s += &logs.concat();
    s += "\n";
    let metrics: Vec<Vec<String>> = metric_rows(m)
        .into_iter()
        .map(|(k, v)| vec![k, v])
        .collect();
    s += &table(&["metric", "value"].map(String::from), &metrics);
    for (k, f) in &m.inputs {
        s += &format!(
            "input      {k} = {} (sha256 {})\n",
            f.path,
            &f.sha256[..12.min(f.sha256.len())]
        );
    }
    if let Some(r) = &m.report {
        s += &format!(
            "report     {}\n",
            runs_dir.join(&m.run_id).join(r).display()
        );
    }
    s
}
