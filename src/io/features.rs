//! Located grains (`camera::Feature`) as a table in trackpy's columns: `y, x, mass,
//! size, ecc, signal, raw_mass, ep, frame`, then `particle` once linked (pixels, image y
//! pointing down), what `trackpy.batch` and `trackpy.link` write with `to_csv`.
//!
//! Reading needs `x`, `y` and `frame`; a missing optional column, or an empty value in
//! one, reads as NaN; other columns (`particle`, pandas' unnamed index column) are
//! ignored. Writing puts exactly trackpy's columns in trackpy's order, so that trackpy,
//! pandas and `pillar-pipe ingest` read the file back.

use super::atomic::atomic_write;
use super::csvdiag::Expect;
use super::fastcsv::read_numeric_csv;
use super::table::{TableFormat, read_table_columns};
use crate::camera::Feature;
use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// trackpy's feature columns in its order, with their types (the eight floats, then
/// `frame`).
pub const FEATURE_COLUMNS: &[(&str, Expect)] = &[
    ("y", Expect::Float),
    ("x", Expect::Float),
    ("mass", Expect::Float),
    ("size", Expect::Float),
    ("ecc", Expect::Float),
    ("signal", Expect::Float),
    ("raw_mass", Expect::Float),
    ("ep", Expect::Float),
    ("frame", Expect::Int),
];

/// The columns a features table must have.
pub const REQUIRED: &[&str] = &["x", "y", "frame"];

/// Read a features table (CSV, or Parquet by extension). Errors name the file, and
/// the line (row) and column of a bad value.
pub fn read_features(path: &Path) -> Result<Vec<Feature>> {
    Ok(read(path, false)?.0)
}

/// A linked table (what `link` and `track` write, or trackpy's `link`): the features
/// and their `particle` ids, read in one pass; a missing `particle` column is an error
/// naming the file.
pub fn read_linked(path: &Path) -> Result<(Vec<Feature>, Vec<i64>)> {
    let (features, particle) = read(path, true)?;
    let particle = particle.ok_or_else(|| Error::MissingColumns {
        file: path.display().to_string(),
        missing: vec!["particle".into()],
        found: FEATURE_COLUMNS.iter().map(|c| c.0.to_string()).collect(),
        expected: vec!["particle".into()],
    })?;
    Ok((features, particle))
}

/// The read behind both: the features, and `particle` when asked for and present.
fn read(path: &Path, with_particle: bool) -> Result<(Vec<Feature>, Option<Vec<i64>>)> {
    let file = path.display().to_string();
    let format = TableFormat::of(path);
    let mut spec: Vec<(&str, Expect)> = FEATURE_COLUMNS.to_vec();
    if with_particle {
        spec.push(("particle", Expect::Int));
    }
    let cols = match read_fast(path, format, &spec, with_particle)? {
        Some(c) => c,
        None => read_slow(path, &spec, with_particle)?,
    };
    let loc = |r: usize| match format {
        TableFormat::Csv => format!("line {}", r + 2),
        TableFormat::Parquet => format!("row {r}"),
    };
    let [y, x, mass, size, ecc, signal, raw_mass, ep] = &cols.floats;
    for (r, (&x, &y)) in x.iter().zip(y).enumerate() {
        for (c, v) in [("x", x), ("y", y)] {
            if !v.is_finite() {
                return Err(Error::Value {
                    file,
                    loc: loc(r),
                    column: c.into(),
                    msg: format!("{v} is not a finite position"),
                });
            }
        }
    }
    let features = (0..cols.frame.len())
        .map(|r| Feature {
            frame: cols.frame[r],
            x: x[r],
            y: y[r],
            mass: mass[r],
            size: size[r],
            ecc: ecc[r],
            signal: signal[r],
            raw_mass: raw_mass[r],
            ep: ep[r],
        })
        .collect();
    Ok((features, cols.particle))
}

/// The float columns in `FEATURE_COLUMNS`' order, `frame`, and `particle` when read.
struct Columns {
    floats: [Vec<f64>; 8],
    frame: Vec<i64>,
    particle: Option<Vec<i64>>,
}

