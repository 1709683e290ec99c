//! The sheared-disk sections of the report (vagberg-sheared-disks): for a sweep, flow
//! curves, Z beside 2τ_dur ν_coll, μ, rotation and R_v against φ, P^el, τ_dur/τ_e and
//! ν_coll/γ̇ against φ and Q (`elastic`), and the
//! Newtonian/Bagnoldian classification with its phase diagrams; for one run, its
//! steady-state summary, P(ϑ) of Eq. 27 at contact making and breaking (`angles`, with
//! the sweep's P(ϑ) at three Q and P(90°) against Q), contact velocities and
//! shear-band profiles and fields (`run_figures`); for a branch's
//! strain-rate ramps, the hysteresis loop (`ramp`). A sweep with grid points missing (a
//! killed one) is shown as far as it goes, naming what is missing.

pub mod angles;
pub mod appendix_a;
mod cdn;
pub mod classify;
pub mod coexistence;
pub mod contour;
mod elastic;
pub mod jamming;
pub mod paper_figures;
pub mod phase_boundaries;
pub mod qc;
pub mod ramp;
pub mod run_figures;
pub mod stress_space;

use crate::error::{Error, Result};
use crate::io::table::read_table;
use crate::stages::report::render::SavedFigure;
use crate::stages::report::render::curves::{PhaseFigure, XyFigure, XySeries};
use crate::stages::report::render::html::{Block, Section};
use crate::stages::report::sections::Figures;
use classify::{Class, Slope, Transition, fit_slope, local_slopes, transitions};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// One finished run of a sweep: its grid point and every summary quantity (mean, error).
#[derive(Debug, Clone)]
pub struct Row {
    pub phi: f64,
    pub q: f64,
    pub rate: f64,
    pub v: BTreeMap<String, (f64, f64)>,
}

impl Row {
    /// A test row at (φ, Q, γ̇) with the values given (no error bars).
    #[cfg(test)]
    pub(crate) fn with(phi: f64, q: f64, rate: f64, values: &[(&str, f64)]) -> Row {
        let v = values
            .iter()
            .map(|&(k, x)| (k.to_string(), (x, 0.0)))
            .collect();
        Row { phi, q, rate, v }
    }

    fn get(&self, k: &str) -> Option<(f64, f64)> {
        self.v.get(k).copied().filter(|(m, _)| m.is_finite())
    }
}

/// A sweep as the report sees it.
#[derive(Debug, Clone)]
pub struct SweepData {
    pub rows: Vec<Row>,
    pub grid: Vec<(f64, f64, f64)>,
    pub missing: Vec<(f64, f64, f64)>,
    /// `cd` or `cdrot`, N, strain (from the shared options).
    pub model: String,
    pub n: Option<u64>,
    pub strain: Option<f64>,
    /// Each run's collision-angle P(ϑ) (`sweep_angles.parquet`), in grid order.
    pub angles: Vec<angles::AnglePdf>,
}

/// Read `sweep.parquet` and `sweep.json` from a sweep's directory; grid points of
/// `sweep.json` without a row are missing.
pub fn read_sweep(dir: &Path) -> Result<SweepData> {
    let gf = dir.join(crate::stages::sweep::GRID);
    let text = std::fs::read_to_string(&gf).map_err(|e| Error::io(&gf, e))?;
    let meta: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::input(gf.display(), e.to_string()))?;
    let point = |v: &serde_json::Value| -> Option<(f64, f64, f64)> {
        Some((v["phi"].as_f64()?, v["q"].as_f64()?, v["rate"].as_f64()?))
    };
    let grid: Vec<(f64, f64, f64)> = meta["grid"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(point)
        .collect();
    let mut rows = Vec::new();
    let tf = dir.join(crate::stages::sweep::TABLE);
    if meta["finished"].as_u64() != Some(0) && tf.exists() {
        let t = read_table(&tf, &[])?;
        let cols = t.columns();
        let (phi, q, rate) = (t.f64("phi")?, t.f64("q")?, t.f64("rate")?);
        let mut vals: BTreeMap<String, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
        for c in &cols {
            let err = format!("{c}_err");
            if ["phi", "q", "rate"].contains(&c.as_str()) || !cols.contains(&err) {
                continue;
            }
            vals.insert(c.clone(), (t.f64_or_nan(c)?, t.f64_or_nan(&err)?));
        }
        for i in 0..phi.len() {
            rows.push(Row {
                phi: phi[i],
                q: q[i],
                rate: rate[i],
                v: vals
                    .iter()
                    .map(|(k, (m, e))| (k.clone(), (m[i], e[i])))
                    .collect(),
            });
        }
    }
    merge_contacts(dir, &mut rows)?;
    let missing = grid
        .iter()
        .filter(|g| !rows.iter().any(|r| (r.phi, r.q, r.rate) == **g))
        .copied()
        .collect();
    let o = &meta["options"];
    Ok(SweepData {
        rows,
        grid,
        missing,
        model: o["model"].as_str().unwrap_or("?").to_string(),
        n: o["n"].as_u64(),
        strain: o["strain"].as_f64(),
        angles: angles::read_sweep_angles(dir)?,
    })
}

