//! trackpy output (`batch` + `link`): columns `y, x, mass, size, ecc, signal, raw_mass,
//! ep, frame, particle` in pixels, image y pointing down, no time column.
//!
//! Canonical frame written: x = (x_px − x0)/s, y = (y0 − y_px)/s with s the pixels per
//! length unit and (x0, y0) the origin in pixels (`--origin-px`; default x0 = 0 and y0 =
//! the largest y_px in the file, i.e. the lowest detected centre, so y ≥ 0 and y points
//! up with the bar on top).

use super::fastcsv::read_numeric_csv;
use super::table::{TableFormat, read_table_columns};
use crate::error::{Error, Result};
use crate::tracks::{LARGE, MAX_ABS_COORD, RowLocator, Tracks, TracksMeta, beyond_bound, finalize};
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
pub(crate) use super::csvdiag::TRACKPY_COLUMNS as EXPECT;

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
        ep,
        found,
    } = read_columns(path)?;
    // trackpy's `ep` (px), its median over the finite values, in the length unit.
    let ep_median = ep.and_then(|mut v| {
        v.retain(|e| e.is_finite() && *e >= 0.0);
        v.sort_by(f64::total_cmp);
        (!v.is_empty()).then(|| crate::stats::quantile_sorted(&v, 0.5) / s)
    });
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
        Some(sz) => crate::tracks::split_by_size(&particle, sz),
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
            let (a, b) = crate::tracks::estimate_radii(&frame, &x, &y, &species)
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
        position_error_ep: ep_median,
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
    /// trackpy's static localisation error estimate (px), when the file has it.
    ep: Option<Vec<f64>>,
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
        let ep = t.take_f64("ep");
        return Ok(TrackpyColumns {
            file,
            x_px,
            y_px,
            frame,
            particle,
            size: Some(size),
            ep,
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
        ep: if table.has("ep") {
            Some(table.f64("ep")?)
        } else {
            None
        },
        found: table.columns(),
    })
}
