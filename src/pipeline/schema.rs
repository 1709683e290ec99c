//! `data_schema/pipeline.schema.json`, embedded at build time: the single description of
//! every stage kind's keys (types, defaults, units). Validation is driven by it, so the
//! file and the checks cannot disagree; `tests/it/pipeline.rs` checks it against the Rust
//! option structs the keys land in.

use serde::Deserialize;
use serde_json::Value as Json;

pub const SCHEMA_TEXT: &str = include_str!("../../data_schema/pipeline.schema.json");

pub use super::kinds::Kind;

#[derive(Debug, Clone, Deserialize)]
pub struct KeySpec {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: String,
    pub required: bool,
    /// Absent for required keys; `null` means "from the data".
    #[serde(default)]
    pub default: Option<Json>,
    #[serde(default)]
    pub unit: Option<String>,
    #[serde(default)]
    pub min: Option<f64>,
    #[serde(default)]
    pub min_exclusive: Option<f64>,
    #[serde(default)]
    pub allowed: Option<Vec<String>>,
    /// Output kinds a `stage` key may name.
    #[serde(default)]
    pub accepts: Option<Vec<String>>,
    /// Keys that may not be given together with this one.
    #[serde(default)]
    pub conflicts: Option<Vec<String>>,
    pub description: String,
}

