//! `sweep`: a grid of independent sheared-disk runs (φ × Q × γ̇), at most `jobs` at a
//! time, each in its own directory with its own manifest, and one summary table —
//! the raw material of vagberg-sheared-disks' phase diagrams (Figs. 3, 17, 25). Runs
//! already finished are read back, not rerun, so an interrupted sweep resumes.

use crate::error::{Error, Result};
use crate::io::table::{write_f64_columns, write_table};
use crate::stages::shear::{ShearOptions, run};
use polars::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone)]
pub struct SweepOptions {
    pub phi: Vec<f64>,
    pub q: Vec<f64>,
    pub rate: Vec<f64>,
    /// Everything else of each run (its phi, q, rate are replaced).
    pub base: ShearOptions,
    pub jobs: usize,
    /// No progress bar.
    pub quiet: bool,
}

pub struct SweepReport {
    pub table: PathBuf,
    pub runs: usize,
    pub reused: usize,
}

/// The directory of one grid point's run.
pub fn run_dir(out: &Path, phi: f64, q: f64, rate: f64) -> PathBuf {
    out.join(format!("phi{phi}_q{q}_rate{rate:e}"))
}

/// The grid points (φ, Q, γ̇), in table order.
pub fn grid(opt: &SweepOptions) -> Vec<(f64, f64, f64)> {
    let mut grid = Vec::new();
    for &phi in &opt.phi {
        for &q in &opt.q {
            for &rate in &opt.rate {
                grid.push((phi, q, rate));
            }
        }
    }
    grid
}

/// Run one grid point (resuming its checkpoint, if any) unless it has finished; then
/// read its summary back: (whether it had finished, the summary).
pub fn run_point(
    out: &Path,
    base: &ShearOptions,
    (phi, q, rate): (f64, f64, f64),
) -> Result<(bool, serde_json::Value)> {
    let dir = run_dir(out, phi, q, rate);
    let reused = dir.join("manifest.json").exists();
    if !reused && let Some(e) = Error::interrupted("not started") {
        return Err(e);
    }
    if !reused {
        let o = ShearOptions {
            phi,
            q,
            rate,
            quiet: true,
            resume: dir.join("checkpoint.bin").exists(),
            ..base.clone()
        };
        run(&dir, &o).map_err(|e| match e {
            Error::Interrupted { .. } => e,
            e => Error::Other(format!("run φ = {phi}, Q = {q}, γ̇ = {rate:e}: {e}")),
        })?;
    }
    let p = dir.join("summary.json");
    let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&p, e))?;
    let v = serde_json::from_str(&text).map_err(|e| Error::input(p.display(), e.to_string()))?;
    Ok((reused, v))
}