/// Add each run's rms contact velocities (`sweep_contacts.parquet`, absent in sweeps
/// written before it) to its row as `v_n_rms`, `v_t_rms`, `v_c_t_rms` with errors.
fn merge_contacts(dir: &Path, rows: &mut [Row]) -> Result<()> {
    let f = dir.join(crate::stages::sweep::CONTACTS);
    if !f.exists() {
        return Ok(());
    }
    let t = match read_table(&f, &[]) {
        Ok(t) => t,
        Err(Error::Input { msg, .. }) if msg.starts_with("no data rows") => return Ok(()),
        Err(e) => return Err(e),
    };
    let (phi, q, rate) = (t.f64("phi")?, t.f64("q")?, t.f64("rate")?);
    for k in ["v_n_rms", "v_t_rms", "v_c_t_rms"] {
        let (m, e) = (t.f64(k)?, t.f64(&format!("{k}_err"))?);
        for i in 0..phi.len() {
            if let Some(r) = rows
                .iter_mut()
                .find(|r| (r.phi, r.q, r.rate) == (phi[i], q[i], rate[i]))
            {
                r.v.insert(k.to_string(), (m[i], e[i]));
            }
        }
    }
    Ok(())
}

/// One classified slope with the (φ, Q) it belongs to.
#[derive(Debug, Clone, Serialize)]
pub struct Classified {
    pub phi: f64,
    pub q: f64,
    /// `all` (every rate of the grid at this φ, Q) or `local` (two neighbouring rates).
    pub scope: &'static str,
    #[serde(flatten)]
    pub slope: Slope,
}

/// A transition with what it runs along and at what it is held.
#[derive(Debug, Clone, Serialize)]
pub struct Located {
    /// `phi` (φ_c at fixed Q, over all rates or a pair of rates) or `q` (Q_c at fixed φ).
    pub along: &'static str,
    /// Q (along φ) or φ (along Q).
    pub at: f64,
    /// The rates the classes come from.
    pub rate_lo: f64,
    pub rate_hi: f64,
    #[serde(flatten)]
    pub t: Transition,
}

/// Every (φ, Q)'s slope over all its rates and between neighbouring rates, and where
/// the class changes along φ and along Q.
#[derive(Debug, Clone, Serialize)]
pub struct Classification {
    pub slopes: Vec<Classified>,
    pub transitions: Vec<Located>,
}

fn key(x: f64) -> i64 {
    (x * 1e9).round() as i64
}

/// A class on an axis: (axis value, class, the value held fixed, rate span).
type OnAxis = (f64, Class, f64, f64, f64);

