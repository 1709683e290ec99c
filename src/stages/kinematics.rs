//! `kinematics`: canonical tracks → the per-particle `kinematics` table for every
//! (start frame, lag) requested, computed and written in blocks of rows so output memory
//! stays bounded however large a frame.

use super::timing::{Phase, PhaseTimer};
use crate::error::{Error, Result};
use crate::io::kinematics_io::{Selection, kinematics_dataframe, kinematics_schema};
use crate::io::sink::stream_table;
use crate::io::{read_tracks, sha256_file, write_with_sidecar};
use crate::kinematics::{Convention, FramePair, KinematicsParams, PairCounts};
use crate::tracks::Tracks;
use polars::prelude::DataFrame;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// How far apart the two frames of a pair are.
#[derive(Debug, Clone, PartialEq)]
pub enum LagSpec {
    /// In frames, one or several.
    Frames(Vec<i64>),
    /// In seconds, mapped to the nearest whole number of frames.
    Time(f64),
}

#[derive(Debug, Clone)]
pub struct KinematicsOptions {
    pub lag: LagSpec,
    /// Neighbour cutoff R_c (length unit); default 1.25 D.
    pub rc: Option<f64>,
    /// Only this start frame (default: every start frame, stepped by `every`).
    pub start: Option<i64>,
    /// Step between start frames (default: the lag).
    pub every: Option<i64>,
    pub convention: Convention,
    /// The columns to write (the keys always; default every column).
    pub columns: Selection,
    pub quiet: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct KinematicsReport {
    pub input: String,
    pub output: String,
    /// R_c used, length unit.
    pub rc: f64,
    /// Large-grain diameter D, length unit.
    pub d_large: f64,
    pub length_unit: String,
    /// Unit of `dt` ("s", or "frame" without a frame time).
    pub time_unit: String,
    pub convention: Convention,
    pub lags: Vec<i64>,
    pub frame_pairs: usize,
    pub rows: usize,
    /// The columns written, in order.
    pub columns: Vec<&'static str>,
    pub counts: PairCounts,
    pub warnings: Vec<String>,
    /// Wall time per phase ([`PHASES`]), seconds.
    pub timings: Vec<Phase>,
}

impl std::fmt::Display for KinematicsReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = &self.counts;
        writeln!(f, "kinematics    {} -> {}", self.input, self.output)?;
        writeln!(
            f,
            "pairs         {} frame pairs, lags {:?} frames, {} rows",
            self.frame_pairs, self.lags, self.rows
        )?;
        if self.columns.len() < crate::io::kinematics_io::COLUMNS.len() {
            writeln!(f, "columns       {}", self.columns.join(", "))?;
        }
        writeln!(
            f,
            "neighbours    R_c = {:.5} {} (1.25 D = {:.5}), convention {:?}",
            self.rc,
            self.length_unit,
            1.25 * self.d_large,
            self.convention
        )?;
        writeln!(
            f,
            "invalid       {} with < 2 neighbours, {} singular (collinear neighbours)",
            c.invalid_few_neighbors, c.invalid_singular
        )?;
        write!(
            f,
            "skipped       {} present only at t, {} only at t+dt",
            c.missing_at_end, c.missing_at_start
        )
    }
}

/// Default output beside the input: `name.tracks.parquet` → `name.kinematics.parquet`.
pub fn default_output(input: &Path) -> PathBuf {
    let stem = input
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "tracks".into());
    let stem = stem.strip_suffix(".tracks").unwrap_or(&stem).to_string();
    input.with_file_name(format!("{stem}.kinematics.parquet"))
}

/// Time of each frame: the `time` column, else frame × frame_time, else the frame index.
fn frame_times(t: &Tracks, ranges: &[(i64, Range<usize>)]) -> (BTreeMap<i64, f64>, String) {
    let unit;
    let m = match (&t.time, t.meta.frame_time) {
        (Some(time), _) => {
            unit = t.meta.time_unit.clone();
            ranges.iter().map(|(f, r)| (*f, time[r.start])).collect()
        }
        (None, Some(dt)) => {
            unit = t.meta.time_unit.clone();
            ranges.iter().map(|(f, _)| (*f, *f as f64 * dt)).collect()
        }
        (None, None) => {
            unit = "frame".into();
            ranges.iter().map(|(f, _)| (*f, *f as f64)).collect()
        }
    };
    (m, unit)
}

