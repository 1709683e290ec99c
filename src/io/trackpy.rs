//! trackpy output (`batch` + `link`): columns `y, x, mass, size, ecc, signal, raw_mass,
//! ep, frame, particle` in pixels, image y pointing down, no time column.
//!
//! Canonical frame written: x = (x_px − x0)/s, y = (y0 − y_px)/s with s the pixels per
//! length unit and (x0, y0) the origin in pixels (`--origin-px`; default x0 = 0 and y0 =
//! the largest y_px in the file, i.e. the lowest detected centre, so y ≥ 0 and y points
//! up with the bar on top).

use super::csvdiag::Expect;
use super::fastcsv::read_numeric_csv;
use super::table::{TableFormat, read_table_columns};
use crate::error::{Error, Result};
use crate::neighbors::{CellList, Cutoff};
use crate::tracks::{
    LARGE, MAX_ABS_COORD, RowLocator, SMALL, Tracks, TracksMeta, beyond_bound, finalize,
};
use std::path::Path;

#[derive(Debug, Clone, Default)]
pub struct TrackpyOptions {
    /// Pixels per length unit (required: trackpy works in pixels).
    pub px_per_unit: Option<f64>,
    /// Name of the length unit the scale refers to.
    pub unit: Option<String>,
    /// Seconds between frames.
    pub frame_time: Option<f64>,
    /// (small, large) radii in the length unit; otherwise estimated.
    pub radii: Option<(f64, f64)>,
    /// Origin (x0, y0) in pixels.
    pub origin_px: Option<(f64, f64)>,
}

/// How trajectories were split into species.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SpeciesSplit {
    /// Threshold on the per-trajectory median of trackpy's `size` (px).
    pub size_threshold_px: f64,
    pub small_trajectories: usize,
    pub large_trajectories: usize,
    pub radius_small: f64,
    pub radius_large: f64,
    /// "given (--radii)" or how they were estimated.
    pub radii_source: String,
}

/// The columns trackpy ingest reads, and how each parses.
pub(crate) const EXPECT: &[(&str, Expect)] = &[
    ("x", Expect::Float),
    ("y", Expect::Float),
    ("frame", Expect::Int),
    ("particle", Expect::Int),
    ("size", Expect::Float),
];

