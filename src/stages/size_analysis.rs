//! The size scan's analyses (li-granular-pillars Sec. V) of a report's pillar runs, as a
//! stage of their own (`sizes`): the scan (flow stress, κ, χ, yield, bar pressure;
//! Fig. 10), every frame pair's transient shear lines (Fig. 11), the outlines at the
//! strains of `CHI_AT` rescaled by W0 (Fig. 9), and g(r) of each run and experiment
//! (Fig. 2). The report draws them (`stages/report/sizes.rs`), so a change in how they
//! are drawn recomputes none of them.
//!
//! Written: the scan's tables (`size_scan.csv`, `size_scan_curves.csv`,
//! `size_scan_pressure.csv`) and everything the report draws, `size_analysis.msgpack`
//! (MessagePack: every f64 exactly, NaN included, which JSON cannot carry).

use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::read_tracks;
use crate::io::table::read_table;
use crate::stages::datasets::DatasetInputs;
use crate::stages::sizes::{CHI_AT, SizeOutputs, SizeScan};
use crate::structure::line_tracks::TrackSummary;
use crate::structure::{ShearLine, shape_distance};
use crate::tracks::Tracks;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The analyses' file, beside the scan's tables.
pub const ANALYSIS: &str = "size_analysis.msgpack";
/// The scan's tables (one row per run; every run's curves against ε; every run's bar
/// pressure profile).
pub const TABLES: [&str; 3] = [
    "size_scan.csv",
    "size_scan_curves.csv",
    "size_scan_pressure.csv",
];

/// g(r) out to this many D, in bins of D/25.
pub const GOFR_R_MAX: f64 = 4.0;
pub const GOFR_BINS: usize = 100;

/// Lines steeper than this to the compression axis are the layer of grains sheared
/// under the bar, not the bulk's transient shear lines.
pub const BAR_LAYER_DEG: f64 = 75.0;

/// The strain at which the Fig. 11 maps of every size stand.
pub const MAP_STRAIN: f64 = 0.1;

/// Everything the report's "Size scan" section draws.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SizeAnalysis {
    /// The pillar runs' data-set labels, in the data sets' order.
    pub labels: Vec<String>,
    /// The scan, or why the runs cannot be compared as one.
    pub scan: std::result::Result<SizeScan, String>,
    /// Each scan row's name, "label (N = n)".
    pub names: Vec<String>,
    /// The shear lines of each scan row that has a kinematics stage.
    pub lines: Vec<RunLines>,
    /// The outlines at each strain of `CHI_AT`.
    pub outlines: Vec<OutlinesAt>,
    /// g(r) of each run (scan order), then of each experiment.
    pub gofr: Vec<GofrCurve>,
    /// The moving/resting front of each scan row with a kinematics stage (Fig. 5a).
    pub fronts: Vec<RunFront>,
}

/// One run's front between moving and resting grains over its frame pairs
/// (`stages::front` with its defaults).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunFront {
    pub row: usize,
    pub pairs: usize,
    /// Median and quartiles of the sides' angles to the bar, degrees.
    pub angle_deg: [f64; 3],
    /// Median rms of the slab boundaries about their lines, in D.
    pub rms_d: f64,
    /// Median fraction of grains on the wrong side.
    pub misplaced: f64,
}

/// One run's transient shear lines (`structure::shear_lines` with its defaults).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunLines {
    /// The scan row.
    pub row: usize,
    /// Every frame pair's lines.
    pub lines: Vec<ShearLine>,
    /// The frame pair (its start frame) the J2 map shows, and its longest line away
    /// from the bar layer: the pair with such a line starting nearest ε = `MAP_STRAIN`.
    pub shown: Option<(i64, ShearLine)>,
    /// The lines linked across consecutive pairs (`structure::line_tracks`).
    pub tracks: TrackSummary,
    /// Median strain between consecutive pairs' starts (a lifetime of one pair).
    pub strain_per_pair: f64,
}

/// The runs' outlines at one strain, lengths over each run's W0 (closed polygons), and
/// the rms half-width difference of each to the largest run's (the last).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct OutlinesAt {
    pub eps: f64,
    /// (scan row, polygon points (x − x_mid, y − y0)/W0).
    pub runs: Vec<(usize, Vec<(f64, f64)>)>,
    /// (scan row, distance to the last run's outline / W0), every run but the last.
    pub distances: Vec<(usize, f64)>,
}

/// g(r) around small and around large grains at the first frame, r over D.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GofrCurve {
    pub name: String,
    pub r_over_d: Vec<f64>,
    pub g_small: Vec<f64>,
    pub g_large: Vec<f64>,
}

