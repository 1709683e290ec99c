//! What each figure of vagberg-sheared-disks plots: its horizontal axis and the
//! quantity on its vertical one. A report figure whose title cites "Fig. N" must plot
//! what Fig. N plots; [`check`] holds a title to that, and the sweep report's test runs
//! it over every figure the report draws (so a figure that shows another quantity
//! under the paper's label fails a test, as the old η_p against γ̇ titled "Figs. 2, 11,
//! 16" would have).

use crate::stages::report::render::Labels;

/// A horizontal axis, read off a figure's x description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    Phi,
    Q,
    Rate,
    Pressure,
    Angle,
    Y,
    Velocity,
    /// A map (Fig. 27): x and y positions.
    Position,
}

fn axis_of(x: &str) -> Option<Axis> {
    let x = x.trim();
    Some(if x.starts_with('φ') {
        Axis::Phi
    } else if x.starts_with('Q') {
        Axis::Q
    } else if x.contains("dγ/dt") {
        Axis::Rate
    } else if x.starts_with('P') {
        Axis::Pressure
    } else if x.contains('ϑ') {
        Axis::Angle
    } else if x.starts_with("y") {
        Axis::Y
    } else if x.starts_with('V') {
        Axis::Velocity
    } else if x.starts_with("x") {
        Axis::Position
    } else {
        return None;
    })
}

/// (figure, its horizontal axes, what its vertical axis description must contain —
/// any one of them).
const FIGURES: &[(u32, &[Axis], &[&str])] = &[
    (1, &[Axis::Q], &["P^el"]),
    (2, &[Axis::Q], &["η_p^el", "B_p^el"]),
    (3, &[Axis::Phi], &["Q"]),
    (4, &[Axis::Q], &["Z"]),
    (5, &[Axis::Q], &["Z", "2 τ_dur ν_coll"]),
    (6, &[Axis::Q], &["τ_dur", "ν_coll"]),
    (8, &[Axis::Angle], &["P(ϑ)"]),
    (9, &[Axis::Q], &["P(ϑ = 90°)"]),
    (10, &[Axis::Q], &["P^el"]),
    (11, &[Axis::Q], &["η_p^el", "B_p^el"]),
    (12, &[Axis::Q], &["Z"]),
    (13, &[Axis::Q], &["Z", "2 τ_dur ν_coll"]),
    (14, &[Axis::Q], &["τ_dur", "ν_coll"]),
    (15, &[Axis::Phi], &["P^el"]),
    (16, &[Axis::Phi], &["η_p^el", "B_p^el"]),
    (17, &[Axis::Phi], &["Q"]),
    (18, &[Axis::Angle], &["P(ϑ)"]),
    (19, &[Axis::Q], &["P(ϑ = 90°)"]),
    (20, &[Axis::Phi], &["θ̇_i"]),
    (21, &[Axis::Velocity], &["V"]),
    (22, &[Axis::Phi], &["P^el"]),
    (23, &[Axis::Phi], &["μ"]),
    (24, &[Axis::Phi], &["R_v"]),
    (25, &[Axis::Phi], &["dγ/dt"]),
    (26, &[Axis::Pressure], &["dγ/dt"]),
    (27, &[Axis::Position], &["y"]),
    (28, &[Axis::Y], &["v_x", "dγ/dt", "φ"]),
    (29, &[Axis::Pressure], &["Σ"]),
    (30, &[Axis::Rate], &["Σ"]),
    (31, &[Axis::Rate], &["Σ"]),
    (32, &[Axis::Q], &["Z/("]),
    (33, &[Axis::Phi], &["B_p"]),
    (34, &[Axis::Phi, Axis::Rate], &["μ"]),
    (35, &[Axis::Phi], &["dγ/dt"]),
    (36, &[Axis::Phi], &["R_v"]),
];