pub fn classify(rows: &[Row]) -> Classification {
    let mut by: BTreeMap<(i64, i64), Vec<&Row>> = BTreeMap::new();
    for r in rows {
        by.entry((key(r.phi), key(r.q))).or_default().push(r);
    }
    let mut slopes = Vec::new();
    for rs in by.values() {
        let pts: Vec<classify::Point> = rs
            .iter()
            .filter_map(|r| r.get("p").map(|(p, e)| (r.rate, p, e)))
            .collect();
        let (phi, q) = (rs[0].phi, rs[0].q);
        if let Some(s) = fit_slope(&pts) {
            slopes.push(Classified {
                phi,
                q,
                scope: "all",
                slope: s,
            });
        }
        if pts.len() > 2 {
            for s in local_slopes(&pts) {
                slopes.push(Classified {
                    phi,
                    q,
                    scope: "local",
                    slope: s,
                });
            }
        }
    }
    let mut located = Vec::new();
    // Along φ at each Q and rate span; along Q at each φ (all rates).
    let mut along_phi: BTreeMap<(i64, &str, i64, i64), Vec<OnAxis>> = BTreeMap::new();
    let mut along_q: BTreeMap<i64, Vec<OnAxis>> = BTreeMap::new();
    for c in &slopes {
        let s = &c.slope;
        along_phi
            .entry((key(c.q), c.scope, key(s.rate_lo), key(s.rate_hi)))
            .or_default()
            .push((c.phi, s.class, c.q, s.rate_lo, s.rate_hi));
        if c.scope == "all" {
            along_q
                .entry(key(c.phi))
                .or_default()
                .push((c.q, s.class, c.phi, s.rate_lo, s.rate_hi));
        }
    }
    for (axis, groups) in [
        ("phi", along_phi.into_values().collect::<Vec<_>>()),
        ("q", along_q.into_values().collect()),
    ] {
        for mut g in groups {
            g.sort_by(|a, b| a.0.total_cmp(&b.0));
            let classes: Vec<(f64, Class)> = g.iter().map(|x| (x.0, x.1)).collect();
            for t in transitions(&classes) {
                located.push(Located {
                    along: axis,
                    at: g[0].2,
                    rate_lo: g[0].3,
                    rate_hi: g[0].4,
                    t,
                });
            }
        }
    }
    Classification {
        slopes,
        transitions: located,
    }
}

fn fmt_pm(m: f64, e: f64) -> String {
    if !m.is_finite() {
        return "–".into();
    }
    let mag = m.abs().max(e.abs());
    if mag != 0.0 && !(1e-3..1e4).contains(&mag) {
        format!("{m:.4e} ± {e:.1e}")
    } else {
        format!("{m:.4} ± {e:.2}")
    }
}

fn pt(p: &(f64, f64, f64)) -> String {
    format!("(φ = {}, Q = {}, γ̇ τ_e = {:e})", p.0, p.1, p.2)
}

/// File-name-safe form of a label.
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// The grid axis a series runs along; the other two group and label it.
#[derive(Debug, Clone, Copy)]
enum Along {
    Phi,
    Q,
    Rate,
}

/// Series of `quantity` against one grid axis, one per value of the other two (in their
/// order), labelled by them after `label`; colours from `colour_of` by group, else one
/// per series in order.
fn series_along(
    rows: &[Row],
    along: Along,
    quantity: &str,
    label: &str,
    markers_only: bool,
    colour_of: Option<&BTreeMap<(i64, i64), usize>>,
) -> Vec<XySeries> {
    let x = |r: &Row| match along {
        Along::Phi => r.phi,
        Along::Q => r.q,
        Along::Rate => r.rate,
    };
    let group = |r: &Row| match along {
        Along::Phi => (key(r.q), key(r.rate)),
        Along::Q => (key(r.phi), key(r.rate)),
        Along::Rate => (key(r.phi), key(r.q)),
    };
    let mut by: BTreeMap<(i64, i64), Vec<&Row>> = BTreeMap::new();
    for r in rows {
        by.entry(group(r)).or_default().push(r);
    }
    by.into_iter()
        .enumerate()
        .filter_map(|(k, (g, mut rs))| {
            rs.sort_by(|a, b| x(a).total_cmp(&x(b)));
            let points: Vec<(f64, f64, f64)> = rs
                .iter()
                .filter_map(|r| r.get(quantity).map(|(m, e)| (x(r), m, e)))
                .collect();
            let r0 = rs[0];
            let name = match along {
                Along::Phi => format!("{label}Q = {}, rate {:.0e}", r0.q, r0.rate),
                Along::Q => format!("{label}φ = {}, rate {:.0e}", r0.phi, r0.rate),
                Along::Rate => format!("{label}φ = {}, Q = {}", r0.phi, r0.q),
            };
            (!points.is_empty()).then(|| XySeries {
                label: name,
                points,
                markers_only,
                colour: colour_of.map_or(k, |c| c.get(&g).copied().unwrap_or(0)),
            })
        })
        .collect()
}

