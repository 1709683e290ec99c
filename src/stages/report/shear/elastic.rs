//! A sweep's elastic pressure and collision figures (vagberg-sheared-disks): η_p^el and
//! B_p^el against Q (Figs. 2, 11) and φ (Fig. 16), var[θ̇/γ̇] (Fig. 20b), P^el against
//! φ (Figs. 15, 22) and against Q (Figs. 1, 10), and τ_dur/τ_e and ν_coll/γ̇ against φ and
//! against Q (Figs. 6, 14). Units d_s = m = τ_e = 1, so P^el = (τ_e²/m) p^el (Eq. 18) is
//! the run's `p_el`, τ_dur/τ_e its `tau_dur` and ν_coll/γ̇ its `nu_coll` (contacts begun
//! per particle per τ_e) over γ̇ τ_e.

use super::{Figures, Row, key, versus_phi, versus_q};
use crate::error::Result;
use crate::stages::report::render::curves::XyFigure;
use std::collections::BTreeMap;

/// The rows with ν_coll/γ̇ added (error scaled alike), as `nu_coll_over_rate`.
fn with_rate_normalised(rows: &[Row]) -> Vec<Row> {
    rows.iter()
        .cloned()
        .map(|mut r| {
            if let Some((m, e)) = r.get("nu_coll") {
                r.v.insert("nu_coll_over_rate".into(), (m / r.rate, e / r.rate));
            }
            r
        })
        .collect()
}

/// What each figure shows: the quantity, its file, its title, the y axis, a log y
/// axis, and for each axis the paper's figure (cited in the title; `None` where the
/// paper draws the quantity only against the other axis) and the caption.
struct Quantity {
    key: &'static str,
    file: &'static str,
    title: &'static str,
    y: &'static str,
    log: bool,
    phi: (Option<&'static str>, &'static str),
    q: (Option<&'static str>, &'static str),
}

