//! Shear-band coexistence (vagberg-sheared-disks Sec. IV, Figs. 24–25, 28, 35–36).
//!
//! - **Band values of one run** (text beside Figs. 28 and 36): from the steady-window
//!   profiles φ(y) and γ̇(y) (equal bins of the periodic y), the Bagnoldian band is where
//!   φ(y) lies below the run's mean φ and f = w_B/L_y is its share of the bins; φ*_B and
//!   φ*_N are the paper's values "in the center of the Bagnoldian and Newtonian bands
//!   (i.e. away from the interface)": the mean φ(y) over each band's centre, its bins
//!   at least half as far from the other band as its deepest bin. Then
//!   f φ*_B + (1 − f) φ*_N equals the mean φ only for sharp interfaces; the report gives
//!   both. Likewise from γ̇(y): the Bagnoldian band is where γ̇(y) exceeds the mean γ̇, f′
//!   its share, γ̇*_B and γ̇*_N its centre values. f and f′ differ where the interface is
//!   wide compared with L_y, as the paper finds. In a homogeneous run the split only
//!   divides noise: the values mean something where R_v is large.
//! - **φ_B and φ_N of a sweep** (Figs. 24–25, 35): at each (Q, γ̇), the runs along φ with
//!   R_v = ⟨δv_x²⟩/⟨v_y²⟩ (Eq. 37) above [`R_V_BANDED`] are shear banded (R_v ≈ 1 in
//!   homogeneous flow); φ_B is bracketed between the last unbanded φ below the banded
//!   stretch and its first banded φ, φ_N between its last banded φ and the first
//!   unbanded φ above. The paper regards R_v as the most reliable of its three measures.
//! - **The P^el kinks and the μ switch (Figs. 22, 23)**, the paper's other two measures: along
//!   φ at each (Q, γ̇), the interval slopes g_k = Δ ln P^el/Δφ (for μ, |Δμ|/Δφ); the
//!   steepest interval, if at least [`STEEP_FACTOR`] times the median g of the curve,
//!   is the jump, and the stretch around it of intervals at least half as steep is the
//!   coexistence region: φ_B is the φ where the stretch begins (the lower kink), φ_N
//!   where it ends (the upper kink). A stretch reaching the grid's end leaves that side
//!   open. The three measures are compared in a table; they disagree when their
//!   estimates (a bracket's middle, a kink's φ) lie more than one grid step apart,
//!   counted in steps of the curve's own φ grid (so a coarse step elsewhere on the
//!   curve does not excuse a disagreement here).

use super::{Figures, Row, SweepData, key, slug};
use crate::error::Result;
use crate::stages::report::render::SavedFigure;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::html::{Block, Section};
use std::collections::BTreeMap;
use std::path::Path;

/// R_v above which a run counts as shear banded (homogeneous flow gives R_v ≈ 1).
pub const R_V_BANDED: f64 = 3.0;

/// The steepest interval must be this many times the curve's median steepness to be a
/// jump (a smooth exponential P^el(φ) has all intervals alike).
pub const STEEP_FACTOR: f64 = 3.0;

/// The steep stretch of y(φ) (points sorted by φ, at least four): (φ_B, φ_N), either
/// `None` where the stretch reaches the grid's end; `None` overall without a jump.
/// `signed`: the jump must rise (P^el); otherwise its size counts either way (μ).
pub fn steep_stretch(pts: &[(f64, f64)], signed: bool) -> Option<(Option<f64>, Option<f64>)> {
    if pts.len() < 4 {
        return None;
    }
    let g: Vec<f64> = pts
        .windows(2)
        .map(|w| {
            let s = (w[1].1 - w[0].1) / (w[1].0 - w[0].0);
            if signed { s } else { s.abs() }
        })
        .collect();
    if g.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let mut sorted = g.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let (k, &top) = g.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    if !(top > 0.0 && top >= STEEP_FACTOR * median.max(0.0)) {
        return None;
    }
    let (mut a, mut b) = (k, k);
    while a > 0 && g[a - 1] >= 0.5 * top {
        a -= 1;
    }
    while b + 1 < g.len() && g[b + 1] >= 0.5 * top {
        b += 1;
    }
    // Interval a runs from point a to a + 1; the stretch from point a to point b + 1.
    Some((
        (a > 0).then(|| pts[a].0),
        (b + 2 < pts.len()).then(|| pts[b + 1].0),
    ))
}

