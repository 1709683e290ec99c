//! The CDn reference check (vagberg-sheared-disks Sec. II): with dissipation from the
//! normal velocity difference only, the model "is well known to have Bagnoldian
//! rheology, with stress ∼ γ̇², for all values of φ and Q" — a statement about the
//! limit γ̇ → 0 (the paper's rheology is always that limit) below jamming. A sweep of
//! model CDn states, for each (φ, Q), which it is, judged on the slope of ln p against
//! ln γ̇ between its two lowest rates (the slope over all rates is given beside it):
//! - *Bagnoldian* as γ̇ → 0: that slope is Bagnoldian (`classify`). Where the slope over
//!   all rates is not, the highest rates are outside the hard-core limit (overlaps no
//!   longer small), which the report says;
//! - *at or near jamming*, outside the claim: either φ lies within [`NEAR_JAMMING`] of
//!   φ_J (the paper's 0.8433: there the finite rates sit in the critical region, whose
//!   slopes run from the critical exponent to 2 whatever the model), or the slope says
//!   the pressure tends to a yield pressure (s + 2e below 1/2, `jamming`'s rule: jammed at
//!   this size, whose jamming point lies below the large-system φ_J);
//! - *undecided*: the lowest rates' slope is neither decided Bagnoldian nor decided
//!   outside [1.5, 2.5];
//! - *against the claim*: a decided slope below Bagnold's, below jamming — a Newtonian
//!   CDn, say, which would fail here (the test plants one) — or above it.

use super::Classification;
use super::classify::{Class, SIGMAS};
use super::jamming::{PHI_J_PAPER, SLOPE_SPLIT};

/// φ this close to the paper's φ_J counts as at jamming.
pub const NEAR_JAMMING: f64 = 0.01;

/// The (φ, Q) groups of the check, each with its points' text.
struct Groups {
    bagnold: Vec<String>,
    /// Bagnoldian as γ̇ → 0 but not over all rates.
    soft_core: Vec<String>,
    jammed: Vec<String>,
    undecided: Vec<String>,
    against: Vec<String>,
    all: usize,
}

fn groups(c: &Classification) -> Groups {
    let mut g = Groups {
        bagnold: Vec::new(),
        soft_core: Vec::new(),
        jammed: Vec::new(),
        undecided: Vec::new(),
        against: Vec::new(),
        all: 0,
    };
    for s in c.slopes.iter().filter(|s| s.scope == "all") {
        g.all += 1;
        // The lowest pair of rates; with two rates only, the slope over all of them.
        let lowest = c
            .slopes
            .iter()
            .filter(|l| l.scope == "local" && l.phi == s.phi && l.q == s.q)
            .min_by(|a, b| a.slope.rate_lo.total_cmp(&b.slope.rate_lo))
            .unwrap_or(s);
        let l = &lowest.slope;
        let text = format!(
            "φ = {}, Q = {} (slope {:.2} ± {:.2} over γ̇ τ_e {:.0e}–{:.0e}; {:.2} ± {:.2} over all {:.0e}–{:.0e})",
            s.phi,
            s.q,
            l.slope,
            l.err,
            l.rate_lo,
            l.rate_hi,
            s.slope.slope,
            s.slope.err,
            s.slope.rate_lo,
            s.slope.rate_hi
        );
        if s.phi >= PHI_J_PAPER - NEAR_JAMMING || l.slope + SIGMAS * l.err < SLOPE_SPLIT {
            g.jammed.push(text);
        } else if l.class == Class::Bagnoldian {
            if s.slope.class == Class::Bagnoldian {
                g.bagnold.push(text);
            } else {
                g.soft_core.push(text);
            }
        } else if l.slope + SIGMAS * l.err >= 1.5 && l.slope - SIGMAS * l.err <= 2.5 {
            g.undecided.push(text);
        } else {
            // Decided below Bagnold's (say Newtonian) or above it: not Bagnoldian.
            g.against.push(text);
        }
    }
    g
}

