//! A fast path for the common case of a plain numeric CSV, such as trackpy's
//! `DataFrame.to_csv` output: one header line, comma-separated unquoted numbers, `\n` or
//! `\r\n` line ends. Only the requested columns are parsed, in chunks on all cores.
//!
//! Anything outside that case (quotes, blank lines, a short row, a value that does not
//! parse, an integer column written as `3.0`, a missing or repeated column) makes the
//! reader answer `Ok(None)`, and the caller reads the file with polars instead, whose
//! path (with `csvdiag`) names the offending line and column. So this reader never
//! decides what is an error; it only makes the clean case fast.

use super::csvdiag::Expect;
use crate::error::{Error, Result};
use memmap2::{Mmap, UncheckedAdvice};
use rayon::prelude::*;
use std::collections::HashMap;
use std::fs::File;
use std::path::Path;

/// One parsed column.
#[derive(Debug, Clone, PartialEq)]
pub enum FastColumn {
    Float(Vec<f64>),
    Int(Vec<i64>),
}

/// Columns by name (only the requested ones present in the header), all of one length.
#[derive(Debug, Clone, PartialEq)]
pub struct FastTable {
    pub columns: HashMap<String, FastColumn>,
    pub rows: usize,
}

impl FastTable {
    /// Move a float column out.
    pub fn take_f64(&mut self, name: &str) -> Option<Vec<f64>> {
        match self.columns.remove(name)? {
            FastColumn::Float(v) => Some(v),
            FastColumn::Int(_) => None,
        }
    }
    /// Move an integer column out.
    pub fn take_i64(&mut self, name: &str) -> Option<Vec<i64>> {
        match self.columns.remove(name)? {
            FastColumn::Int(v) => Some(v),
            FastColumn::Float(_) => None,
        }
    }
}

/// Bytes per parallel chunk: large enough that a chunk's setup is noise, small enough
/// that the chunks balance over the cores.
pub const CHUNK_BYTES: usize = 16 << 20;

/// Read the columns of `expect` that the header names. `Ok(None)`: not a plain
/// numeric CSV, read it another way. `Err`: the file could not be read.
pub fn read_numeric_csv(path: &Path, expect: &[(&str, Expect)]) -> Result<Option<FastTable>> {
    read_numeric_csv_chunked(path, expect, CHUNK_BYTES)
}

