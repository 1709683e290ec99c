//! Streaming table output: batches of rows appended to a Parquet or CSV file that is
//! written under a temporary name and renamed into place only when complete.

use super::atomic::atomic_write;
use super::format::TableFormat;
use crate::error::{Error, Result};
use polars::prelude::*;
use polars_parquet::parquet::compression::CompressionOptions;
use polars_parquet::write::{
    CompressedPage, Encoding, ParquetType, StatisticsOptions, Version, WriteOptions,
    array_to_columns, compress,
};
use rayon::prelude::*;
use std::fs::File;
use std::path::Path;

enum Writer<'a> {
    Parquet(Box<ParallelParquet<'a>>),
    Csv(polars::io::csv::write::BatchedWriter<&'a mut File>),
}

/// An open output table; `write` appends one batch.
pub struct TableSink<'a> {
    w: Writer<'a>,
    file: String,
    /// The file's descriptor, to start each batch's write-back (see [`start_writeback`]).
    fd: std::os::fd::RawFd,
    pub rows: usize,
}

impl TableSink<'_> {
    pub fn write(&mut self, df: &DataFrame) -> Result<()> {
        self.rows += df.height();
        match &mut self.w {
            Writer::Parquet(w) => w.write_batch(df),
            Writer::Csv(w) => w.write_batch(df),
        }
        .map_err(|e| Error::polars(format!("{}: writing", self.file), e))?;
        start_writeback(self.fd);
        Ok(())
    }
    fn finish(mut self) -> Result<()> {
        match &mut self.w {
            Writer::Parquet(w) => w.writer.finish().map(|_| ()),
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
        let fd = std::os::fd::AsRawFd::as_raw_fd(f);
        let pe = |e| Error::polars(format!("{file}: opening"), e);
        let w = match TableFormat::of(path) {
            TableFormat::Parquet => {
                Writer::Parquet(Box::new(ParallelParquet::new(f, schema).map_err(pe)?))
            }
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
            fd,
            rows: 0,
        };
        produce(&mut sink)?;
        rows = sink.rows;
        sink.finish()
    })?;
    Ok(rows)
}

/// Asks the kernel to start writing the file's dirty pages to disk now, without
/// waiting. Every table is synced before it is renamed into place (nothing is lost);
/// written back batch by batch while the next batch is computed, that final sync of a
/// large table finds little left to do (for a 133 MB kinematics table it took 54 ms,
/// a tenth of the command). A hint only: errors are ignored (the sync reports them).
fn start_writeback(fd: std::os::fd::RawFd) {
    #[cfg(target_os = "linux")]
    // SAFETY: a plain system call on a descriptor this process holds open; it touches
    // no memory of ours.
    unsafe {
        libc::sync_file_range(fd, 0, 0, libc::SYNC_FILE_RANGE_WRITE);
    }
    #[cfg(not(target_os = "linux"))]
    let _ = fd;
}

/// All of `df` as one Parquet file into `f`, columns encoded in parallel (`write_table`).
pub(super) fn write_parquet(f: &mut File, df: &DataFrame) -> PolarsResult<()> {
    let mut w = ParallelParquet::new(f, df.schema())?;
    w.write_batch(df)?;
    w.writer.finish().map(|_| ())
}

/// polars' batched Parquet writer, with each batch's columns encoded and compressed in
/// parallel here. polars' own `write_batch` encodes in parallel but compresses page by
/// page on the writing thread, which for wide float tables (the kinematics table: 24
/// columns) is most of the time. The pages, and so the file, are the same bytes.
struct ParallelParquet<'a> {
    writer: polars::io::parquet::write::BatchedWriter<&'a mut File>,
    fields: Vec<ParquetType>,
    encodings: Vec<Vec<Encoding>>,
    options: WriteOptions,
}

/// Rows per row group, polars' own default: a batch's encoded pages are freed before
/// the next group is encoded, so a million-row batch reuses one group's worth of
/// buffers instead of touching (and having the kernel zero) fresh memory for all of
/// them.
const ROW_GROUP: usize = 512 * 512;

/// The compression of every table this tool writes: LZ4 decodes at memory speed and
/// still halves typical track tables.
const COMPRESSION: ParquetCompression = ParquetCompression::Lz4Raw;

impl<'a> ParallelParquet<'a> {
    fn new(f: &'a mut File, schema: &Schema) -> PolarsResult<Self> {
        let mut writer = ParquetWriter::new(f)
            .with_compression(COMPRESSION)
            .batched(schema)?;
        let arrow = schema.to_arrow(CompatLevel::newest());
        let mut encodings = polars::io::parquet::write::get_encodings(&arrow).to_vec();
        // polars asks for dictionary encoding of float columns too, estimates each
        // one's count of distinct values (hashing every value: a tenth of the
        // `kinematics` command's processor time), then fails to build a float
        // dictionary and writes them plain (polars-parquet 0.55.2, pinned). Asking for
        // plain directly writes the same bytes (tested) without the estimate.
        for (enc, field) in encodings.iter_mut().zip(arrow.iter_values()) {
            if matches!(field.dtype, ArrowDataType::Float32 | ArrowDataType::Float64) {
                *enc = vec![Encoding::Plain];
            }
        }
        let fields = writer.parquet_schema().fields().to_vec();
        // As `ParquetWriter::materialize_options` builds them for the same settings.
        let options = WriteOptions {
            statistics: StatisticsOptions::default(),
            version: Version::V1,
            compression: CompressionOptions::Lz4Raw,
            data_page_size: None,
        };
        Ok(Self {
            writer,
            fields,
            encodings,
            options,
        })
    }

