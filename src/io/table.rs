//! Generic table reading and writing with polars: CSV or Parquet chosen by extension,
//! typed column extraction with row-level errors, atomic writes.

use super::atomic::atomic_write;
use super::csvdiag::{self, Expect};
pub use super::format::TableFormat;
use crate::error::{Error, Result};
use polars::prelude::*;
use std::path::Path;
use std::sync::Arc;

/// A table read from disk with where it came from.
pub struct Table {
    pub df: DataFrame,
    pub file: String,
    pub format: TableFormat,
}

/// Read a CSV or Parquet table. Columns named in `expect` are parsed with that type;
/// on any parse failure the file is scanned again to name the line and column.
pub fn read_table(path: &Path, expect: &[(&str, Expect)]) -> Result<Table> {
    read_table_columns(path, expect, false)
}

/// As `read_table`; with `only_expected`, CSV columns not named in `expect` are not
/// parsed at all (trackpy files carry six columns we never use).
pub fn read_table_columns(
    path: &Path,
    expect: &[(&str, Expect)],
    only_expected: bool,
) -> Result<Table> {
    let file = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.len() == 0 {
        return Err(Error::input(&file, "empty file"));
    }
    let format = TableFormat::of(path);
    let df = match format {
        TableFormat::Parquet => {
            let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
            guarded_parquet(path, f, true, |r| r.finish())?
        }
        TableFormat::Csv => {
            let header = csvdiag::read_header(path)?;
            // polars panics on some headers that name a column twice (issue 24's fuzz:
            // "slice index starts at 1 but ends at 0"); a repeated name is ambiguous anyway.
            if let Some((i, h)) = header
                .iter()
                .enumerate()
                .find(|(i, h)| header[..*i].contains(h))
            {
                return Err(Error::Value {
                    file,
                    loc: "line 1".into(),
                    column: h.clone(),
                    msg: format!("column name repeated (field {})", i + 1),
                });
            }
            let fields = expect
                .iter()
                .filter(|(c, _)| header.iter().any(|h| h == c))
                .map(|(c, e)| {
                    let dt = match e {
                        Expect::Int => DataType::Int64,
                        Expect::Float => DataType::Float64,
                    };
                    Field::new((*c).into(), dt)
                });
            let schema = Schema::from_iter(fields);
            let keep: Vec<PlSmallStr> = expect
                .iter()
                .filter(|(c, _)| header.iter().any(|h| h == c))
                .map(|(c, _)| (*c).into())
                .collect();
            let read = guarded(|| {
                CsvReadOptions::default()
                    .with_has_header(true)
                    .with_columns((only_expected && !keep.is_empty()).then(|| keep.into()))
                    .with_schema_overwrite(Some(Arc::new(schema)))
                    .try_into_reader_with_file_path(Some(path.to_path_buf()))
                    .and_then(|r| r.finish())
            });
            match read {
                Ok(Ok(df)) => df,
                Ok(Err(e)) => {
                    csvdiag::diagnose(path, expect)?;
                    return Err(Error::polars(format!("{file}: reading CSV"), e));
                }
                // A panic inside polars on malformed input: the diagnostics place the
                // problem when they can.
                Err(p) => {
                    csvdiag::diagnose(path, expect)?;
                    return Err(Error::input(
                        &file,
                        format!("reading CSV: the reader failed ({})", panic_text(&*p)),
                    ));
                }
            }
        }
    };
    if df.height() == 0 {
        return Err(Error::input(&file, "no data rows (header only)"));
    }
    Ok(Table { df, file, format })
}

/// `read` on a Parquet reader of `f` (the file `path`), after `parquet_guard::check`
/// (against allocations that abort) where `check`. polars' Parquet decoder asserts on
/// some corrupt metadata (issue 24's fuzz found "thrift bool field" and "offset + length
/// <= self.length") instead of returning an error; a corrupt file must not take the
/// process down, so a panic becomes an error naming the file. The check reads the same
/// metadata, so it runs under the same guard, as must anything that interprets what
/// polars read (its schema conversion panics on some column types).
fn guarded_parquet<T>(
    path: &Path,
    f: std::fs::File,
    check: bool,
    read: impl FnOnce(ParquetReader<std::fs::File>) -> PolarsResult<T>,
) -> Result<T> {
    let file = path.display().to_string();
    let read = guarded(|| {
        if check {
            super::parquet_guard::check_file(&f, path)?;
        }
        Ok(read(ParquetReader::new(f)))
    })
    .map_err(|p| {
        Error::input(
            &file,
            format!(
                "reading Parquet: a corrupt file, or a column type this program cannot read ({})",
                panic_text(&*p)
            ),
        )
    })??;
    read.map_err(|e| Error::polars(format!("{file}: reading Parquet"), e))
}