/// As `read_numeric_csv` with a chosen chunk size (tests use tiny chunks so that chunk
/// boundaries fall everywhere).
///
/// Two passes over a memory map of the file: count each chunk's lines, then parse every
/// chunk straight into its rows of the final columns. Fresh memory is only the columns
/// themselves (on a VM, first-touching memory costs more than parsing into it), and the
/// map's pages are dropped from this process as each chunk finishes.
pub fn read_numeric_csv_chunked(
    path: &Path,
    expect: &[(&str, Expect)],
    chunk_bytes: usize,
) -> Result<Option<FastTable>> {
    let f = File::open(path).map_err(|e| Error::io(path, e))?;
    if f.metadata().map_err(|e| Error::io(path, e))?.len() == 0 {
        return Ok(None);
    }
    // SAFETY: the map is only read. A file changed by another process while it is read
    // can give wrong values (as with any reader), which the usual tools accept too
    // (polars maps CSV files the same way).
    let map = unsafe { Mmap::map(&f) }.map_err(|e| Error::io(path, e))?;
    let bytes: &[u8] = &map;
    let len = bytes.len();
    let Some(nl) = memchr::memchr(b'\n', &bytes[..len.min(1 << 16)]) else {
        return Ok(None);
    };
    let Some(layout) = Layout::from_header(&bytes[..nl], expect) else {
        return Ok(None);
    };
    // Chunk boundaries: each nominal cut moved to just after the next newline.
    let mut cuts = vec![nl + 1];
    let step = chunk_bytes.max(1);
    let mut next = nl + 1 + step;
    while next < len {
        match memchr::memchr(b'\n', &bytes[next - 1..len.min(next + (1 << 16))]) {
            Some(k) => {
                let cut = next + k;
                if cut > *cuts.last().expect("non-empty") && cut < len {
                    cuts.push(cut);
                }
                next = cut + step;
            }
            // The last line, without a final newline: it ends the last chunk.
            None if next + (1 << 16) >= len => break,
            // A line longer than 64 KiB: not a plain numeric table.
            None => return Ok(None),
        }
    }
    cuts.push(len);
    let chunks: Vec<(usize, usize)> = cuts.windows(2).map(|w| (w[0], w[1])).collect();
    let lines: Vec<usize> = chunks
        .par_iter()
        .map(|&(a, b)| {
            let c = &bytes[a..b];
            memchr::memchr_iter(b'\n', c).count() + usize::from(!c.ends_with(b"\n"))
        })
        .collect();
    let rows: usize = lines.iter().sum();
    if rows == 0 {
        return Ok(None);
    }
    let mut columns: Vec<FastColumn> = layout
        .kinds
        .iter()
        .map(|k| match k {
            Expect::Float => FastColumn::Float(vec![0.0; rows]),
            Expect::Int => FastColumn::Int(vec![0; rows]),
        })
        .collect();
    // Each chunk's rows of every column, as disjoint mutable slices.
    let mut per_chunk: Vec<Vec<ColumnSlice>> = (0..chunks.len()).map(|_| Vec::new()).collect();
    for col in &mut columns {
        match col {
            FastColumn::Float(v) => split_rows(v, &lines, &mut per_chunk, ColumnSlice::Float),
            FastColumn::Int(v) => split_rows(v, &lines, &mut per_chunk, ColumnSlice::Int),
        }
    }
    let ok = chunks
        .par_iter()
        .zip(per_chunk.par_iter_mut())
        .map(|(&(a, b), out)| {
            // A quote can hide a comma or a newline inside a field.
            let chunk = &bytes[a..b];
            let ok = memchr::memchr(b'"', chunk).is_none() && layout.parse(chunk, out);
            // SAFETY: a read-only file map; dropped pages are read again from the page
            // cache if touched, and this chunk is not touched again.
            let _ = unsafe { map.unchecked_advise_range(UncheckedAdvice::DontNeed, a, b - a) };
            ok
        })
        .all(|ok| ok);
    if !ok {
        return Ok(None);
    }
    let columns = layout.names.into_iter().zip(columns).collect();
    Ok(Some(FastTable { columns, rows }))
}

