//! The size-scan section (li-granular-pillars Sec. V): when a report shows two or more
//! `simulate pillar` runs, it compares them as the paper compares its sizes — flow
//! stress against width with the fit through the origin (Fig. 10a, b), the bar's contact
//! pressure (Fig. 10c), dissipation (Fig. 10d), the shape's scaling χ = W/W0 and the
//! rescaled outlines (Fig. 9), g(r) by species beside any experiment's (Fig. 2) — and
//! states the paper's size-independence claims as checks with their values. The scan's
//! tables are written beside the report (`size_scan*.csv`).

use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::read_tracks;
use crate::io::table::read_table;
use crate::stages::report::DatasetInputs;
use crate::stages::report::render::SavedFigure;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::figures::{MapFigure, MapPanel};
use crate::stages::report::render::html::{Block, Section};
use crate::stages::report::sections::Figures;
use crate::stages::sizes::{CHI_AT, SizeOutputs, SizeScan};
use crate::structure::{ShearLine, shape_distance};
use crate::tracks::Tracks;
use std::path::{Path, PathBuf};

/// g(r) out to this many D, in bins of D/25.
const GOFR_R_MAX: f64 = 4.0;
const GOFR_BINS: usize = 100;

/// A `simulate pillar` run directory behind a data set (its stress table's folder).
fn pillar_run(d: &DatasetInputs) -> Option<PathBuf> {
    let dir = d.stress.as_ref()?.parent()?.to_path_buf();
    let text = std::fs::read_to_string(dir.join(crate::stages::manifest::MANIFEST)).ok()?;
    let m: serde_json::Value = serde_json::from_str(&text).ok()?;
    (m["command"] == "simulate pillar").then_some(dir)
}

fn line(label: String, colour: usize, points: Vec<(f64, f64)>) -> XySeries {
    XySeries {
        label,
        points: points.into_iter().map(|(x, y)| (x, y, 0.0)).collect(),
        markers_only: false,
        colour,
    }
}