/// φ_B and φ_N at one (Q, γ̇) by each of the paper's three measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Measures {
    pub q: f64,
    pub rate: f64,
    /// From R_v (brackets).
    pub r_v: Option<Boundaries>,
    /// From the kinks of P^el and the switch of μ: (φ_B, φ_N).
    pub p_el: Option<(Option<f64>, Option<f64>)>,
    pub mu: Option<(Option<f64>, Option<f64>)>,
    /// The curve's φ grid, ascending.
    pub grid: Vec<f64>,
}

/// The three measures at every (Q, γ̇) where at least one finds a region.
pub fn measures(rows: &[Row]) -> Vec<Measures> {
    let rv = boundaries(rows);
    let mut by: BTreeMap<(i64, i64), (f64, f64, Vec<&Row>)> = BTreeMap::new();
    for r in rows {
        by.entry((key(r.q), key(r.rate)))
            .or_insert_with(|| (r.q, r.rate, Vec::new()))
            .2
            .push(r);
    }
    let mut out = Vec::new();
    for (q, rate, mut rs) in by.into_values() {
        rs.sort_by(|a, b| a.phi.total_cmp(&b.phi));
        let curve = |f: &dyn Fn(&Row) -> Option<f64>| -> Vec<(f64, f64)> {
            rs.iter().filter_map(|r| f(r).map(|y| (r.phi, y))).collect()
        };
        let p_el = steep_stretch(
            &curve(&|r| r.get("p_el").filter(|p| p.0 > 0.0).map(|p| p.0.ln())),
            true,
        );
        let mu = steep_stretch(&curve(&|r| r.get("mu").map(|m| m.0)), false);
        let r_v = rv
            .iter()
            .find(|b| key(b.q) == key(q) && key(b.rate) == key(rate))
            .cloned();
        if p_el.is_none() && mu.is_none() && r_v.is_none() {
            continue;
        }
        let grid: Vec<f64> = rs.iter().map(|r| r.phi).collect();
        out.push(Measures {
            q,
            rate,
            r_v,
            p_el,
            mu,
            grid,
        });
    }
    out
}

impl Measures {
    /// φ as a fractional index of the grid (k at grid[k], linear between).
    pub(super) fn index(&self, phi: f64) -> f64 {
        let g = &self.grid;
        match g.windows(2).position(|w| phi <= w[1]) {
            Some(k) => k as f64 + ((phi - g[k]) / (g[k + 1] - g[k])).max(0.0),
            None => (g.len().max(1) - 1) as f64,
        }
    }

    /// Where two measures of the same boundary lie more than one grid step apart, in
    /// words (empty when they agree or cannot be compared).
    pub fn disagreements(&self) -> Vec<String> {
        let est: [(&str, Option<f64>, Option<f64>); 3] = [
            (
                "R_v",
                self.r_v.as_ref().and_then(|b| mid(b.phi_b)),
                self.r_v.as_ref().and_then(|b| mid(b.phi_n)),
            ),
            (
                "P^el kink",
                self.p_el.and_then(|x| x.0),
                self.p_el.and_then(|x| x.1),
            ),
            (
                "μ switch",
                self.mu.and_then(|x| x.0),
                self.mu.and_then(|x| x.1),
            ),
        ];
        let mut out = Vec::new();
        for (side, pick) in [("φ_B", 0usize), ("φ_N", 1)] {
            for i in 0..3 {
                for j in i + 1..3 {
                    let v = |k: usize| if pick == 0 { est[k].1 } else { est[k].2 };
                    if let (Some(a), Some(b)) = (v(i), v(j))
                        && (self.index(a) - self.index(b)).abs() > 1.0 + 1e-9
                    {
                        out.push(format!(
                            "{side}: {} {a:.4} against {} {b:.4}",
                            est[i].0, est[j].0
                        ));
                    }
                }
            }
        }
        out
    }
}

/// The middle of a bracket.
pub(super) fn mid(b: Option<(f64, f64)>) -> Option<f64> {
    b.map(|(a, c)| 0.5 * (a + c))
}