/// The analyses of `datasets`, or None when fewer than two are pillar runs.
pub fn analyse(datasets: &[DatasetInputs]) -> Result<Option<SizeAnalysis>> {
    let runs: Vec<(String, PathBuf)> = datasets
        .iter()
        .filter_map(|d| d.pillar_run().map(|p| (d.label.clone(), p)))
        .collect();
    if runs.len() < 2 {
        return Ok(None);
    }
    let labels = runs.iter().map(|r| r.0.clone()).collect();
    let dirs: Vec<PathBuf> = runs.iter().map(|r| r.1.clone()).collect();
    let scan = match crate::stages::sizes::scan(&dirs) {
        Ok(s) => s,
        Err(e) => {
            return Ok(Some(SizeAnalysis {
                labels,
                scan: Err(e.to_string()),
                names: Vec::new(),
                lines: Vec::new(),
                outlines: Vec::new(),
                gofr: Vec::new(),
                fronts: Vec::new(),
            }));
        }
    };
    let label = |run: &Path| {
        runs.iter()
            .find(|r| r.1 == run)
            .map_or_else(|| run.display().to_string(), |r| r.0.clone())
    };
    let names: Vec<String> = scan
        .rows
        .iter()
        .map(|r| format!("{} (N = {})", label(&r.run), r.n))
        .collect();
    let lines = shear_lines(datasets, &scan)?;
    let fronts = fronts(datasets, &scan)?;
    // Each run's tracks, read once for its outlines and its g(r).
    let tracks = scan
        .rows
        .iter()
        .map(|r| {
            let path = r.run.join("tracks.parquet");
            read_tracks(&path).map(|(t, _)| (path.display().to_string(), t))
        })
        .collect::<Result<Vec<_>>>()?;
    let outlines = outlines(&scan, &tracks)?;
    let gofr = gofr(datasets, &names, &tracks)?;
    Ok(Some(SizeAnalysis {
        labels,
        scan: Ok(scan),
        names,
        lines,
        outlines,
        gofr,
        fronts,
    }))
}

/// Fig. 5a: the front of every frame pair of each run's kinematics.
fn fronts(datasets: &[DatasetInputs], scan: &SizeScan) -> Result<Vec<RunFront>> {
    let mut out = Vec::new();
    for (row, r) in scan.rows.iter().enumerate() {
        let Some(kin) = kinematics_of(datasets, &r.run) else {
            continue;
        };
        let f = crate::stages::front::fronts(&kin, &Default::default())?;
        out.push(RunFront {
            row,
            pairs: f.pairs,
            angle_deg: f.angle_deg,
            rms_d: f.rms_d,
            misplaced: f.misplaced,
        });
    }
    Ok(out)
}

/// The analyses of `datasets` written into `out` (the tables and `ANALYSIS`), or None
/// when fewer than two are pillar runs (nothing written).
pub fn run(datasets: &[DatasetInputs], out: &Path) -> Result<Option<SizeAnalysis>> {
    let Some(a) = analyse(datasets)? else {
        return Ok(None);
    };
    if let Ok(scan) = &a.scan {
        crate::stages::sizes::write(
            scan,
            &SizeOutputs {
                table: out.join(TABLES[0]),
                curves: Some(out.join(TABLES[1])),
                pressure: Some(out.join(TABLES[2])),
            },
        )?;
    }
    let bytes =
        rmp_serde::to_vec_named(&a).map_err(|e| Error::Other(format!("size analysis: {e}")))?;
    crate::io::atomic_write_bytes(&out.join(ANALYSIS), &bytes)?;
    Ok(Some(a))
}

/// The analyses `run` wrote to `path`.
pub fn read(path: &Path) -> Result<SizeAnalysis> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    rmp_serde::from_slice(&bytes).map_err(|e| {
        Error::input(
            path.display(),
            format!("not a size analysis of this version: {e}"),
        )
    })
}

/// Fig. 11: the shear lines of every frame pair of each run's kinematics, and the pair
/// the maps show. The maps stand at one strain for every size (Fig. 11 compares sizes at
/// one moment).
fn shear_lines(datasets: &[DatasetInputs], scan: &SizeScan) -> Result<Vec<RunLines>> {
    let mut out = Vec::new();
    for (row, r) in scan.rows.iter().enumerate() {
        let Some(kin) = kinematics_of(datasets, &r.run) else {
            continue;
        };
        let tracked = crate::stages::line_tracks::analyse(&kin, &Default::default())?;
        let by_frame: Vec<(i64, Vec<ShearLine>)> = tracked
            .pairs
            .iter()
            .map(|p| p.0)
            .zip(tracked.lines)
            .collect();
        let strain_per_pair = strain_per_pair(&r.run, &tracked.pairs)?;
        let is_bulk = |l: &&ShearLine| l.angle_deg < BAR_LAYER_DEG;
        let target = frame_at_strain(&r.run, MAP_STRAIN)?;
        let shown = by_frame
            .iter()
            .filter(|(_, ls)| ls.iter().any(|l| is_bulk(&l)))
            .min_by_key(|(f, _)| target.map_or(0, |t| (*f - t).abs()))
            .and_then(|(f, ls)| {
                ls.iter()
                    .filter(is_bulk)
                    .max_by(|a, b| a.length_d.total_cmp(&b.length_d))
                    .map(|l| (*f, l.clone()))
            });
        out.push(RunLines {
            row,
            lines: by_frame.into_iter().flat_map(|(_, ls)| ls).collect(),
            shown,
            tracks: tracked.tracks.summary,
            strain_per_pair,
        });
    }
    Ok(out)
}

