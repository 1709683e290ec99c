//! The ramp section of the report (vagberg-sheared-disks Sec. III.4, Fig. 31): the
//! dimensionless shear stress Σ = σ τ_e²/m (Eq. 18; m = τ_e = 1 here) against γ̇ τ_e
//! while γ̇ is ramped up and down at the rate κ̃ (Eqs. 38–41), both branches on one pair
//! of log axes so that a hysteresis loop shows, with Σ of the two branches compared at
//! the same rates.

use super::{Figures, slug};
use crate::error::{Error, Result};
use crate::io::csvdiag::Expect;
use crate::io::table::read_table;
use crate::stages::report::render::SavedFigure;
use crate::stages::report::render::curves::{XyFigure, XySeries};
use crate::stages::report::render::html::{Block, Section};
use std::path::Path;

/// One ramp as the report sees it: `summary.json` and the windowed `ramp.parquet` of a
/// `simulate shear --ramp` run.
#[derive(Debug, Clone)]
pub struct RampData {
    /// `up` or `down`.
    pub direction: String,
    /// κ̃ = κ τ_e / ln 10 (Eq. 39).
    pub kappa: f64,
    /// γ̇ τ_e at the start and the end.
    pub rate_start: f64,
    pub rate_end: f64,
    /// Averaging window, τ_e.
    pub window: f64,
    pub n: Option<u64>,
    pub phi: Option<f64>,
    pub q: Option<f64>,
    pub model: String,
    /// Whether the ramp continued another's final state (else random positions).
    pub continued: bool,
    /// Window means (γ̇ τ_e, Σ, P), in time order.
    pub points: Vec<(f64, f64, f64)>,
}

impl RampData {
    fn up(&self) -> bool {
        self.direction == "up"
    }
    /// (γ̇ τ_e, Σ) with Σ > 0, sorted by rate (a log axis and a log interpolation).
    fn sigma_by_rate(&self) -> Vec<(f64, f64)> {
        let mut v: Vec<(f64, f64)> = self
            .points
            .iter()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.1.is_finite())
            .map(|p| (p.0, p.1))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    }
}

/// Read a ramp's directory.
pub fn read_ramp(dir: &Path) -> Result<RampData> {
    let sf = dir.join("summary.json");
    let text = std::fs::read_to_string(&sf).map_err(|e| Error::io(&sf, e))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::input(sf.display(), e.to_string()))?;
    let num = |k: &str| {
        v[k].as_f64().ok_or_else(|| {
            Error::input(sf.display(), format!("'{k}' missing: not a ramp's summary"))
        })
    };
    let direction = v["ramp"]
        .as_str()
        .filter(|d| ["up", "down"].contains(d))
        .ok_or_else(|| Error::input(sf.display(), "'ramp' is neither up nor down"))?
        .to_string();
    let tf = dir.join("ramp.parquet");
    let t = read_table(
        &tf,
        &[
            ("rate", Expect::Float),
            ("sigma", Expect::Float),
            ("p", Expect::Float),
        ],
    )?;
    t.require(&["rate", "sigma", "p"])?;
    let (rate, sigma, p) = (t.f64("rate")?, t.f64_or_nan("sigma")?, t.f64_or_nan("p")?);
    let pa = &v["params"];
    Ok(RampData {
        direction,
        kappa: num("kappa_tilde")?,
        rate_start: num("rate_start")?,
        rate_end: num("rate_end")?,
        window: num("window_tau_e")?,
        n: pa["n"].as_u64(),
        phi: pa["phi"].as_f64(),
        q: pa["q"].as_f64(),
        model: pa["model"].as_str().unwrap_or("?").to_string(),
        continued: v["started_from"].is_string(),
        points: (0..rate.len()).map(|i| (rate[i], sigma[i], p[i])).collect(),
    })
}

/// Σ at `rate` on a branch sorted by rate, interpolated linearly in ln Σ against ln γ̇
/// (both branches are power laws piecewise: Σ ∝ γ̇² Bagnoldian, ∝ γ̇ Newtonian).
fn sigma_at(branch: &[(f64, f64)], rate: f64) -> Option<f64> {
    let k = branch.iter().position(|p| p.0 >= rate)?;
    if branch[k].0 == rate || k == 0 {
        return (branch[k].0 == rate).then_some(branch[k].1);
    }
    let (a, b) = (branch[k - 1], branch[k]);
    let t = (rate / a.0).ln() / (b.0 / a.0).ln();
    Some((a.1.ln() + t * (b.1 / a.1).ln()).exp())
}

/// Σ of the up and the down branch at `count` rates spaced evenly in ln γ̇ over the
/// range both cover: (γ̇ τ_e, Σ up, Σ down). Empty when the ranges do not overlap.
pub fn matching_rates(
    up: &[(f64, f64)],
    down: &[(f64, f64)],
    count: usize,
) -> Vec<(f64, f64, f64)> {
    let (Some(u0), Some(u1), Some(d0), Some(d1)) =
        (up.first(), up.last(), down.first(), down.last())
    else {
        return Vec::new();
    };
    let (lo, hi) = (u0.0.max(d0.0), u1.0.min(d1.0));
    if lo >= hi || count < 2 {
        return Vec::new();
    }
    (0..count)
        .filter_map(|i| {
            let r = lo * (hi / lo).powf(i as f64 / (count - 1) as f64);
            // powf's rounding must not push the last rate past the end of a branch.
            let r = r.clamp(lo, hi);
            Some((r, sigma_at(up, r)?, sigma_at(down, r)?))
        })
        .collect()
}

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map_or("?".into(), |x| x.to_string())
}

