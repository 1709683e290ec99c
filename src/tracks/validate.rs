use super::Tracks;
use crate::error::{Error, Result};

/// How a row index maps to a location a user can find in the source file.
#[derive(Debug, Clone, Copy)]
pub enum RowLocator {
    /// Text file: row r is on line r + `first_data_line` (1-based).
    Line { first_data_line: usize },
    /// Binary table: 0-based row index.
    Row,
    /// Row r came from a source line recorded per row (LAMMPS dumps).
    Explicit,
}

/// The largest |x|, |y| and radius accepted, in the table's length unit
/// (`max_abs` in `data_schema/tracks.schema.json`). Beyond it a value is a corrupt or
/// mis-scaled file rather than a grain: f64 then resolves no better than 1e-4 units,
/// too coarse for the displacements of Eqs. 13–18, and the squared distances of the
/// neighbour search and the fits lose all precision long before they overflow.
pub const MAX_ABS_COORD: f64 = 1e12;

/// Within ±`MAX_ABS_COORD` (false for NaN and ±inf).
fn bounded(v: f64) -> bool {
    v.abs() <= MAX_ABS_COORD
}

/// Validate every row against `data_schema/tracks.schema.json` (frame ≥ 0, finite
/// coordinates within ±`MAX_ABS_COORD`, 0 < radius ≤ `MAX_ABS_COORD`, species 0/1), sort
/// by (frame, particle) and reject duplicates. `lines` gives explicit source lines for
/// `RowLocator::Explicit`.
pub fn finalize(
    mut t: Tracks,
    file: &str,
    locator: RowLocator,
    lines: Option<&[usize]>,
) -> Result<Tracks> {
    let loc = |r: usize| -> String {
        match locator {
            RowLocator::Line { first_data_line } => format!("line {}", r + first_data_line),
            RowLocator::Row => format!("row {r}"),
            RowLocator::Explicit => match lines {
                Some(l) => format!("line {}", l[r]),
                None => format!("row {r}"),
            },
        }
    };
    let bad = |r: usize, column: &str, msg: String| Error::Value {
        file: file.to_string(),
        loc: loc(r),
        column: column.to_string(),
        msg,
    };
    if t.is_empty() {
        return Err(Error::input(file, "no data rows (empty table)"));
    }
    // One branch-free sweep per column first; the row-by-row walk below only runs to
    // name the first bad row when there is one.
    let finite = |v: &[f64]| v.iter().fold(true, |ok, x| ok & x.is_finite());
    let clean = t.frame.iter().fold(true, |ok, &f| ok & (f >= 0))
        && t.x.iter().fold(true, |ok, &v| ok & bounded(v))
        && t.y.iter().fold(true, |ok, &v| ok & bounded(v))
        && t.radius
            .iter()
            .fold(true, |ok, &r| ok & (r > 0.0) & bounded(r))
        && t.species
            .as_ref()
            .is_none_or(|s| s.iter().fold(true, |ok, &v| ok & ((v == 0) | (v == 1))))
        && t.time.as_deref().is_none_or(finite)
        && t.theta.as_deref().is_none_or(finite);
    for r in (0..t.len()).filter(|_| !clean) {
        if t.frame[r] < 0 {
            return Err(bad(
                r,
                "frame",
                format!("negative frame {}; expected an integer >= 0", t.frame[r]),
            ));
        }
        for (name, v) in [("x", t.x[r]), ("y", t.y[r]), ("radius", t.radius[r])] {
            if !v.is_finite() {
                return Err(bad(r, name, format!("{v} is not a finite number")));
            }
            if !bounded(v) {
                return Err(bad(r, name, beyond_bound(v, "")));
            }
        }
        if t.radius[r] <= 0.0 {
            return Err(bad(
                r,
                "radius",
                format!("radius {} must be > 0", t.radius[r]),
            ));
        }
        if let Some(s) = &t.species
            && !(s[r] == 0 || s[r] == 1)
        {
            return Err(bad(
                r,
                "species",
                format!(
                    "species {} not allowed; expected 0 (small) or 1 (large)",
                    s[r]
                ),
            ));
        }
        for (name, col) in [("time", &t.time), ("theta", &t.theta)] {
            if let Some(c) = col
                && !c[r].is_finite()
            {
                return Err(bad(r, name, format!("{} is not a finite number", c[r])));
            }
        }
    }
    let sorted =
        (1..t.len()).all(|r| (t.frame[r - 1], t.particle[r - 1]) < (t.frame[r], t.particle[r]));
    // Strictly increasing keys have no duplicates; otherwise sort a permutation, look
    // for equal neighbours, and apply it.
    if !sorted {
        let mut perm: Vec<usize> = (0..t.len()).collect();
        perm.sort_by_key(|&i| (t.frame[i], t.particle[i], i));
        for w in perm.windows(2) {
            let (a, b) = (w[0], w[1]);
            if t.frame[a] == t.frame[b] && t.particle[a] == t.particle[b] {
                return Err(Error::Duplicate {
                    file: file.to_string(),
                    frame: t.frame[a],
                    particle: t.particle[a],
                    first: loc(a),
                    second: loc(b),
                });
            }
        }
        t.permute(&perm);
    }
    t.meta.boxes.sort_by_key(|b| b.frame);
    Ok(t)
}

/// The message for a value past `MAX_ABS_COORD` (`unit`: a unit to name, e.g. " px").
pub fn beyond_bound(v: f64, unit: &str) -> String {
    format!(
        "{v:e}{unit} is beyond ±{MAX_ABS_COORD:e}{unit}, the largest coordinate accepted (a corrupt or mis-scaled file; see data_schema/tracks.schema.json)"
    )
}
