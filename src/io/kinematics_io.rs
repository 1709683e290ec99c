//! The `kinematics` table (`data_schema/kinematics.schema.json`).

use crate::error::{Error, Result};
use crate::kinematics::{F64_COLUMNS, KinematicsColumns};
use polars::prelude::*;

/// One frame pair's rows as a DataFrame in the schema's column order. The columns
/// are moved in, not copied.
pub fn kinematics_dataframe(
    frame: i64,
    frame_end: i64,
    dt: f64,
    k: KinematicsColumns,
) -> Result<DataFrame> {
    let n = k.len();
    let mut f64s = F64_COLUMNS
        .iter()
        .zip(k.f64s)
        .map(|(name, v)| Column::new((*name).into(), v));
    let mut next_f64 = || f64s.next().expect("16 float columns");
    let (x, y) = (next_f64(), next_f64());
    let mut cols = vec![
        Column::new("frame".into(), vec![frame; n]),
        Column::new("frame_end".into(), vec![frame_end; n]),
        Column::new("dt".into(), vec![dt; n]),
        Column::new("particle".into(), k.particle),
        x,
        y,
        Column::new("species".into(), k.species),
        Column::new("n_neighbors".into(), k.n_neighbors),
        Column::new("valid".into(), k.valid),
        Column::new(
            "status".into(),
            k.status.iter().map(|s| s.name()).collect::<Vec<&str>>(),
        ),
    ];
    cols.extend(f64s);
    DataFrame::new(n, cols).map_err(|e| Error::polars("building kinematics table", e))
}

/// The kinematics table's polars schema (from an empty batch, so it cannot drift
/// from `kinematics_dataframe`).
pub fn kinematics_schema() -> Schema {
    kinematics_dataframe(0, 0, 0.0, KinematicsColumns::default())
        .expect("empty frame builds")
        .schema()
        .as_ref()
        .clone()
}