/// One chunk's rows of an output column.
enum ColumnSlice<'a> {
    Float(&'a mut [f64]),
    Int(&'a mut [i64]),
}

/// Which header fields are parsed, into which output column, as what.
struct Layout {
    fields: usize,
    /// Per header field: output column index, or `usize::MAX` to skip.
    slot: Vec<usize>,
    names: Vec<String>,
    kinds: Vec<Expect>,
}

impl Layout {
    fn from_header(line: &[u8], expect: &[(&str, Expect)]) -> Option<Layout> {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        if !line.is_ascii() || line.contains(&b'"') {
            return None;
        }
        let header: Vec<&str> = std::str::from_utf8(line).ok()?.split(',').collect();
        // polars matches names as written; a padded name is the slow path's to judge.
        if header.iter().any(|h| h.trim() != *h) {
            return None;
        }
        let mut slot = vec![usize::MAX; header.len()];
        let (mut names, mut kinds) = (Vec::new(), Vec::new());
        for &(name, kind) in expect {
            let mut at = header.iter().enumerate().filter(|(_, h)| **h == name);
            if let Some((i, _)) = at.next() {
                if at.next().is_some() {
                    return None;
                }
                slot[i] = names.len();
                names.push(name.to_string());
                kinds.push(kind);
            }
        }
        if names.is_empty() {
            return None;
        }
        Some(Layout {
            fields: header.len(),
            slot,
            names,
            kinds,
        })
    }

    /// Parse whole lines into `out` (one slice per output column, exactly one slot per
    /// line); `false` at the first irregularity. One pass over the bytes: wanted fields
    /// are parsed where they stand, the others skipped to their comma.
    fn parse(&self, bytes: &[u8], out: &mut [ColumnSlice]) -> bool {
        let slots = out.first().map_or(0, |c| match c {
            ColumnSlice::Float(v) => v.len(),
            ColumnSlice::Int(v) => v.len(),
        });
        let n = bytes.len();
        let (mut p, mut row) = (0, 0);
        while p < n {
            if row == slots {
                return false;
            }
            for i in 0..self.fields {
                let rest = &bytes[p..];
                let used = match self.slot[i] {
                    usize::MAX => skip_field(rest),
                    k => match &mut out[k] {
                        ColumnSlice::Float(v) => match parse_f64(rest) {
                            Some((x, used)) => {
                                v[row] = x;
                                used
                            }
                            None => return false,
                        },
                        ColumnSlice::Int(v) => match parse_i64(rest) {
                            Some((x, used)) => {
                                v[row] = x;
                                used
                            }
                            None => return false,
                        },
                    },
                };
                let mut e = p + used;
                if i + 1 < self.fields {
                    if bytes.get(e) != Some(&b',') {
                        return false;
                    }
                    p = e + 1;
                } else {
                    if bytes.get(e) == Some(&b'\r') {
                        e += 1;
                    }
                    match bytes.get(e) {
                        Some(b'\n') => p = e + 1,
                        None => p = e,
                        Some(_) => return false,
                    }
                }
            }
            row += 1;
        }
        row == slots
    }
}

/// Length of the field at the start of `b` (up to its comma or line end).
fn skip_field(b: &[u8]) -> usize {
    b.iter()
        .position(|&c| c == b',' || c == b'\n')
        .unwrap_or(b.len())
}

/// Powers of ten that are exact in f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The number at the start of `b` and its length in bytes. Plain decimals with at most
/// 19 digits whose value is m·10^e with m < 2^53 and |e| ≤ 22 take Clinger's fast path
/// (one correctly rounded multiplication or division, so the same double as any exact
/// parser); everything else (`nan`, long mantissas, large exponents) goes to
/// fast-float2 on the whole field.
fn parse_f64(b: &[u8]) -> Option<(f64, usize)> {
    let n = b.len();
    let mut i = 0;
    let neg = match b.first() {
        Some(b'-') => {
            i = 1;
            true
        }
        Some(b'+') => {
            i = 1;
            false
        }
        _ => false,
    };
    let (mut m, mut digits, mut frac) = (0u64, 0u32, 0i32);
    while i < n && b[i].is_ascii_digit() {
        m = m.wrapping_mul(10).wrapping_add((b[i] - b'0') as u64);
        digits += 1;
        i += 1;
    }
    if i < n && b[i] == b'.' {
        i += 1;
        while i < n && b[i].is_ascii_digit() {
            m = m.wrapping_mul(10).wrapping_add((b[i] - b'0') as u64);
            digits += 1;
            frac += 1;
            i += 1;
        }
    }
    let mut exp = 0i32;
    if i < n && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        let eneg = match b.get(j) {
            Some(b'-') => {
                j += 1;
                true
            }
            Some(b'+') => {
                j += 1;
                false
            }
            _ => false,
        };
        let start = j;
        while j < n && b[j].is_ascii_digit() && j - start < 6 {
            exp = exp * 10 + (b[j] - b'0') as i32;
            j += 1;
        }
        if j == start {
            return parse_field_slow(b);
        }
        exp = if eneg { -exp } else { exp };
        i = j;
    }
    let e = exp - frac;
    let at_end = i == n || matches!(b[i], b',' | b'\n' | b'\r');
    if digits == 0 || digits > 19 || m >= (1u64 << 53) || !(-22..=22).contains(&e) || !at_end {
        return parse_field_slow(b);
    }
    let v = if e >= 0 {
        m as f64 * POW10[e as usize]
    } else {
        m as f64 / POW10[(-e) as usize]
    };
    Some((if neg { -v } else { v }, i))
}

/// fast-float2 on the whole field (up to its comma or line end, `\r` excluded).
fn parse_field_slow(b: &[u8]) -> Option<(f64, usize)> {
    let mut end = skip_field(b);
    if end > 0 && b[end - 1] == b'\r' {
        end -= 1;
    }
    fast_float2::parse(&b[..end]).ok().map(|v| (v, end))
}