/// A Parquet table opened for reading one column at a time, so a reader never holds
/// polars' copy of the whole table beside its own (for 2 M tracks, 100 MB less memory
/// to fault in). Every column comes from the one file opened and checked here, even if
/// another is renamed onto its path meanwhile.
pub struct ParquetColumns {
    /// The file's column names (a frame of no rows, every column of type null), for
    /// `require`, `has` and `columns`.
    pub schema: Table,
    rows: usize,
    f: std::fs::File,
}

impl ParquetColumns {
    /// Opens `path` after the checks `read_table` makes (not empty, not corrupt, some
    /// rows).
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let meta = f.metadata().map_err(|e| Error::io(path, e))?;
        if meta.len() == 0 {
            return Err(Error::input(&file, "empty file"));
        }
        let handle = f.try_clone().map_err(|e| Error::io(path, e))?;
        // Names only: a column of a type polars cannot hold (a decimal or struct column
        // written by another tool) is then an unknown column like any other, and only
        // the columns read are converted.
        let (names, rows) = guarded_parquet(path, handle, true, |mut r| {
            let names: Vec<PlSmallStr> = r.schema()?.iter_names().cloned().collect();
            Ok((names, r.num_rows()?))
        })?;
        let schema = Schema::from_iter(names.into_iter().map(|n| Field::new(n, DataType::Null)));
        if rows == 0 {
            return Err(Error::input(&file, "no data rows (header only)"));
        }
        Ok(ParquetColumns {
            schema: Table {
                df: DataFrame::empty_with_schema(&schema),
                file,
                format: TableFormat::Parquet,
            },
            rows,
            f,
        })
    }

    /// Column `name` as a table of that one column.
    pub fn column(&self, name: &str) -> Result<Table> {
        let path = Path::new(&self.schema.file);
        let handle = self.f.try_clone().map_err(|e| Error::io(path, e))?;
        let df = guarded_parquet(path, handle, false, |r| {
            r.with_columns(Some(vec![name.to_string()])).finish()
        })?;
        if df.height() != self.rows {
            return Err(Error::input(
                &self.schema.file,
                format!(
                    "column '{name}' has {} rows, the file {}",
                    df.height(),
                    self.rows
                ),
            ));
        }
        Ok(Table {
            df,
            file: self.schema.file.clone(),
            format: TableFormat::Parquet,
        })
    }
}

/// Readers running under [`guarded`] now, in any thread.
static GUARDED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// `read`, a panic in it caught (polars asserts on some malformed files instead of
/// returning an error); the caller turns it into an error naming the file.
fn guarded<T>(read: impl FnOnce() -> T) -> std::thread::Result<T> {
    use std::sync::atomic::Ordering::SeqCst;
    GUARDED.fetch_add(1, SeqCst);
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(read));
    GUARDED.fetch_sub(1, SeqCst);
    r
}

/// For the command-line program: while a reader runs under [`guarded`], panics print
/// nothing. Their message reaches the user in the error that names the file; printed
/// as well ("thread 'main' panicked at …, run with RUST_BACKTRACE=1"), a clean error
/// about a malformed file looks like a crash. Any other panic prints as before. (Not
/// for tests, which run many at once: one test's failure must not be silenced because
/// another is reading a file.)
pub fn quiet_guarded_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if GUARDED.load(std::sync::atomic::Ordering::SeqCst) == 0 {
                default(info);
            }
        }));
    });
}

/// The message of a caught panic.
fn panic_text(p: &(dyn std::any::Any + Send)) -> &str {
    p.downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| p.downcast_ref::<&str>().copied())
        .unwrap_or("a panic without a message")
}

impl Table {
    pub fn columns(&self) -> Vec<String> {
        self.df
            .get_column_names()
            .iter()
            .map(|s| s.to_string())
            .collect()
    }
    pub fn has(&self, name: &str) -> bool {
        self.df.column(name).is_ok()
    }

    /// Error listing found and expected columns when any of `required` is absent.
    pub fn require(&self, required: &[&str]) -> Result<()> {
        let found = self.columns();
        let missing: Vec<String> = required
            .iter()
            .filter(|c| !found.iter().any(|f| f == *c))
            .map(|c| c.to_string())
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(Error::MissingColumns {
            file: self.file.clone(),
            missing,
            found,
            expected: required.iter().map(|s| s.to_string()).collect(),
        })
    }

    fn loc(&self, row: usize) -> String {
        match self.format {
            TableFormat::Csv => format!("line {}", row + 2),
            TableFormat::Parquet => format!("row {row}"),
        }
    }

    fn null_error(&self, name: &str, c: &Column) -> Error {
        let row = (0..c.len())
            .find(|&i| c.get(i).map(|v| v.is_null()).unwrap_or(true))
            .unwrap_or(0);
        Error::Value {
            file: self.file.clone(),
            loc: self.loc(row),
            column: name.into(),
            msg: "missing value".into(),
        }
    }

