//! A structural check of a Parquet file before polars decodes it. polars sizes its
//! buffers from each page header's value count without checking it against the column
//! chunk's: a corrupt count (issue 24's fuzz found 2^61) makes it ask for exabytes, and a
//! failed allocation aborts the process — no panic to catch, no file named. Walking the
//! page headers (no decompression) and bounding every count by its chunk's, and those
//! by the file's size, turns that into an error naming the file, row group and column.

use crate::error::{Error, Result};
use polars_parquet::parquet::page::CompressedPage;
use polars_parquet::parquet::read::{get_page_iterator, read_metadata};
use std::path::Path;

/// Values a file of `len` bytes may claim per column chunk: run-length encoding packs
/// many values per byte, but not a thousand (plus room for tiny files of constants).
fn max_values(len: u64) -> u64 {
    len.saturating_mul(1000).saturating_add(1_000_000)
}

/// Refuse a Parquet file whose metadata or page headers claim more values than it can
/// hold. Memory-maps the file; reads only the footer and the page headers.
pub fn check(path: &Path) -> Result<()> {
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    check_file(&f, path)
}

/// As [`check`], on the open file `f` (named `path` in errors).
pub fn check_file(f: &std::fs::File, path: &Path) -> Result<()> {
    let file = path.display().to_string();
    // SAFETY: the map is read only; a file truncated under us by another process could
    // fault, as any reader of a file being rewritten can fail; ours are written under a
    // temporary name and renamed, never rewritten in place.
    let map = unsafe { memmap2::Mmap::map(f) }.map_err(|e| Error::io(path, e))?;
    let len = map.len() as u64;
    let bad = |msg: String| Error::input(&file, format!("reading Parquet: corrupt file: {msg}"));
    let meta = read_metadata(&mut std::io::Cursor::new(&map[..]))
        .map_err(|e| bad(format!("footer: {e}")))?;
    let cap = max_values(len);
    if meta.num_rows as u64 > cap {
        return Err(bad(format!(
            "the footer claims {} rows in {len} bytes",
            meta.num_rows
        )));
    }
    let buffer = polars_buffer::Buffer::from_owner(map);
    for (g, rg) in meta.row_groups.iter().enumerate() {
        for col in rg.parquet_columns() {
            let name = col.descriptor().path_in_schema.join(".");
            let at = |what: String| bad(format!("row group {g}, column '{name}': {what}"));
            let total = col.num_values();
            if total < 0 || total as u64 > cap {
                return Err(at(format!("claims {total} values in {len} bytes")));
            }
            let pages = get_page_iterator(
                col,
                std::io::Cursor::new(buffer.clone()),
                Vec::new(),
                len as usize,
            )
            .map_err(|e| at(e.to_string()))?;
            for page in pages {
                if let CompressedPage::Data(p) = page.map_err(|e| at(e.to_string()))?
                    && p.num_values() as i64 > total
                {
                    return Err(at(format!(
                        "a page claims {} values, its column chunk {total}",
                        p.num_values()
                    )));
                }
            }
        }
    }
    Ok(())
}