/// One run's band values.
#[derive(Debug, Clone, PartialEq)]
pub struct Bands {
    /// φ(y) in the centre of the Bagnoldian and Newtonian bands (away from the
    /// interfaces): φ*_B, φ*_N.
    pub phi_b: f64,
    pub phi_n: f64,
    /// w_B/L_y: the share of y where φ(y) lies below the mean φ.
    pub f: f64,
    /// f φ*_B + (1 − f) φ*_N, to hold against the mean φ (they differ by the
    /// interfaces' weight).
    pub phi_lever: f64,
    /// γ̇(y) τ_e in the centre of each band (the Bagnoldian one where γ̇(y) exceeds the
    /// mean), its share f′, and f′ γ̇*_B + (1 − f′) γ̇*_N.
    pub gdot_b: f64,
    pub gdot_n: f64,
    pub f_prime: f64,
    pub gdot_lever: f64,
}

/// The centre value of each side of a periodic profile split at its mean: a bin's depth
/// is its distance (in bins, across the periodic boundary of the Lees–Edwards box) to
/// the nearest bin on the other side; a side's centre is its bins at least half as deep
/// as its deepest (the middle half to two thirds of a band). Returns (centre of the side `below` the
/// mean selects, centre of the other, that side's share of the bins); `None` for an
/// empty, broken or flat profile.
fn split_centres(v: &[f64], below: bool) -> Option<(f64, f64, f64)> {
    if v.is_empty() || v.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n as f64;
    let side: Vec<bool> = v.iter().map(|&x| (x < mean) == below).collect();
    let count = side.iter().filter(|&&b| b).count();
    if count == 0 || count == n {
        return None;
    }
    let depth: Vec<usize> = (0..n)
        .map(|i| {
            (1..=n / 2)
                .find(|&d| side[(i + d) % n] != side[i] || side[(i + n - d) % n] != side[i])
                .unwrap_or(n)
        })
        .collect();
    let centre = |which: bool| {
        let deepest = (0..n)
            .filter(|&i| side[i] == which)
            .map(|i| depth[i])
            .max()?;
        let core: Vec<f64> = (0..n)
            .filter(|&i| side[i] == which && 2 * depth[i] >= deepest)
            .map(|i| v[i])
            .collect();
        Some(core.iter().sum::<f64>() / core.len() as f64)
    };
    Some((centre(true)?, centre(false)?, count as f64 / n as f64))
}

/// Band values from profiles φ(y) and γ̇(y) in equal bins of the periodic y; `None`
/// when a profile is empty, not finite, or flat (no bin on one side of its mean).
pub fn bands(phi: &[f64], gdot: &[f64]) -> Option<Bands> {
    let (phi_b, phi_n, f) = split_centres(phi, true)?;
    let (gdot_b, gdot_n, f_prime) = split_centres(gdot, false)?;
    Some(Bands {
        phi_b,
        phi_n,
        f,
        phi_lever: f * phi_b + (1.0 - f) * phi_n,
        gdot_b,
        gdot_n,
        f_prime,
        gdot_lever: f_prime * gdot_b + (1.0 - f_prime) * gdot_n,
    })
}

/// The banded stretch along φ at one (Q, γ̇): brackets of φ_B and φ_N (`None` where the
/// grid ends inside the banded stretch).
#[derive(Debug, Clone, PartialEq)]
pub struct Boundaries {
    pub q: f64,
    pub rate: f64,
    pub phi_b: Option<(f64, f64)>,
    pub phi_n: Option<(f64, f64)>,
    /// The banded runs' φ.
    pub banded: Vec<f64>,
}

/// φ_B and φ_N at every (Q, γ̇) whose runs along φ include a banded one.
pub fn boundaries(rows: &[Row]) -> Vec<Boundaries> {
    let mut by: BTreeMap<(i64, i64), Vec<(f64, f64)>> = BTreeMap::new();
    let mut at: BTreeMap<(i64, i64), (f64, f64)> = BTreeMap::new();
    for r in rows {
        if let Some((rv, _)) = r.get("r_v") {
            let k = (key(r.q), key(r.rate));
            by.entry(k).or_default().push((r.phi, rv));
            at.insert(k, (r.q, r.rate));
        }
    }
    let mut out = Vec::new();
    for (k, mut pts) in by {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let first = pts.iter().position(|p| p.1 > R_V_BANDED);
        let last = pts.iter().rposition(|p| p.1 > R_V_BANDED);
        let (Some(a), Some(b)) = (first, last) else {
            continue;
        };
        let (q, rate) = at[&k];
        out.push(Boundaries {
            q,
            rate,
            phi_b: (a > 0).then(|| (pts[a - 1].0, pts[a].0)),
            phi_n: (b + 1 < pts.len()).then(|| (pts[b].0, pts[b + 1].0)),
            banded: pts[a..=b]
                .iter()
                .filter(|p| p.1 > R_V_BANDED)
                .map(|p| p.0)
                .collect(),
        });
    }
    out
}

