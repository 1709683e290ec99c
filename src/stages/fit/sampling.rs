//! The sampling protocol of Li et al. Sec. IV for `fit`: (η^s, D²min/R²) pairs from
//! tracks (start times every (2/3) R/v_c, lags {2, 4, …, 128}/15 R/v_c mapped to the
//! nearest frames, R_c = 1.25 D) or from a `kinematics` table as it is.

use crate::error::{Error, Result};
use crate::fit::Samples;
use crate::io::csvdiag::Expect;
use crate::io::table::{ParquetColumns, Table, TableFormat, read_table};
use crate::kinematics::{Convention, KinematicsParams, frame_pair};
use crate::stages::fit::{
    FitOptions, MIN_NEIGHBORS_FOR_D2MIN, MIN_STARTS, Protocol, START_SPACING, default_lags,
};
use crate::tracks::Tracks;
use std::collections::BTreeMap;
use std::path::Path;

/// One row of the scatter table.
#[derive(Default)]
pub(crate) struct ScatterRows {
    pub(crate) start: Vec<i64>,
    pub(crate) end: Vec<i64>,
    pub(crate) particle: Vec<i64>,
    pub(crate) species: Vec<i32>,
    pub(crate) eta_s: Vec<f64>,
    pub(crate) y: Vec<f64>,
}

fn nearest_frame(frames: &[i64], times: &BTreeMap<i64, f64>, t: f64) -> i64 {
    *frames
        .iter()
        .min_by(|a, b| (times[a] - t).abs().total_cmp(&(times[b] - t).abs()))
        .expect("non-empty")
}

