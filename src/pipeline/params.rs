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
pub use super::kinds::ramp::RampParams;
pub use super::kinds::render::RenderParams;
pub use super::kinds::report::ReportParams;
pub use super::kinds::shear::RAMP_ONLY;
pub use super::kinds::sweep::SweepParams;
pub use super::kinds::track::TrackParams;
pub use crate::stages::fit::params::FitParams;
use serde_json::Value as Json;

/// Fill defaults: the stage table (validated, `kind` removed) → every key's value.
pub fn resolve(kind: Kind, given: Json) -> std::result::Result<Json, String> {
    kind.def().resolve(given)
}

/// Every key of a kind with its Rust default (what the schema file must document).
pub fn rust_defaults(kind: Kind) -> Json {
    resolve(kind, Json::Object(Default::default())).expect("defaults deserialise")
}

pub use super::kinds::{parse_pair, typed};