    /// The column cast to f64 (ints widened), nulls kept.
    fn float_column(&self, name: &str) -> Result<Column> {
        let c = self
            .df
            .column(name)
            .map_err(|e| Error::polars(&self.file, e))?;
        c.cast(&DataType::Float64).map_err(|_| Error::Value {
            file: self.file.clone(),
            loc: "whole column".into(),
            column: name.into(),
            msg: format!("has type {}, expected numbers", c.dtype()),
        })
    }

    /// Column as f64 (ints are widened). Nulls are an error naming the row.
    pub fn f64(&self, name: &str) -> Result<Vec<f64>> {
        let c = self.float_column(name)?;
        if c.null_count() > 0 {
            return Err(self.null_error(name, &c));
        }
        let ca = c.f64().map_err(|e| Error::polars(&self.file, e))?;
        Ok(values(ca))
    }

    /// Column as f64 with nulls read as NaN, for columns whose schema allows nulls
    /// (κ of the stress–strain table where P_in = 0).
    pub fn f64_or_nan(&self, name: &str) -> Result<Vec<f64>> {
        let c = self.float_column(name)?;
        let ca = c.f64().map_err(|e| Error::polars(&self.file, e))?;
        Ok(ca.iter().map(|v| v.unwrap_or(f64::NAN)).collect())
    }

    /// Column as i64; floats must be whole numbers.
    pub fn i64(&self, name: &str) -> Result<Vec<i64>> {
        let c = self
            .df
            .column(name)
            .map_err(|e| Error::polars(&self.file, e))?;
        if c.dtype().is_float() {
            let v = self.f64(name)?;
            return v
                .iter()
                .enumerate()
                .map(|(i, &x)| {
                    if x.fract() == 0.0 && x.is_finite() {
                        Ok(x as i64)
                    } else {
                        Err(Error::Value {
                            file: self.file.clone(),
                            loc: self.loc(i),
                            column: name.into(),
                            msg: format!("{x} is not an integer"),
                        })
                    }
                })
                .collect();
        }
        let c = c.cast(&DataType::Int64).map_err(|_| Error::Value {
            file: self.file.clone(),
            loc: "whole column".into(),
            column: name.into(),
            msg: format!("has type {}, expected integers", c.dtype()),
        })?;
        if c.null_count() > 0 {
            return Err(self.null_error(name, &c));
        }
        let ca = c.i64().map_err(|e| Error::polars(&self.file, e))?;
        Ok(values(ca))
    }
}

/// The values of a column without nulls, copied chunk by chunk (a memcpy per chunk
/// rather than an iterator per value).
fn values<T: PolarsNumericType>(ca: &ChunkedArray<T>) -> Vec<T::Native> {
    let mut out = Vec::with_capacity(ca.len());
    for arr in ca.downcast_iter() {
        out.extend_from_slice(arr.values());
    }
    out
}

impl Table {
    /// A boolean column without nulls ("true"/"false" in CSV).
    pub fn bool(&self, name: &str) -> Result<Vec<bool>> {
        let c = self
            .df
            .column(name)
            .map_err(|e| Error::polars(&self.file, e))?;
        let ca = c.bool().map_err(|_| {
            Error::input(
                &self.file,
                format!("column '{name}': expected true/false, found {}", c.dtype()),
            )
        })?;
        if ca.null_count() > 0 {
            return Err(self.null_error(name, c));
        }
        Ok((0..ca.len()).map(|i| ca.get(i).unwrap_or(false)).collect())
    }
}

/// Write `df` to `path` (Parquet unless the extension is `.csv`), atomically.
/// Write equal-length f64 columns under `names` (in that order) as one table; `what`
/// names the table in an error ("the series").
pub fn write_f64_columns(names: &[&str], cols: &[Vec<f64>], path: &Path, what: &str) -> Result<()> {
    let rows = cols.first().map_or(0, Vec::len);
    let mut df = DataFrame::new(
        rows,
        names
            .iter()
            .zip(cols)
            .map(|(n, c)| Column::new((*n).into(), c))
            .collect(),
    )
    .map_err(|e| Error::polars(format!("building {what}"), e))?;
    write_table(&mut df, path)
}

pub fn write_table(df: &mut DataFrame, path: &Path) -> Result<()> {
    let file = path.display().to_string();
    atomic_write(path, |f| {
        match TableFormat::of(path) {
            TableFormat::Parquet => super::sink::write_parquet(f, df),
            TableFormat::Csv => CsvWriter::new(f).include_header(true).finish(df),
        }
        .map_err(|e| Error::polars(format!("{file}: writing"), e))
    })
}