const QUANTITIES: &[Quantity] = &[
    Quantity {
        key: "eta_p_el",
        file: "eta_p_el",
        title: "η_p^el = p^el/(k_d dγ/dt)",
        y: "η_p^el = P^el / (dγ/dt τ_0)",
        log: true,
        phi: (
            Some("Fig. 16(a,c)"),
            "The elastic pressure analog of viscosity η_p^el = P^el/(γ̇ τ_0) = p^el/(k_d γ̇) (vagberg-sheared-disks Fig. 2's definition) against φ for each (Q, γ̇): independent of γ̇ as γ̇ → 0 where the flow is Newtonian, proportional to γ̇ (vanishing as γ̇ → 0) where it is Bagnoldian (vagberg-sheared-disks Fig. 16(a,c), CDrot at Q = 1 and 20).",
        ),
        q: (
            Some("Figs. 2(a,c), 11(a,c)"),
            "η_p^el = P^el/(γ̇ τ_0) = p^el/(k_d γ̇) against Q for each (φ, γ̇): independent of γ̇ (and of Q) below Q_c, where the flow is Newtonian; proportional to γ̇ above it, where it is Bagnoldian, so the curves fan out with γ̇ there (vagberg-sheared-disks Fig. 2(a,c) for CD, Fig. 11(a,c) for CDrot).",
        ),
    },
    Quantity {
        key: "b_p_el",
        file: "b_p_el",
        title: "B_p^el = p^el/(m (dγ/dt)²)",
        y: "B_p^el = P^el / (dγ/dt τ_e)²",
        log: true,
        phi: (
            Some("Fig. 16(b,d)"),
            "The elastic Bagnold coefficient B_p^el = P^el/(γ̇ τ_e)² = p^el/(m γ̇²) against φ for each (Q, γ̇): independent of γ̇ where the flow is Bagnoldian, growing as 1/γ̇ where it is Newtonian (vagberg-sheared-disks Fig. 16(b,d)).",
        ),
        q: (
            Some("Figs. 2(b,d), 11(b,d)"),
            "B_p^el = P^el/(γ̇ τ_e)² = p^el/(m γ̇²) against Q for each (φ, γ̇): independent of γ̇ above Q_c (Bagnoldian), roughly linear in Q there; growing as 1/γ̇ below it (vagberg-sheared-disks Fig. 2(b,d) for CD, Fig. 11(b,d) for CDrot).",
        ),
    },
    Quantity {
        key: "theta_dot_over_gamma_dot_var",
        file: "rotation_var",
        title: "var[θ̇_i/(dγ/dt)]",
        y: "var[θ̇_i / (dγ/dt)]",
        log: true,
        phi: (
            Some("Fig. 20b, Eq. 28"),
            "The variance of the spin in units of γ̇ (Eq. 28: ⟨(θ̇_i/γ̇)²⟩ − ⟨θ̇_i/γ̇⟩², both averages over particles and the steady window's samples) against φ for each (Q, γ̇): small where disks roll with the affine rotation, growing where contacts are long-lived (vagberg-sheared-disks Fig. 20(b), CDrot).",
        ),
        q: (
            None,
            "var[θ̇_i/γ̇] (Eq. 28) against Q for each (φ, γ̇); the paper draws it against φ only (Fig. 20(b)).",
        ),
    },
    Quantity {
        key: "p_el",
        file: "p_el",
        title: "Elastic pressure P^el",
        y: "P^el = p_el τ_e² / m",
        log: true,
        phi: (
            Some("Figs. 15, 22"),
            "The elastic part of the dimensionless pressure P^el against φ for each (Q, γ̇): at small γ̇ a jump in P^el signals the transition at φ_c from Bagnoldian to Newtonian rheology, broadening as γ̇ grows (vagberg-sheared-disks Fig. 15 for CDrot at several Q, Fig. 22 at several γ̇ for Q = 1).",
        ),
        q: (
            Some("Figs. 1, 10"),
            "P^el against Q for each (φ, γ̇): falling roughly as 1/Q, a sharp drop at Q_c(φ) from Newtonian (below) to Bagnoldian rheology (above), then rising roughly linearly in Q (vagberg-sheared-disks Fig. 1 for CD, Fig. 10 for CDrot).",
        ),
    },
    Quantity {
        key: "tau_dur",
        file: "tau_dur",
        title: "Contact duration τ_dur / τ_e",
        y: "τ_dur / τ_e",
        log: true,
        phi: (
            None,
            "The mean duration of a contact (the contacts begun in the steady window followed to its end, those still open censored) in units of τ_e against φ for each (Q, γ̇): of order 1 and independent of γ̇ at small γ̇ where the flow is Bagnoldian, growing by orders of magnitude where it is Newtonian at dense φ (the paper draws it against Q: vagberg-sheared-disks Figs. 6(a,c), 14(a,c)).",
        ),
        q: (
            Some("Figs. 6(a,c), 14(a,c)"),
            "τ_dur/τ_e against Q for each (φ, γ̇) (vagberg-sheared-disks Figs. 6(a,c) for CD, 14(a,c) for CDrot).",
        ),
    },
    Quantity {
        key: "nu_coll_over_rate",
        file: "nu_coll",
        title: "Collision rate ν_coll / (dγ/dt)",
        y: "ν_coll / (dγ/dt)",
        log: true,
        phi: (
            None,
            "Contacts begun per particle per unit strain, ν_coll/γ̇, against φ for each (Q, γ̇): independent of γ̇ at small γ̇ where the flow is Bagnoldian, so that Z = 2 τ_dur ν_coll vanishes as γ̇ τ_e (the paper draws it against Q: vagberg-sheared-disks Figs. 6(b,d), 14(b,d)).",
        ),
        q: (
            Some("Figs. 6(b,d), 14(b,d)"),
            "ν_coll/γ̇ against Q for each (φ, γ̇) (vagberg-sheared-disks Figs. 6(b,d) for CD, 14(b,d) for CDrot).",
        ),
    },
];

/// A title with the paper's figure appended when it has one.
fn titled(title: &str, against: &str, fig: Option<&str>) -> String {
    match fig {
        Some(f) => format!("{title} against {against} ({f})"),
        None => format!("{title} against {against}"),
    }
}