/// Run the protocol on tracks: samples plus the protocol actually used.
pub(crate) fn from_tracks(
    input: &Path,
    tracks: &Tracks,
    opt: &FitOptions,
    warnings: &mut Vec<String>,
) -> Result<(Samples, ScatterRows, Protocol)> {
    let file = input.display().to_string();
    let d = match opt.diameter {
        Some(d) => d,
        None => tracks
            .large_diameter()
            .ok_or_else(|| Error::input(&file, "no rows"))?,
    };
    let r = 0.5 * d;
    let v = opt.bar_speed.or(tracks.meta.bar_speed).ok_or_else(|| {
        Error::param(
            "bar-speed",
            format!("{file}: no bar speed v_c in the metadata; pass --bar-speed (length unit/s): times are in R/v_c"),
        )
    })?;
    let tau = r / v;
    let ranges = tracks.frame_ranges();
    let ft = tracks.meta.frame_time.unwrap_or(1.0);
    let times: BTreeMap<i64, f64> = ranges
        .iter()
        .map(|(f, rg)| {
            (
                *f,
                tracks.time.as_ref().map_or(*f as f64 * ft, |t| t[rg.start]),
            )
        })
        .collect();
    let frames: Vec<i64> = times.keys().copied().collect();
    let (first, last) = (frames[0], *frames.last().expect("rows"));
    let t0 = times[&first];
    let lags_req = opt.lags.clone().unwrap_or_else(default_lags);
    let mut lags_frames: Vec<i64> = Vec::new();
    for &l in &lags_req {
        let lf = ((l * tau / ft).round() as i64).max(1);
        if !lags_frames.contains(&lf) {
            lags_frames.push(lf);
        }
    }
    lags_frames.sort_unstable();
    let lags_used: Vec<f64> = lags_frames.iter().map(|&l| l as f64 * ft / tau).collect();
    for (&req, lf) in lags_req.iter().zip(
        lags_req
            .iter()
            .map(|&l| ((l * tau / ft).round() as i64).max(1)),
    ) {
        let got = lf as f64 * ft / tau;
        if (got / req - 1.0).abs() > 0.1 {
            warnings.push(format!(
                "lag {req:.3} R/v_c maps to {lf} frame(s) = {got:.3} R/v_c ({:+.0}%): frames are {ft} s, R/v_c = {tau:.3} s",
                100.0 * (got / req - 1.0)
            ));
        }
    }
    let max_lag = *lags_frames.last().expect("lags");
    let starts_req: Vec<f64> = match &opt.starts {
        Some(s) => s.clone(),
        None => (0..)
            .map(|k| k as f64 * START_SPACING)
            .take_while(|s| t0 + s * tau <= times[&last] + 1e-9)
            .collect(),
    };
    let mut start_frames: Vec<i64> = Vec::new();
    for s in &starts_req {
        let f = nearest_frame(&frames, &times, t0 + s * tau);
        if !start_frames.contains(&f) && f + lags_frames[0] <= last {
            start_frames.push(f);
        }
    }
    let full = start_frames
        .iter()
        .filter(|&&s| s + max_lag <= last)
        .count();
    if start_frames.len() < MIN_STARTS {
        warnings.push(format!(
            "{} start times (the protocol asks for at least {MIN_STARTS}): the run is short for spacing {:.3} R/v_c",
            start_frames.len(),
            START_SPACING
        ));
    }
    if full < start_frames.len() {
        warnings.push(format!(
            "{} of {} starts are too late for the longest lag ({max_lag} frames) and contribute only shorter lags",
            start_frames.len() - full,
            start_frames.len()
        ));
    }
    let index: BTreeMap<i64, usize> = ranges
        .iter()
        .enumerate()
        .map(|(k, (f, _))| (*f, k))
        .collect();
    let params = KinematicsParams {
        rc: opt.rc_over_d * d,
        convention: Convention::Paper,
    };
    let mut s = Samples::default();
    let mut rows = ScatterRows::default();
    let bar = crate::stages::progress(
        (start_frames.len() * lags_frames.len()) as u64,
        "fit sampling",
        opt.quiet,
    );
    let (mut two_neighbours, mut at_rest) = (0usize, 0usize);
    for (g, &fs) in start_frames.iter().enumerate() {
        for &lf in &lags_frames {
            bar.inc(1);
            let fe = fs + lf;
            let (Some(&ia), Some(&ib)) = (index.get(&fs), index.get(&fe)) else {
                continue;
            };
            let a = tracks.view(fs, ranges[ia].1.clone());
            let b = tracks.view(fe, ranges[ib].1.clone());
            let (ks, _) = frame_pair(&a, &b, times[&fe] - times[&fs], &params)?;
            two_neighbours += ks
                .iter()
                .filter(|k| k.valid && k.n_neighbors < MIN_NEIGHBORS_FOR_D2MIN)
                .count();
            for k in ks
                .iter()
                .filter(|k| k.valid && k.n_neighbors >= MIN_NEIGHBORS_FOR_D2MIN)
            {
                if k.strain.eta_s < ETA_S_AT_REST {
                    at_rest += 1;
                    continue;
                }
                let y = k.d2min / (r * r);
                s.push_lag(
                    k.strain.eta_s,
                    y,
                    g as u32,
                    lf.clamp(0, u32::MAX as i64) as u32,
                );
                rows.start.push(fs);
                rows.end.push(fe);
                rows.particle.push(k.particle);
                rows.species.push(k.species);
                rows.eta_s.push(k.strain.eta_s);
                rows.y.push(y);
            }
        }
    }
    bar.finish_and_clear();
    note_two_neighbours(two_neighbours, warnings);
    note_at_rest(at_rest, warnings);
    let protocol = Protocol {
        source: "tracks".into(),
        diameter: d,
        rc_over_d: opt.rc_over_d,
        bar_speed: Some(v),
        time_scale: Some(tau),
        lags_frames,
        lags_requested: lags_req,
        lags_used,
        start_frames,
        binning: opt.binning,
    };
    Ok((s, rows, protocol))
}

/// A `kinematics` table's columns: a CSV read whole, a Parquet file a column at a time
/// (only the eight the fit reads, never polars' copy of all 24 beside ours: 1.4 GB at
/// 4 M rows).
enum Columns {
    Whole(Table),
    Parquet(ParquetColumns),
}

