//! `pillar-pipe front`: the front between moving and resting grains
//! (li-granular-pillars Fig. 5a, "about 45°") in every frame pair of a `kinematics`
//! table: a grain moves when its speed is at least `moving` times the pair's reference
//! speed (the 95th percentile of speeds, the grains the bar drives). One row per pair
//! and side (`structure::front`), with the sidecar; the report gives the median angle
//! and its quartiles over the pairs.

use crate::error::{Error, Result};
use crate::io::{sha256_file, sidecar_path, write_with_sidecar};
use crate::structure::front::{Front, front};
use serde::Serialize;
use std::collections::BTreeSet;
use std::path::Path;

#[derive(Debug, Clone, Serialize)]
pub struct FrontOptions {
    /// A grain moves when |v| ≥ `moving` × the pair's 95th-percentile speed.
    pub moving: f64,
    /// Only this start frame (default: every pair).
    pub frame: Option<i64>,
    /// Large-grain diameter D (the slab width); default the table's sidecar.
    pub diameter: Option<f64>,
}

impl Default for FrontOptions {
    fn default() -> Self {
        FrontOptions {
            moving: 0.5,
            frame: None,
            diameter: None,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct FrontReport {
    pub input: String,
    pub d_large: f64,
    /// Frame pairs with a front on at least one side.
    pub pairs: usize,
    /// Median and quartiles of every side's angle to the bar (x axis), degrees.
    pub angle_deg: [f64; 3],
    /// Median rms of the slab boundaries about their line, in D.
    pub rms_d: f64,
    /// Median fraction of grains on the wrong side of the front.
    pub misplaced: f64,
    /// (start frame, end frame, front) of each pair.
    #[serde(skip)]
    pub fronts: Vec<(i64, i64, Front)>,
}

impl std::fmt::Display for FrontReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, a1, a3] = self.angle_deg;
        write!(
            f,
            "front       {} frame pairs: angle to the bar {a:.1}° [{a1:.1}, {a3:.1}] (median [quartiles]), boundary rms {:.2} D, {:.1} % of grains on the wrong side",
            self.pairs,
            self.rms_d,
            100.0 * self.misplaced
        )
    }
}

fn quantiles(mut v: Vec<f64>) -> [f64; 3] {
    v.retain(|x| x.is_finite());
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return [f64::NAN; 3];
    }
    [0.5, 0.25, 0.75].map(|p| crate::stats::quantile_sorted(&v, p))
}

/// The fronts of the kinematics table at `input`, written nowhere.
pub fn fronts(input: &Path, opt: &FrontOptions) -> Result<FrontReport> {
    if !(opt.moving > 0.0 && opt.moving < 1.0) {
        return Err(Error::param(
            "moving",
            format!("{} is not a fraction in (0, 1)", opt.moving),
        ));
    }
    let t = crate::stages::shear_lines::read_kinematics(input)?;
    t.require(&["speed"])?;
    let file = t.file.clone();
    let meta: Option<serde_json::Value> = std::fs::read_to_string(sidecar_path(input))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok());
    let d = crate::stages::shear_lines::diameter(input, &file, meta.as_ref(), opt.diameter)?;
    let (frame, frame_end) = (t.i64("frame")?, t.i64("frame_end")?);
    let (x, y, speed) = (t.f64("x")?, t.f64("y")?, t.f64_or_nan("speed")?);
    let pairs: BTreeSet<(i64, i64)> = frame
        .iter()
        .copied()
        .zip(frame_end.iter().copied())
        .filter(|(a, _)| opt.frame.is_none_or(|f| f == *a))
        .collect();
    if pairs.is_empty() {
        return Err(Error::input(
            &file,
            format!("no frame pair starts at frame {}", opt.frame.unwrap_or(-1)),
        ));
    }
    let mut fronts = Vec::new();
    for &(a, b) in &pairs {
        let rows: Vec<usize> = (0..frame.len())
            .filter(|&i| frame[i] == a && frame_end[i] == b && speed[i].is_finite())
            .collect();
        let mut s: Vec<f64> = rows.iter().map(|&i| speed[i]).collect();
        s.sort_by(f64::total_cmp);
        if s.is_empty() {
            continue;
        }
        let v_ref = crate::stats::quantile_sorted(&s, 0.95);
        if !(v_ref > 0.0) {
            continue;
        }
        let xs: Vec<f64> = rows.iter().map(|&i| x[i]).collect();
        let ys: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
        let mv: Vec<bool> = rows
            .iter()
            .map(|&i| speed[i] >= opt.moving * v_ref)
            .collect();
        if let Some(f) = front(&xs, &ys, &mv, d)
            && (f.left.is_some() || f.right.is_some())
        {
            fronts.push((a, b, f));
        }
    }
    let sides = || {
        fronts
            .iter()
            .flat_map(|(_, _, f)| [f.left.as_ref(), f.right.as_ref()])
            .flatten()
    };
    let rep = FrontReport {
        input: file.clone(),
        d_large: d,
        pairs: fronts.len(),
        angle_deg: quantiles(sides().map(|s| s.angle_deg).collect()),
        rms_d: quantiles(sides().map(|s| s.rms_d).collect())[0],
        misplaced: quantiles(fronts.iter().map(|f| f.2.misplaced).collect())[0],
        fronts,
    };
    Ok(rep)
}

/// [`fronts`], written to `output` one row per pair and side, with the sidecar.
pub fn run(input: &Path, output: &Path, opt: &FrontOptions) -> Result<FrontReport> {
    let rep = fronts(input, opt)?;
    let file = rep.input.clone();
    let d = rep.d_large;
    // One row per pair and side.
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); 9];
    for (a, b, f) in &rep.fronts {
        for (k, s) in [(0.0, &f.left), (1.0, &f.right)] {
            let Some(s) = s else { continue };
            for (c, v) in cols.iter_mut().zip([
                *a as f64,
                *b as f64,
                k,
                s.angle_deg,
                s.slope,
                s.intercept,
                s.rms_d,
                s.slabs as f64,
                f.misplaced,
            ]) {
                c.push(v);
            }
        }
    }
    let names = [
        "frame",
        "frame_end",
        "side",
        "angle_deg",
        "slope",
        "intercept",
        "rms_d",
        "slabs",
        "misplaced",
    ];
    let sidecar = serde_json::json!({
        "table": "front",
        "columns": {"side": "0 left of the median x, 1 right", "angle_deg": "the line's angle to the x axis (the bar), degrees", "slope": "dy/dx", "intercept": "y at x = 0 (length unit)", "rms_d": "rms of the slab boundaries about the line, in D", "slabs": "slabs on the line", "misplaced": "fraction of the pair's grains on the wrong side of their slab's boundary"},
        "d_large": d,
        "summary": {"pairs": rep.pairs, "angle_deg": rep.angle_deg, "rms_d": rep.rms_d, "misplaced": rep.misplaced},
        "provenance": {
            "tool": crate::stages::TOOL, "tool_version": crate::stages::VERSION,
            "source": file, "source_sha256": sha256_file(input)?,
            "parameters": opt,
        },
    });
    let sidecar = serde_json::to_string_pretty(&sidecar).expect("json");
    write_with_sidecar(output, &sidecar, || {
        crate::io::table::write_f64_columns(&names, &cols, output, "the front table")
    })?;
    Ok(rep)
}
