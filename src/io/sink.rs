//! Streaming table output: batches of rows appended to a Parquet or CSV file that is
//! written under a temporary name and renamed into place only when complete.

use super::atomic::atomic_write;
use super::table::TableFormat;
use crate::error::{Error, Result};
use polars::prelude::*;
use std::fs::File;
use std::path::Path;

enum Writer<'a> {
    Parquet(Box<polars::io::parquet::write::BatchedWriter<&'a mut File>>),
    Csv(polars::io::csv::write::BatchedWriter<&'a mut File>),
}

/// An open output table; `write` appends one batch.
pub struct TableSink<'a> {
    w: Writer<'a>,
    file: String,
    pub rows: usize,
}

impl TableSink<'_> {
    pub fn write(&mut self, df: &DataFrame) -> Result<()> {
        self.rows += df.height();
        match &mut self.w {
            Writer::Parquet(w) => w.write_batch(df),
            Writer::Csv(w) => w.write_batch(df),
        }
        .map_err(|e| Error::polars(format!("{}: writing", self.file), e))
    }
    fn finish(mut self) -> Result<()> {
        match &mut self.w {
            Writer::Parquet(w) => w.finish().map(|_| ()),
            Writer::Csv(w) => w.finish(),
        }
        .map_err(|e| Error::polars(format!("{}: finishing", self.file), e))
    }
}

/// Stream a table with `schema` to `path`: `produce` gets the sink and writes batches.
/// The file appears at `path` only if `produce` and the footer succeed.
pub fn stream_table<F>(path: &Path, schema: &Schema, produce: F) -> Result<usize>
where
    F: FnOnce(&mut TableSink) -> Result<()>,
{
    let file = path.display().to_string();
    let mut rows = 0;
    atomic_write(path, |f| {
        let pe = |e| Error::polars(format!("{file}: opening"), e);
        let w = match TableFormat::of(path) {
            TableFormat::Parquet => Writer::Parquet(Box::new(
                ParquetWriter::new(f)
                    .with_compression(ParquetCompression::Lz4Raw)
                    .batched(schema)
                    .map_err(pe)?,
            )),
            TableFormat::Csv => Writer::Csv(
                CsvWriter::new(f)
                    .include_header(true)
                    .batched(schema)
                    .map_err(pe)?,
            ),
        };
        let mut sink = TableSink {
            w,
            file: file.clone(),
            rows: 0,
        };
        produce(&mut sink)?;
        rows = sink.rows;
        sink.finish()
    })?;
    Ok(rows)
}