/// The integer at the start of `b` and its length: optional sign, 1 to 18 digits.
fn parse_i64(b: &[u8]) -> Option<(i64, usize)> {
    let (neg, start) = match b.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let mut v: i64 = 0;
    let mut i = start;
    while i < b.len() && b[i].is_ascii_digit() {
        if i - start == 18 {
            return None;
        }
        v = v * 10 + (b[i] - b'0') as i64;
        i += 1;
    }
    if i == start {
        return None;
    }
    Some((if neg { -v } else { v }, i))
}

/// A column cut into each chunk's rows (`lines[k]` of them for chunk k), each piece
/// wrapped by `wrap` and pushed onto that chunk's list.
fn split_rows<'a, T>(
    v: &'a mut [T],
    lines: &[usize],
    per_chunk: &mut [Vec<ColumnSlice<'a>>],
    wrap: fn(&'a mut [T]) -> ColumnSlice<'a>,
) {
    let mut rest = v;
    for (chunk, &n) in per_chunk.iter_mut().zip(lines) {
        let (h, t) = rest.split_at_mut(n);
        chunk.push(wrap(h));
        rest = t;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::csvdiag::TRACKPY_COLUMNS as EXPECT;
    use crate::io::table::read_table_columns;

    /// A scratch file, removed again when dropped.
    struct TmpFile(std::path::PathBuf);

    impl std::ops::Deref for TmpFile {
        type Target = std::path::PathBuf;
        fn deref(&self) -> &std::path::PathBuf {
            &self.0
        }
    }

    impl AsRef<Path> for TmpFile {
        fn as_ref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TmpFile {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    fn tmp(name: &str, text: &[u8]) -> TmpFile {
        let p = std::env::temp_dir().join(format!("pp-fastcsv-{}-{name}", std::process::id()));
        std::fs::write(&p, text).unwrap();
        TmpFile(p)
    }

    /// The slow path's columns, for comparison.
    fn polars_columns(p: &Path) -> FastTable {
        let t = read_table_columns(p, EXPECT, true).unwrap();
        let mut columns = HashMap::new();
        for (name, kind) in EXPECT {
            let c = match kind {
                Expect::Float => FastColumn::Float(t.f64(name).unwrap()),
                Expect::Int => FastColumn::Int(t.i64(name).unwrap()),
            };
            columns.insert(name.to_string(), c);
        }
        FastTable {
            rows: t.df.height(),
            columns,
        }
    }

    #[test]
    fn numbers_parse_to_the_same_double_as_fast_float() {
        let mut rng = crate::rng::Rng::new(3);
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "-0.0",
            "+1.5",
            "0.1",
            "1e22",
            "1e23",
            "9007199254740992",
            "9007199254740993",
            "123456789012345678901",
            "1.7976931348623157e308",
            "5e-324",
            "1e-400",
            "nan",
            "NaN",
            "inf",
            "-inf",
            ".5",
            "5.",
            "1.5E-3",
            "2e+5",
            "0.000123",
            "00012.5",
            "4.9406564584124654e-324",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for _ in 0..20000 {
            let int = (rng.uniform() * 10f64.powi((rng.uniform() * 12.0) as i32)) as u64;
            let frac_digits = (rng.uniform() * 12.0) as usize;
            let frac: String = (0..frac_digits)
                .map(|_| char::from(b'0' + (rng.uniform() * 10.0) as u8))
                .collect();
            let sign = if rng.uniform() < 0.3 { "-" } else { "" };
            let mut s = format!("{sign}{int}.{frac}");
            if rng.uniform() < 0.2 {
                s += &format!("e{}", (rng.uniform() * 60.0) as i32 - 30);
            }
            cases.push(s);
        }
        for s in &cases {
            let want: f64 = fast_float2::parse(s.as_bytes()).unwrap();
            for tail in ["", ",7", "\n", "\r\n"] {
                let field = format!("{s}{tail}");
                let (got, used) = parse_f64(field.as_bytes()).unwrap();
                assert_eq!(used, s.len(), "{field:?}");
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "{s}: {got:e} vs {want:e}"
                );
            }
        }
        for bad in ["", "-", "abc", "1.2.3", "1e", "1x"] {
            let ok = parse_f64(bad.as_bytes()).is_some_and(|(_, used)| used == bad.len());
            assert!(!ok, "{bad:?} accepted");
        }
        assert_eq!(parse_i64(b"-42,"), Some((-42, 3)));
        assert_eq!(parse_i64(b"1234567890123456789"), None);
        assert_eq!(parse_i64(b"x"), None);
    }

    #[test]
    fn matches_the_polars_reader_at_every_chunk_size_and_line_ending() {
        let p = tmp("gen.csv", b"");
        crate::bench::write_trackpy_csv(&p, 5000, 9).unwrap();
        let lf = std::fs::read(&p).unwrap();
        let want = polars_columns(&p);
        let crlf: Vec<u8> = String::from_utf8(lf.clone())
            .unwrap()
            .replace('\n', "\r\n")
            .into_bytes();
        let no_final_newline = lf[..lf.len() - 1].to_vec();
        // pandas' default to_csv writes the index as an unnamed first column.
        let text = String::from_utf8(lf.clone()).unwrap();
        let indexed: String = text
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i == 0 {
                    format!(",{l}\n")
                } else {
                    format!("{},{l}\n", i - 1)
                }
            })
            .collect();
        for (name, bytes) in [
            ("lf.csv", lf),
            ("crlf.csv", crlf),
            ("nofinal.csv", no_final_newline),
            ("indexed.csv", indexed.into_bytes()),
        ] {
            let p = tmp(name, &bytes);
            for chunk in [1, 7, 100, 4096, CHUNK_BYTES] {
                let got = read_numeric_csv_chunked(&p, EXPECT, chunk)
                    .unwrap()
                    .unwrap_or_else(|| panic!("{name} at chunk {chunk} declined"));
                assert_eq!(got, want, "{name} at chunk {chunk}");
            }
        }
    }

    #[test]
    fn the_bundled_trackpy_sample_takes_the_fast_path_with_the_same_values() {
        let p =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/trackpy-sample/tracks.csv");
        if !p.exists() {
            return;
        }
        let got = read_numeric_csv(&p, EXPECT).unwrap().expect("fast path");
        assert_eq!(got, polars_columns(&p));
    }

    #[test]
    fn anything_unusual_is_left_to_the_slow_path() {
        let head = "y,x,size,frame,particle\n";
        for (what, body) in [
            (
                "quoted header",
                "\"y\",x,size,frame,particle\n1,2,3,0,1\n".to_string(),
            ),
            ("blank line", format!("{head}1,2,3,0,1\n\n1,2,3,1,1\n")),
            ("short row", format!("{head}1,2,3,0\n")),
            ("long row", format!("{head}1,2,3,0,1,9\n")),
            ("malformed number", format!("{head}1,2x,3,0,1\n")),
            ("empty value", format!("{head}1,,3,0,1\n")),
            ("integer written as float", format!("{head}1,2,3,0.0,1\n")),
            ("space in a value", format!("{head}1, 2,3,0,1\n")),
            (
                "padded header name",
                "y, x,size,frame,particle\n1,2,3,0,1\n".to_string(),
            ),
            (
                "quoted field with a newline",
                "y,x,size,frame,particle,note\n1,2,3,0,1,\"a\n4,5,6,1,2,b\"\n".to_string(),
            ),
            ("header only", head.to_string()),
            (
                "repeated column",
                "x,x,y,size,frame,particle\n1,1,2,3,0,1\n".to_string(),
            ),
        ] {
            let p = tmp("odd.csv", body.as_bytes());
            for chunk in [1, CHUNK_BYTES] {
                assert!(
                    read_numeric_csv_chunked(&p, EXPECT, chunk)
                        .unwrap()
                        .is_none(),
                    "{what} (chunk {chunk}) was read by the fast path"
                );
            }
        }
        // A missing column is simply absent; the caller decides.
        let p = tmp("nosize.csv", b"y,x,frame,particle\n1,2,0,1\n");
        let t = read_numeric_csv(&p, EXPECT).unwrap().unwrap();
        assert!(!t.columns.contains_key("size"));
        assert_eq!(t.rows, 1);
    }
}