pub fn run_sweep(out: &Path, opt: &SweepOptions) -> Result<SweepReport> {
    if opt.phi.is_empty() || opt.q.is_empty() || opt.rate.is_empty() {
        return Err(Error::param(
            "sweep",
            "give at least one value each of --phi, --q and --rate",
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let grid = grid(opt);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opt.jobs.max(1))
        .build()
        .map_err(|e| Error::Other(format!("thread pool: {e}")))?;
    let bar = crate::stages::progress(grid.len() as u64, "sweep", opt.quiet);
    let results: Vec<Result<(bool, serde_json::Value)>> = pool.install(|| {
        use rayon::prelude::*;
        grid.par_iter()
            .map(|&point| run_point(out, &opt.base, point))
            .collect()
    });
    bar.finish_and_clear();
    let stopped = results
        .iter()
        .filter(|r| matches!(r, Err(Error::Interrupted { .. })))
        .count();
    if let (true, Some(signal)) = (stopped > 0, crate::interrupt::requested()) {
        let finished = results.iter().filter(|r| r.is_ok()).count();
        return Err(Error::Interrupted {
            signal,
            what: format!(
                "{finished} of {} runs finished; the runs under way saved checkpoints and the \
                 same sweep command continues them",
                grid.len()
            ),
        });
    }
    let mut points = Vec::new();
    let mut reused = 0;
    for (point, r) in grid.iter().zip(results) {
        let (was, v) = r?;
        reused += was as usize;
        points.push((*point, v));
    }
    let mut rep = write_outputs(out, &grid, &points, &opt.base)?;
    let dirs: Vec<_> = points
        .iter()
        .map(|((phi, q, rate), _)| ((*phi, *q, *rate), run_dir(out, *phi, *q, *rate)))
        .collect();
    write_contacts(out, &dirs)?;
    rep.reused = reused;
    Ok(rep)
}

/// The table of a sweep, one row per finished run.
pub const TABLE: &str = "sweep.parquet";
/// The collision-angle histograms of a sweep's runs (ϑ of vagberg-sheared-disks Eq. 27),
/// one row per run and bin.
pub const ANGLES: &str = "sweep_angles.parquet";
/// The rms relative velocities at contact of a sweep's runs, one row per run.
pub const CONTACTS: &str = "sweep_contacts.parquet";
/// The grid the sweep was asked for and what its runs share, so that a reader can tell
/// which points are missing.
pub const GRID: &str = "sweep.json";

/// Write `sweep.parquet` (one row per finished run, in grid order: φ, Q, γ̇ and every
/// summary quantity with its `_err`) and `sweep.json` (the whole grid, the shared
/// options, and the points missing from the table). `points` may lack grid points.
pub fn write_outputs(
    out: &Path,
    grid: &[(f64, f64, f64)],
    points: &[((f64, f64, f64), serde_json::Value)],
    base: &ShearOptions,
) -> Result<SweepReport> {
    let mut cols: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for ((phi, q, rate), v) in points {
        for (k, x) in [("phi", *phi), ("q", *q), ("rate", *rate)] {
            cols.entry(k.into()).or_default().push(x);
        }
        for (k, x) in v.as_object().into_iter().flatten() {
            if let (Some(m), Some(e)) = (
                x.get("mean").and_then(|m| m.as_f64()),
                x.get("err").and_then(|e| e.as_f64()),
            ) {
                cols.entry(k.clone()).or_default().push(m);
                cols.entry(format!("{k}_err")).or_default().push(e);
            }
        }
    }
    let n = points.len();
    let mut names: Vec<String> = vec!["phi".into(), "q".into(), "rate".into()];
    names.extend(
        cols.keys()
            .filter(|k| !["phi", "q", "rate"].contains(&k.as_str()))
            .cloned(),
    );
    let empty = Vec::new();
    let columns: Vec<Column> = names
        .iter()
        .map(|k| (k, cols.get(k).unwrap_or(&empty)))
        .filter(|(_, c)| c.len() == n)
        .map(|(k, c)| Column::new(k.as_str().into(), c))
        .collect();
    let mut df =
        DataFrame::new(n, columns).map_err(|e| Error::polars("building the sweep table", e))?;
    let table = out.join(TABLE);
    write_table(&mut df, &table)?;
    write_angles(out, points)?;
    let missing: Vec<&(f64, f64, f64)> = grid
        .iter()
        .filter(|g| !points.iter().any(|(p, _)| p == *g))
        .collect();
    let mut shared = serde_json::to_value(base).expect("json");
    if let Some(o) = shared.as_object_mut() {
        for k in ["phi", "q", "rate", "quiet", "resume"] {
            o.remove(k);
        }
    }
    let meta = serde_json::json!({
        "grid": grid.iter().map(|(phi, q, rate)| serde_json::json!({"phi": phi, "q": q, "rate": rate})).collect::<Vec<_>>(),
        "finished": n,
        "missing": missing.iter().map(|(phi, q, rate)| serde_json::json!({"phi": phi, "q": q, "rate": rate})).collect::<Vec<_>>(),
        "options": shared,
    });
    crate::io::atomic_write_str(
        &out.join(GRID),
        &serde_json::to_string_pretty(&meta).expect("json"),
    )?;
    Ok(SweepReport {
        table,
        runs: n,
        reused: 0,
    })
}

/// rms of `v` and its standard error by the delta method, treating the values as
/// independent: se(⟨v²⟩) = sd(v²)/√n, se(rms) = se(⟨v²⟩)/(2 rms).
fn rms(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m2 = v.iter().map(|x| x * x).sum::<f64>() / n;
    let var = v.iter().map(|x| (x * x - m2).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    let r = m2.sqrt();
    (
        r,
        if r > 0.0 {
            (var / n).sqrt() / (2.0 * r)
        } else {
            0.0
        },
    )
}

/// `sweep_contacts.parquet` (vagberg-sheared-disks Sec. III.1, the text beside Fig. 6):
/// for every run with a `contact_velocities.parquet`, the root mean square of the normal
/// and tangential components of the centre-of-mass velocity difference v_ij of the
/// contacts sampled in its steady window (`v_n`, `v_t`, and `v_c_t` with the rotation
/// included), in units of d_s γ̇. A per-run reduction of a table the run already writes:
/// the simulation and its tables are untouched. The errors treat the sampled contacts
/// as independent, which contacts drawn at one time are not: a lower bound.
pub fn write_contacts(out: &Path, points: &[((f64, f64, f64), PathBuf)]) -> Result<()> {
    let names = [
        "phi",
        "q",
        "rate",
        "contacts",
        "v_n_rms",
        "v_n_rms_err",
        "v_t_rms",
        "v_t_rms_err",
        "v_c_t_rms",
        "v_c_t_rms_err",
    ];
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for ((phi, q, rate), dir) in points {
        let f = dir.join("contact_velocities.parquet");
        if !f.exists() {
            continue;
        }
        let t = crate::io::table::read_table(&f, &[])?;
        let (vn, vt, vct) = (t.f64("v_n")?, t.f64("v_t")?, t.f64("v_c_t")?);
        if vn.len() < 2 {
            continue;
        }
        let (a, b, c) = (rms(&vn), rms(&vt), rms(&vct));
        let row = [
            *phi,
            *q,
            *rate,
            vn.len() as f64,
            a.0,
            a.1,
            b.0,
            b.1,
            c.0,
            c.1,
        ];
        for (col, x) in cols.iter_mut().zip(row) {
            col.push(x);
        }
    }
    write_f64_columns(
        &names,
        &cols,
        &out.join(CONTACTS),
        "the sweep's contact table",
    )
}

/// `sweep_angles.parquet`: for every finished run whose summary carries them, its
/// collision-angle counts at making and breaking by 3.6° bin, and P(ϑ) per degree of both
/// together (Figs. 8, 18 draw it at three Q per φ). Runs without the histograms (none
/// since they were added) have no rows.
fn write_angles(out: &Path, points: &[((f64, f64, f64), serde_json::Value)]) -> Result<()> {
    use crate::dem::shear::{ANGLE_BIN_DEG, ANGLE_BINS, angle_edge};
    let names = [
        "phi",
        "q",
        "rate",
        "theta_lo_deg",
        "theta_hi_deg",
        "making",
        "breaking",
        "pdf",
    ];
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    for ((phi, q, rate), v) in points {
        let counts = |key: &str| -> Option<Vec<f64>> {
            let a = v.get(key)?.as_array()?;
            let c: Vec<f64> = a.iter().filter_map(|x| x.as_f64()).collect();
            (c.len() == ANGLE_BINS && a.len() == ANGLE_BINS).then_some(c)
        };
        let (Some(mk), Some(br)) = (
            counts("collision_angle_making"),
            counts("collision_angle_breaking"),
        ) else {
            continue;
        };
        let total: f64 = mk.iter().chain(&br).sum();
        for k in 0..ANGLE_BINS {
            let pdf = if total > 0.0 {
                (mk[k] + br[k]) / (total * ANGLE_BIN_DEG)
            } else {
                0.0
            };
            let row = [
                *phi,
                *q,
                *rate,
                angle_edge(k),
                angle_edge(k + 1),
                mk[k],
                br[k],
                pdf,
            ];
            for (c, x) in cols.iter_mut().zip(row) {
                c.push(x);
            }
        }
    }
    write_f64_columns(&names, &cols, &out.join(ANGLES), "the sweep's angle table")
}

#[cfg(test)]
mod contact_tests {
    use super::*;

    #[test]
    fn rms_and_its_error_by_hand() {
        // v = ±1, ±3: ⟨v²⟩ = 5, rms √5; v² = 1, 9, 1, 9 has sample variance 64/3.
        let (r, e) = rms(&[1.0, -1.0, 3.0, -3.0]);
        assert!((r - 5f64.sqrt()).abs() < 1e-12);
        let want = (64.0f64 / 3.0 / 4.0).sqrt() / (2.0 * 5f64.sqrt());
        assert!((e - want).abs() < 1e-12, "{e} {want}");
    }
}