#[derive(Debug, Clone, Deserialize)]
pub struct StageSpec {
    pub kind: String,
    pub description: String,
    pub output: String,
    pub keys: Vec<KeySpec>,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Section {
    pub description: String,
    pub keys: Vec<KeySpec>,
}

#[derive(Debug, Clone, Deserialize)]
pub struct PipelineSchema {
    pub version: u32,
    pub description: String,
    pub pipeline: Section,
    pub executor: Section,
    pub common_keys: Vec<KeySpec>,
    pub stages: Vec<StageSpec>,
}

impl PipelineSchema {
    pub fn stage(&self, kind: Kind) -> &StageSpec {
        self.stages
            .iter()
            .find(|s| s.kind == kind.name())
            .unwrap_or_else(|| panic!("pipeline.schema.json has no '{}' stage", kind.name()))
    }
    /// A stage key or a common key.
    pub fn key(&self, kind: Kind, name: &str) -> Option<&KeySpec> {
        self.stage(kind)
            .keys
            .iter()
            .chain(&self.common_keys)
            .find(|k| k.name == name)
    }
    pub fn allowed_keys(&self, kind: Kind) -> Vec<&str> {
        self.stage(kind)
            .keys
            .iter()
            .chain(&self.common_keys)
            .map(|k| k.name.as_str())
            .collect()
    }
}

/// Parse the embedded schema. Panics only if the file is malformed, which the schema
/// test catches.
pub fn load() -> PipelineSchema {
    serde_json::from_str(SCHEMA_TEXT)
        .unwrap_or_else(|e| panic!("data_schema/pipeline.schema.json is malformed: {e}"))
}

/// Check one value against its spec; returns it normalised (integers given for floats
/// become floats) or what is wrong, for the caller to prefix with key and line.
pub fn check(spec: &KeySpec, v: &toml::Value) -> std::result::Result<toml::Value, String> {
    use toml::Value as T;
    let found = || match v {
        T::String(s) => format!("string \"{s}\""),
        other => format!("{} {other}", other.type_str()),
    };
    let num = |x: &T| match x {
        T::Float(f) => Some(*f),
        T::Integer(i) => Some(*i as f64),
        _ => None,
    };
    let bound = |x: f64| -> std::result::Result<(), String> {
        if !x.is_finite() {
            return Err(format!("{x} is not finite"));
        }
        if let Some(m) = spec.min
            && x < m
        {
            return Err(format!("{x} is below the minimum {m}"));
        }
        if let Some(m) = spec.min_exclusive
            && x <= m
        {
            return Err(format!("{x} must be greater than {m}"));
        }
        Ok(())
    };
    let floats = |a: &[T]| -> std::result::Result<Vec<T>, String> {
        a.iter()
            .map(|x| {
                let f =
                    num(x).ok_or_else(|| format!("expected numbers, found {}", x.type_str()))?;
                bound(f)?;
                Ok(T::Float(f))
            })
            .collect()
    };
    match (spec.ty.as_str(), v) {
        ("string" | "path" | "folder" | "stage", T::String(s)) => {
            if let Some(a) = &spec.allowed
                && !a.contains(s)
            {
                return Err(format!("'{s}' is not one of: {}", a.join(", ")));
            }
            if s.is_empty() {
                return Err("empty string".into());
            }
            Ok(v.clone())
        }
        ("integer", T::Integer(i)) => bound(*i as f64).map(|_| v.clone()),
        ("float", T::Integer(_) | T::Float(_)) => {
            let f = num(v).expect("number");
            bound(f).map(|_| T::Float(f))
        }
        ("bool", T::Boolean(_)) => Ok(v.clone()),
        ("branches", T::Array(a)) if !a.is_empty() && a.iter().all(|x| x.is_str()) => Ok(v.clone()),
        // Each key's values are checked against its own spec when the points are made.
        ("vary", T::Table(t)) if !t.is_empty() => {
            let mut len = None;
            for (k, x) in t {
                let T::Array(a) = x else {
                    return Err(format!(
                        "'{k}': expected an array of values, found {}",
                        x.type_str()
                    ));
                };
                if a.is_empty() {
                    return Err(format!("'{k}': an empty list"));
                }
                match len {
                    Some(n) if n != a.len() => {
                        return Err(format!(
                            "'{k}' has {} values, another key {n}: point i takes the i-th value of every key, so the lists are as long",
                            a.len()
                        ));
                    }
                    _ => len = Some(a.len()),
                }
            }
            Ok(v.clone())
        }
        ("integer[]", T::Array(a)) if !a.is_empty() => {
            for x in a {
                match x {
                    T::Integer(i) => bound(*i as f64)?,
                    o => return Err(format!("expected integers, found {}", o.type_str())),
                }
            }
            Ok(v.clone())
        }
        ("float[]", T::Array(a)) if !a.is_empty() => floats(a).map(T::Array),
        ("string[]", T::Array(a)) if a.iter().all(|x| x.is_str()) => Ok(v.clone()),
        ("float[2]", T::Array(a)) if a.len() == 2 => floats(a).map(T::Array),
        ("integer[2]", T::Array(a)) if a.len() == 2 => {
            for x in a {
                match x {
                    T::Integer(i) => bound(*i as f64)?,
                    o => return Err(format!("expected integers, found {}", o.type_str())),
                }
            }
            Ok(v.clone())
        }
        ("float{}", T::Table(t)) => {
            let mut out = toml::Table::new();
            for (k, x) in t {
                let f = num(x)
                    .ok_or_else(|| format!("'{k}': expected a number, found {}", x.type_str()))?;
                if !f.is_finite() {
                    return Err(format!("'{k}': {f} is not finite"));
                }
                out.insert(k.clone(), T::Float(f));
            }
            Ok(T::Table(out))
        }
        (ty, _) => Err(format!("expected {}, found {}", describe(ty), found())),
    }
}

fn describe(ty: &str) -> &'static str {
    match ty {
        "string" => "a string",
        "path" => "a file path (string)",
        "folder" => "a folder path (string)",
        "stage" => "a stage name (string)",
        "integer" => "an integer",
        "float" => "a number",
        "bool" => "true or false",
        "branches" => "a non-empty array of branch names",
        "integer[]" => "a non-empty array of integers",
        "float[]" => "a non-empty array of numbers",
        "float[2]" => "an array of two numbers",
        "integer[2]" => "an array of two integers",
        "float{}" => "a table of numbers, { name = value, ... }",
        "string[]" => "an array of strings",
        "vary" => "a table of key = [values, ...]",
        _ => "a value of an unknown schema type",
    }
}

/// TOML value → JSON (the option structs are filled through serde_json).
pub fn to_json(v: &toml::Value) -> Json {
    use toml::Value as T;
    match v {
        T::String(s) => Json::String(s.clone()),
        T::Integer(i) => Json::from(*i),
        T::Float(f) => serde_json::Number::from_f64(*f).map_or(Json::Null, Json::Number),
        T::Boolean(b) => Json::Bool(*b),
        T::Datetime(d) => Json::String(d.to_string()),
        T::Array(a) => Json::Array(a.iter().map(to_json).collect()),
        T::Table(t) => Json::Object(t.iter().map(|(k, v)| (k.clone(), to_json(v))).collect()),
    }
}