/// The ramps of one data set: Σ against γ̇ τ_e, up filled and joined, down open (as in
/// Fig. 31), a pair of colours per κ̃; a table of the ramps; Σ up against Σ down at matching
/// rates for each κ̃ that has both.
pub fn ramp_section(
    label: &str,
    ramps: &[RampData],
    figdir: &Path,
    figures: &mut Vec<SavedFigure>,
) -> Result<Section> {
    let mut f = Figures {
        figdir,
        prefix: format!("ramp_{}", slug(label)),
        figures,
        blocks: Vec::new(),
    };
    let mut kappas: Vec<f64> = ramps.iter().map(|r| r.kappa).collect();
    kappas.sort_by(f64::total_cmp);
    kappas.dedup();
    let colour = |k: f64| kappas.iter().position(|x| *x == k).unwrap_or(0);
    f.blocks.push(Block::Table {
        header: [
            "ramp",
            "γ̇ τ_e from",
            "to",
            "κ̃",
            "window (τ_e)",
            "windows",
            "N",
            "φ",
            "Q",
            "model",
            "start",
        ]
        .map(String::from)
        .to_vec(),
        rows: ramps
            .iter()
            .map(|r| {
                vec![
                    r.direction.clone(),
                    format!("{:.2e}", r.rate_start),
                    format!("{:.2e}", r.rate_end),
                    format!("{:e}", r.kappa),
                    r.window.to_string(),
                    r.points.len().to_string(),
                    opt(r.n),
                    opt(r.phi),
                    opt(r.q),
                    r.model.to_uppercase(),
                    if r.continued {
                        "where a ramp ended".into()
                    } else {
                        "random positions".into()
                    },
                ]
            })
            .collect(),
    });
    let series = ramps
        .iter()
        .map(|r| XySeries {
            label: format!("{}, κ̃ = {:e}", r.direction, r.kappa),
            points: r.points.iter().map(|p| (p.0, p.1, 0.0)).collect(),
            markers_only: !r.up(),
            // Up and down of one κ̃ in neighbouring colours, so each loop reads as one.
            colour: 2 * colour(r.kappa) + usize::from(!r.up()),
        })
        .collect();
    f.add(
        &XyFigure {
            title: "Σ along strain-rate ramps up and down (Fig. 31)".into(),
            x_desc: "dγ/dt · τ_e".into(),
            y_desc: "Σ = σ τ_e² / m".into(),
            x_log: true,
            y_log: true,
            series,
        },
        "sigma",
        "The dimensionless shear stress Σ against γ̇ τ_e while γ̇ is ramped at fixed φ by a factor 10^{±κ̃} every τ_e, velocities and spins rescaled with it (Eqs. 38–41), Σ and γ̇ averaged over windows (the paper: 10³ τ_e): filled and joined going up, open going down, a pair of colours per κ̃. Each ramp starts from random positions, so its first windows are a transient. Where the two branches part, the ramp outran the steady state: going up the flow stays Bagnoldian (Σ ∝ γ̇²) past the coexistence region, going down Newtonian (Σ ∝ γ̇); the loop narrows as κ̃ decreases (vagberg-sheared-disks Fig. 31).".into(),
    )?;
    for &k in &kappas {
        let of = |up: bool| -> Vec<(f64, f64)> {
            ramps
                .iter()
                .filter(|r| r.kappa == k && r.up() == up)
                .flat_map(RampData::sigma_by_rate)
                .collect::<Vec<_>>()
        };
        let (mut up, mut down) = (of(true), of(false));
        if up.is_empty() || down.is_empty() {
            continue;
        }
        up.sort_by(|a, b| a.0.total_cmp(&b.0));
        down.sort_by(|a, b| a.0.total_cmp(&b.0));
        let rows: Vec<Vec<String>> = matching_rates(&up, &down, 6)
            .into_iter()
            .map(|(r, su, sd)| {
                vec![
                    format!("{r:.3e}"),
                    format!("{su:.4e}"),
                    format!("{sd:.4e}"),
                    format!("{:.3}", sd / su),
                ]
            })
            .collect();
        if rows.is_empty() {
            f.blocks.push(Block::Paragraph(format!(
                "κ̃ = {k:e}: the up and down ramps cover no common range of γ̇."
            )));
            continue;
        }
        f.blocks.push(Block::Paragraph(format!(
            "κ̃ = {k:e}: Σ of the two branches at the same γ̇ τ_e (interpolated in ln Σ against ln γ̇ between window means, at six rates spaced evenly in ln γ̇ over the range both cover); a ratio away from 1 is the hysteresis."
        )));
        f.blocks.push(Block::Table {
            header: ["γ̇ τ_e", "Σ up", "Σ down", "Σ down / Σ up"]
                .map(String::from)
                .to_vec(),
            rows,
        });
    }
    Ok(Section {
        id: format!("ramp-{}", slug(label)),
        title: format!("Strain-rate ramps {label}: hysteresis (Fig. 31)"),
        blocks: f.blocks,
    })
}