/// The (start, end) frame pairs to compute.
pub fn plan_pairs(
    frames: &[i64],
    lags: &[i64],
    start: Option<i64>,
    every: Option<i64>,
) -> Vec<(i64, i64)> {
    let (Some(&first), Some(&last)) = (frames.first(), frames.last()) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for &lag in lags {
        match start {
            Some(s) => out.push((s, s + lag)),
            None => {
                let step = every.unwrap_or(lag).max(1);
                let mut s = first;
                while s + lag <= last {
                    out.push((s, s + lag));
                    s += step;
                }
            }
        }
    }
    out
}

/// Rows per block, each written as one Parquet row group. Small enough that the
/// blocks in flight hold little memory (a million-particle pair peaked at 414 MB with
/// blocks of 2^18 rows, 333 MB with 2^16, and ran 0.38 s against 0.35 s: fresh memory
/// costs page faults, which on these VMs can take longer than the computing), large
/// enough for Parquet's per-group overhead (2^16 rows are 12 MB of columns).
const BLOCK_ROWS: usize = 1 << 16;

/// The phases `--timings` reports, in order.
pub const PHASES: [&str; 5] = [
    "read + hash",
    "other",
    "compute",
    "compute ‖ write",
    "write",
];

/// The kinematics table's rows in blocks of about [`BLOCK_ROWS`], frame pair after frame
/// pair: a pair larger than a block is split (its setup, the pairing and cell list,
/// built once for its blocks), and consecutive smaller pairs share a block, computed in
/// parallel, one pair per task (a movie of a few thousand particles a frame otherwise
/// computes each pair on one thread and writes a row group per pair).
struct Blocks<'t> {
    tracks: &'t Tracks,
    ranges: &'t [(i64, Range<usize>)],
    index: &'t BTreeMap<i64, usize>,
    times: &'t BTreeMap<i64, f64>,
    file: &'t str,
    params: KinematicsParams,
    columns: &'t Selection,
    pairs: &'t [(i64, i64)],
    next_pair: usize,
    /// The pair being split, its start and end frames, and its next row.
    current: Option<(FramePair<'t>, (i64, i64), usize)>,
}