/// The figure numbers a title cites: "Fig. 30", "Figs. 4–5, 12–13", "Fig. 16(a,c)",
/// "Fig. 34a" (panels are not told apart).
pub fn cited(title: &str) -> Vec<u32> {
    let mut out = Vec::new();
    let mut rest = title;
    while let Some(i) = rest.find("Fig") {
        rest = &rest[i + 3..];
        let Some(list) = rest.strip_prefix("s. ").or_else(|| rest.strip_prefix(". ")) else {
            continue;
        };
        let mut r = list;
        loop {
            let digits = r.len() - r.trim_start_matches(|c: char| c.is_ascii_digit()).len();
            let Ok(n) = r[..digits].parse::<u32>() else {
                break;
            };
            r = r[digits..].trim_start_matches(|c: char| c.is_ascii_lowercase());
            if r.starts_with('(') {
                r = r.find(')').map_or("", |k| &r[k + 1..]);
            }
            let mut last = n;
            if let Some(t) = r.strip_prefix('–') {
                let d = t.len() - t.trim_start_matches(|c: char| c.is_ascii_digit()).len();
                if let Ok(m) = t[..d].parse::<u32>() {
                    last = m;
                    r = t[d..].trim_start_matches(|c: char| c.is_ascii_lowercase());
                }
            }
            out.extend(n..=last.max(n));
            match r.strip_prefix(", ").or_else(|| r.strip_prefix(" and ")) {
                Some(t) => r = t,
                None => break,
            }
        }
        rest = r;
    }
    out
}

/// Whether the figure drawn with `l` plots what each paper figure its title cites
/// plots; the reason when not. Figures that say nothing of their labels pass.
pub fn check(l: &Labels) -> Result<(), String> {
    if l.title.is_empty() {
        return Ok(());
    }
    for n in cited(&l.title) {
        let Some((_, axes, ys)) = FIGURES.iter().find(|f| f.0 == n) else {
            return Err(format!(
                "\"{}\" cites Fig. {n}, which vagberg-sheared-disks does not have as a plot",
                l.title
            ));
        };
        let axis = axis_of(&l.x);
        if !axis.is_some_and(|a| axes.contains(&a)) {
            return Err(format!(
                "\"{}\" cites Fig. {n}, whose horizontal axis is {axes:?}, but is drawn against \"{}\"",
                l.title, l.x
            ));
        }
        if !ys.iter().any(|y| l.y.contains(y)) {
            return Err(format!(
                "\"{}\" cites Fig. {n}, which plots {ys:?}, but its vertical axis is \"{}\"",
                l.title, l.y
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn citations_are_read_as_written_in_titles() {
        assert_eq!(cited("Σ against dγ/dt (Fig. 30)"), [30]);
        assert_eq!(
            cited("Z and 2 τ_dur ν_coll against Q (Figs. 4–5, 12–13)"),
            [4, 5, 12, 13]
        );
        assert_eq!(cited("η_p^el against Q (Figs. 2(a,c), 11(a,c))"), [2, 11]);
        assert_eq!(cited("μ along P (Fig. 34a)"), [34]);
        assert_eq!(cited("var[θ̇_i/(dγ/dt)] against φ (Fig. 20b, Eq. 28)"), [20]);
        assert_eq!(cited("Figs. 8 and 18"), [8, 18]);
        assert!(cited("Flow curves: η_p = p/(k_d dγ/dt)").is_empty());
        assert!(cited("Figure of merit").is_empty());
    }

    /// The mislabels this check exists for: total η_p against γ̇ under Figs. 2, 11, 16;
    /// Z against φ under Figs. 4–5; the slope classes in (φ, γ̇) under Fig. 17.
    #[test]
    fn a_figure_that_shows_another_quantity_under_the_papers_label_is_refused() {
        let bad = [
            Labels::of(
                "Flow curves (Figs. 2, 11, 16)",
                "dγ/dt · τ_e",
                "η_p = p / (k_d dγ/dt)",
            ),
            Labels::of("Z (Figs. 4–5, 12–13)", "φ", "Z, 2 τ_dur ν_coll"),
            Labels::of("Phase diagram (Figs. 17, 25)", "φ", "dγ/dt τ_e"),
            Labels::of("x (Fig. 7)", "Q", "Z"),
        ];
        for l in &bad {
            assert!(check(l).is_err(), "{l:?}");
        }
        let good = [
            Labels::of(
                "η_p^el against Q (Figs. 2, 11)",
                "Q",
                "η_p^el = P^el / (dγ/dt τ_0)",
            ),
            Labels::of("Z against Q (Figs. 4–5, 12–13)", "Q", "Z, 2 τ_dur ν_coll"),
            Labels::of("μ along P (Fig. 34b)", "dγ/dt τ_e", "μ = Σ / P"),
            Labels::of("no citation", "φ", "anything"),
        ];
        for l in &good {
            assert_eq!(check(l), Ok(()), "{l:?}");
        }
    }
}