impl Columns {
    fn open(input: &Path) -> Result<Self> {
        Ok(match TableFormat::of(input) {
            TableFormat::Parquet => Columns::Parquet(ParquetColumns::open(input)?),
            TableFormat::Csv => Columns::Whole(read_table(
                input,
                &[
                    ("frame", Expect::Int),
                    ("frame_end", Expect::Int),
                    ("particle", Expect::Int),
                    ("eta_s", Expect::Float),
                    ("d2min", Expect::Float),
                ],
            )?),
        })
    }
    /// The table's columns (for a Parquet file, without their values).
    fn schema(&self) -> &Table {
        match self {
            Columns::Whole(t) => t,
            Columns::Parquet(p) => &p.schema,
        }
    }
    fn i64(&self, c: &str) -> Result<Vec<i64>> {
        match self {
            Columns::Whole(t) => t.i64(c),
            Columns::Parquet(p) => p.column(c)?.i64(c),
        }
    }
    fn f64(&self, c: &str) -> Result<Vec<f64>> {
        match self {
            Columns::Whole(t) => t.f64(c),
            Columns::Parquet(p) => p.column(c)?.f64(c),
        }
    }
    fn bool(&self, c: &str) -> Result<Vec<bool>> {
        match self {
            Columns::Whole(t) => t.bool(c),
            Columns::Parquet(p) => p.column(c)?.bool(c),
        }
    }
}

/// Fit the rows of a `kinematics` table as they are (valid rows only).
pub(crate) fn from_kinematics(
    input: &Path,
    opt: &FitOptions,
    warnings: &mut Vec<String>,
) -> Result<(Samples, ScatterRows, Protocol)> {
    let file = input.display().to_string();
    let t = Columns::open(input)?;
    t.schema()
        .require(&["frame", "frame_end", "particle", "valid", "eta_s", "d2min"])?;
    let meta: Option<serde_json::Value> = std::fs::read_to_string(crate::io::sidecar_path(input))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok());
    let d = match (
        opt.diameter,
        meta.as_ref().and_then(|m| m["d_large"].as_f64()),
    ) {
        (Some(d), _) | (None, Some(d)) => d,
        _ => {
            return Err(Error::param(
                "diameter",
                format!(
                    "{file}: no large-grain diameter in a sidecar; pass --diameter D (D²min is scaled by R² = (D/2)²)"
                ),
            ));
        }
    };
    if let Some(rc) = meta.as_ref().and_then(|m| m["rc"].as_f64())
        && ((rc / d) / opt.rc_over_d - 1.0).abs() > 1e-6
    {
        warnings.push(format!(
            "the table was computed with R_c = {:.4} D, not {} D",
            rc / d,
            opt.rc_over_d
        ));
    }
    let r = 0.5 * d;
    let (start, end, particle) = (t.i64("frame")?, t.i64("frame_end")?, t.i64("particle")?);
    let (eta, d2, valid) = (t.f64("eta_s")?, t.f64("d2min")?, t.bool("valid")?);
    let n_nb: Option<Vec<i64>> = if t.schema().has("n_neighbors") {
        Some(t.i64("n_neighbors")?)
    } else {
        None
    };
    let species: Vec<i32> = if t.schema().has("species") {
        t.i64("species")?.into_iter().map(|v| v as i32).collect()
    } else {
        vec![-1; start.len()]
    };
    let mut groups: BTreeMap<i64, u32> = BTreeMap::new();
    let mut s = Samples::default();
    let mut rows = ScatterRows::default();
    let mut lags: Vec<i64> = Vec::new();
    let (mut two_neighbours, mut at_rest) = (0usize, 0usize);
    for k in 0..start.len() {
        if !valid[k] {
            continue;
        }
        if n_nb
            .as_ref()
            .is_some_and(|n| n[k] < MIN_NEIGHBORS_FOR_D2MIN as i64)
        {
            two_neighbours += 1;
            continue;
        }
        if !(eta[k].is_finite() && d2[k].is_finite()) {
            return Err(Error::Value {
                file: file.clone(),
                loc: format!("row {}", k + 1),
                column: "eta_s/d2min".into(),
                msg: "not finite in a valid row".into(),
            });
        }
        if eta[k] < ETA_S_AT_REST {
            at_rest += 1;
            continue;
        }
        let n = groups.len() as u32;
        let g = *groups.entry(start[k]).or_insert(n);
        let y = d2[k] / (r * r);
        let lag = end[k] - start[k];
        s.push_lag(eta[k], y, g, lag.clamp(0, u32::MAX as i64) as u32);
        if !lags.contains(&lag) {
            lags.push(lag);
        }
        rows.start.push(start[k]);
        rows.end.push(end[k]);
        rows.particle.push(particle[k]);
        rows.species.push(species[k]);
        rows.eta_s.push(eta[k]);
        rows.y.push(y);
    }
    lags.sort_unstable();
    // Start indices in time order (as from tracks), whatever the table's row order: the
    // stationarity check splits the starts into thirds by index.
    let rank: BTreeMap<u32, u32> = groups
        .values()
        .enumerate()
        .map(|(r, &g)| (g, r as u32))
        .collect();
    for g in s.group.iter_mut() {
        *g = rank[g];
    }
    note_two_neighbours(two_neighbours, warnings);
    note_at_rest(at_rest, warnings);
    if lags.len() == 1 {
        warnings.push(format!(
            "a single lag ({} frames): η^s spans only what one lag gives",
            lags[0]
        ));
    }
    let protocol = Protocol {
        source: "kinematics".into(),
        diameter: d,
        rc_over_d: meta
            .as_ref()
            .and_then(|m| m["rc"].as_f64())
            .map_or(opt.rc_over_d, |rc| rc / d),
        bar_speed: opt.bar_speed,
        time_scale: None,
        lags_frames: lags,
        lags_requested: vec![],
        lags_used: vec![],
        start_frames: groups.keys().copied().collect(),
        binning: opt.binning,
    };
    Ok((s, rows, protocol))
}