/// The section, or None when fewer than two pillar runs are shown.
pub fn size_section(
    datasets: &[DatasetInputs],
    out_dir: &Path,
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Option<Section>> {
    let runs: Vec<(String, PathBuf)> = datasets
        .iter()
        .filter_map(|d| pillar_run(d).map(|p| (d.label.clone(), p)))
        .collect();
    if runs.len() < 2 {
        return Ok(None);
    }
    let dirs: Vec<PathBuf> = runs.iter().map(|r| r.1.clone()).collect();
    let mut f = Figures {
        figdir,
        prefix: "sizes".into(),
        figures,
        blocks: Vec::new(),
    };
    let scan = match crate::stages::sizes::scan(&dirs) {
        Ok(s) => s,
        Err(e) => {
            f.blocks.push(Block::Paragraph(format!(
                "The data sets {} are pillar runs of different sizes, but they cannot be compared as a size scan: {e}",
                runs.iter().map(|r| r.0.as_str()).collect::<Vec<_>>().join(", ")
            )));
            return Ok(Some(section(f.blocks)));
        }
    };
    crate::stages::sizes::write(
        &scan,
        &SizeOutputs {
            table: out_dir.join("size_scan.csv"),
            curves: Some(out_dir.join("size_scan_curves.csv")),
            pressure: Some(out_dir.join("size_scan_pressure.csv")),
        },
    )?;
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
    f.blocks.push(Block::Paragraph(format!(
        "{} pillar runs compared as the paper compares its sizes (li-granular-pillars Sec. V); stresses in m g μ/D, lengths in D. Tables: size_scan.csv, size_scan_curves.csv, size_scan_pressure.csv beside this report.",
        scan.rows.len()
    )));
    f.blocks.push(run_table(&scan, &names));
    f.blocks.push(checks_table(&scan));
    curves(&mut f, &scan, &names)?;
    shear_lines(&mut f, datasets, &scan, &names)?;
    // Each run's tracks, read once for its outlines and its g(r).
    let tracks = scan
        .rows
        .iter()
        .map(|r| {
            let path = r.run.join("tracks.parquet");
            read_tracks(&path).map(|(t, _)| (path.display().to_string(), t))
        })
        .collect::<Result<Vec<_>>>()?;
    outlines(&mut f, &scan, &names, &tracks)?;
    gofr(&mut f, datasets, &names, &tracks)?;
    Ok(Some(section(f.blocks)))
}

fn section(blocks: Vec<Block>) -> Section {
    Section {
        id: "sizes".into(),
        title: "Size scan (li-granular-pillars Sec. V)".into(),
        blocks,
    }
}

fn run_table(scan: &SizeScan, names: &[String]) -> Block {
    let rows = scan
        .rows
        .iter()
        .zip(names)
        .map(|(r, name)| {
            let snaps = r.pressure.as_ref().map_or(0, |p| p.1);
            vec![
                name.clone(),
                format!("{:.2}", r.w0_over_d),
                format!("{:.3} ± {:.3}", r.sigma, r.sigma_err),
                format!("{:.4}", r.sigma / r.w0_over_d),
                format!("{:.3}", r.kappa),
                format!("{:.3}", r.chi[0]),
                format!("{:.3}", r.chi[1]),
                match r.yielding.point() {
                    Some(p) => format!(
                        "{:.4} [{:.4}, {:.4}]",
                        p.eps_y, p.eps_interval[0], p.eps_interval[1]
                    ),
                    None => "not reached".into(),
                },
                match r.yielding.point() {
                    Some(p) => format!(
                        "{:.3} [{:.3}, {:.3}] (σ_y/W0 {:.4})",
                        p.sigma_y,
                        p.sigma_interval[0],
                        p.sigma_interval[1],
                        p.sigma_y / r.w0_over_d
                    ),
                    None => "not reached".into(),
                },
                match &r.pressure {
                    Ok(_) => format!("{:.2} ({snaps} snapshots)", r.p_centre()),
                    Err(e) => format!("none: {e}"),
                },
            ]
        })
        .collect();
    Block::Table {
        header: [
            "run",
            "W0/D",
            "⟨σ⟩, 0.05 ≤ ε ≤ 0.2",
            "⟨σ⟩/W0",
            "⟨κ⟩",
            "χ(0.1)",
            "χ(0.2)",
            "ε_y (95 %)",
            "σ_y (95 %)",
            "p at the bar's centre, 0.1 ≤ ε ≤ 0.2",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    }
}

fn checks_table(scan: &SizeScan) -> Block {
    let verdict = |ok: bool| if ok { "holds" } else { "does not hold" }.to_string();
    let mut rows = Vec::new();
    if let Some(fit) = &scan.fit {
        rows.push(vec![
            "⟨σ⟩ ∝ W0 (Fig. 10b)".into(),
            "linear through the origin".into(),
            format!(
                "c = {:.4} [{:.4}, {:.4}] m g μ/D per D (95 %)",
                fit.c, fit.c_interval[0], fit.c_interval[1]
            ),
            String::new(),
        ]);
    }
    if let Some(c) = &scan.checks {
        rows.push(vec![
            "⟨σ⟩/W0 independent of size".into(),
            "spread ≤ 10 %".into(),
            format!("{:.1} %", 100.0 * c.sigma_over_w0_spread),
            verdict(c.sigma_over_w0_spread <= 0.10),
        ]);
        rows.push(vec![
            "yield stress grows linearly with size: σ_y/W0 independent of size (abstract)".into(),
            "spread ≤ 10 %".into(),
            c.sigma_y_over_w0_spread.map_or_else(
                || "not made: a run does not yield by ε = 0.2".into(),
                |s| format!("{:.1} %", 100.0 * s),
            ),
            c.sigma_y_over_w0_spread
                .map_or_else(|| "—".into(), |s| verdict(s <= 0.10)),
        ]);
        rows.push(vec![
            "κ independent of size (Fig. 10d)".into(),
            "spread ≤ 0.03".into(),
            format!("{:.3}", c.kappa_spread),
            verdict(c.kappa_spread <= 0.03),
        ]);
        for (k, at) in CHI_AT.iter().enumerate() {
            rows.push(vec![
                format!("W/W0 at ε = {at} independent of size (self-similar shape)"),
                "spread ≤ 5 %".into(),
                format!("{:.1} %", 100.0 * c.chi_spread[k]),
                verdict(c.chi_spread[k] <= 0.05),
            ]);
        }
    }
    Block::Table {
        header: ["the paper's claim", "judged by", "measured", "verdict"]
            .map(String::from)
            .to_vec(),
        rows,
    }
}

/// Figs. 10a–d and χ(ε).
fn curves(f: &mut Figures, scan: &SizeScan, names: &[String]) -> Result<()> {
    let by_strain = |k: usize| -> Vec<XySeries> {
        scan.rows
            .iter()
            .zip(names)
            .enumerate()
            .map(|(c, (r, name))| {
                let (eps, v) = (&r.curves[0], &r.curves[k]);
                let pts = eps.iter().zip(v).filter(|(_, y)| y.is_finite());
                line(name.clone(), c, pts.map(|(&x, &y)| (x, y)).collect())
            })
            .collect()
    };
    for (k, file, title, y, caption) in [
        (
            1,
            "stress",
            "Stress–strain by size (Fig. 10a)",
            "σ  (m g μ / D)",
            "σ = F_bar/W against ε for every size: wider pillars flow at higher stress (li-granular-pillars Fig. 10a).",
        ),
        (
            2,
            "kappa",
            "Dissipation by size (Fig. 10d)",
            "κ = P_g-s / P_in",
            "The fraction of the input power dissipated by substrate friction against ε; the paper finds it independent of size (li-granular-pillars Fig. 10d).",
        ),
        (
            3,
            "chi",
            "Shape scaling χ = W/W0",
            "χ = W / W0",
            "The width at the bar (grains within 2 D of it) over its initial value against ε: curves that coincide mean a self-similar shape evolution (li-granular-pillars Sec. V).",
        ),
    ] {
        f.add(
            &XyFigure {
                title: title.into(),
                x_desc: "ε".into(),
                y_desc: y.into(),
                x_log: false,
                y_log: false,
                series: by_strain(k),
            },
            file,
            caption.into(),
        )?;
    }
    // Fig. 10b: the runs with their errors and the fitted line through the origin.
    let mut series = vec![XySeries {
        label: "runs".into(),
        points: scan
            .rows
            .iter()
            .map(|r| (r.w0_over_d, r.sigma, r.sigma_err))
            .collect(),
        markers_only: true,
        colour: 0,
    }];
    if let Some(fit) = &scan.fit {
        let w_max = scan.rows.iter().map(|r| r.w0_over_d).fold(0.0, f64::max) * 1.1;
        series.push(line(
            format!("⟨σ⟩ = {:.3} W0/D", fit.c),
            1,
            vec![(0.0, 0.0), (w_max, fit.c * w_max)],
        ));
    }
    f.add(
        &XyFigure {
            title: "Flow stress against width (Fig. 10b)".into(),
            x_desc: "W0 / D".into(),
            y_desc: "⟨σ⟩ (0.05 ≤ ε ≤ 0.2)  (m g μ / D)".into(),
            x_log: false,
            y_log: false,
            series,
        },
        "sigma_w0",
        "The mean flow stress over 0.05 ≤ ε ≤ 0.2 (errors from four blocks) against the initial width, with the weighted fit through the origin: \"smaller is weaker\" (li-granular-pillars Fig. 10b).".into(),
    )?;
    let pressure: Vec<XySeries> = scan
        .rows
        .iter()
        .zip(names)
        .enumerate()
        .filter_map(|(c, (r, name))| {
            let (p, _) = r.pressure.as_ref().ok()?;
            Some(line(
                name.clone(),
                c,
                p.x_over_w
                    .iter()
                    .copied()
                    .zip(p.p.iter().copied())
                    .collect(),
            ))
        })
        .collect();
    if !pressure.is_empty() {
        f.add(
            &XyFigure {
                title: "Contact pressure along the bar (Fig. 10c)".into(),
                x_desc: "x / W".into(),
                y_desc: "p  (m g μ / D)".into(),
                x_log: false,
                y_log: false,
                series: pressure,
            },
            "pressure",
            "The bar's normal force per length across the contact interface (W its span, radii included), averaged over the force snapshots at 0.1 ≤ ε ≤ 0.2: near zero at the edges, highest around the centre, and growing with the width (li-granular-pillars Fig. 10c).".into(),
        )?;
    }
    Ok(())
}

/// Lines steeper than this to the compression axis are the layer of grains sheared
/// under the bar, not the bulk's transient shear lines.
const BAR_LAYER_DEG: f64 = 75.0;

/// Median and quartiles of `v` (NaN for none).
fn quartiles(v: &mut [f64]) -> [f64; 3] {
    v.sort_by(f64::total_cmp);
    let q = |p: f64| {
        if v.is_empty() {
            f64::NAN
        } else {
            crate::stats::quantile_sorted(v, p)
        }
    };
    [q(0.5), q(0.25), q(0.75)]
}

/// Fig. 11: the transient shear lines of every frame pair of each run's kinematics
/// (`structure::shear_lines` with its defaults), their angle to the compression axis
/// and width distributions by size, and the paper's claims (about 45°, about 2 D wide,
/// independent of size) as checks.
fn shear_lines(
    f: &mut Figures,
    datasets: &[DatasetInputs],
    scan: &SizeScan,
    names: &[String],
) -> Result<()> {
    let mut rows = Vec::new();
    let (mut angles, mut widths) = (Vec::new(), Vec::new());
    let mut bulk_width_medians = Vec::new();
    // Per run: (index, name, start frame, its longest line) for the J2 maps.
    let mut shown: Vec<(usize, String, i64, ShearLine)> = Vec::new();
    for (c, (r, name)) in scan.rows.iter().zip(names).enumerate() {
        let Some(kin) = datasets
            .iter()
            .find(|d| pillar_run(d).as_deref() == Some(r.run.as_path()))
            .and_then(|d| d.kinematics.clone())
        else {
            continue;
        };
        let by_frame = crate::stages::shear_lines::every_pair(&kin, &Default::default())?;
        let is_bulk = |l: &&ShearLine| l.angle_deg < BAR_LAYER_DEG;
        // The maps stand at one strain for every size (Fig. 11 compares sizes at one
        // moment): the frame pair with a line away from the bar layer that starts
        // nearest the frame at ε = MAP_STRAIN, and its longest such line. Each map's
        // title states its own ε.
        let target = frame_at_strain(&r.run, MAP_STRAIN)?;
        if let Some((frame, line)) = by_frame
            .iter()
            .filter(|(_, ls)| ls.iter().any(|l| is_bulk(&l)))
            .min_by_key(|(f, _)| target.map_or(0, |t| (*f - t).abs()))
            .and_then(|(f, ls)| {
                ls.iter()
                    .filter(is_bulk)
                    .max_by(|a, b| a.length_d.total_cmp(&b.length_d))
                    .map(|l| (*f, l.clone()))
            })
        {
            shown.push((c, name.clone(), frame, line));
        }
        let lines: Vec<ShearLine> = by_frame.into_iter().flat_map(|(_, ls)| ls).collect();
        let bulk: Vec<_> = lines.iter().filter(is_bulk).collect();
        let [a, a1, a3] = quartiles(&mut bulk.iter().map(|l| l.angle_deg).collect::<Vec<_>>());
        let [w, w1, w3] = quartiles(&mut bulk.iter().map(|l| l.width_d).collect::<Vec<_>>());
        rows.push(vec![
            name.clone(),
            format!("{}", lines.len()),
            format!("{}", lines.len() - bulk.len()),
            format!("{a:.1} [{a1:.1}, {a3:.1}]"),
            format!("{w:.2} [{w1:.2}, {w3:.2}]"),
        ]);
        if !bulk.is_empty() {
            bulk_width_medians.push(w);
        }
        let hist = |v: Vec<f64>, lo: f64, step: f64, bins: usize| -> Vec<(f64, f64)> {
            let mut h = vec![0.0; bins];
            for x in &v {
                let k = ((x - lo) / step).floor();
                if k >= 0.0 && (k as usize) < bins {
                    h[k as usize] += 1.0 / v.len() as f64;
                }
            }
            (0..bins)
                .map(|k| (lo + (k as f64 + 0.5) * step, h[k]))
                .collect()
        };
        angles.push(line(
            name.clone(),
            c,
            hist(lines.iter().map(|l| l.angle_deg).collect(), 0.0, 10.0, 9),
        ));
        widths.push(line(
            name.clone(),
            c,
            hist(bulk.iter().map(|l| l.width_d).collect(), 0.0, 0.5, 12),
        ));
    }
    if rows.is_empty() {
        f.blocks.push(Block::Paragraph(
            "No shear lines: none of the pillar runs has a kinematics stage (add one with lags = [8], Δt = 8/15 R/v_c, as Fig. 11).".into(),
        ));
        return Ok(());
    }
    f.blocks.push(Block::Table {
        header: [
            "run",
            "lines (every frame pair)",
            "of them in the bar layer (> 75°)",
            "angle to the compression axis, median [quartiles], °",
            "width, median [quartiles], D",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    if let (Some(lo), Some(hi)) = (
        bulk_width_medians.iter().copied().reduce(f64::min),
        bulk_width_medians.iter().copied().reduce(f64::max),
    ) {
        f.blocks.push(Block::Paragraph(format!(
            "Check — shear-line width between 1.5 and 3 D at every size (li-granular-pillars Fig. 11: about 2 D): median widths {lo:.2}–{hi:.2} D, {}. Method and its limits: docs/shear-lines.md.",
            if lo >= 1.5 && hi <= 3.0 { "holds" } else { "does not hold" }
        )));
    }
    j2_maps(f, datasets, scan, &shown)?;
    for (series, file, title, x, caption) in [
        (
            angles,
            "line_angles",
            "Shear-line angles by size (Fig. 11)",
            "angle to the compression axis (°)",
            "Fraction of the transient shear lines in 10° bins of their angle to the compression axis, every frame pair of each run at Δt of its kinematics stage: the paper finds about 45° at every size (lines near 90° are the layer under the bar).",
        ),
        (
            widths,
            "line_widths",
            "Shear-line widths by size (Fig. 11)",
            "width (D)",
            "Fraction of the shear lines away from the bar layer in 0.5 D bins of their width (√12 times the rms spread of their grains across the line): the paper finds about 2 D at every size.",
        ),
    ] {
        f.add(
            &XyFigure {
                title: title.into(),
                x_desc: x.into(),
                y_desc: "fraction of lines".into(),
                x_log: false,
                y_log: false,
                series,
            },
            file,
            caption.into(),
        )?;
    }
    Ok(())
}

/// Fig. 11: for each run, the J2 map of the frame pair nearest ε = `MAP_STRAIN` with a
/// shear line away from the bar layer, and a zoom around its longest line (a square 12 D across, or 1.2 line lengths), on one
/// log colour scale.
fn j2_maps(
    f: &mut Figures,
    datasets: &[DatasetInputs],
    scan: &SizeScan,
    shown: &[(usize, String, i64, ShearLine)],
) -> Result<()> {
    let mut panels = Vec::new();
    for (c, _, frame, line) in shown {
        let Some(d) = datasets
            .iter()
            .find(|d| pillar_run(d).as_deref() == Some(scan.rows[*c].run.as_path()))
        else {
            continue;
        };
        let loaded = super::data::Loaded::read(d)?;
        let Some(dd) = loaded.tracks.as_ref().and_then(|t| t.large_diameter()) else {
            continue;
        };
        let Some(p) = loaded.map_panels(&[*frame]).into_iter().next() else {
            continue;
        };
        let grains: Vec<(f64, f64, f64, f64)> = p
            .grains
            .iter()
            .map(|&(x, y, r, v)| (x, y, r, v[1]))
            .collect();
        let half = (6.0f64).max(0.6 * line.length_d) * dd;
        let zoom: Vec<(f64, f64, f64, f64)> = grains
            .iter()
            .copied()
            .filter(|g| (g.0 - line.x).abs() <= half && (g.1 - line.y).abs() <= half)
            .collect();
        panels.push(MapPanel {
            title: format!("N = {}, {}", scan.rows[*c].n, p.title),
            grains,
        });
        panels.push(MapPanel {
            title: format!(
                "zoom: line at {:.0}°, {:.1} D wide, {:.0} D long",
                line.angle_deg, line.width_d, line.length_d
            ),
            grains: zoom,
        });
    }
    if panels.is_empty() {
        return Ok(());
    }
    f.add(
        &MapFigure {
            quantity: "J2 = η^s/Δt in v_c/R (Eq. 18)".into(),
            log: true,
            columns: 2,
            panels,
        },
        "j2_lines",
        "J2 at Δt of each run's kinematics stage (8/15 R/v_c in paper-sizes) for the frame pair starting nearest ε = 0.1 (the same strain for every size; each title gives its ε) among those with a shear line away from the bar layer, and a zoom around its longest line: the transient shear lines of li-granular-pillars Fig. 11, about 45° to the compression axis and a few grains wide at every size.".into(),
    )
}

/// The strain at which the Fig. 11 maps of every size stand.
const MAP_STRAIN: f64 = 0.1;

/// The strain of each frame of a run (its stress table).
fn frame_at_strain(run: &Path, eps: f64) -> Result<Option<i64>> {
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

/// Fig. 9: each run's outline at ε = 0.1 and 0.2 rescaled by its W0, overlaid, and the
/// rms distance of each to the largest run's.
fn outlines(
    f: &mut Figures,
    scan: &SizeScan,
    names: &[String],
    tracks: &[(String, Tracks)],
) -> Result<()> {
    let mut rows = Vec::new();
    for eps in CHI_AT {
        let mut series = Vec::new();
        let mut got = Vec::new();
        for (c, ((r, name), (source, t))) in scan.rows.iter().zip(names).zip(tracks).enumerate() {
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
            series.push(line(name.clone(), c, pts));
            got.push((name.clone(), o));
        }
        if let Some((big_name, big)) = got.last() {
            for (name, o) in &got[..got.len() - 1] {
                rows.push(vec![
                    format!("{eps}"),
                    format!("{name} vs {big_name}"),
                    format!(
                        "{:.3}",
                        shape_distance(&o.outline, o.w0, &big.outline, big.w0)
                    ),
                ]);
            }
        }
        if series.is_empty() {
            continue;
        }
        f.add(
            &XyFigure {
                title: format!("Outlines rescaled by W0 at ε = {eps} (Fig. 9)"),
                x_desc: "x / W0".into(),
                y_desc: "y / W0".into(),
                x_log: false,
                y_log: false,
                series,
            },
            &format!("outline_{}", (eps * 100.0).round() as i64),
            format!("Each pillar's outline (outermost grain edges in slabs one D thick) at ε = {eps}, lengths over its own initial width W0: outlines that coincide are the same shape at another size (li-granular-pillars Fig. 9)."),
        )?;
    }
    if !rows.is_empty() {
        f.blocks.push(Block::Table {
            header: ["ε", "outlines", "rms half-width difference / W0"]
                .map(String::from)
                .to_vec(),
            rows,
        });
    }
    Ok(())
}

/// Fig. 2: g(r) around small and around large grains of each run's first frame and of
/// each experiment's (data sets with tracks and no simulation).
fn gofr(
    f: &mut Figures,
    datasets: &[DatasetInputs],
    names: &[String],
    runs: &[(String, Tracks)],
) -> Result<()> {
    // The runs' tracks as read, then each experiment's (data sets with tracks and no
    // simulation).
    let mut experiments = Vec::new();
    for d in datasets
        .iter()
        .filter(|d| d.stress.is_none() && d.shear.is_none() && d.sweep.is_none())
    {
        if let Some(p) = &d.tracks {
            experiments.push((d.label.clone(), p.display().to_string(), read_tracks(p)?.0));
        }
    }
    let sources: Vec<(&String, &String, &Tracks)> = names
        .iter()
        .zip(runs)
        .map(|(n, (p, t))| (n, p, t))
        .chain(experiments.iter().map(|(n, p, t)| (n, p, t)))
        .collect();
    let (mut small, mut large) = (Vec::new(), Vec::new());
    for (c, (name, path, t)) in sources.into_iter().enumerate() {
        let (g, _, d) = crate::stages::gofr::of_tracks(t, path, None, GOFR_R_MAX, GOFR_BINS)
            .map_err(|e| Error::Other(format!("g(r) of {name}: {e}")))?;
        let pts = |v: &[f64]| g.r.iter().map(|r| r / d).zip(v.iter().copied()).collect();
        small.push(line(name.clone(), c, pts(&g.g_small)));
        large.push(line(name.clone(), c, pts(&g.g_large)));
    }
    for (series, file, who) in [
        (small, "gofr_small", "small"),
        (large, "gofr_large", "large"),
    ] {
        f.add(
            &XyFigure {
                title: format!("g(r) around {who} grains (Fig. 2)"),
                x_desc: "r / D".into(),
                y_desc: "g(r)".into(),
                x_log: false,
                y_log: false,
                series,
            },
            file,
            format!("The pair distribution around {who} grains at the first frame, normalised by the density of all grains (→ 1 far out); in open pillars only centres 4 D inside the convex hull count (li-granular-pillars Fig. 2)."),
        )?;
    }
    Ok(())
}
