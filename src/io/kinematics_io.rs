//! The `kinematics` table (`data_schema/kinematics.schema.json`).

use crate::error::{Error, Result};
use crate::kinematics::{F64_COLUMNS, FloatColumns, KinematicsColumns};
use polars::prelude::*;

/// The table's columns, in order.
pub const COLUMNS: [&str; 24] = [
    "frame",
    "frame_end",
    "dt",
    "particle",
    "x",
    "y",
    "species",
    "n_neighbors",
    "valid",
    "status",
    "j11",
    "j12",
    "j21",
    "j22",
    "eta_xx",
    "eta_xy",
    "eta_yy",
    "eta_m",
    "eta_s",
    "j2",
    "d2min",
    "vx",
    "vy",
    "speed",
];

/// Columns every table has, whatever was asked: a row's identity.
pub const KEY_COLUMNS: [&str; 3] = ["frame", "frame_end", "particle"];

/// Which of [`COLUMNS`] a run writes (`kinematics --columns`): the keys and those
/// asked for, in the table's order. A table written with fewer columns is the full
/// table's columns, bit for bit; a later stage that needs one it lacks says so.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Selection([bool; 24]);

impl Default for Selection {
    fn default() -> Self {
        Selection::all()
    }
}

impl Selection {
    pub fn all() -> Self {
        Selection([true; 24])
    }

    /// The keys and `names` (any order, repeats allowed; `all` for every column).
    pub fn of<S: AsRef<str>>(names: &[S]) -> Result<Self> {
        let mut keep = [false; 24];
        for k in KEY_COLUMNS {
            keep[index(k).expect("a key is a column")] = true;
        }
        let mut all = false;
        for name in names {
            let name = name.as_ref().trim();
            if name.is_empty() {
                return Err(Error::param(
                    "columns",
                    "an empty column name (a stray comma?); give names such as d2min,eta_s",
                ));
            }
            if name == "all" {
                all = true;
                continue;
            }
            match index(name) {
                Some(i) => keep[i] = true,
                None => {
                    return Err(Error::param(
                        "columns",
                        format!(
                            "unknown column '{name}'; the kinematics table's columns are {} (or 'all'); {} are always written",
                            COLUMNS.join(", "),
                            KEY_COLUMNS.join(", ")
                        ),
                    ));
                }
            }
        }
        Ok(if all {
            Selection::all()
        } else {
            Selection(keep)
        })
    }

    pub fn is_all(&self) -> bool {
        self.0.iter().all(|&k| k)
    }

    pub fn keeps(&self, name: &str) -> bool {
        index(name).is_some_and(|i| self.0[i])
    }

    /// The columns written, in the table's order.
    pub fn names(&self) -> Vec<&'static str> {
        COLUMNS
            .into_iter()
            .zip(self.0)
            .filter_map(|(c, k)| k.then_some(c))
            .collect()
    }

    /// The float columns the kernel must store.
    pub fn floats(&self) -> FloatColumns {
        FloatColumns(F64_COLUMNS.map(|c| self.keeps(c)))
    }
}

fn index(name: &str) -> Option<usize> {
    COLUMNS.iter().position(|&c| c == name)
}

/// One frame pair's rows as a DataFrame of the `sel` columns in the schema's order.
/// The columns are moved in, not copied; float columns outside `sel` may be empty.
pub fn kinematics_dataframe(
    frame: i64,
    frame_end: i64,
    dt: f64,
    k: KinematicsColumns,
    sel: &Selection,
) -> Result<DataFrame> {
    let n = k.len();
    let mut cols = Vec::with_capacity(COLUMNS.len());
    let mut floats = F64_COLUMNS.iter().zip(k.f64s);
    let mut float = |cols: &mut Vec<Column>| {
        let (name, v) = floats.next().expect("16 float columns");
        if sel.keeps(name) {
            cols.push(Column::new((*name).into(), v));
        }
    };
    let keep = |name| sel.keeps(name);
    if keep("frame") {
        cols.push(Column::new("frame".into(), vec![frame; n]));
    }
    if keep("frame_end") {
        cols.push(Column::new("frame_end".into(), vec![frame_end; n]));
    }
    if keep("dt") {
        cols.push(Column::new("dt".into(), vec![dt; n]));
    }
    if keep("particle") {
        cols.push(Column::new("particle".into(), k.particle));
    }
    float(&mut cols);
    float(&mut cols);
    if keep("species") {
        cols.push(Column::new("species".into(), k.species));
    }
    if keep("n_neighbors") {
        cols.push(Column::new("n_neighbors".into(), k.n_neighbors));
    }
    if keep("valid") {
        cols.push(Column::new("valid".into(), k.valid));
    }
    if keep("status") {
        cols.push(Column::new(
            "status".into(),
            k.status.iter().map(|s| s.name()).collect::<Vec<&str>>(),
        ));
    }
    for _ in 2..F64_COLUMNS.len() {
        float(&mut cols);
    }
    DataFrame::new(n, cols).map_err(|e| Error::polars("building kinematics table", e))
}

/// The polars schema of a table of the `sel` columns (from an empty batch, so it
/// cannot drift from `kinematics_dataframe`).
pub fn kinematics_schema(sel: &Selection) -> Schema {
    kinematics_dataframe(0, 0, 0.0, KinematicsColumns::default(), sel)
        .expect("empty frame builds")
        .schema()
        .as_ref()
        .clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_column_list_is_the_tables() {
        let names: Vec<String> = kinematics_schema(&Selection::all())
            .iter_names()
            .map(|s| s.to_string())
            .collect();
        assert_eq!(names, COLUMNS);
    }

    #[test]
    fn a_selection_keeps_the_keys_in_table_order() {
        let s = Selection::of(&["d2min", "eta_s", "d2min", " valid"]).unwrap();
        assert_eq!(
            s.names(),
            ["frame", "frame_end", "particle", "valid", "eta_s", "d2min"]
        );
        let names: Vec<String> = kinematics_schema(&s)
            .iter_names()
            .map(|s| s.to_string())
            .collect();
        assert_eq!(names, s.names());
        assert!(!s.is_all());
        assert_eq!(
            s.floats()
                .0
                .iter()
                .zip(F64_COLUMNS)
                .filter_map(|(&k, c)| k.then_some(c))
                .collect::<Vec<_>>(),
            ["eta_s", "d2min"]
        );
        assert!(Selection::of(&["d2min", "all"]).unwrap().is_all());
        assert!(Selection::of::<&str>(&[]).unwrap().names() == KEY_COLUMNS);
    }

    #[test]
    fn an_unknown_column_is_named_with_the_choices() {
        let e = Selection::of(&["d2min", "D2min"]).unwrap_err().to_string();
        assert!(e.contains("'D2min'"), "{e}");
        assert!(e.contains("eta_s") && e.contains("always written"), "{e}");
        // Every name is checked, `all` or not, and an empty one is named as such.
        let e = Selection::of(&["all", "bogus"]).unwrap_err().to_string();
        assert!(e.contains("'bogus'"), "{e}");
        let e = Selection::of(&["d2min", ""]).unwrap_err().to_string();
        assert!(e.contains("empty column name"), "{e}");
    }
}
