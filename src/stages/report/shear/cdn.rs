//! The CDn reference check (vagberg-sheared-disks Sec. II): with dissipation from the
//! normal velocity difference only, the model "is well known to have Bagnoldian
//! rheology, with stress ∼ γ̇², for all values of φ and Q" — below jamming. A sweep of
//! model CDn states, for each (φ, Q) classified over all its rates, whether it is
//! Bagnoldian, and for those that are not, what they are instead: a pressure that
//! barely moves with γ̇ (slope < 1/2) is a yield stress, the system jammed at its size
//! (φ_J ≈ 0.8433 for large systems; a small system's jamming point lies lower and
//! spreads by about N^(-1/2)), which is outside the claim.

use super::Classification;
use super::classify::Class;

/// The check's sentence, from the classification's `all` slopes.
pub fn check(c: &Classification) -> String {
    let all: Vec<_> = c.slopes.iter().filter(|s| s.scope == "all").collect();
    if all.is_empty() {
        return "CDn reference (Sec. II: Bagnoldian at every φ below jamming and every Q): not made, no (φ, Q) has two rates.".into();
    }
    let bagnold: Vec<_> = all
        .iter()
        .filter(|s| s.slope.class == Class::Bagnoldian)
        .collect();
    let jammed: Vec<_> = all
        .iter()
        .filter(|s| s.slope.slope + super::classify::SIGMAS * s.slope.err < 0.5)
        .collect();
    let other: Vec<_> = all
        .iter()
        .filter(|s| {
            s.slope.class != Class::Bagnoldian
                && s.slope.slope + super::classify::SIGMAS * s.slope.err >= 0.5
        })
        .collect();
    let list = |v: &[&&super::Classified]| {
        v.iter()
            .map(|s| {
                format!(
                    "φ = {}, Q = {} (slope {:.2} ± {:.2})",
                    s.phi, s.q, s.slope.slope, s.slope.err
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    let mut text = format!(
        "Check — CDn is Bagnoldian below jamming at every φ and Q (vagberg-sheared-disks Sec. II): {} of {} (φ, Q) Bagnoldian over all their rates",
        bagnold.len(),
        all.len()
    );
    if !jammed.is_empty() {
        text += &format!(
            "; jammed at this size, a yield stress (slope below 1/2, outside the claim): {}",
            list(&jammed)
        );
    }
    if !other.is_empty() {
        text += &format!("; neither, or the data cannot tell: {}", list(&other));
    }
    text += if other.is_empty() {
        ". Holds below jamming."
    } else {
        ". Does not hold at every unjammed point: lower rates (the Bagnoldian limit is γ̇ → 0; near φ_J it is reached only below a crossover rate) or longer runs would tell."
    };
    text
}

#[cfg(test)]
mod tests {
    use super::super::classify::{Slope, class_of};
    use super::super::{Classification, Classified};
    use super::*;

    fn at(phi: f64, q: f64, slope: f64, err: f64) -> Classified {
        let (class, note) = class_of(slope, err);
        Classified {
            phi,
            q,
            scope: "all",
            slope: Slope {
                slope,
                err,
                rate_lo: 1e-5,
                rate_hi: 1e-3,
                class,
                note,
            },
        }
    }

    #[test]
    fn jammed_points_are_named_apart_from_failures() {
        let c = |s: Vec<Classified>| Classification {
            slopes: s,
            transitions: Vec::new(),
        };
        let good = check(&c(vec![at(0.80, 1.0, 2.0, 0.1), at(0.82, 1.0, 1.9, 0.1)]));
        assert!(
            good.contains("2 of 2") && good.ends_with("Holds below jamming."),
            "{good}"
        );
        let jam = check(&c(vec![at(0.80, 1.0, 2.0, 0.1), at(0.84, 1.0, 0.1, 0.1)]));
        assert!(
            jam.contains("1 of 2")
                && jam.contains("jammed at this size")
                && jam.contains("φ = 0.84"),
            "{jam}"
        );
        assert!(jam.ends_with("Holds below jamming."), "{jam}");
        let bad = check(&c(vec![at(0.80, 1.0, 1.0, 0.05)]));
        assert!(
            bad.contains("neither") && bad.contains("Does not hold"),
            "{bad}"
        );
        assert!(check(&c(Vec::new())).contains("not made"));
    }
}