pub fn read_trackpy(path: &Path, opt: &TrackpyOptions) -> Result<(Tracks, SpeciesSplit)> {
    let s = opt.px_per_unit.ok_or_else(|| {
        Error::input(
            path.display(),
            "trackpy positions are in pixels and no scale was given: pass --px-per-unit F --unit U (e.g. --px-per-unit 31.496 --unit cm), put them in an ingest.toml beside the input, or pass --unit px to keep pixels",
        )
    })?;
    if !(s > 0.0 && s.is_finite()) {
        return Err(Error::param("px-per-unit", format!("{s} must be > 0")));
    }
    let unit = opt.unit.clone().ok_or_else(|| {
        Error::param(
            "unit",
            "missing length unit: --px-per-unit needs --unit (e.g. --unit cm)",
        )
    })?;
    let TrackpyColumns {
        file,
        x_px,
        y_px,
        frame,
        particle,
        size,
        found,
    } = read_columns(path)?;
    // Checked in pixels, the file's own values, before any scaling (the bound of
    // `tracks::MAX_ABS_COORD`: no camera frame is 1e12 px wide).
    let bounded = |v: &[f64]| v.iter().fold(true, |ok, x| ok & (x.abs() <= MAX_ABS_COORD));
    let clean = bounded(&x_px) && bounded(&y_px);
    for (r, (&x, &y)) in x_px.iter().zip(&y_px).enumerate().filter(|_| !clean) {
        for (c, v) in [("x", x), ("y", y)] {
            let msg = if !v.is_finite() {
                format!("{v} is not a finite number")
            } else if v.abs() > MAX_ABS_COORD {
                beyond_bound(v, " px")
            } else {
                continue;
            };
            return Err(Error::Value {
                file: file.clone(),
                loc: format!("line {}", r + 2),
                column: c.into(),
                msg,
            });
        }
    }
    let (x0, y0) = opt
        .origin_px
        .unwrap_or((0.0, y_px.iter().copied().fold(f64::NEG_INFINITY, f64::max)));
    // In place: a 10 M-row file's columns are 80 MB each.
    let (mut x, mut y) = (x_px, y_px);
    x.iter_mut().for_each(|v| *v = (*v - x0) / s);
    y.iter_mut().for_each(|v| *v = (y0 - *v) / s);

    let (species, threshold, n_small, n_large) = match &size {
        Some(sz) => split_by_size(&particle, sz),
        None if opt.radii.is_some() => {
            return Err(Error::input(
                &file,
                "no `size` column to tell the two species apart; trackpy's size column is needed",
            ));
        }
        None => {
            return Err(Error::MissingColumns {
                file: file.clone(),
                missing: vec!["size".into()],
                found,
                expected: vec![
                    "x".into(),
                    "y".into(),
                    "frame".into(),
                    "particle".into(),
                    "size".into(),
                ],
            });
        }
    };
    let (rs, rl, source) = match opt.radii {
        Some((a, b)) => (a, b, "given (--radii)".to_string()),
        None => {
            let (a, b) = estimate_radii(&frame, &x, &y, &species)
                .map_err(|e| Error::input(&file, format!("{e}")))?;
            (
                a,
                b,
                "estimated: half the median distance to the nearest same-species neighbour in the best-populated frame; pass --radii SMALL,LARGE to set them"
                    .to_string(),
            )
        }
    };
    let radius = species
        .iter()
        .map(|&sp| if sp == LARGE { rl } else { rs })
        .collect();
    let time = opt
        .frame_time
        .map(|dt| frame.iter().map(|&f| f as f64 * dt).collect());
    let meta = TracksMeta {
        length_unit: unit,
        time_unit: if opt.frame_time.is_some() {
            "s"
        } else {
            "frame"
        }
        .into(),
        frame_time: opt.frame_time,
        coordinate_frame: format!(
            "from trackpy pixels: x = (x_px - {x0}) / {s}, y = ({y0} - y_px) / {s}; y up"
        ),
        ..TracksMeta::default()
    };
    let t = Tracks {
        frame,
        particle,
        x,
        y,
        radius,
        time,
        species: Some(species),
        theta: None,
        meta,
    };
    let t = finalize(t, &file, RowLocator::Line { first_data_line: 2 }, None)?;
    Ok((
        t,
        SpeciesSplit {
            size_threshold_px: threshold,
            small_trajectories: n_small,
            large_trajectories: n_large,
            radius_small: rs,
            radius_large: rl,
            radii_source: source,
        },
    ))
}

/// The columns trackpy output is read for, in pixels and frames.
struct TrackpyColumns {
    file: String,
    x_px: Vec<f64>,
    y_px: Vec<f64>,
    frame: Vec<i64>,
    particle: Vec<i64>,
    size: Option<Vec<f64>>,
    /// The file's columns, for the error when `size` is missing.
    found: Vec<String>,
}

/// A plain numeric CSV with all five columns takes the fast reader; anything else
/// (Parquet, quirks, errors to locate, a missing column) polars and its diagnostics.
fn read_columns(path: &Path) -> Result<TrackpyColumns> {
    let file = path.display().to_string();
    if TableFormat::of(path) == TableFormat::Csv
        && let Some(mut t) = read_numeric_csv(path, EXPECT)?
        && let (Some(x_px), Some(y_px), Some(frame), Some(particle), Some(size)) = (
            t.take_f64("x"),
            t.take_f64("y"),
            t.take_i64("frame"),
            t.take_i64("particle"),
            t.take_f64("size"),
        )
    {
        return Ok(TrackpyColumns {
            file,
            x_px,
            y_px,
            frame,
            particle,
            size: Some(size),
            found: Vec::new(),
        });
    }
    let table = read_table_columns(path, EXPECT, true)?;
    table.require(&["x", "y", "frame", "particle"])?;
    Ok(TrackpyColumns {
        file: table.file.clone(),
        x_px: table.f64("x")?,
        y_px: table.f64("y")?,
        frame: table.i64("frame")?,
        particle: table.i64("particle")?,
        size: if table.has("size") {
            Some(table.f64("size")?)
        } else {
            None
        },
        found: table.columns(),
    })
}