impl<'t> Blocks<'t> {
    /// Pair `(fa, fb)` set up.
    fn pair(&self, (fa, fb): (i64, i64)) -> Result<FramePair<'t>> {
        let a = self.tracks.view(fa, self.ranges[self.index[&fa]].1.clone());
        let b = self.tracks.view(fb, self.ranges[self.index[&fb]].1.clone());
        let dt = self.times[&fb] - self.times[&fa];
        if !(dt > 0.0) {
            return Err(Error::input(
                self.file,
                format!("frames {fa} and {fb} have non-increasing times (dt = {dt})"),
            ));
        }
        FramePair::new(a, &b, dt, &self.params)
    }

    /// Rows of pair `(fa, fb)` at most (those of its first frame).
    fn rows_at_most(&self, (fa, _): (i64, i64)) -> usize {
        self.ranges[self.index[&fa]].1.len()
    }

    /// The next block as a table and its counts (a pair's pairing counts come with its
    /// first block); `None` after the last.
    fn next_block(
        &mut self,
        bar: &indicatif::ProgressBar,
    ) -> Option<Result<(DataFrame, PairCounts)>> {
        if self.current.is_none() {
            let first = *self.pairs.get(self.next_pair)?;
            if self.rows_at_most(first) <= BLOCK_ROWS {
                return Some(self.small_pairs(bar));
            }
            self.next_pair += 1;
            match self.pair(first) {
                Ok(p) => self.current = Some((p, first, 0)),
                Err(e) => return Some(Err(e)),
            }
        }
        let (pair, (fa, fb), from) = self.current.as_mut().expect("set above");
        let mut counts = PairCounts::default();
        if *from == 0 {
            counts = pair.pairing_counts();
        }
        let rows = *from..(*from + BLOCK_ROWS).min(pair.len());
        let ks = pair.columns_of(rows.clone(), self.columns.floats());
        counts.add(&FramePair::block_counts(&ks));
        let df = kinematics_dataframe(*fa, *fb, pair.dt(), ks, self.columns);
        *from = rows.end;
        if rows.end == pair.len() {
            self.current = None;
            bar.inc(1);
        }
        Some(df.map(|df| (df, counts)))
    }

    /// The next pairs of at most a block's rows together, as one block (at least one
    /// pair); the first error in pair order, if any.
    fn small_pairs(&mut self, bar: &indicatif::ProgressBar) -> Result<(DataFrame, PairCounts)> {
        let (from, mut rows) = (self.next_pair, 0);
        while let Some(&p) = self.pairs.get(self.next_pair) {
            let r = self.rows_at_most(p);
            if self.next_pair > from && (rows + r > BLOCK_ROWS) {
                break;
            }
            rows += r;
            self.next_pair += 1;
        }
        let group = &self.pairs[from..self.next_pair];
        let this = &*self;
        let parts: Vec<Result<(DataFrame, PairCounts)>> = group
            .par_iter()
            .map(|&(fa, fb)| {
                let pair = this.pair((fa, fb))?;
                let ks = pair.columns_of(0..pair.len(), this.columns.floats());
                let mut counts = pair.pairing_counts();
                counts.add(&FramePair::block_counts(&ks));
                Ok((
                    kinematics_dataframe(fa, fb, pair.dt(), ks, this.columns)?,
                    counts,
                ))
            })
            .collect();
        bar.inc(group.len() as u64);
        let mut block: Option<(DataFrame, PairCounts)> = None;
        for part in parts {
            let (df, c) = part?;
            match &mut block {
                None => block = Some((df, c)),
                Some((all, counts)) => {
                    all.vstack_mut_owned(df)
                        .map_err(|e| Error::polars("joining frame pairs", e))?;
                    counts.add(&c);
                }
            }
        }
        Ok(block.expect("at least one pair"))
    }
}