/// Series of `quantity` against φ, one per (Q, γ̇).
fn versus_phi(
    rows: &[Row],
    quantity: &str,
    label: &str,
    markers_only: bool,
    colour_of: &BTreeMap<(i64, i64), usize>,
) -> Vec<XySeries> {
    series_along(
        rows,
        Along::Phi,
        quantity,
        label,
        markers_only,
        Some(colour_of),
    )
}

/// Series of `quantity` against Q, one per (φ, γ̇).
fn versus_q(rows: &[Row], quantity: &str) -> Vec<XySeries> {
    series_along(rows, Along::Q, quantity, "", false, None)
}

/// The sweep's section: what exists, the flow curves and φ dependences, the
/// classification (table, phase diagrams, transitions). Writes the classification to
/// `classification.csv` and `classification.json` in `out_dir`.
pub fn sweep_section(
    label: &str,
    data: &SweepData,
    out_dir: &Path,
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Section> {
    let mut f = Figures {
        figdir,
        prefix: format!("sweep_{}", slug(label)),
        figures,
        blocks: Vec::new(),
    };
    let rates: Vec<f64> = {
        let mut r: Vec<f64> = data.rows.iter().map(|r| r.rate).collect();
        r.sort_by(f64::total_cmp);
        r.dedup();
        r
    };
    f.blocks.push(Block::Paragraph(format!(
        "{label}: model {}, N = {}, strain {} per run; {} of {} grid points finished ({} φ, {} rates).",
        data.model.to_uppercase(),
        data.n.map_or("?".into(), |n| n.to_string()),
        data.strain.map_or("?".into(), |s| s.to_string()),
        data.rows.len(),
        data.grid.len(),
        {
            let mut p: Vec<i64> = data.rows.iter().map(|r| key(r.phi)).collect();
            p.sort();
            p.dedup();
            p.len()
        },
        rates.len(),
    )));
    if !data.missing.is_empty() {
        f.blocks.push(Block::Paragraph(format!(
            "Missing ({} grid points not finished; the figures and the classification show only what exists): {}.",
            data.missing.len(),
            data.missing.iter().map(pt).collect::<Vec<_>>().join(", ")
        )));
    }
    if data.rows.is_empty() {
        return Ok(Section {
            id: format!("sweep-{}", slug(label)),
            title: format!("Sweep {label}"),
            blocks: f.blocks,
        });
    }
    // Flow curves: one series per (φ, Q) against γ̇.
    let flow = |quantity: &str| series_along(&data.rows, Along::Rate, quantity, "", false, None);
    f.add(
        &XyFigure {
            title: "Flow curves: η_p = p/(k_d dγ/dt) against dγ/dt".into(),
            x_desc: "dγ/dt · τ_e".into(),
            y_desc: "η_p = p / (k_d dγ/dt)".into(),
            x_log: true,
            y_log: true,
            series: flow("eta_p"),
        },
        "eta_p",
        "η_p = p/(k_d γ̇) of the total pressure against γ̇ τ_e for each φ (and Q), run errors as bars: flat where the flow is Newtonian (p ∝ γ̇), proportional to γ̇ where it is Bagnoldian (p ∝ γ̇²). The paper draws the elastic part η_p^el against Q and φ (Figs. 2, 11, 16; below).".into(),
    )?;
    f.add(
        &XyFigure {
            title: "Flow curves: B_p = p/(m (dγ/dt)²) against dγ/dt".into(),
            x_desc: "dγ/dt · τ_e".into(),
            y_desc: "B_p = p / (dγ/dt)²  (m = d_s = 1)".into(),
            x_log: true,
            y_log: true,
            series: flow("b_p"),
        },
        "b_p",
        "B_p = p/(m γ̇²) of the total pressure against γ̇ τ_e for each φ (and Q): flat where the flow is Bagnoldian (p ∝ γ̇²), proportional to 1/γ̇ where it is Newtonian. The paper draws the elastic part B_p^el against Q and φ (Figs. 2, 11, 16; below).".into(),
    )?;
    // Against φ: one colour per (Q, γ̇).
    let mut colour_of = BTreeMap::new();
    for r in &data.rows {
        let n = colour_of.len();
        colour_of.entry((key(r.q), key(r.rate))).or_insert(n);
    }
    let mut zs = versus_phi(&data.rows, "z", "Z, ", false, &colour_of);
    zs.extend(versus_phi(
        &data.rows,
        "two_tau_dur_nu_coll",
        "2τν, ",
        true,
        &colour_of,
    ));
    f.add(
        &XyFigure {
            title: "Z and 2 τ_dur ν_coll against φ".into(),
            x_desc: "φ".into(),
            y_desc: "Z, 2 τ_dur ν_coll (contacts per particle)".into(),
            x_log: false,
            y_log: false,
            series: zs,
        },
        "z",
        "The contact number Z (filled, line) and 2 τ_dur ν_coll (open) against φ: two independent measurements (contacts counted; durations, censoring-aware, times collision rates) that agree where the contacts are binary collisions and their durations are measured without bias (Eq. 25; the paper draws them against Q, Figs. 4–5, 12–13, below when the grid has several Q).".into(),
    )?;
    for (quantity, file, title, y, log, caption) in [
        (
            "mu",
            "mu",
            "Macroscopic friction μ = σ/p against φ (Fig. 23)",
            "μ = σ / p",
            false,
            "μ = σ/p against φ for each (Q, γ̇) (vagberg-sheared-disks Fig. 23).",
        ),
        (
            "theta_dot_over_gamma_dot",
            "rotation",
            "⟨θ̇_i⟩/(dγ/dt) against φ (Fig. 20a)",
            "⟨θ̇_i⟩ / (dγ/dt)",
            false,
            "The mean spin ⟨θ̇_i⟩ in units of γ̇ against φ: −1/2 is the rotation of the affine flow, which dilute CDrot disks follow (vagberg-sheared-disks Fig. 20(a)).",
        ),
        (
            "r_v",
            "r_v",
            "R_v = ⟨δv_x²⟩/⟨v_y²⟩ against φ (Fig. 24)",
            "R_v",
            true,
            "R_v = ⟨δv_x²⟩/⟨v_y²⟩ (Eqs. 35–37) against φ: 1 for isotropic velocity fluctuations, large where shear bands form (vagberg-sheared-disks Fig. 24).",
        ),
    ] {
        let series = versus_phi(&data.rows, quantity, "", false, &colour_of);
        if series.is_empty() {
            continue;
        }
        f.add(
            &XyFigure {
                title: title.into(),
                x_desc: "φ".into(),
                y_desc: y.into(),
                x_log: false,
                y_log: log,
                series,
            },
            file,
            caption.into(),
        )?;
    }
    elastic::add_figures(&mut f, &data.rows, &colour_of)?;
    angles::add_sweep_figures(&mut f, &data.rows, &data.angles)?;
    elastic::add_contact_velocities(&mut f, &data.rows)?;
    // Classification.
    let c = classify(&data.rows);
    write_classification(out_dir, label, &c)?;
    if data.model == "cdn" {
        f.blocks.push(Block::Paragraph(cdn::check(&c)));
    }
    let classes = ["Newtonian", "Bagnoldian", "undecided"]
        .map(String::from)
        .to_vec();
    let idx = |c: Class| match c {
        Class::Newtonian => 0,
        Class::Bagnoldian => 1,
        Class::Undecided => 2,
    };
    if c.slopes.is_empty() {
        f.blocks.push(Block::Paragraph(
            "No classification: every (φ, Q) has fewer than two rates with a pressure.".into(),
        ));
    } else {
        f.blocks.push(Block::Paragraph(format!(
            "Newtonian or Bagnoldian: the slope s of ln p against ln γ̇ (weighted by the runs' errors of p) with its standard error e; Newtonian when s ± {0}e lies within [0.5, 1.5], Bagnoldian within [1.5, 2.5], undecided otherwise (the data cannot tell, or the slope is in neither regime). `all`: every rate of the grid; `local`: two neighbouring rates. Written to classification_{1}.csv and .json beside the report.",
            classify::SIGMAS, slug(label)
        )));
        f.blocks.push(Block::Table {
            header: [
                "φ",
                "Q",
                "rates γ̇ τ_e",
                "scope",
                "slope ± error",
                "class",
                "why",
            ]
            .map(String::from)
            .to_vec(),
            rows: c
                .slopes
                .iter()
                .map(|s| {
                    vec![
                        s.phi.to_string(),
                        s.q.to_string(),
                        format!("{:.1e} – {:.1e}", s.slope.rate_lo, s.slope.rate_hi),
                        s.scope.into(),
                        format!("{:.3} ± {:.3}", s.slope.slope, s.slope.err),
                        s.slope.class.name().into(),
                        s.slope.note.clone(),
                    ]
                })
                .collect(),
        });
        let trans: Vec<String> = c
            .transitions
            .iter()
            .map(|l| {
                let what = if l.along == "phi" { format!("φ_c(Q = {})", l.at) } else { format!("Q_c(φ = {})", l.at) };
                format!(
                    "{what} between {} and {} ({} → {}; midpoint {:.4} ± {:.4} from the grid spacing; rates {:.1e}–{:.1e})",
                    l.t.lo, l.t.hi, l.t.from.name(), l.t.to.name(), 0.5 * (l.t.lo + l.t.hi), 0.5 * (l.t.hi - l.t.lo), l.rate_lo, l.rate_hi
                )
            })
            .collect();
        f.blocks.push(Block::Paragraph(if trans.is_empty() {
            "Transition: not bracketed by this grid (no decided Newtonian point next to a decided Bagnoldian one along φ or Q).".into()
        } else {
            format!("Transition located: {}.", trans.join("; "))
        }));
        // (φ, γ̇) at each Q: local slopes at the rates' geometric mean; with a single
        // pair of rates per (φ, Q), the overall slope.
        let qs: Vec<i64> = {
            let mut v: Vec<i64> = c.slopes.iter().map(|s| key(s.q)).collect();
            v.sort();
            v.dedup();
            v
        };
        for qk in &qs {
            let local: Vec<&Classified> = c
                .slopes
                .iter()
                .filter(|s| key(s.q) == *qk && s.scope == "local")
                .collect();
            let use_: Vec<&Classified> = if local.is_empty() {
                c.slopes.iter().filter(|s| key(s.q) == *qk).collect()
            } else {
                local
            };
            let q = use_[0].q;
            let bands = c
                .transitions
                .iter()
                .filter(|l| l.along == "phi" && key(l.at) == *qk)
                .map(|l| (l.t.lo, l.t.hi, l.rate_lo, l.rate_hi))
                .collect();
            f.add(
                &PhaseFigure {
                    title: format!("Slope classes in the (φ, dγ/dt) plane at Q = {q}"),
                    x_desc: "φ".into(),
                    y_desc: "dγ/dt τ_e (geometric mean of the two rates)".into(),
                    y_log: true,
                    classes: classes.clone(),
                    points: use_.iter().map(|s| (s.phi, (s.slope.rate_lo * s.slope.rate_hi).sqrt(), idx(s.slope.class))).collect(),
                    bands,
                },
                &format!("phase_phi_rate_q{}", slug(&q.to_string())),
                format!("Each (φ, neighbouring rates) at Q = {q} classified from the local slope of ln p against ln γ̇; shaded: the transition φ_c bracketed by the grid. The paper's own diagrams are Fig. 17 (the (φ, Q) plane, by Appendix A) and Fig. 25 (this plane with the coexistence region), both below when the grid allows."),
            )?;
        }
        if qs.len() > 1 {
            f.add(
                &PhaseFigure {
                    title: "Slope classes in the (φ, Q) plane".into(),
                    x_desc: "φ".into(),
                    y_desc: "Q".into(),
                    y_log: true,
                    classes,
                    points: c.slopes.iter().filter(|s| s.scope == "all").map(|s| (s.phi, s.q, idx(s.slope.class))).collect(),
                    bands: Vec::new(),
                },
                "phase_phi_q",
                "Each (φ, Q) classified from the slope of ln p against ln γ̇ over all the grid's rates, beside the paper's own lines (Q_c(φ) from the drop of P^el, Fig. 3; Q_c, Q* and φ_c by Appendix A, Fig. 17; below).".into(),
            )?;
        }
    }
    let phi_j = jamming::estimate(&data.rows);
    f.blocks.push(Block::Paragraph(jamming::paragraph(&phi_j)));
    qc::add_figures(&mut f, &data.rows, &phi_j)?;
    appendix_a::add_figures(&mut f, &data.rows, &c, phi_j.value)?;
    coexistence::add_sweep(&mut f, &data.rows);
    let mu_j = stress_space::mu_j(&data.rows, phi_j.value);
    phase_boundaries::add_figures(&mut f, &data.rows, &c, phi_j.value, &mu_j)?;
    let phi_j_short = match phi_j.held_because {
        Some(_) => format!("{:.4}, the paper's, held", phi_j.value),
        None => format!(
            "{:.4} [{:.4}, {:.4}] from the grid",
            phi_j.value, phi_j.lo, phi_j.hi
        ),
    };
    f.blocks.push(Block::Paragraph(stress_space::mu_j_paragraph(
        &mu_j,
        &phi_j_short,
    )));
    contour::add_figures(&mut f, &data.rows)?;
    stress_space::add_figures(&mut f, &data.rows)?;
    Ok(Section {
        id: format!("sweep-{}", slug(label)),
        title: format!("Sweep {label}: flow curves and phase diagram"),
        blocks: f.blocks,
    })
}

fn write_classification(out_dir: &Path, label: &str, c: &Classification) -> Result<()> {
    let mut csv = String::from("phi,q,scope,rate_lo,rate_hi,slope,slope_err,class,note\n");
    for s in &c.slopes {
        csv += &format!(
            "{},{},{},{:e},{:e},{},{},{},\"{}\"\n",
            s.phi,
            s.q,
            s.scope,
            s.slope.rate_lo,
            s.slope.rate_hi,
            s.slope.slope,
            s.slope.err,
            s.slope.class.name(),
            s.slope.note.replace('"', "'")
        );
    }
    let stem = format!("classification_{}", slug(label));
    crate::io::atomic_write_str(&out_dir.join(format!("{stem}.csv")), &csv)?;
    crate::io::atomic_write_str(
        &out_dir.join(format!("{stem}.json")),
        &serde_json::to_string_pretty(c).expect("json"),
    )
}

/// One run's section: the steady-state summary, P(ϑ) at contact making and breaking,
/// the contact velocities (Fig. 21), the profiles (Fig. 28) and local fields (Fig. 27).
pub fn shear_section(
    label: &str,
    dir: &Path,
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Section> {
    let mut f = Figures {
        figdir,
        prefix: format!("shear_{}", slug(label)),
        figures,
        blocks: Vec::new(),
    };
    let sf = dir.join("summary.json");
    let mut rate = None;
    if sf.exists() {
        let text = std::fs::read_to_string(&sf).map_err(|e| Error::io(&sf, e))?;
        let v: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| Error::input(sf.display(), e.to_string()))?;
        let p = &v["params"];
        rate = p["rate"].as_f64();
        f.blocks.push(Block::Paragraph(format!(
            "{label}: N = {}, φ = {}, Q = {}, γ̇ τ_e = {}, {}, strain {}; means over the steady window with errors from {} blocks.",
            p["n"], p["phi"], p["q"], p["rate"], p["model"].as_str().unwrap_or("?").to_uppercase(), v["strain"], v["blocks"]
        )));
        let rows = v
            .as_object()
            .into_iter()
            .flatten()
            .filter_map(|(k, x)| {
                Some(vec![
                    k.clone(),
                    fmt_pm(x.get("mean")?.as_f64()?, x.get("err")?.as_f64()?),
                ])
            })
            .collect();
        f.blocks.push(Block::Table {
            header: vec!["quantity".into(), "mean ± error".into()],
            rows,
        });
    }
    let af = dir.join("collision_angles.parquet");
    if af.exists() {
        angles::add_run_figure(&mut f, &af)?;
    }
    run_figures::add(&mut f, dir, rate)?;
    Ok(Section {
        id: format!("shear-{}", slug(label)),
        title: format!("Sheared disks {label}"),
        blocks: f.blocks,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A planted CDrot-like sweep over φ 0.76–0.84, Q 1–300 and three rates: Newtonian
    /// below Q_c(φ) = 0.5 + 0.3 (φ_J − φ)^−1.1 and Bagnoldian above (a jump in P^el),
    /// banded (R_v = 10) at Q = 1 over φ 0.79–0.81 at the lowest rate and at 0.80 at the
    /// middle one, with every summary quantity the report draws.
    fn planted() -> SweepData {
        let mut rows = Vec::new();
        let mut angles = Vec::new();
        let phis: Vec<f64> = (0..9).map(|k| (76 + k) as f64 / 100.0).collect();
        let qs = [1.0, 3.0, 10.0, 30.0, 100.0, 300.0];
        let rates = [1e-5, 1e-4, 1e-3];
        for &phi in &phis {
            for &q in &qs {
                let q_c = 0.5 + 0.3 * (jamming::PHI_J_PAPER - phi).powf(-1.1);
                let newtonian = q < q_c;
                for &rate in &rates {
                    let p_el: f64 = if newtonian {
                        (50.0 * (phi - 0.76)).exp() * rate / q
                    } else {
                        1e3 * q * (30.0 * (phi - 0.76)).exp() * rate * rate
                    };
                    let p = 1.1 * p_el;
                    let banded = q == 1.0
                        && ((rate == 1e-5 && (0.785..0.815).contains(&phi))
                            || (rate == 1e-4 && (phi - 0.80).abs() < 1e-9));
                    let z = if newtonian { 3.5 } else { 2e3 * rate };
                    let mut v = BTreeMap::new();
                    let mut put = |k: &str, m: f64| {
                        v.insert(k.to_string(), (m, 0.01 * m.abs()));
                    };
                    put("p", p);
                    put("sigma", 0.3 * p);
                    put("mu", 0.3 + 0.1 * rate.sqrt());
                    put("p_el", p_el);
                    put("eta_p", p * q / rate);
                    put("b_p", p / (rate * rate));
                    put("eta_p_el", p_el * q / rate);
                    put("b_p_el", p_el / (rate * rate));
                    put("z", z);
                    put("two_tau_dur_nu_coll", z);
                    put("r_v", if banded { 10.0 } else { 1.0 });
                    put("theta_dot_over_gamma_dot", -0.5);
                    put("theta_dot_over_gamma_dot_var", 0.1 + phi);
                    put("tau_dur", if newtonian { 100.0 } else { 1.0 });
                    put("nu_coll", rate * 3.0);
                    put("p_theta_90", if newtonian { 0.01 } else { 0.001 });
                    put("v_n_rms", if newtonian { 0.1 } else { 2.0 });
                    put("v_t_rms", 2.0);
                    rows.push(Row { phi, q, rate, v });
                }
                angles.push(angles::AnglePdf {
                    phi,
                    q,
                    rate: 1e-5,
                    points: (0..100)
                        .map(|k| (-178.2 + 3.6 * k as f64, 0.0028))
                        .collect(),
                });
            }
        }
        let grid = rows.iter().map(|r| (r.phi, r.q, r.rate)).collect();
        SweepData {
            rows,
            grid,
            missing: Vec::new(),
            model: "cdrot".into(),
            n: Some(1024),
            strain: Some(5.0),
            angles,
        }
    }

    /// Every figure of a sweep's section that cites a figure of vagberg-sheared-disks
    /// plots that figure's quantity against its axis (`paper_figures::check`), and the
    /// figures the paper's coexistence, transitions and collision sections need are
    /// all drawn.
    #[test]
    fn every_figure_titled_with_a_papers_figure_shows_that_figures_quantity() {
        let dir = std::env::temp_dir().join(format!("pp-shear-figs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut figures = Vec::new();
        sweep_section("planted", &planted(), &dir, &dir, &mut figures).unwrap();
        let wrong: Vec<String> = figures
            .iter()
            .filter_map(|f| paper_figures::check(&f.labels).err())
            .collect();
        assert!(wrong.is_empty(), "{wrong:#?}");
        let mut cited: Vec<u32> = figures
            .iter()
            .flat_map(|f| paper_figures::cited(&f.labels.title))
            .collect();
        cited.sort();
        cited.dedup();
        for n in [
            1, 2, 3, 4, 5, 6, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 22, 23, 24, 25, 26,
            29, 30, 32, 33,
        ] {
            assert!(cited.contains(&n), "no figure cites Fig. {n}: {cited:?}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
