//! The CDn reference check (vagberg-sheared-disks Sec. II): with dissipation from the
//! normal velocity difference only, the model "is well known to have Bagnoldian
//! rheology, with stress ∼ γ̇², for all values of φ and Q" — below jamming. A sweep of
//! model CDn states, for each (φ, Q), which it is:
//! - *Bagnoldian* over all its rates;
//! - *near or above jamming at this size*: the slope of ln p against ln γ̇ between its
//!   two lowest rates is below 3/2 by two standard errors. CDn has no Newtonian phase,
//!   so a slope below Bagnold's at the lowest rates is the approach to jamming's yield
//!   stress (φ_J ≈ 0.8433 for large systems; a small system's jamming point lies lower
//!   and spreads by about N^(-1/2)). Outside the claim;
//! - *undecided*: the data cannot tell (an interval straddling 3/2);
//! - *against the claim*: anything else (decided, not Bagnoldian, below jamming).

use super::Classification;
use super::classify::Class;

/// The (φ, Q) groups of the check, each with its points' text.
struct Groups {
    bagnold: usize,
    jammed: Vec<String>,
    undecided: Vec<String>,
    against: Vec<String>,
    all: usize,
}

fn groups(c: &Classification) -> Groups {
    let mut g = Groups {
        bagnold: 0,
        jammed: Vec::new(),
        undecided: Vec::new(),
        against: Vec::new(),
        all: 0,
    };
    for s in c.slopes.iter().filter(|s| s.scope == "all") {
        g.all += 1;
        let lowest = c
            .slopes
            .iter()
            .filter(|l| l.scope == "local" && l.phi == s.phi && l.q == s.q)
            .min_by(|a, b| a.slope.rate_lo.total_cmp(&b.slope.rate_lo));
        let text = |l: &super::Classified| {
            format!(
                "φ = {}, Q = {} (slope {:.2} ± {:.2} over γ̇ τ_e {:.0e}–{:.0e})",
                s.phi, s.q, l.slope.slope, l.slope.err, l.slope.rate_lo, l.slope.rate_hi
            )
        };
        if s.slope.class == Class::Bagnoldian {
            g.bagnold += 1;
        } else if let Some(l) =
            lowest.filter(|l| l.slope.slope + super::classify::SIGMAS * l.slope.err < 1.5)
        {
            g.jammed.push(text(l));
        } else if s.slope.class == Class::Undecided
            && s.slope.slope - super::classify::SIGMAS * s.slope.err < 1.5
            && s.slope.slope + super::classify::SIGMAS * s.slope.err > 1.5
        {
            g.undecided.push(text(s));
        } else {
            g.against.push(text(s));
        }
    }
    g
}

/// The check's sentence, from the classification's slopes.
pub fn check(c: &Classification) -> String {
    let g = groups(c);
    if g.all == 0 {
        return "CDn reference (Sec. II: Bagnoldian at every φ below jamming and every Q): not made, no (φ, Q) has two rates.".into();
    }
    let mut text = format!(
        "Check — CDn is Bagnoldian below jamming at every φ and Q (vagberg-sheared-disks Sec. II): {} of {} (φ, Q) Bagnoldian over all their rates",
        g.bagnold, g.all
    );
    if !g.jammed.is_empty() {
        text += &format!(
            "; near or above jamming at this size, outside the claim (slope between the two lowest rates below 3/2: CDn has no Newtonian phase, so this is the approach to a yield stress): {}",
            g.jammed.join("; ")
        );
    }
    if !g.undecided.is_empty() {
        text += &format!(
            "; the data cannot tell (the interval straddles 3/2; lower rates or longer runs would): {}",
            g.undecided.join("; ")
        );
    }
    if !g.against.is_empty() {
        text += &format!("; against the claim: {}", g.against.join("; "));
    }
    text += if g.against.is_empty() {
        ". Holds wherever the data decide below jamming."
    } else {
        ". Does not hold."
    };
    text
}

#[cfg(test)]
mod tests {
    use super::super::classify::{Slope, class_of};
    use super::super::{Classification, Classified};
    use super::*;

    fn at(phi: f64, scope: &'static str, rates: (f64, f64), slope: f64, err: f64) -> Classified {
        let (class, note) = class_of(slope, err);
        Classified {
            phi,
            q: 1.0,
            scope,
            slope: Slope {
                slope,
                err,
                rate_lo: rates.0,
                rate_hi: rates.1,
                class,
                note,
            },
        }
    }

    fn c(s: Vec<Classified>) -> Classification {
        Classification {
            slopes: s,
            transitions: Vec::new(),
        }
    }

    /// The four groups, as a CDn sweep at N = 256 gave them: φ = 0.80 Bagnoldian,
    /// φ = 0.84 flattening at the lowest rates (jammed at that size), φ = 0.76 straddling
    /// 3/2; and a decided Newtonian point, which is against the claim.
    #[test]
    fn each_point_is_named_in_its_group() {
        let (lo, mid, hi) = ((3e-5, 1e-4), (1e-4, 1e-3), (3e-5, 1e-3));
        let good = check(&c(vec![
            at(0.80, "all", hi, 2.0, 0.1),
            at(0.80, "local", lo, 2.0, 0.2),
        ]));
        assert!(
            good.contains("1 of 1") && good.ends_with("below jamming."),
            "{good}"
        );
        let mixed = check(&c(vec![
            at(0.80, "all", hi, 2.0, 0.1),
            at(0.84, "all", hi, 0.74, 0.06),
            at(0.84, "local", lo, 0.67, 0.2),
            at(0.84, "local", mid, 0.76, 0.1),
            at(0.76, "all", hi, 1.64, 0.08),
            at(0.76, "local", lo, 1.84, 0.28),
        ]));
        assert!(mixed.contains("1 of 3"), "{mixed}");
        assert!(
            mixed.contains("outside the claim") && mixed.contains("φ = 0.84, Q = 1 (slope 0.67"),
            "{mixed}"
        );
        assert!(
            mixed.contains("cannot tell") && mixed.contains("φ = 0.76"),
            "{mixed}"
        );
        assert!(mixed.ends_with("below jamming."), "{mixed}");
        // Newtonian all the way down, lowest local slope 1.0 ± 0.05: in CDn that is the
        // approach to jamming; decided Newtonian with a Bagnoldian lowest pair is against.
        let against = check(&c(vec![
            at(0.78, "all", hi, 1.0, 0.05),
            at(0.78, "local", lo, 2.0, 0.1),
        ]));
        assert!(
            against.contains("against the claim") && against.ends_with("Does not hold."),
            "{against}"
        );
        assert!(check(&c(Vec::new())).contains("not made"));
    }
}
