//! Shear-band coexistence (vagberg-sheared-disks Sec. IV, Figs. 24–25, 28, 35–36).
//!
//! - **Band values of one run** (text beside Figs. 28 and 36): from the steady-window
//!   profiles φ(y) and γ̇(y) (equal bins of y), the Bagnoldian band is where φ(y) lies
//!   below the run's mean φ; f = w_B/L_y is its share of the bins, and φ*_B, φ*_N are the
//!   mean φ(y) over the bins of each band, so that φ = f φ*_B + (1 − f) φ*_N holds exactly.
//!   Likewise from γ̇(y): the Bagnoldian band is where γ̇(y) exceeds the mean γ̇, f′ its
//!   share, and γ̇*_B, γ̇*_N the band means, so that γ̇ = f′ γ̇*_B + (1 − f′) γ̇*_N. f and f′
//!   differ where the interface is wide compared with L_y, as the paper finds. In a
//!   homogeneous run the split only divides noise: the values mean something where R_v
//!   is large.
//! - **φ_B and φ_N of a sweep** (Figs. 24–25, 35): at each (Q, γ̇), the runs along φ with
//!   R_v = ⟨δv_x²⟩/⟨v_y²⟩ (Eq. 37) above [`R_V_BANDED`] are shear banded (R_v ≈ 1 in
//!   homogeneous flow); φ_B is bracketed between the last unbanded φ below the banded
//!   stretch and its first banded φ, φ_N between its last banded φ and the first
//!   unbanded φ above. The paper regards R_v as the most reliable of its three measures;
//!   the P^el kink and the switch of μ between branches are not located here.

use super::{Figures, Row, key};
use crate::stages::report::render::html::Block;
use std::collections::BTreeMap;

/// R_v above which a run counts as shear banded (homogeneous flow gives R_v ≈ 1).
pub const R_V_BANDED: f64 = 3.0;

/// One run's band values.
#[derive(Debug, Clone, PartialEq)]
pub struct Bands {
    pub phi_b: f64,
    pub phi_n: f64,
    pub f: f64,
    pub gdot_b: f64,
    pub gdot_n: f64,
    pub f_prime: f64,
}

/// Band values from profiles φ(y) and γ̇(y) in equal bins; `None` when a profile is
/// empty, not finite, or flat (no bin on one side of its mean).
pub fn bands(phi: &[f64], gdot: &[f64]) -> Option<Bands> {
    let split = |v: &[f64], below: bool| -> Option<(f64, f64, f64)> {
        if v.is_empty() || v.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let (b, n): (Vec<f64>, Vec<f64>) = v.iter().partition(|&&x| (x < mean) == below);
        if b.is_empty() || n.is_empty() {
            return None;
        }
        let avg = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
        Some((avg(&b), avg(&n), b.len() as f64 / v.len() as f64))
    };
    let (phi_b, phi_n, f) = split(phi, true)?;
    let (gdot_b, gdot_n, f_prime) = split(gdot, false)?;
    Some(Bands {
        phi_b,
        phi_n,
        f,
        gdot_b,
        gdot_n,
        f_prime,
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
    f.blocks.push(Block::Paragraph(match bands(phi, gdot) {
        Some(b) => format!(
            "Band values (vagberg-sheared-disks, text beside Figs. 28 and 36): the Bagnoldian band is where φ(y) lies below the mean φ — f = w_B/L_y = {:.2}, φ*_B = {}, φ*_N = {} (φ = f φ*_B + (1 − f) φ*_N) — and, from γ̇(y) above the mean γ̇, f′ = {:.2}, γ̇*_B τ_e = {}, γ̇*_N τ_e = {}. They describe shear bands only where R_v (summary above) is large, well above {R_V_BANDED}; in homogeneous flow the split divides noise.",
            b.f,
            fmt(b.phi_b),
            fmt(b.phi_n),
            b.f_prime,
            fmt(b.gdot_b),
            fmt(b.gdot_n)
        ),
        None => "Band values: none (a profile is flat or incomplete).".into(),
    }));
}

/// The banded stretches of a sweep along φ, as a table with the rule.
pub(super) fn add_sweep(f: &mut Figures, rows: &[Row]) {
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
        "Shear-band coexistence (vagberg-sheared-disks Figs. 24–25, 35): runs with R_v > {R_V_BANDED} are shear banded; along φ at each (Q, γ̇), φ_B lies between the last unbanded φ below the banded stretch and its first banded φ, φ_N between its last banded φ and the first unbanded φ above (the paper's R_v measure; the P^el kink and the μ branches are not located here, and the paper finds the boundaries move with the system size, Fig. 36)."
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
        let mean = phi.iter().sum::<f64>() / 20.0;
        assert!((b.f * b.phi_b + (1.0 - b.f) * b.phi_n - mean).abs() < 1e-12);
        // A wide interface moves f′ away from f.
        let mut g2 = gdot.clone();
        g2[5] = 3.5e-5;
        g2[6] = 3e-5;
        let b2 = bands(&phi, &g2).unwrap();
        assert_eq!(b2.f, 0.25);
        assert_eq!(b2.f_prime, 0.35);
        let gm = g2.iter().sum::<f64>() / 20.0;
        assert!((b2.f_prime * b2.gdot_b + (1.0 - b2.f_prime) * b2.gdot_n - gm).abs() < 1e-18);
        // Flat or broken profiles have no bands.
        assert_eq!(bands(&[0.8; 20], &gdot), None);
        assert_eq!(bands(&[], &[]), None);
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