/// A plain numeric CSV with every column present and every value a number: the fast
/// reader. `None`: anything else.
fn read_fast(
    path: &Path,
    format: TableFormat,
    spec: &[(&str, Expect)],
    with_particle: bool,
) -> Result<Option<Columns>> {
    if format != TableFormat::Csv {
        return Ok(None);
    }
    let Some(mut t) = read_numeric_csv(path, spec)? else {
        return Ok(None);
    };
    if REQUIRED.iter().any(|c| !t.columns.contains_key(*c)) {
        return Ok(None);
    }
    let Some(frame) = t.take_i64("frame") else {
        return Ok(None);
    };
    // A particle column that is not all whole numbers goes the slow way, which names
    // the bad value's line.
    let particle = match (with_particle, t.columns.contains_key("particle")) {
        (true, true) => match t.take_i64("particle") {
            Some(p) => Some(p),
            None => return Ok(None),
        },
        _ => None,
    };
    let rows = t.rows;
    let floats = FEATURE_COLUMNS[..8]
        .iter()
        .map(|&(name, _)| t.take_f64(name).unwrap_or_else(|| vec![f64::NAN; rows]))
        .collect::<Vec<_>>()
        .try_into()
        .expect("eight float columns");
    Ok(Some(Columns {
        floats,
        frame,
        particle,
    }))
}

/// Through polars, whose path names the line and column of a bad value.
fn read_slow(path: &Path, spec: &[(&str, Expect)], with_particle: bool) -> Result<Columns> {
    let table = read_table_columns(path, spec, true)?;
    if REQUIRED.iter().any(|c| !table.has(c)) {
        // The file's own columns, not only those read.
        let found = match table.format {
            TableFormat::Csv => super::csvdiag::read_header(path)?,
            TableFormat::Parquet => table.columns(),
        };
        return Err(Error::MissingColumns {
            file: table.file.clone(),
            missing: REQUIRED
                .iter()
                .filter(|c| !table.has(c))
                .map(|c| c.to_string())
                .collect(),
            found,
            expected: REQUIRED.iter().map(|c| c.to_string()).collect(),
        });
    }
    let rows = table.df.height();
    let mut floats = Vec::with_capacity(8);
    for &(name, _) in &FEATURE_COLUMNS[..8] {
        floats.push(if REQUIRED.contains(&name) {
            table.f64(name)?
        } else if table.has(name) {
            table.f64_or_nan(name)?
        } else {
            vec![f64::NAN; rows]
        });
    }
    let particle = if with_particle && table.has("particle") {
        Some(table.i64("particle")?)
    } else {
        None
    };
    Ok(Columns {
        floats: floats.try_into().expect("eight float columns"),
        frame: table.i64("frame")?,
        particle,
    })
}

/// Write `features` as CSV in trackpy's column order, with a `particle` column when
/// given (one per feature), atomically: a failed write leaves no file.
pub fn write_features(path: &Path, features: &[Feature], particle: Option<&[i64]>) -> Result<()> {
    if let Some(p) = particle
        && p.len() != features.len()
    {
        return Err(Error::Other(format!(
            "{}: {} particle ids for {} features",
            path.display(),
            p.len(),
            features.len()
        )));
    }
    atomic_write(path, |f| {
        let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
        write_csv(&mut w, features, particle)
            .and_then(|_| w.flush())
            .map_err(|e| Error::io(path, e))
    })
}

