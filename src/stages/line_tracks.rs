//! `pillar-pipe shear-line-tracks`: the shear lines of every frame pair of a
//! `kinematics` table, linked across consecutive pairs (li-granular-pillars Sec. V:
//! "these shear lines are transient in time"). The rule and the measures are
//! `structure::line_tracks`'; this picks the pairs, detects, links and writes one row
//! per line with its track (the `shear_lines` table plus `track` and `track_pairs`).

use crate::error::{Error, Result};
use crate::geom::Vec2;
use crate::io::table::write_table;
use crate::io::{sha256_file, sidecar_path, write_with_sidecar};
use crate::stages::shear_lines::{diameter, lines_table, read_kinematics};
use crate::structure::line_tracks::{
    LineTracks, LinkOptions, PairLines, TrackSummary, line_ids, link,
};
use crate::structure::{ShearLine, ShearLineOptions, shear_lines};
use polars::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Default)]
pub struct TracksOptions {
    /// Large-grain diameter D (length unit); default: the table's sidecar `d_large`.
    pub diameter: Option<f64>,
    pub detect: ShearLineOptions,
    pub link: LinkOptions,
}

/// One run's lines, pair by pair, and their tracks.
#[derive(Debug, Clone)]
pub struct Tracked {
    /// (frame, frame_end, Δt in the table's time unit, NaN without a `dt` column) of the
    /// pairs used, in time order.
    pub pairs: Vec<(i64, i64, f64)>,
    /// Pairs of the table left out: other lags, or overlapping the pairs used.
    pub skipped: usize,
    pub lines: Vec<Vec<ShearLine>>,
    pub tracks: LineTracks,
    pub d_large: f64,
    /// The table's units, from its sidecar ("length", "time" without one).
    pub length_unit: String,
    pub time_unit: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct TracksReport {
    pub input: String,
    pub output: String,
    pub d_large: f64,
    pub length_unit: String,
    pub time_unit: String,
    pub pairs: usize,
    pub skipped_pairs: usize,
    /// Δt of the pairs (time unit), NaN without a `dt` column.
    pub dt: f64,
    pub detect: ShearLineOptions,
    pub link: LinkOptions,
    pub summary: TrackSummary,
}

/// Default output beside the input: `name.kinematics.parquet` → `name.shear_line_tracks.csv`.
pub fn default_output(input: &Path) -> PathBuf {
    let p = crate::stages::shear_lines::default_output(input);
    let name = p
        .file_name()
        .map(|n| {
            n.to_string_lossy()
                .replace(".shear_lines.csv", ".shear_line_tracks.csv")
        })
        .unwrap_or_else(|| "shear_line_tracks.csv".into());
    p.with_file_name(name)
}

/// The lines of the table's pairs at its smallest lag, each starting where the one
/// before ends (the first pair kept, then greedily), linked.
pub fn analyse(input: &Path, opt: &TracksOptions) -> Result<Tracked> {
    let t = read_kinematics(input)?;
    t.require(&["particle"])?;
    let meta: Option<serde_json::Value> = std::fs::read_to_string(sidecar_path(input))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok());
    let d = diameter(input, &t.file, meta.as_ref(), opt.diameter)?;
    let (frame, frame_end) = (t.i64("frame")?, t.i64("frame_end")?);
    let particle = t.i64("particle")?;
    let (x, y, j2) = (t.f64("x")?, t.f64("y")?, t.f64_or_nan("j2")?);
    let dt_col = if t.has("dt") {
        Some(t.f64_or_nan("dt")?)
    } else {
        None
    };
    let mut rows: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
    for i in 0..frame.len() {
        rows.entry((frame[i], frame_end[i])).or_default().push(i);
    }
    let Some(lag) = rows.keys().map(|(a, b)| b - a).min() else {
        return Err(Error::input(&t.file, "has no rows: no frame pair to link"));
    };
    let mut kept: Vec<(i64, i64)> = Vec::new();
    for &(a, b) in rows.keys().filter(|(a, b)| b - a == lag) {
        if kept.last().is_none_or(|&(_, end)| a >= end) {
            kept.push((a, b));
        }
    }
    let skipped = rows.len() - kept.len();
    let mut pairs = Vec::with_capacity(kept.len());
    let mut lines = Vec::with_capacity(kept.len());
    let mut by_pair = Vec::with_capacity(kept.len());
    for (a, b) in kept {
        let r = &rows[&(a, b)];
        let pos: Vec<Vec2> = r.iter().map(|&i| Vec2::new(x[i], y[i])).collect();
        let j: Vec<f64> = r.iter().map(|&i| j2[i]).collect();
        let ids: Vec<i64> = r.iter().map(|&i| particle[i]).collect();
        let found = shear_lines(&pos, &j, d, &opt.detect)?;
        by_pair.push(PairLines {
            frame: a,
            frame_end: b,
            grains: found.summary.determined,
            lines: line_ids(&found.lines, &ids),
        });
        pairs.push((a, b, dt_col.as_ref().map_or(f64::NAN, |c| c[r[0]])));
        lines.push(found.lines);
    }
    let tracks = link(&by_pair, &opt.link);
    let unit = |k: &str, none: &str| {
        meta.as_ref()
            .and_then(|m| m[k].as_str())
            .unwrap_or(none)
            .to_string()
    };
    Ok(Tracked {
        length_unit: unit("length_unit", "length"),
        time_unit: unit("time_unit", "time"),
        pairs,
        skipped,
        lines,
        tracks,
        d_large: d,
    })
}

