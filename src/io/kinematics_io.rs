//! The `kinematics` table (`data_schema/kinematics.schema.json`).

use crate::error::{Error, Result};
use crate::kinematics::ParticleKinematics;
use polars::prelude::*;

/// One frame pair's rows as a DataFrame in the schema's column order.
pub fn kinematics_dataframe(
    frame: i64,
    frame_end: i64,
    dt: f64,
    ks: &[ParticleKinematics],
) -> Result<DataFrame> {
    let n = ks.len();
    let f = |g: fn(&ParticleKinematics) -> f64| ks.iter().map(g).collect::<Vec<f64>>();
    let cols = vec![
        Column::new("frame".into(), vec![frame; n]),
        Column::new("frame_end".into(), vec![frame_end; n]),
        Column::new("dt".into(), vec![dt; n]),
        Column::new(
            "particle".into(),
            ks.iter().map(|k| k.particle).collect::<Vec<_>>(),
        ),
        Column::new("x".into(), f(|k| k.pos.x)),
        Column::new("y".into(), f(|k| k.pos.y)),
        Column::new(
            "species".into(),
            ks.iter().map(|k| k.species).collect::<Vec<i32>>(),
        ),
        Column::new(
            "n_neighbors".into(),
            ks.iter()
                .map(|k| k.n_neighbors as i32)
                .collect::<Vec<i32>>(),
        ),
        Column::new(
            "valid".into(),
            ks.iter().map(|k| k.valid).collect::<Vec<bool>>(),
        ),
        Column::new(
            "status".into(),
            ks.iter().map(|k| k.status.name()).collect::<Vec<&str>>(),
        ),
        Column::new("j11".into(), f(|k| k.j.a11)),
        Column::new("j12".into(), f(|k| k.j.a12)),
        Column::new("j21".into(), f(|k| k.j.a21)),
        Column::new("j22".into(), f(|k| k.j.a22)),
        Column::new("eta_xx".into(), f(|k| k.strain.eta_xx)),
        Column::new("eta_xy".into(), f(|k| k.strain.eta_xy)),
        Column::new("eta_yy".into(), f(|k| k.strain.eta_yy)),
        Column::new("eta_m".into(), f(|k| k.strain.eta_m)),
        Column::new("eta_s".into(), f(|k| k.strain.eta_s)),
        Column::new("j2".into(), f(|k| k.j2)),
        Column::new("d2min".into(), f(|k| k.d2min)),
        Column::new("vx".into(), f(|k| k.velocity.x)),
        Column::new("vy".into(), f(|k| k.velocity.y)),
        Column::new("speed".into(), f(|k| k.velocity.norm())),
    ];
    DataFrame::new(n, cols).map_err(|e| Error::polars("building kinematics table", e))
}

/// The kinematics table's polars schema (from an empty batch, so it cannot drift
/// from `kinematics_dataframe`).
pub fn kinematics_schema() -> Schema {
    kinematics_dataframe(0, 0, 0.0, &[])
        .expect("empty frame builds")
        .schema()
        .as_ref()
        .clone()
}