fn write_csv(
    w: &mut impl Write,
    features: &[Feature],
    particle: Option<&[i64]>,
) -> std::io::Result<()> {
    let names: Vec<&str> = FEATURE_COLUMNS.iter().map(|c| c.0).collect();
    write!(w, "{}", names.join(","))?;
    if particle.is_some() {
        write!(w, ",particle")?;
    }
    writeln!(w)?;
    for (i, f) in features.iter().enumerate() {
        for v in [f.y, f.x, f.mass, f.size, f.ecc, f.signal, f.raw_mass, f.ep] {
            write_f64(w, v)?;
            w.write_all(b",")?;
        }
        write!(w, "{}", f.frame)?;
        if let Some(p) = particle {
            write!(w, ",{}", p[i])?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// The shortest text that reads back as the same number (an exponent where Rust's
/// `Debug` uses one; `NaN`, `inf`, `-inf` as pandas reads them).
fn write_f64(w: &mut impl Write, v: f64) -> std::io::Result<()> {
    if v.is_finite() && v == v.trunc() && v.abs() < 1e16 {
        // `2.0` rather than `2`: the column stays a float column to pandas and polars.
        write!(w, "{v:.1}")
    } else {
        write!(w, "{v:?}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str, body: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("pp-features-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, body).unwrap();
        p
    }

    fn feature(frame: i64, x: f64, y: f64) -> Feature {
        Feature {
            frame,
            x,
            y,
            mass: 2000.5,
            size: 5.125,
            ecc: 0.05,
            signal: 40.0,
            raw_mass: 9000.0,
            ep: 0.0012,
        }
    }

    #[test]
    fn written_features_read_back_the_same_with_and_without_particles() {
        let feats = vec![
            feature(0, 12.345678901234, 0.1),
            feature(0, 1e-7, 123456.75),
            Feature {
                ep: f64::NAN,
                ..feature(3, 5.0, 6.0)
            },
        ];
        let p = tmp("w.csv", "");
        write_features(&p, &feats, Some(&[0, 1, 7])).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(
            text.starts_with("y,x,mass,size,ecc,signal,raw_mass,ep,frame,particle\n"),
            "{text}"
        );
        let back = read_features(&p).unwrap();
        assert_eq!(back.len(), 3);
        assert_eq!(back[..2], feats[..2]);
        assert!(back[2].ep.is_nan() && back[2].frame == 3 && back[2].x == 5.0);
        write_features(&p, &feats[..2], None).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("y,x,mass,size,ecc,signal,raw_mass,ep,frame\n"));
        assert_eq!(read_features(&p).unwrap(), feats[..2]);
        assert!(write_features(&p, &feats, Some(&[1])).is_err());
    }

    /// trackpy's to_csv with pandas' index column, only the required columns, an empty
    /// optional value (pandas' NaN): all read; extra columns ignored.
    #[test]
    fn trackpy_and_pandas_variants_are_read() {
        let p = tmp(
            "idx.csv",
            ",y,x,mass,size,ecc,signal,raw_mass,ep,frame,particle\n\
             0,1.5,2.5,100.0,3.0,0.1,5.0,900.0,0.01,0,4\n\
             1,7.5,8.5,101.0,3.1,0.2,6.0,901.0,0.02,1,4\n",
        );
        let f = read_features(&p).unwrap();
        assert_eq!((f[1].frame, f[1].x, f[1].y, f[1].ep), (1, 8.5, 7.5, 0.02));
        let p = tmp("min.csv", "frame,x,y,note\n2,1.0,2.0,a\n3,1.5,2.5,b\n");
        let f = read_features(&p).unwrap();
        assert_eq!((f[1].frame, f[1].x, f[1].y), (3, 1.5, 2.5));
        assert!(f[0].mass.is_nan() && f[0].ep.is_nan());
        let p = tmp("gaps.csv", "y,x,ep,frame\n1,2,,0\n3,4,0.5,1\n");
        let f = read_features(&p).unwrap();
        assert!(f[0].ep.is_nan());
        assert_eq!((f[1].frame, f[1].ep), (1, 0.5));
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let p = tmp("nox.csv", "y,mass,frame\n1,2,0\n");
        let e = read_features(&p).unwrap_err().to_string();
        assert!(e.contains("nox.csv") && e.contains("\"x\""), "{e}");
        let p = tmp("badx.csv", "y,x,frame\n1,2,0\n1,zz,0\n");
        let e = read_features(&p).unwrap_err().to_string();
        assert!(
            e.contains("badx.csv") && e.contains("line 3") && e.contains("column 'x'"),
            "{e}"
        );
        let p = tmp("nanx.csv", "y,x,frame\n1,2,0\n1,2,0\n1,NaN,0\n");
        let e = read_features(&p).unwrap_err().to_string();
        assert!(
            e.contains("nanx.csv") && e.contains("line 4") && e.contains("column 'x'"),
            "{e}"
        );
        let p = tmp("badframe.csv", "y,x,frame\n1,2,0.5\n");
        let e = read_features(&p).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("column 'frame'"), "{e}");
    }

    #[test]
    fn linked_tables_read_their_particle_ids_in_the_same_pass() {
        let fs = [feature(0, 1.5, 2.0), feature(1, 1.75, 2.25)];
        let dir = std::env::temp_dir().join(format!("pp-linked-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("linked.csv");
        write_features(&p, &fs, Some(&[7, 3])).unwrap();
        let (got, pid) = read_linked(&p).unwrap();
        assert_eq!(got, fs);
        assert_eq!(pid, vec![7, 3]);
        // Unlinked: the missing column is named.
        write_features(&p, &fs, None).unwrap();
        let e = read_linked(&p).unwrap_err().to_string();
        assert!(e.contains("linked.csv") && e.contains("particle"), "{e}");
        // A particle id that is not a whole number: its line and column.
        let bad = tmp("bad-pid.csv", "y,x,frame,particle\n1,2,0,4\n1,2,1,4.5\n");
        let e = read_linked(&bad).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("particle"), "{e}");
        // read_features ignores the column, as before.
        assert_eq!(read_features(&bad).unwrap().len(), 2);
        std::fs::remove_dir_all(&dir).ok();
    }
}