/// η^s below this is round-off of a neighbourhood that did not move at all (simulated
/// grains held by the substrate keep bit-identical positions): on log axes such samples
/// would sit at 1e-16 and drag the fit, so they are left out and counted.
pub const ETA_S_AT_REST: f64 = 1e-9;

fn note_at_rest(n: usize, warnings: &mut Vec<String>) {
    if n > 0 {
        warnings.push(format!(
            "{n} samples at rest (η^s < {ETA_S_AT_REST:e}: the neighbourhood did not move) left out"
        ));
    }
}

fn note_two_neighbours(n: usize, warnings: &mut Vec<String>) {
    if n > 0 {
        warnings.push(format!(
            "{n} valid samples with only 2 neighbours left out: their D²min is identically 0"
        ));
    }
}

/// Whether `input` is a `kinematics` table (else tracks): its sidecar says so (a table
/// of a few `--columns` is then recognised, and its missing column named), or, without
/// one, it has both columns the fit reads.
pub(crate) fn is_kinematics(input: &Path) -> Result<bool> {
    let side = crate::io::sidecar_path(input);
    if let Ok(text) = std::fs::read_to_string(&side)
        && let Ok(meta) = serde_json::from_str::<serde_json::Value>(&text)
        && let Some(table) = meta["table"].as_str()
    {
        return Ok(table == "kinematics");
    }
    // The column names only: the whole table would be read again by the fit.
    let t = match TableFormat::of(input) {
        TableFormat::Parquet => ParquetColumns::open(input)?.schema,
        TableFormat::Csv => read_table(input, &[])?,
    };
    Ok(t.has("d2min") && t.has("eta_s"))
}
