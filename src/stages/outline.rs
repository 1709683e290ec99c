//! `pillar-pipe outline`: a pillar's outline at a frame (li-granular-pillars Fig. 9),
//! rescaled by its initial width W0, and optionally how far it is from another pillar's
//! outline rescaled the same way (self-similarity as a number; `structure::outline`).

use crate::error::{Error, Result};
use crate::geom::Vec2;
use crate::io::table::write_table;
use crate::io::{read_tracks, sha256_file, write_with_sidecar};
use crate::structure::{Outline, shape_distance};
use crate::tracks::Tracks;
use polars::prelude::*;
use std::path::Path;

/// A frame's outline with slabs one large diameter thick, and the pillar's W0 (the
/// widest slab of its first frame) and x centre there (length unit).
pub struct FrameOutline {
    pub outline: Outline,
    pub frame: i64,
    pub w0: f64,
    pub x_mid: f64,
}

/// The outline of `frame` (default: the last) of the tracks at `input`.
pub fn outline_of(input: &Path, frame: Option<i64>) -> Result<FrameOutline> {
    let (t, _) = read_tracks(input)?;
    outline_of_tracks(&t, &input.display().to_string(), frame)
}

/// The outline of `frame` (default: the last) of tracks `t` read from `source` (named in
/// errors).
pub fn outline_of_tracks(t: &Tracks, source: &str, frame: Option<i64>) -> Result<FrameOutline> {
    let ranges = t.frame_ranges();
    let d = t
        .large_diameter()
        .ok_or_else(|| Error::input(source, "no radii to take D from"))?;
    let of = |rows: std::ops::Range<usize>| {
        let pos: Vec<Vec2> = rows.clone().map(|i| Vec2::new(t.x[i], t.y[i])).collect();
        Outline::of(&pos, &t.radius[rows], d)
    };
    let (f0, r0) = ranges
        .first()
        .cloned()
        .ok_or_else(|| Error::input(source, "no rows"))?;
    let first = of(r0);
    let w0 = first
        .half_width()
        .iter()
        .fold(0.0f64, |m, &w| m.max(2.0 * w));
    let x_mid = 0.5
        * (first.left.iter().copied().fold(f64::INFINITY, f64::min)
            + first
                .right
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max));
    let (f, rows) = match frame {
        None => ranges.last().cloned().unwrap_or((f0, 0..0)),
        Some(f) => ranges
            .iter()
            .find(|(k, _)| *k == f)
            .cloned()
            .ok_or_else(|| Error::param("frame", format!("{}: no frame {f}", source)))?,
    };
    Ok(FrameOutline {
        outline: of(rows),
        frame: f,
        w0,
        x_mid,
    })
}

/// Write the outline of `input` at `frame`, in units of W0 with x from the first frame's
/// centre and y from the lowest grain edge; with `against`, also the shape distance to
/// that pillar's outline at `against_frame`; the table gets its `.meta.json` sidecar.
pub fn run(
    input: &Path,
    frame: Option<i64>,
    against: Option<(&Path, Option<i64>)>,
    output: &Path,
) -> Result<(FrameOutline, Option<f64>)> {
    let a = outline_of(input, frame)?;
    let o = &a.outline;
    let n = o.y.len();
    let scale = |v: &[f64], shift: f64| v.iter().map(|x| (x - shift) / a.w0).collect::<Vec<f64>>();
    let mut df = DataFrame::new(
        n,
        vec![
            Column::new("y_over_w0".into(), scale(&o.y, o.y0)),
            Column::new("left_over_w0".into(), scale(&o.left, a.x_mid)),
            Column::new("right_over_w0".into(), scale(&o.right, a.x_mid)),
        ],
    )
    .map_err(|e| Error::polars("the outline table", e))?;
    let (distance, against_meta) = match against {
        None => (None, serde_json::Value::Null),
        Some((path, f)) => {
            let b = outline_of(path, f)?;
            let meta = serde_json::json!({
                "source": path.display().to_string(), "source_sha256": sha256_file(path)?,
                "frame": b.frame, "w0": b.w0,
            });
            (
                Some(shape_distance(&a.outline, a.w0, &b.outline, b.w0)),
                meta,
            )
        }
    };
    let sidecar = serde_json::json!({
        "table": "outline",
        "frame": a.frame,
        "w0": a.w0,
        "shape_distance_over_w0": distance,
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": input.display().to_string(), "source_sha256": sha256_file(input)?,
            "against": against_meta,
            "parameters": {"frame": frame, "against_frame": against.and_then(|(_, f)| f)},
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || write_table(&mut df, output))?;
    Ok((a, distance))
}