pub fn run(input: &Path, output: &Path, opt: &KinematicsOptions) -> Result<KinematicsReport> {
    let file = input.display().to_string();
    let mut clock = PhaseTimer::default();
    // The provenance hash reads the file a second time: on its own thread, it is done
    // by the time the tracks are decoded.
    let (read, source_sha256) = std::thread::scope(|s| {
        let hash = s.spawn(|| sha256_file(input));
        let read = read_tracks(input);
        let hashed = hash
            .join()
            .unwrap_or_else(|_| Err(Error::input(&file, "hashing the input failed")));
        (read, hashed)
    });
    let (tracks, mut warnings) = read?;
    let source_sha256 = source_sha256?;
    clock.lap("read + hash");
    let ranges = tracks.frame_ranges();
    let d_large = tracks
        .large_diameter()
        .ok_or_else(|| Error::input(&file, "no rows"))?;
    let rc = opt.rc.unwrap_or(1.25 * d_large);
    if !(rc > 0.0 && rc.is_finite()) {
        return Err(Error::param(
            "rc",
            format!("{rc} must be a positive length"),
        ));
    }
    let (times, time_unit) = frame_times(&tracks, &ranges);
    let lags = match &opt.lag {
        LagSpec::Frames(l) => l.clone(),
        LagSpec::Time(s) => {
            let ft = tracks.meta.frame_time.ok_or_else(|| {
                Error::param(
                    "lag-time",
                    format!("{file} has no frame time; give --lag in frames"),
                )
            })?;
            let lag = (s / ft).round() as i64;
            if ((lag as f64) * ft - s).abs() > 1e-9 * s.abs().max(1.0) {
                warnings.push(format!(
                    "--lag-time {s} s is not a whole number of frames ({ft} s each): using {lag} frames = {} s",
                    lag as f64 * ft
                ));
            }
            vec![lag]
        }
    };
    if let Some(bad) = lags.iter().find(|&&l| l < 1) {
        return Err(Error::param("lag", format!("lag {bad} must be >= 1 frame")));
    }
    if let Some(e) = opt.every
        && e < 1
    {
        return Err(Error::param("every", format!("{e} must be >= 1 frame")));
    }
    let index: BTreeMap<i64, usize> = ranges
        .iter()
        .enumerate()
        .map(|(k, (f, _))| (*f, k))
        .collect();
    let frames: Vec<i64> = index.keys().copied().collect();
    let planned = plan_pairs(&frames, &lags, opt.start, opt.every);
    let pairs: Vec<(i64, i64)> = planned
        .iter()
        .copied()
        .filter(|(a, b)| index.contains_key(a) && index.contains_key(b))
        .collect();
    if pairs.len() < planned.len() {
        warnings.push(format!(
            "{} of {} frame pairs skipped: a frame is absent from the tracks",
            planned.len() - pairs.len(),
            planned.len()
        ));
    }
    if pairs.is_empty() {
        return Err(Error::param(
            "lag",
            format!(
                "no frame pair with lags {lags:?} fits in frames {}..{} of {file}",
                frames.first().unwrap_or(&0),
                frames.last().unwrap_or(&0)
            ),
        ));
    }
    let params = KinematicsParams {
        rc,
        convention: opt.convention,
    };
    let mut counts = PairCounts::default();
    let bar = crate::stages::progress(pairs.len() as u64, "kinematics", opt.quiet);
    let mut meta = serde_json::json!({
        "table": "kinematics",
        "length_unit": tracks.meta.length_unit,
        "time_unit": time_unit,
        "d_large": d_large,
        "rc": rc,
        "convention": opt.convention,
        "lags": lags,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": file, "source_sha256": source_sha256,
            "parameters": {"lags": lags, "rc": rc, "start": opt.start, "every": opt.every, "convention": opt.convention},
        },
        "bar_speed": tracks.meta.bar_speed,
    });
    // Only a partial table says which columns it has (a full one is as before).
    if !opt.columns.is_all() {
        let names = opt.columns.names();
        meta["columns"] = serde_json::json!(names);
        meta["provenance"]["parameters"]["columns"] = serde_json::json!(names);
    }
    let meta = serde_json::to_string_pretty(&meta).expect("json");
    let mut blocks = Blocks {
        tracks: &tracks,
        ranges: &ranges,
        index: &index,
        times: &times,
        file: &file,
        params,
        columns: &opt.columns,
        pairs: &pairs,
        next_pair: 0,
        current: None,
    };
    let rows = write_with_sidecar(output, &meta, || {
        stream_table(output, &kinematics_schema(&opt.columns), |sink| {
            clock.lap("other");
            // Block by block (one Parquet row group each, every frame pair in turn):
            // each block's writing overlaps the computing of the next (`rayon::join`;
            // both share the threads), and only two blocks' columns are ever held.
            let mut done = blocks.next_block(&bar).transpose()?;
            clock.lap("compute");
            while let Some((df, c)) = done {
                counts.add(&c);
                let (next, written) = rayon::join(|| blocks.next_block(&bar), || sink.write(&df));
                written?;
                done = next.transpose()?;
                clock.lap(if done.is_some() {
                    "compute ‖ write"
                } else {
                    "write"
                });
            }
            Ok(())
        })
    })?;
    clock.lap("write");
    bar.finish_and_clear();
    Ok(KinematicsReport {
        input: file,
        output: output.display().to_string(),
        rc,
        d_large,
        length_unit: tracks.meta.length_unit.clone(),
        time_unit,
        convention: opt.convention,
        lags,
        frame_pairs: pairs.len(),
        rows,
        columns: opt.columns.names(),
        counts,
        warnings,
        timings: clock.finish(),
    })
}