/// Add P^el, τ_dur/τ_e and ν_coll/γ̇ against φ, and against Q when the grid has several
/// Q (the paper's axis for Figs. 1, 6, 10, 14); quantities no run has are left out.
pub(super) fn add_figures(
    f: &mut Figures,
    rows: &[Row],
    colour_of: &BTreeMap<(i64, i64), usize>,
) -> Result<()> {
    let rows = with_rate_normalised(rows);
    let qs = {
        let mut v: Vec<i64> = rows.iter().map(|r| key(r.q)).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    for q in QUANTITIES {
        let series = versus_phi(&rows, q.key, "", false, colour_of);
        if series.is_empty() {
            continue;
        }
        f.add(
            &XyFigure {
                title: titled(q.title, "φ", q.phi.0),
                x_desc: "φ".into(),
                y_desc: q.y.into(),
                x_log: false,
                y_log: q.log,
                series,
            },
            q.file,
            q.phi.1.into(),
        )?;
        if qs > 1 {
            f.add(
                &XyFigure {
                    title: titled(q.title, "Q", q.q.0),
                    x_desc: "Q".into(),
                    y_desc: q.y.into(),
                    x_log: true,
                    y_log: q.log,
                    series: versus_q(&rows, q.key),
                },
                &format!("{}_vs_q", q.file),
                q.q.1.into(),
            )?;
        }
    }
    Ok(())
}

/// The rms normal and tangential relative velocities at contact, v_ij,N and v_ij,T,
/// against Q (vagberg-sheared-disks Sec. III.1, the text after Fig. 9; it has no figure
/// of them): equal above Q_c and falling with Q, then v_ij,N dropping sharply below Q_c
/// while v_ij,T levels off.
pub(super) fn add_contact_velocities(f: &mut Figures, rows: &[Row]) -> Result<()> {
    if !rows.iter().any(|r| r.get("v_n_rms").is_some()) {
        return Ok(());
    }
    let mut qs: Vec<i64> = rows.iter().map(|r| key(r.q)).collect();
    qs.sort();
    qs.dedup();
    if qs.len() < 2 {
        return Ok(());
    }
    let mut series = super::series_along(rows, super::Along::Q, "v_n_rms", "v_ij,N, ", false, None);
    // Both group by (φ, γ̇) in the same order, so each tangential series takes its normal
    // partner's colour.
    series.extend(super::series_along(
        rows,
        super::Along::Q,
        "v_t_rms",
        "v_ij,T, ",
        true,
        None,
    ));
    f.add(
        &XyFigure {
            title: "rms relative velocities at contact v_ij,N and v_ij,T against Q (Sec. III.1; no figure in the paper)".into(),
            x_desc: "Q".into(),
            y_desc: "rms of V_ij,N, V_ij,T  [d_s dγ/dt]".into(),
            x_log: true,
            y_log: true,
            series,
        },
        "contact_rms_q",
        "v_ij,N (lines) and v_ij,T (markers), the root mean square of the normal and tangential components of the centre-of-mass velocity difference over each run's sampled contacts (contact_velocities, Eq. 34), in units of d_s γ̇, against Q for each (φ, γ̇) (vagberg-sheared-disks Sec. III.1, the text after Fig. 9, which has no figure of them): about equal above Q_c and falling as Q falls, then v_ij,N drops sharply below Q_c while v_ij,T levels off. Errors treat the sampled contacts as independent (a lower bound).".into(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(phi: f64, q: f64, rate: f64, nu: f64) -> Row {
        Row {
            phi,
            q,
            rate,
            v: [("nu_coll".to_string(), (nu, 0.1 * nu))].into(),
        }
    }

    #[test]
    fn collision_rate_per_strain_and_series_against_q() {
        let rows: Vec<Row> = [(0.8, 1.0), (0.8, 10.0), (0.8, 3.0), (0.76, 1.0)]
            .into_iter()
            .map(|(phi, q)| row(phi, q, 1e-2, 0.2 * q))
            .collect();
        let rows = with_rate_normalised(&rows);
        let (m, e) = rows[0].v["nu_coll_over_rate"];
        assert!((m - 20.0).abs() < 1e-12 && (e - 2.0).abs() < 1e-12);
        let s = versus_q(&rows, "nu_coll_over_rate");
        assert_eq!(s.len(), 2, "one series per (φ, γ̇)");
        let at_08 = s.iter().find(|x| x.label.starts_with("φ = 0.8,")).unwrap();
        let qs: Vec<f64> = at_08.points.iter().map(|p| p.0).collect();
        assert_eq!(qs, [1.0, 3.0, 10.0], "sorted by Q");
        assert!((at_08.points[2].1 - 200.0).abs() < 1e-9);
    }
}
