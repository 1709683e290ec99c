//! Stage parameters as typed structs, one per kind (each in its kind's file,
//! `kinds/<kind>.rs`, re-exported here): a validated stage table is deserialised into
//! one (filling defaults), serialised back as the resolved parameters recorded in
//! manifests and hashed into cache keys, and turned into the stage function's options.
//! Defaults come from the stages' own option defaults so the CLI and pipelines agree;
//! the schema test checks the schema file documents them.

use super::kinds::Kind;
pub use super::kinds::compare::CompareParams;
pub use super::kinds::ingest::IngestParams;
pub use super::kinds::kinematics::KinematicsParams;
pub use super::kinds::ramp::{RAMP_ONLY, RampParams};
pub use super::kinds::render::RenderParams;
pub use super::kinds::report::ReportParams;
pub use super::kinds::sweep::SweepParams;
pub use super::kinds::track::TrackParams;
use crate::error::{Error, Result};
pub use crate::stages::fit::params::FitParams;
use serde::de::DeserializeOwned;
use serde_json::Value as Json;

/// Fill defaults: the stage table (validated, `kind` removed) → every key's value.
pub fn resolve(kind: Kind, given: Json) -> std::result::Result<Json, String> {
    kind.def().resolve(given)
}

/// Every key of a kind with its Rust default (what the schema file must document).
pub fn rust_defaults(kind: Kind) -> Json {
    resolve(kind, Json::Object(Default::default())).expect("defaults deserialise")
}

/// Typed parameters back from resolved JSON (always succeeds for resolved values).
pub fn typed<T: DeserializeOwned>(stage: &str, params: &Json) -> Result<T> {
    let mut p = params.clone();
    if let Some(o) = p.as_object_mut() {
        o.remove("kind");
    }
    serde_json::from_value(p).map_err(|e| Error::param(stage, e.to_string()))
}

/// `A,B` as two numbers (`--origin-px 165.98,850`, `--strain 0.1,0.2`).
pub fn parse_pair(s: &str) -> std::result::Result<(f64, f64), String> {
    let v: Vec<&str> = s.split(',').collect();
    if v.len() != 2 {
        return Err(format!("expected two numbers A,B, got '{s}'"));
    }
    let a = v[0]
        .trim()
        .parse::<f64>()
        .map_err(|e| format!("'{}': {e}", v[0]))?;
    let b = v[1]
        .trim()
        .parse::<f64>()
        .map_err(|e| format!("'{}': {e}", v[1]))?;
    Ok((a, b))
}