/// Species per row from the per-trajectory median `size`, split into two populations by
/// Otsu's threshold (the split minimising the within-class variance).
fn split_by_size(particle: &[i64], size: &[f64]) -> (Vec<i32>, f64, usize, usize) {
    use rayon::prelude::*;
    // Sizes grouped by trajectory (a counting sort), then a median per group.
    let (dense, ids) = crate::tracks::dense_ids(particle);
    let mut start = vec![0usize; ids.len() + 1];
    for &d in &dense {
        start[d as usize + 1] += 1;
    }
    for k in 0..ids.len() {
        start[k + 1] += start[k];
    }
    let mut fill = start[..ids.len()].to_vec();
    let mut grouped = vec![0.0; size.len()];
    for (&d, &v) in dense.iter().zip(size) {
        grouped[fill[d as usize]] = v;
        fill[d as usize] += 1;
    }
    let mut groups = Vec::with_capacity(ids.len());
    let mut rest = grouped.as_mut_slice();
    for k in 0..ids.len() {
        let (g, r) = rest.split_at_mut(start[k + 1] - start[k]);
        groups.push(g);
        rest = r;
    }
    let med: Vec<f64> = groups
        .into_par_iter()
        .map(crate::stats::median_select)
        .collect();
    let mut vals = med.clone();
    vals.sort_by(f64::total_cmp);
    let threshold = otsu(&vals);
    let large: Vec<bool> = med.iter().map(|&m| m > threshold).collect();
    let n_large = large.iter().filter(|&&l| l).count();
    let species = dense
        .iter()
        .map(|&d| if large[d as usize] { LARGE } else { SMALL })
        .collect();
    (species, threshold, med.len() - n_large, n_large)
}

/// Otsu threshold of sorted values: midpoint of the split with the largest
/// between-class variance.
pub fn otsu(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n < 2 {
        return sorted.first().copied().unwrap_or(0.0);
    }
    let total: f64 = sorted.iter().sum();
    let mut best = (f64::NEG_INFINITY, 0.5 * (sorted[0] + sorted[n - 1]));
    let mut left = 0.0;
    for k in 1..n {
        left += sorted[k - 1];
        if sorted[k] == sorted[k - 1] {
            continue;
        }
        let (w0, w1) = (k as f64, (n - k) as f64);
        let (m0, m1) = (left / w0, (total - left) / w1);
        let between = w0 * w1 * (m0 - m1).powi(2);
        if between > best.0 {
            best = (between, 0.5 * (sorted[k - 1] + sorted[k]));
        }
    }
    best.1
}

/// Radii from geometry: in a dense packing most grains touch their nearest neighbour of
/// the same species, so half the median nearest same-species distance estimates each
/// radius. Uses the frame with the most detections.
fn estimate_radii(frame: &[i64], x: &[f64], y: &[f64], species: &[i32]) -> Result<(f64, f64)> {
    // Detections per frame through dense frame indices (a map per row costs more than
    // the whole neighbour search below).
    let (dense, frames) = crate::tracks::dense_ids(frame);
    let mut counts = vec![0usize; frames.len()];
    for &d in &dense {
        counts[d as usize] += 1;
    }
    let best = (0..frames.len())
        .max_by_key(|&k| (counts[k], std::cmp::Reverse(frames[k])))
        .map(|k| frames[k])
        .unwrap_or(0);
    let idx: Vec<usize> = (0..frame.len()).filter(|&i| frame[i] == best).collect();
    let mut out = [0.0; 2];
    for (k, sp) in [SMALL, LARGE].into_iter().enumerate() {
        let pts: Vec<crate::geom::Vec2> = idx
            .iter()
            .filter(|&&i| species[i] == sp)
            .map(|&i| crate::geom::Vec2::new(x[i], y[i]))
            .collect();
        if pts.len() < 2 {
            return Err(Error::Other(format!(
                "cannot estimate the radius of species {sp}: fewer than 2 grains; pass --radii SMALL,LARGE"
            )));
        }
        // Search radius: a few mean spacings of this species.
        let (xmin, xmax) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.x), a.1.max(p.x)));
        let (ymin, ymax) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.y), a.1.max(p.y)));
        let spacing = (((xmax - xmin) * (ymax - ymin)).max(1e-300) / pts.len() as f64).sqrt();
        let cl = CellList::new(&pts, 3.0 * spacing, Cutoff::Strict, None)?;
        let mut nn: Vec<f64> = pts
            .iter()
            .enumerate()
            .filter_map(|(i, &p)| {
                let mut best = f64::INFINITY;
                cl.for_each_within(p, |j, d| {
                    if j != i {
                        best = best.min(d.norm());
                    }
                });
                best.is_finite().then_some(best)
            })
            .collect();
        nn.sort_by(f64::total_cmp);
        out[k] = 0.5 * crate::stats::median_sorted(&nn);
    }
    Ok((out[0], out[1]))
}
