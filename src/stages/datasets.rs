//! The inputs of one side of a report or a size scan (experiment, simulation, …): the
//! files of a pipeline branch's stages by role.

use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// One side of the report (experiment, simulation, …).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct DatasetInputs {
    pub label: String,
    pub tracks: Option<PathBuf>,
    pub kinematics: Option<PathBuf>,
    pub fit: Option<PathBuf>,
    /// A table with `frame`, `strain` and `stress` columns, optionally `stress_reduced`
    /// and `kappa_exact` (the simulator's stress–strain output).
    pub stress: Option<PathBuf>,
    /// Per-grain forces (the simulator's forces table, data_schema/forces.schema.json);
    /// drawn at the grains' positions in `tracks`.
    #[serde(default)]
    pub forces: Option<PathBuf>,
    /// A force sensor's stress–strain table (`ingest-force`: `strain`, `stress`,
    /// `stress_reduced` by sensor row), drawn with the stress–strain curves only (its
    /// rows are not the tracks' frames).
    #[serde(default)]
    pub measured_stress: Option<PathBuf>,
    /// A sheared-disk run's directory (`summary.json`, `collision_angles.parquet`, …).
    #[serde(default)]
    pub shear: Option<PathBuf>,
    /// A sweep's directory (`sweep.parquet`, `sweep.json`).
    #[serde(default)]
    pub sweep: Option<PathBuf>,
    /// Strain-rate ramps' directories (`summary.json`, `ramp.parquet`), drawn together
    /// as one hysteresis loop (vagberg-sheared-disks Fig. 31).
    #[serde(default)]
    pub ramps: Vec<PathBuf>,
    /// A parameter study's folder (`grid.csv`, `grid.json`), drawn against its varied key.
    #[serde(default)]
    pub grid: Option<PathBuf>,
}

impl DatasetInputs {
    /// The `simulate pillar` run directory behind the data set (its stress table's
    /// folder), if it is one.
    pub fn pillar_run(&self) -> Option<PathBuf> {
        let dir = self.stress.as_ref()?.parent()?.to_path_buf();
        let text = std::fs::read_to_string(dir.join(crate::stages::manifest::MANIFEST)).ok()?;
        let m: serde_json::Value = serde_json::from_str(&text).ok()?;
        (m["command"] == "simulate pillar").then_some(dir)
    }

    /// An experiment's data set: tracks and no simulation.
    pub fn is_experiment(&self) -> bool {
        self.stress.is_none() && self.shear.is_none() && self.sweep.is_none() && self.grid.is_none()
    }
}