/// [`analyse`], then the table of every line with its track at `output`.
pub fn run(input: &Path, output: &Path, opt: &TracksOptions) -> Result<TracksReport> {
    if !(opt.link.min_overlap > 0.0 && opt.link.min_overlap <= 1.0) {
        return Err(Error::param(
            "min-overlap",
            format!("{} must be in (0, 1]", opt.link.min_overlap),
        ));
    }
    let a = analyse(input, opt)?;
    let rep = TracksReport {
        input: input.display().to_string(),
        output: output.display().to_string(),
        d_large: a.d_large,
        length_unit: a.length_unit.clone(),
        time_unit: a.time_unit.clone(),
        pairs: a.pairs.len(),
        skipped_pairs: a.skipped,
        dt: a.pairs.first().map_or(f64::NAN, |p| p.2),
        detect: opt.detect,
        link: opt.link,
        summary: a.tracks.summary.clone(),
    };
    let mut rows = Vec::new();
    let (mut track, mut track_pairs) = (Vec::new(), Vec::new());
    for (k, ls) in a.lines.iter().enumerate() {
        for (l, line) in ls.iter().enumerate() {
            rows.push((a.pairs[k].0, a.pairs[k].1, line));
            let id = a.tracks.track[k][l];
            track.push(id as i64);
            track_pairs.push(a.tracks.lifetime[id] as i64);
        }
    }
    let mut df = lines_table(&rows)?;
    df.with_column(Column::new("track".into(), track))
        .and_then(|df| df.with_column(Column::new("track_pairs".into(), track_pairs)))
        .map_err(|e| Error::polars("the shear-line tracks table", e))?;
    let sidecar = serde_json::json!({
        "table": "shear_lines",
        "length_unit": rep.length_unit,
        "time_unit": rep.time_unit,
        "d_large": a.d_large,
        "dt": rep.dt,
        "tracks": rep.summary,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": rep.input, "source_sha256": sha256_file(input)?,
            "parameters": {"diameter": opt.diameter, "detect": opt.detect, "link": opt.link},
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || write_table(&mut df, output))?;
    Ok(rep)
}

impl std::fmt::Display for TracksReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.summary;
        writeln!(
            f,
            "line tracks {}: {} frame pairs of dt = {} {} linked ({} other pairs left out), D = {} {}",
            self.input,
            self.pairs,
            self.dt,
            self.time_unit,
            self.skipped_pairs,
            self.d_large,
            self.length_unit
        )?;
        writeln!(
            f,
            "lines       {} in {} tracks: {:.2} per pair, {:.2} born per pair",
            s.lines, s.tracks, s.lines_per_pair, s.births_per_pair
        )?;
        let hist: Vec<String> = s
            .lifetime_counts
            .iter()
            .enumerate()
            .map(|(l, c)| format!("{}:{c}", l + 1))
            .collect();
        writeln!(
            f,
            "lifetime    mean {:.2} pairs ({:.4} {}) over {} uncensored tracks, {:.0} % lived one pair; pairs:count {}; {} censored (alive at the first or last pair)",
            s.mean_lifetime,
            s.mean_lifetime * self.dt,
            self.time_unit,
            s.lifetime_counts.iter().sum::<usize>(),
            100.0 * s.single_pair_fraction,
            if hist.is_empty() {
                "-".into()
            } else {
                hist.join(" ")
            },
            s.censored
        )?;
        write!(
            f,
            "persistence {:.0} % of lines continue into the next pair; {:.0} % of line grains are in a line again (chance {:.0} %)",
            100.0 * s.continued_fraction,
            100.0 * s.grain_persistence,
            100.0 * s.grain_chance
        )
    }
}