/// The check's sentence, from the classification's slopes.
pub fn check(c: &Classification) -> String {
    let g = groups(c);
    if g.all == 0 {
        return "CDn reference (Sec. II: Bagnoldian as γ̇ → 0 at every φ below jamming and every Q): not made, no (φ, Q) has two rates.".into();
    }
    let mut text = format!(
        "Check — CDn is Bagnoldian as γ̇ → 0 at every φ below jamming and every Q (vagberg-sheared-disks Sec. II), judged on the slope of ln p against ln γ̇ between each point's two lowest rates: {} of {} (φ, Q) Bagnoldian over all their rates",
        g.bagnold.len(),
        g.all
    );
    if !g.soft_core.is_empty() {
        text += &format!(
            "; {} Bagnoldian at their lowest rates but not over all (the highest rates leave the hard-core limit): {}",
            g.soft_core.len(),
            g.soft_core.join("; ")
        );
    }
    if !g.jammed.is_empty() {
        text += &format!(
            "; at or near jamming, outside the claim (φ within {NEAR_JAMMING} of φ_J = {PHI_J_PAPER}, or a slope below {SLOPE_SPLIT} by {SIGMAS} errors: a yield pressure at this size): {}",
            g.jammed.join("; ")
        );
    }
    if !g.undecided.is_empty() {
        text += &format!(
            "; the data cannot tell (lower rates or longer runs would): {}",
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

    /// One (φ, Q = 1): its slope over all rates (3e-5–1e-2) and between its two lowest.
    fn pair(phi: f64, all: (f64, f64), lowest: (f64, f64)) -> Vec<Classified> {
        vec![
            at(phi, "all", (3e-5, 1e-2), all.0, all.1),
            at(phi, "local", (3e-5, 1e-4), lowest.0, lowest.1),
        ]
    }

    /// The groups, as CDn sweeps at N = 256 and 1024 gave them: φ = 0.80 Bagnoldian;
    /// φ = 0.82 Bagnoldian at its lowest rates, slope 1.1 between 1e-3 and 1e-2 (soft
    /// core); φ = 0.84 near the paper's φ_J; φ = 0.76 straddling 3/2; and two that are
    /// against the claim: a Newtonian CDn (slope 1.0 ± 0.05 at the lowest rates, far
    /// below jamming), which the old rule had filed as "near jamming".
    #[test]
    fn each_point_is_named_in_its_group() {
        let (lo, mid, hi, top) = ((3e-5, 1e-4), (1e-4, 1e-3), (3e-5, 1e-2), (1e-3, 1e-2));
        let good = check(&c(pair(0.80, (2.0, 0.1), (2.0, 0.2))));
        assert!(
            good.contains("1 of 1") && good.ends_with("below jamming."),
            "{good}"
        );
        let mixed = check(&c(vec![
            at(0.80, "all", hi, 2.0, 0.1),
            at(0.80, "local", lo, 2.0, 0.2),
            at(0.82, "all", hi, 1.3, 0.05),
            at(0.82, "local", lo, 1.9, 0.1),
            at(0.82, "local", top, 1.1, 0.05),
            at(0.84, "all", hi, 1.08, 0.06),
            at(0.84, "local", lo, 1.08, 0.15),
            at(0.84, "local", mid, 0.76, 0.1),
            at(0.76, "all", hi, 1.64, 0.08),
            at(0.76, "local", lo, 1.64, 0.28),
        ]));
        assert!(mixed.contains("1 of 4"), "{mixed}");
        assert!(
            mixed.contains("leave the hard-core limit): φ = 0.82"),
            "{mixed}"
        );
        assert!(
            mixed.contains("outside the claim") && mixed.contains("φ = 0.84, Q = 1 (slope 1.08"),
            "{mixed}"
        );
        assert!(
            mixed.contains("cannot tell") && mixed.contains("φ = 0.76"),
            "{mixed}"
        );
        assert!(mixed.ends_with("below jamming."), "{mixed}");
        // Newtonian at the lowest rates far below jamming: against the claim.
        let against = check(&c(pair(0.78, (1.0, 0.05), (1.0, 0.05))));
        assert!(
            against.contains("against the claim: φ = 0.78") && against.ends_with("Does not hold."),
            "{against}"
        );
        // A yield pressure at this size (slope 0.2 ± 0.1 at the lowest rates) below the
        // paper's φ_J: jammed at this size, outside the claim.
        let jammed = check(&c(pair(0.83, (0.3, 0.05), (0.2, 0.1))));
        assert!(
            jammed.contains("outside the claim") && jammed.ends_with("below jamming."),
            "{jammed}"
        );
        // A decided slope above Bagnold's (2.8 ± 0.1) is against the claim too.
        let steep = check(&c(pair(0.78, (2.8, 0.1), (2.8, 0.1))));
        assert!(steep.contains("against the claim: φ = 0.78"), "{steep}");
        assert!(check(&c(Vec::new())).contains("not made"));
    }
}
