//! The table schemas in `data_schema/`, embedded at build time and used to validate
//! tables. The JSON files are the single source of truth for column names, types and
//! units; writers build their column lists from here, and a test checks they agree.

use serde::Deserialize;

#[derive(Debug, Clone, Deserialize)]
pub struct ColumnSpec {
    pub name: String,
    #[serde(rename = "type")]
    pub dtype: String,
    pub required: bool,
    #[serde(default)]
    pub unit: Option<String>,
    #[serde(default)]
    pub min: Option<f64>,
    #[serde(default)]
    pub min_exclusive: Option<f64>,
    #[serde(default)]
    pub finite: bool,
    /// Largest accepted magnitude (the tracks' coordinates: `tracks::MAX_ABS_COORD`).
    #[serde(default)]
    pub max_abs: Option<f64>,
    #[serde(default)]
    pub allowed: Option<Vec<i64>>,
    #[serde(default)]
    pub description: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
pub struct TableSchema {
    pub table: String,
    pub version: u32,
    pub description: String,
    pub columns: Vec<ColumnSpec>,
}

impl TableSchema {
    pub fn column(&self, name: &str) -> Option<&ColumnSpec> {
        self.columns.iter().find(|c| c.name == name)
    }
    pub fn required(&self) -> Vec<&str> {
        self.columns
            .iter()
            .filter(|c| c.required)
            .map(|c| c.name.as_str())
            .collect()
    }
    pub fn names(&self) -> Vec<&str> {
        self.columns.iter().map(|c| c.name.as_str()).collect()
    }
}

/// The embedded schema files, by table name.
pub const SCHEMA_FILES: &[(&str, &str)] = &[
    ("tracks", include_str!("../data_schema/tracks.schema.json")),
    (
        "kinematics",
        include_str!("../data_schema/kinematics.schema.json"),
    ),
    (
        "bar_forces",
        include_str!("../data_schema/bar_forces.schema.json"),
    ),
    (
        "stress_strain",
        include_str!("../data_schema/stress_strain.schema.json"),
    ),
    ("forces", include_str!("../data_schema/forces.schema.json")),
    (
        "shear_series",
        include_str!("../data_schema/shear_series.schema.json"),
    ),
    (
        "collision_angles",
        include_str!("../data_schema/collision_angles.schema.json"),
    ),
    ("sweep", include_str!("../data_schema/sweep.schema.json")),
    (
        "sweep_angles",
        include_str!("../data_schema/sweep_angles.schema.json"),
    ),
    (
        "sweep_contacts",
        include_str!("../data_schema/sweep_contacts.schema.json"),
    ),
    (
        "shear_profile",
        include_str!("../data_schema/shear_profile.schema.json"),
    ),
    (
        "shear_ramp",
        include_str!("../data_schema/shear_ramp.schema.json"),
    ),
    (
        "contact_velocities",
        include_str!("../data_schema/contact_velocities.schema.json"),
    ),
    (
        "shear_fields",
        include_str!("../data_schema/shear_fields.schema.json"),
    ),
    ("gofr", include_str!("../data_schema/gofr.schema.json")),
    (
        "shear_lines",
        include_str!("../data_schema/shear_lines.schema.json"),
    ),
    (
        "features",
        include_str!("../data_schema/features.schema.json"),
    ),
    (
        "ground_truth",
        include_str!("../data_schema/ground_truth.schema.json"),
    ),
];

/// Parse one embedded schema. Panics only if a file in `data_schema/` is malformed,
/// which `tests/it/ingest.rs` (`schema_files_and_code_agree`) catches at test time.
pub fn load(table: &str) -> TableSchema {
    let text = SCHEMA_FILES
        .iter()
        .find(|(t, _)| *t == table)
        .map(|(_, s)| *s)
        .unwrap_or_else(|| panic!("no embedded schema for table '{table}'"));
    serde_json::from_str(text)
        .unwrap_or_else(|e| panic!("data_schema/{table}.schema.json is malformed: {e}"))
}