fn fmt(x: f64) -> String {
    if x != 0.0 && !(1e-3..1e3).contains(&x.abs()) {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// One run's band values under its profiles (φ(y), γ̇(y) in equal bins).
pub(super) fn add_run(f: &mut Figures, phi: &[f64], gdot: &[f64]) {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    f.blocks.push(Block::Paragraph(match bands(phi, gdot) {
        Some(b) => format!(
            "Band values (vagberg-sheared-disks, text beside Figs. 28 and 36: the values in the centre of each band, away from the interface): the Bagnoldian band is where φ(y) lies below the mean φ, f = w_B/L_y = {:.2}; in each band's centre (its bins at least half as far from the other band as its deepest) φ*_B = {}, φ*_N = {} (f φ*_B + (1 − f) φ*_N = {} against the mean φ = {}: the difference is the interfaces' weight). From γ̇(y) above its mean: f′ = {:.2}, γ̇*_B τ_e = {}, γ̇*_N τ_e = {} (f′ γ̇*_B + (1 − f′) γ̇*_N = {} against {}). They describe shear bands only where R_v (summary above) is large, well above {R_V_BANDED}; in homogeneous flow the split divides noise.",
            b.f,
            fmt(b.phi_b),
            fmt(b.phi_n),
            fmt(b.phi_lever),
            fmt(mean(phi)),
            b.f_prime,
            fmt(b.gdot_b),
            fmt(b.gdot_n),
            fmt(b.gdot_lever),
            fmt(mean(gdot)),
        ),
        None => "Band values: none (a profile is flat or incomplete).".into(),
    }));
}

/// φ_B and φ_N by the three measures side by side, with where they disagree.
fn add_measures(f: &mut Figures, rows: &[Row]) {
    let m = measures(rows);
    if m.is_empty() {
        return;
    }
    let side = |x: Option<(Option<f64>, Option<f64>)>, k: usize| match x {
        None => "no jump".to_string(),
        Some(p) => [p.0, p.1][k].map_or("grid end".into(), |v| v.to_string()),
    };
    let rv = |x: &Option<Boundaries>, k: usize| match x {
        None => "not banded".to_string(),
        Some(b) => {
            [b.phi_b, b.phi_n][k].map_or("beyond the grid".into(), |(a, c)| format!("{a} – {c}"))
        }
    };
    f.blocks.push(Block::Paragraph(format!(
        "φ_B and φ_N by the paper's three measures (vagberg-sheared-disks Figs. 22–25): R_v as above; the kinks of P^el (Fig. 22) and the switch of μ between its branches (Fig. 23), each the steep stretch along φ around the steepest interval of ln P^el (rising) or of μ (either way) — at least {STEEP_FACTOR}× the curve's median steepness, extended over neighbouring intervals at least half as steep — φ_B where it begins, φ_N where it ends. They disagree when two estimates (a bracket's middle, a kink's φ) lie more than one step of the curve's φ grid apart."
    )));
    f.blocks.push(Block::Table {
        header: [
            "Q",
            "γ̇ τ_e",
            "φ_B: R_v",
            "P^el kink",
            "μ switch",
            "φ_N: R_v",
            "P^el kink",
            "μ switch",
            "beyond the grid step",
        ]
        .map(String::from)
        .to_vec(),
        rows: m
            .iter()
            .map(|x| {
                let d = x.disagreements();
                vec![
                    x.q.to_string(),
                    format!("{:.1e}", x.rate),
                    rv(&x.r_v, 0),
                    side(x.p_el, 0),
                    side(x.mu, 0),
                    rv(&x.r_v, 1),
                    side(x.p_el, 1),
                    side(x.mu, 1),
                    if d.is_empty() {
                        "agree (or not comparable)".into()
                    } else {
                        d.join("; ")
                    },
                ]
            })
            .collect(),
    });
}

/// The banded stretches of a sweep along φ, as a table with the rule, and the three
/// measures of φ_B and φ_N side by side.
pub(super) fn add_sweep(f: &mut Figures, rows: &[Row]) {
    add_measures(f, rows);
    let b = boundaries(rows);
    if b.is_empty() {
        if rows.iter().any(|r| r.get("r_v").is_some()) {
            f.blocks.push(Block::Paragraph(format!(
                "Shear-band coexistence: no run has R_v > {R_V_BANDED}, so no banded stretch along φ (φ_B, φ_N) is located."
            )));
        }
        return;
    }
    let bracket = |x: Option<(f64, f64)>| {
        x.map_or("beyond the grid".to_string(), |(a, b)| format!("{a} – {b}"))
    };
    f.blocks.push(Block::Paragraph(format!(
        "Shear-band coexistence (vagberg-sheared-disks Figs. 24–25, 35): runs with R_v > {R_V_BANDED} are shear banded; along φ at each (Q, γ̇), φ_B lies between the last unbanded φ below the banded stretch and its first banded φ, φ_N between its last banded φ and the first unbanded φ above (the paper's R_v measure, which it regards as the most reliable; the paper finds the boundaries move with the system size, Fig. 36)."
    )));
    f.blocks.push(Block::Table {
        header: ["Q", "γ̇ τ_e", "φ_B between", "φ_N between", "banded φ"]
            .map(String::from)
            .to_vec(),
        rows: b
            .iter()
            .map(|x| {
                vec![
                    x.q.to_string(),
                    format!("{:.1e}", x.rate),
                    bracket(x.phi_b),
                    bracket(x.phi_n),
                    x.banded
                        .iter()
                        .map(|p| p.to_string())
                        .collect::<Vec<_>>()
                        .join(", "),
                ]
            })
            .collect(),
    });
}

/// One size's R_v brackets at one (Q, γ̇), for the two-size comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct SizeRow {
    pub model: String,
    pub n: u64,
    pub q: f64,
    pub rate: f64,
    pub b: Boundaries,
}

/// Sweeps of one model at two or more N: each size's R_v brackets at every (Q, γ̇) the
/// sizes share (Fig. 36). Sweeps without N, or alone at their model, are left out.
pub fn by_size(sweeps: &[(String, &SweepData)]) -> Vec<SizeRow> {
    let mut out = Vec::new();
    let mut models: Vec<&str> = sweeps.iter().map(|s| s.1.model.as_str()).collect();
    models.sort();
    models.dedup();
    for model in models {
        let of: Vec<(u64, &SweepData)> = sweeps
            .iter()
            .filter(|s| s.1.model == model)
            .filter_map(|s| s.1.n.map(|n| (n, s.1)))
            .collect();
        let mut ns: Vec<u64> = of.iter().map(|x| x.0).collect();
        ns.sort();
        ns.dedup();
        if ns.len() < 2 {
            continue;
        }
        for (n, d) in &of {
            for b in boundaries(&d.rows) {
                let shared = of.iter().filter(|(m, _)| m != n).any(|(_, e)| {
                    e.rows
                        .iter()
                        .any(|r| key(r.q) == key(b.q) && key(r.rate) == key(b.rate))
                });
                if shared {
                    out.push(SizeRow {
                        model: model.to_string(),
                        n: *n,
                        q: b.q,
                        rate: b.rate,
                        b,
                    });
                }
            }
        }
    }
    out
}

/// R_v against φ at two or more system sizes of one model on one figure (Fig. 36), with
/// each size's R_v brackets; `None` when no model has two sizes.
pub fn size_section(
    sweeps: &[(String, &SweepData)],
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Option<Section>> {
    let mut models: Vec<&str> = sweeps.iter().map(|s| s.1.model.as_str()).collect();
    models.sort();
    models.dedup();
    let mut f = Figures {
        figdir,
        prefix: "sweep_sizes".into(),
        figures,
        blocks: Vec::new(),
    };
    for model in models {
        let of: Vec<&(String, &SweepData)> = sweeps
            .iter()
            .filter(|s| s.1.model == model && s.1.n.is_some())
            .collect();
        let mut ns: Vec<u64> = of.iter().filter_map(|s| s.1.n).collect();
        ns.sort();
        ns.dedup();
        if ns.len() < 2 {
            continue;
        }
        // One series per (N, Q, γ̇); open symbols (markers only) for the smaller sizes.
        let mut series = Vec::new();
        let mut colour: BTreeMap<(i64, i64), usize> = BTreeMap::new();
        for (label, d) in &of {
            let n = d.n.unwrap_or(0);
            // (Q, γ̇) → (Q, γ̇, [(φ, R_v, error)]).
            type Curves = BTreeMap<(i64, i64), (f64, f64, Vec<(f64, f64, f64)>)>;
            let mut by: Curves = BTreeMap::new();
            for r in &d.rows {
                if let Some((rv, e)) = r.get("r_v") {
                    by.entry((key(r.q), key(r.rate)))
                        .or_insert_with(|| (r.q, r.rate, Vec::new()))
                        .2
                        .push((r.phi, rv, e));
                }
            }
            for (k, (q, rate, mut pts)) in by {
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                let next = colour.len();
                series.push(XySeries {
                    label: format!("N = {n} ({label}), Q = {q}, rate {rate:.0e}"),
                    points: pts,
                    markers_only: n < ns[ns.len() - 1],
                    colour: *colour.entry(k).or_insert(next),
                });
            }
        }
        f.add(
            &XyFigure {
                title: format!("R_v against φ at {} system sizes, model {} (Fig. 36)", ns.len(), model.to_uppercase()),
                x_desc: "φ".into(),
                y_desc: "R_v = ⟨δv_x²⟩/⟨v_y²⟩".into(),
                x_log: false,
                y_log: true,
                series,
            },
            &format!("r_v_sizes_{}", slug(model)),
            format!("The shear-banding parameter R_v (Eq. 37) against φ for N = {} (largest: lines; smaller: markers only), one colour per (Q, γ̇) (vagberg-sheared-disks Fig. 36: the coexistence region narrows as the system shrinks).", ns.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", ")),
        )?;
    }
    let rows = by_size(sweeps);
    if f.blocks.is_empty() {
        return Ok(None);
    }
    let bracket = |x: Option<(f64, f64)>| {
        x.map_or("beyond the grid".to_string(), |(a, b)| format!("{a} – {b}"))
    };
    f.blocks.push(Block::Paragraph(if rows.is_empty() {
        format!("No size has a run with R_v > {R_V_BANDED} at a (Q, γ̇) another size shares, so the coexistence boundaries cannot be compared across sizes.")
    } else {
        format!("φ_B and φ_N bracketed by R_v > {R_V_BANDED} (the rule of the sweeps' sections) at each size; the paper finds the region narrower at the smaller size.")
    }));
    if !rows.is_empty() {
        f.blocks.push(Block::Table {
            header: ["model", "N", "Q", "γ̇ τ_e", "φ_B between", "φ_N between"]
                .map(String::from)
                .to_vec(),
            rows: rows
                .iter()
                .map(|r| {
                    vec![
                        r.model.to_uppercase(),
                        r.n.to_string(),
                        r.q.to_string(),
                        format!("{:.1e}", r.rate),
                        bracket(r.b.phi_b),
                        bracket(r.b.phi_n),
                    ]
                })
                .collect(),
        });
    }
    Ok(Some(Section {
        id: "sweep-sizes".into(),
        title: "Sheared disks at two system sizes".into(),
        blocks: f.blocks,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_two_band_profile_gives_its_band_values_and_fractions() {
        // 20 bins: 5 Bagnoldian (φ 0.78, γ̇ 4e-5), 15 Newtonian (φ 0.81, γ̇ 1e-5).
        let phi: Vec<f64> = (0..20).map(|k| if k < 5 { 0.78 } else { 0.81 }).collect();
        let gdot: Vec<f64> = (0..20).map(|k| if k < 5 { 4e-5 } else { 1e-5 }).collect();
        let b = bands(&phi, &gdot).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        assert!(
            close(b.phi_b, 0.78) && close(b.phi_n, 0.81) && b.f == 0.25,
            "{b:?}"
        );
        assert!(close(b.gdot_b, 4e-5) && close(b.gdot_n, 1e-5) && b.f_prime == 0.25);
        // A sharp interface: the lever rule holds exactly.
        let mean = phi.iter().sum::<f64>() / 20.0;
        assert!((b.phi_lever - mean).abs() < 1e-12);
        // A wide interface moves f′ away from f. The Bagnoldian band by γ̇ is now bins
        // 0–6 (4e-5 ×5, 3.5e-5, 3e-5), depths 1, 2, 3, 4, 3, 2, 1: its centre, the bins
        // at least 2 deep, is 1–5, mean (4 × 4e-5 + 3.5e-5)/5 = 3.9e-5; the interface's
        // outer bin (3e-5) is left out, as are the edges of the Newtonian band.
        let mut g2 = gdot.clone();
        g2[5] = 3.5e-5;
        g2[6] = 3e-5;
        let b2 = bands(&phi, &g2).unwrap();
        assert_eq!(b2.f, 0.25);
        assert_eq!(b2.f_prime, 0.35);
        assert!(close(b2.gdot_b, 3.9e-5) && close(b2.gdot_n, 1e-5), "{b2:?}");
        // So the lever rule misses the mean γ̇ by the interface's weight.
        let gm = g2.iter().sum::<f64>() / 20.0;
        assert!((b2.gdot_lever - gm).abs() > 1e-7, "{b2:?}");
        // The band centres, by hand: a Bagnoldian band across the periodic boundary
        // (bins 18, 19, 0, 1, 2) whose edges (18, 2) sit near the mean; its middle half
        // is bins 19, 0, 1 (depths 2, 3, 2 of a deepest 3; the edges are 1 deep).
        let mut p3 = vec![0.81; 20];
        for (k, v) in [(18, 0.80), (19, 0.78), (0, 0.77), (1, 0.78), (2, 0.80)] {
            p3[k] = v;
        }
        let b3 = bands(&p3, &gdot).unwrap();
        assert!(
            close(b3.phi_b, (0.78 + 0.77 + 0.78) / 3.0) && close(b3.phi_n, 0.81),
            "{b3:?}"
        );
        assert_eq!(b3.f, 0.25);
        // Flat or broken profiles have no bands.
        assert_eq!(bands(&[0.8; 20], &gdot), None);
        assert_eq!(bands(&[], &[]), None);
    }

    #[test]
    fn the_steep_stretch_gives_the_two_kinks() {
        // ln P^el rising by 1 per 0.01 of φ outside, by 20 per 0.01 between 0.79 and 0.81.
        let phis = [0.76, 0.77, 0.78, 0.79, 0.80, 0.81, 0.82, 0.83];
        let mut y = 0.0;
        let mut pts = vec![(phis[0], y)];
        for w in phis.windows(2) {
            y += if w[0] >= 0.79 - 1e-9 && w[1] <= 0.81 + 1e-9 {
                20.0
            } else {
                1.0
            };
            pts.push((w[1], y));
        }
        assert_eq!(steep_stretch(&pts, true), Some((Some(0.79), Some(0.81))));
        // Falling is no P^el jump, but is a μ switch.
        let down: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, -p.1)).collect();
        assert_eq!(steep_stretch(&down, true), None);
        assert_eq!(steep_stretch(&down, false), Some((Some(0.79), Some(0.81))));
        // A smooth exponential has no jump; a jump at the grid's end leaves φ_N open.
        let smooth: Vec<(f64, f64)> = phis.iter().map(|&p| (p, 100.0 * p)).collect();
        assert_eq!(steep_stretch(&smooth, true), None);
        let mut end = pts[..5].to_vec();
        end[4].1 = end[3].1 + 20.0;
        assert_eq!(steep_stretch(&end, true), Some((Some(0.79), None)));
    }

    #[test]
    fn the_three_measures_are_compared_within_the_grid_step() {
        // R_v banded at 0.79 and 0.80 (φ_B in 0.78–0.79, φ_N in 0.80–0.81); P^el jumps
        // between 0.79 and 0.81; μ switches between 0.77 and 0.78, off by more than a step.
        let phis: [f64; 8] = [0.76, 0.77, 0.78, 0.79, 0.80, 0.81, 0.82, 0.83];
        let rows: Vec<Row> = phis
            .iter()
            .map(|&phi| {
                let rv = if (0.785..0.805).contains(&phi) {
                    10.0
                } else {
                    1.0
                };
                let p = if phi < 0.79 + 1e-9 {
                    1e-6 * (phi * 100.0).exp()
                } else if phi < 0.81 - 1e-9 {
                    1e-6 * (79.0f64).exp() * (2000.0 * (phi - 0.79)).exp()
                } else {
                    1e-6 * (79.0f64 + 40.0).exp() * (100.0 * (phi - 0.81)).exp()
                };
                let mu = if phi < 0.775 { 0.2 } else { 0.4 + 0.01 * phi };
                Row {
                    phi,
                    q: 1.0,
                    rate: 1e-5,
                    v: [
                        ("r_v".to_string(), (rv, 0.1)),
                        ("p_el".to_string(), (p, 0.0)),
                        ("mu".to_string(), (mu, 0.0)),
                    ]
                    .into(),
                }
            })
            .collect();
        let m = measures(&rows);
        assert_eq!(m.len(), 1);
        let m = &m[0];
        assert_eq!(m.p_el, Some((Some(0.79), Some(0.81))));
        assert_eq!(m.mu, Some((Some(0.77), Some(0.78))));
        assert_eq!(m.grid, phis);
        // Fractional grid index: 0.785 is half way between 0.78 (2) and 0.79 (3).
        assert!((m.index(0.785) - 2.5).abs() < 1e-9 && m.index(0.76) == 0.0);
        let d = m.disagreements();
        // R_v's 0.785 and the kink's 0.79 agree; μ's 0.77 is off from both, on each side.
        assert!(
            !d.iter().any(|s| s.contains("R_v 0.7850 against P^el")),
            "{d:?}"
        );
        assert!(
            d.iter()
                .any(|s| s.starts_with("φ_B: R_v 0.7850 against μ switch 0.7700")),
            "{d:?}"
        );
        assert!(
            d.iter()
                .any(|s| s.starts_with("φ_N: P^el kink 0.8100 against μ switch 0.7800")),
            "{d:?}"
        );
    }

    #[test]
    fn sizes_of_one_model_are_compared_where_they_share_a_rate() {
        let row = |phi: f64, rate: f64, rv: f64| Row {
            phi,
            q: 1.0,
            rate,
            v: [("r_v".to_string(), (rv, 0.1))].into(),
        };
        let sweep = |model: &str, n: u64, rows: Vec<Row>| SweepData {
            rows,
            grid: Vec::new(),
            missing: Vec::new(),
            model: model.into(),
            n: Some(n),
            strain: None,
            angles: Vec::new(),
        };
        // The large system bands over 0.79–0.81, the small one only at 0.80.
        let phis = [0.78, 0.79, 0.80, 0.81, 0.82];
        let big = sweep(
            "cdrot",
            1024,
            phis.iter()
                .map(|&p| {
                    row(
                        p,
                        1e-5,
                        if (0.785..0.815).contains(&p) {
                            10.0
                        } else {
                            1.0
                        },
                    )
                })
                .collect(),
        );
        let small = sweep(
            "cdrot",
            256,
            phis.iter()
                .map(|&p| {
                    row(
                        p,
                        1e-5,
                        if (0.795..0.805).contains(&p) {
                            10.0
                        } else {
                            1.0
                        },
                    )
                })
                .collect(),
        );
        let other = sweep(
            "cd",
            256,
            phis.iter().map(|&p| row(p, 1e-5, 10.0)).collect(),
        );
        let sweeps = vec![
            ("big".to_string(), &big),
            ("small".to_string(), &small),
            ("cd".to_string(), &other),
        ];
        let rows = by_size(&sweeps);
        assert_eq!(rows.len(), 2, "{rows:?}");
        let b = rows.iter().find(|r| r.n == 1024).unwrap();
        let s = rows.iter().find(|r| r.n == 256).unwrap();
        assert_eq!(
            (b.b.phi_b, b.b.phi_n),
            (Some((0.78, 0.79)), Some((0.81, 0.82)))
        );
        assert_eq!(
            (s.b.phi_b, s.b.phi_n),
            (Some((0.79, 0.80)), Some((0.80, 0.81)))
        );
        // One size alone: nothing to compare.
        assert!(by_size(&sweeps[..1]).is_empty());
    }

    #[test]
    fn phi_b_and_phi_n_bracket_the_banded_stretch() {
        let row = |phi: f64, rate: f64, rv: f64| Row {
            phi,
            q: 1.0,
            rate,
            v: [("r_v".to_string(), (rv, 0.1))].into(),
        };
        let rows = vec![
            row(0.80, 1e-5, 20.0),
            row(0.78, 1e-5, 1.1),
            row(0.79, 1e-5, 8.0),
            row(0.81, 1e-5, 1.3),
            row(0.78, 1e-4, 1.0),
            row(0.80, 1e-4, 1.2),
            row(0.82, 1e-4, 5.0),
        ];
        let b = boundaries(&rows);
        assert_eq!(b.len(), 2, "{b:?}");
        let slow = b.iter().find(|x| x.rate == 1e-5).unwrap();
        assert_eq!(slow.phi_b, Some((0.78, 0.79)));
        assert_eq!(slow.phi_n, Some((0.80, 0.81)));
        assert_eq!(slow.banded, [0.79, 0.80]);
        // The grid ends inside the banded stretch: φ_N is not bracketed.
        let fast = b.iter().find(|x| x.rate == 1e-4).unwrap();
        assert_eq!((fast.phi_b, fast.phi_n), (Some((0.80, 0.82)), None));
    }
}