    fn write_batch(&mut self, df: &DataFrame) -> PolarsResult<()> {
        let rows = df.height();
        for at in (0..rows).step_by(ROW_GROUP) {
            // One chunk per row group (a no-op for the usual one-chunk batch).
            let mut group = df.slice(at as i64, ROW_GROUP);
            group.rechunk_mut_par();
            for batch in group.iter_chunks(CompatLevel::newest(), false) {
                self.write_row_group(batch.len(), batch.columns())?;
            }
        }
        Ok(())
    }

    fn write_row_group(&mut self, rows: usize, columns: &[ArrayRef]) -> PolarsResult<()> {
        if rows == 0 {
            return Ok(());
        }
        let (fields, encodings, options) = (&self.fields, &self.encodings, self.options);
        let pages: Vec<Vec<CompressedPage>> = columns
            .par_iter()
            .zip(fields.par_iter())
            .zip(encodings.par_iter())
            .map(|((array, ty), enc)| -> PolarsResult<Vec<CompressedPage>> {
                let mut out = Vec::new();
                for leaf in array_to_columns(array, ty.clone(), options, enc)? {
                    for page in leaf {
                        out.push(compress(page?, Vec::new(), options.compression)?);
                    }
                }
                Ok(out)
            })
            .collect::<PolarsResult<_>>()?;
        self.writer.write_row_group(rows as u64, &pages)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table of every column kind the tool writes, `n` rows, in `chunks` pieces.
    fn table(n: usize, chunks: usize) -> DataFrame {
        let piece = |lo: usize, hi: usize| {
            let r = lo..hi;
            df!(
                "frame" => r.clone().map(|i| (i / 1000) as i64).collect::<Vec<_>>(),
                "x" => r.clone().map(|i| (i as f64 * 0.37).sin()).collect::<Vec<_>>(),
                "species" => r.clone().map(|i| (i % 2) as i32).collect::<Vec<_>>(),
                "valid" => r.clone().map(|i| i % 7 != 0).collect::<Vec<_>>(),
                "status" => r.clone().map(|i| if i % 7 == 0 { "singular" } else { "ok" }).collect::<Vec<_>>(),
                "d2min" => r.clone().map(|i| if i % 11 == 0 { f64::NAN } else { i as f64 }).collect::<Vec<_>>(),
                "dt" => r.clone().map(|_| 0.5).collect::<Vec<_>>(),
                "lattice" => r.clone().map(|i| (i % 50_000) as f64).collect::<Vec<_>>(),
                "sparse" => r.map(|i| if i % 3 == 0 { i as f64 } else { f64::NAN }).collect::<Vec<_>>(),
            )
            .unwrap()
        };
        let step = n.div_ceil(chunks);
        let mut df = piece(0, step.min(n));
        for lo in (step..n).step_by(step) {
            df.vstack_mut(&piece(lo, (lo + step).min(n))).unwrap();
        }
        df
    }

    /// The parallel writer's file is, byte for byte, what polars writes for the same
    /// table with the same compression and row groups, and reads back equal (several
    /// row groups, a chunked batch, NaN, strings, booleans; float columns all distinct,
    /// constant, with 50,000 values repeated, mostly NaN, all of which polars writes
    /// plain after estimating their distinct values, which the writer here skips).
    #[test]
    fn parallel_parquet_is_polars_parquet_byte_for_byte() {
        let dir = std::env::temp_dir().join(format!("pp-sink-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let n = 2 * ROW_GROUP + 12_345;
        let df = table(n, 3);
        let ours = dir.join("ours.parquet");
        let rows = stream_table(&ours, df.schema(), |sink| {
            sink.write(&df)?;
            sink.write(&df.slice(0, 10))
        })
        .unwrap();
        assert_eq!(rows, n + 10);
        let mut want = df.clone();
        want.vstack_mut(&df.slice(0, 10)).unwrap();
        let theirs = dir.join("theirs.parquet");
        let mut f = File::create(&theirs).unwrap();
        let mut w = ParquetWriter::new(&mut f)
            .with_compression(COMPRESSION)
            .batched(df.schema())
            .unwrap();
        for part in [df.clone(), df.slice(0, 10)] {
            let mut part = part;
            part.align_chunks_par();
            for at in (0..part.height()).step_by(ROW_GROUP) {
                let mut g = part.slice(at as i64, ROW_GROUP);
                g.rechunk_mut_par();
                w.write_batch(&g).unwrap();
            }
        }
        w.finish().unwrap();
        drop(f);
        assert_eq!(
            std::fs::read(&ours).unwrap(),
            std::fs::read(&theirs).unwrap()
        );
        let back = ParquetReader::new(File::open(&ours).unwrap())
            .finish()
            .unwrap();
        assert!(back.equals_missing(&want));
        std::fs::remove_dir_all(&dir).ok();
    }
}