/// The kinematics table of the data set whose pillar run is `run`.
fn kinematics_of(datasets: &[DatasetInputs], run: &Path) -> Option<PathBuf> {
    datasets
        .iter()
        .find(|d| d.pillar_run().as_deref() == Some(run))
        .and_then(|d| d.kinematics.clone())
}

/// The median strain between consecutive pairs' start frames, from the run's stress
/// table (NaN with fewer than two pairs).
fn strain_per_pair(run: &Path, pairs: &[(i64, i64, f64)]) -> Result<f64> {
    let t = read_table(
        &run.join("stress_strain.parquet"),
        &[("frame", Expect::Int), ("strain", Expect::Float)],
    )?;
    let strain: std::collections::HashMap<i64, f64> =
        t.i64("frame")?.into_iter().zip(t.f64("strain")?).collect();
    let mut d: Vec<f64> = pairs
        .windows(2)
        .filter_map(|w| Some(strain.get(&w[1].0)? - strain.get(&w[0].0)?))
        .collect();
    Ok(crate::stats::median_select(&mut d))
}

/// The frame of a run nearest strain `eps` (within 0.01), from its stress table.
pub fn frame_at_strain(run: &Path, eps: f64) -> Result<Option<i64>> {
    let t = read_table(
        &run.join("stress_strain.parquet"),
        &[("frame", Expect::Int), ("strain", Expect::Float)],
    )?;
    let (frames, strain) = (t.i64("frame")?, t.f64("strain")?);
    Ok(frames
        .iter()
        .zip(&strain)
        .filter(|(_, s)| (*s - eps).abs() <= 0.01)
        .min_by(|a, b| (a.1 - eps).abs().total_cmp(&(b.1 - eps).abs()))
        .map(|(f, _)| *f))
}

/// Fig. 9: each run's outline at each strain of `CHI_AT` rescaled by its W0, and the
/// rms distance of each to the largest run's.
fn outlines(scan: &SizeScan, tracks: &[(String, Tracks)]) -> Result<Vec<OutlinesAt>> {
    let mut out = Vec::new();
    for eps in CHI_AT {
        let mut runs = Vec::new();
        let mut got = Vec::new();
        for (row, (r, (source, t))) in scan.rows.iter().zip(tracks).enumerate() {
            let Some(frame) = frame_at_strain(&r.run, eps)? else {
                continue;
            };
            let o = crate::stages::outline::outline_of_tracks(t, source, Some(frame))?;
            let mut pts: Vec<(f64, f64)> = o
                .outline
                .polygon()
                .iter()
                .map(|p| ((p.x - o.x_mid) / o.w0, (p.y - o.outline.y0) / o.w0))
                .collect();
            if let Some(&first) = pts.first() {
                pts.push(first);
            }
            runs.push((row, pts));
            got.push((row, o));
        }
        let mut distances = Vec::new();
        if let Some((_, big)) = got.last() {
            for (row, o) in &got[..got.len() - 1] {
                distances.push((*row, shape_distance(&o.outline, o.w0, &big.outline, big.w0)));
            }
        }
        out.push(OutlinesAt {
            eps,
            runs,
            distances,
        });
    }
    Ok(out)
}

/// Fig. 2: g(r) around small and around large grains of each run's first frame, then of
/// each experiment's (data sets with tracks and no simulation).
fn gofr(
    datasets: &[DatasetInputs],
    names: &[String],
    runs: &[(String, Tracks)],
) -> Result<Vec<GofrCurve>> {
    let mut experiments = Vec::new();
    for d in datasets.iter().filter(|d| d.is_experiment()) {
        if let Some(p) = &d.tracks {
            experiments.push((d.label.clone(), p.display().to_string(), read_tracks(p)?.0));
        }
    }
    names
        .iter()
        .zip(runs)
        .map(|(n, (p, t))| (n, p, t))
        .chain(experiments.iter().map(|(n, p, t)| (n, p, t)))
        .map(|(name, path, t)| {
            let (g, _, d) = crate::stages::gofr::of_tracks(t, path, None, GOFR_R_MAX, GOFR_BINS)
                .map_err(|e| Error::Other(format!("g(r) of {name}: {e}")))?;
            Ok(GofrCurve {
                name: name.clone(),
                r_over_d: g.r.iter().map(|r| r / d).collect(),
                g_small: g.g_small,
                g_large: g.g_large,
            })
        })
        .collect()
}
