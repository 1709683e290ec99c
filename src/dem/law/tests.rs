//! Every law against hand-computed values of its equation, and the conservation laws
//! any pair law must keep.

use super::*;

fn vagberg(alpha: f64, damping: Damping) -> ContactLaw {
    ContactLaw::new(
        Normal::RelativePowerLaw { alpha },
        damping,
        Tangential::None,
        ContactPoint::RadiusRatio,
    )
    .unwrap()
}

fn still() -> Motion {
    Motion {
        dvx: 0.0,
        dvy: 0.0,
        w_i: 0.0,
        w_j: 0.0,
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-300)
}

/// Disks of radii 0.5 and 0.7 (d_ij = 1.2) with centres 1.1 apart along x, i to the
/// right: overlap δ/d_ij = 1/12, n̂ = +x̂.
const D: (f64, f64) = (1.1, 0.0);
const R: (f64, f64) = (0.5, 0.7);

#[test]
fn vagberg_eq2_elastic_force_for_alpha_2_and_5_2() {
    let mut h = 0.0;
    let harmonic = vagberg(2.0, Damping::Cd { k_d: 0.0 });
    let c = harmonic.pair(D, R, still(), &mut h, 0.0).unwrap();
    // (k_e/d_ij)(1 − r/d_ij)^(α−1) = (1/1.2)(1/12).
    let want = 1.0 / 1.2 / 12.0;
    assert!(close(c.fx, want, 1e-15) && c.fy == 0.0, "{c:?}");
    assert!(close(c.f_n, want, 1e-15));
    let hertz = vagberg(2.5, Damping::Cd { k_d: 0.0 });
    let c = hertz.pair(D, R, still(), &mut h, 0.0).unwrap();
    let want = (1.0f64 / 12.0).powf(1.5) / 1.2;
    assert!(close(c.fx, want, 1e-14), "{c:?} vs {want}");
    // Apart: nothing.
    assert!(harmonic.pair((1.2, 0.0), R, still(), &mut h, 0.0).is_none());
    assert!(harmonic.pair((0.0, 1.3), R, still(), &mut h, 0.0).is_none());
}

#[test]
fn vagberg_eq3_cd_damps_the_centres_relative_velocity() {
    let mut h = 0.0;
    let law = vagberg(2.0, Damping::Cd { k_d: 0.5 });
    let m = Motion {
        dvx: 0.3,
        dvy: -0.2,
        w_i: 0.4,
        w_j: -0.1,
    };
    let c = law.pair(D, R, m, &mut h, 0.0).unwrap();
    // f = f_el n̂ − k_d (v_i − v_j); spins play no part in CD.
    let el = 1.0 / 1.2 / 12.0;
    assert!(close(c.fx, el - 0.15, 1e-14), "{c:?}");
    assert!(close(c.fy, 0.1, 1e-14), "{c:?}");
    assert!(close(c.dis.0, -0.15, 1e-15) && close(c.dis.1, 0.1, 1e-15));
}

/// CDn: only the normal part of v_i − v_j is damped, so a pair sliding past each other
/// feels no dissipative force and no torque; one approaching feels −k_d v_n n̂.
#[test]
fn cdn_damps_only_the_normal_relative_velocity() {
    let mut h = 0.0;
    let law = vagberg(2.0, Damping::CdNormal { k_d: 0.5 });
    let m = Motion {
        dvx: 0.3,
        dvy: -0.2,
        w_i: 0.4,
        w_j: -0.1,
    };
    let c = law.pair(D, R, m, &mut h, 0.0).unwrap();
    // n̂ = x̂: v_n = 0.3, f_dis = (−0.15, 0); the tangential −0.2 and the spins do nothing.
    let el = 1.0 / 1.2 / 12.0;
    assert!(close(c.fx, el - 0.15, 1e-14), "{c:?}");
    assert_eq!((c.fy, c.t_i, c.t_j), (0.0, 0.0, 0.0), "{c:?}");
    assert_eq!(c.dis, (-0.15, 0.0));
    // Along a diagonal normal the force stays along n̂.
    let d = (0.8, 0.6);
    let c = law.pair(d, R, m, &mut h, 0.0).unwrap();
    let vn = 0.3 * 0.8 - 0.2 * 0.6;
    assert!(close(c.dis.0, -0.5 * vn * 0.8, 1e-14) && close(c.dis.1, -0.5 * vn * 0.6, 1e-14));
    assert!(
        ContactLaw::new(
            Normal::RelativePowerLaw { alpha: 2.0 },
            Damping::CdNormal { k_d: -1.0 },
            Tangential::None,
            ContactPoint::RadiusRatio
        )
        .is_err()
    );
}

#[test]
fn vagberg_eqs5_to_7_cdrot_contact_point_velocity_and_torques() {
    let mut h = 0.0;
    let law = vagberg(2.0, Damping::CdRot { k_d: 0.5 });
    let (w_i, w_j) = (0.4, -0.1);
    let m = Motion {
        dvx: 0.3,
        dvy: -0.2,
        w_i,
        w_j,
    };
    let c = law.pair(D, R, m, &mut h, 0.0).unwrap();
    // Contact point from i: s_ji = −d R_i/d_ij = (−0.458333…, 0); from j:
    // s_ij = d R_j/d_ij = (0.641666…, 0). ẑ × (s_x, 0) = (0, s_x).
    let (s_ji, s_ij) = (-1.1 * 0.5 / 1.2, 1.1 * 0.7 / 1.2);
    let dv = (0.3, -0.2 + w_i * s_ji - w_j * s_ij);
    let f_dis = (-0.5 * dv.0, -0.5 * dv.1);
    let el = 1.0 / 1.2 / 12.0;
    assert!(close(c.fx, el + f_dis.0, 1e-14), "{c:?}");
    assert!(close(c.fy, f_dis.1, 1e-14), "{c:?}");
    // Eq. 7: T_i = (s_ji × f_dis)_z, T_j = (s_ij × (−f_dis))_z.
    assert!(close(c.t_i, s_ji * f_dis.1, 1e-14), "{c:?}");
    assert!(close(c.t_j, -s_ij * f_dis.1, 1e-14), "{c:?}");
    // Numbers written out once, against a slip of sign in the above.
    assert!(close(c.t_i, -0.0731423611111, 1e-9), "{}", c.t_i);
    assert!(close(c.t_j, -0.1023993055556, 1e-9), "{}", c.t_j);
}

fn pillar_law(normal: Normal, gamma_n: f64) -> ContactLaw {
    ContactLaw::new(
        normal,
        Damping::ViscousNormal { gamma_n },
        Tangential::CundallStrack {
            k_t: 300.0,
            mu: 0.2,
        },
        ContactPoint::Midway,
    )
    .unwrap()
}

#[test]
fn li_eq4_linear_spring_with_damping_never_pulls() {
    let law = pillar_law(Normal::Linear { k_n: 1000.0 }, 2.0);
    let mut s = 0.0;
    // δ = 1.2 − 1.1 = 0.1 m; approaching at 0.5 m/s along n̂: k δ + γ 0.5.
    let m = Motion {
        dvx: -0.5,
        ..still()
    };
    let c = law.pair(D, R, m, &mut s, 1e-3).unwrap();
    assert!(
        close(c.f_n, 1000.0 * (1.2 - 1.1) + 2.0 * 0.5, 1e-12),
        "{c:?}"
    );
    // Separating fast enough to pull: clipped to zero.
    let m = Motion {
        dvx: 100.0,
        ..still()
    };
    let c = law.pair(D, R, m, &mut s, 1e-3).unwrap();
    assert_eq!(c.f_n, 0.0);
}

#[test]
fn li_eq7_cundall_strack_spring_and_coulomb_limit() {
    let law = pillar_law(Normal::Linear { k_n: 1000.0 }, 0.0);
    let f_n = 1000.0 * (1.2 - 1.1);
    // Sliding along t̂ = ẑ × x̂ = +ŷ at 0.01 m/s for dt = 1e-3: u = 1e-5, F_t = −k_t u.
    let m = Motion {
        dvy: 0.01,
        ..still()
    };
    let mut s = 0.0;
    let c = law.pair(D, R, m, &mut s, 1e-3).unwrap();
    assert!(
        close(s, 1e-5, 1e-12) && close(c.f_t, -300.0 * 1e-5, 1e-12),
        "{c:?}"
    );
    assert!(close(c.fy, c.f_t, 1e-15) && close(c.fx, f_n, 1e-15));
    // Midway lever arms: T_i = T_j = −½|d| F_t.
    assert!(close(c.t_i, -0.55 * c.f_t, 1e-14) && c.t_i == c.t_j);
    // A stretched spring is held at μ F_n / k_t, keeping its sign.
    let mut s = -1.0;
    let c = law.pair(D, R, m, &mut s, 1e-3).unwrap();
    assert!(close(s, -0.2 * f_n / 300.0, 1e-14), "{s}");
    assert!(close(c.f_t, 0.2 * f_n, 1e-14));
    // Spinning grains slip at the contact point: ω_i = ω_j = ω gives v_t = −|d| ω.
    let m = Motion {
        w_i: 0.01,
        w_j: 0.01,
        ..still()
    };
    let mut s = 0.0;
    law.pair(D, R, m, &mut s, 1e-3).unwrap();
    assert!(close(s, -1.1 * 0.01 * 1e-3, 1e-12), "{s}");
    // Apart: the history is forgotten.
    let mut s = 0.3;
    assert!(law.pair((2.0, 0.0), R, m, &mut s, 1e-3).is_none());
    assert_eq!(s, 0.0);
}

#[test]
fn hertzian_power_law_and_its_energy() {
    let law = pillar_law(Normal::PowerLaw { k: 5e5, alpha: 2.5 }, 0.0);
    let mut s = 0.0;
    let c = law.pair(D, R, still(), &mut s, 1e-3).unwrap();
    assert!(close(c.f_n, 5e5 * 0.1f64.powf(1.5), 1e-13), "{c:?}");
    // Every normal law's force is −dE/dr (finite differences of `energy`).
    for law in [
        law,
        pillar_law(Normal::Linear { k_n: 1000.0 }, 0.0),
        pillar_law(Normal::PowerLaw { k: 7.0, alpha: 3.0 }, 0.0),
        vagberg(2.0, Damping::None),
        vagberg(2.5, Damping::None),
    ] {
        let (dist, rs, h) = (1.1, 1.2, 1e-6);
        let de = (law.energy(dist - h, rs) - law.energy(dist + h, rs)) / (2.0 * h);
        let mut s = 0.0;
        let f = law.pair((dist, 0.0), R, still(), &mut s, 0.0).unwrap().f_n;
        assert!(close(f, de, 1e-6), "{law:?}: F = {f}, −dE/dr = {de}");
        assert_eq!(law.energy(rs + 0.1, rs), 0.0);
    }
}

#[test]
fn wall_contact_is_a_grain_of_infinite_radius() {
    let law = pillar_law(Normal::Linear { k_n: 1000.0 }, 0.0);
    let mut s = 0.0;
    // Grain of radius 0.5 with its centre 0.4 above a floor (n̂ = +ŷ): δ = 0.1.
    // Moving along +x at 0.02 m/s and spinning at ω = 0.1: the contact point
    // (0.4 below the centre) slips at v_x + 0.4 ω along +x, and t̂ = ẑ × ŷ = −x̂.
    let c = law
        .wall(0.4, (0.0, 1.0), 0.5, (0.02, 0.0, 0.1), &mut s, 1e-3)
        .unwrap();
    assert!(close(c.f_n, 100.0, 1e-14) && close(c.fy, 100.0, 1e-14));
    let vt = -(0.02 + 0.4 * 0.1);
    assert!(close(s, vt * 1e-3, 1e-12), "{s}");
    assert!(close(c.fx, -c.f_t, 1e-15) && close(c.t_i, -0.4 * c.f_t, 1e-14));
    // Friction opposes the contact point's slip (+x): the force is along −x.
    assert!(c.fx < 0.0);
    assert!(
        law.wall(0.6, (0.0, 1.0), 0.5, (0.0, 0.0, 0.0), &mut s, 1e-3)
            .is_none()
    );
    assert_eq!(s, 0.0);
}

/// Newton's third law for torques: for any law and configuration, the pair exerts no
/// net torque, d × f + T_i + T_j = 0 (angular momentum is conserved).
#[test]
fn every_law_conserves_angular_momentum() {
    let mut rng = crate::rng::Rng::new(7);
    let normals = [
        Normal::Linear { k_n: 1e3 },
        Normal::PowerLaw { k: 1e4, alpha: 2.5 },
        Normal::RelativePowerLaw { alpha: 2.0 },
    ];
    let dampings = [
        Damping::None,
        Damping::ViscousNormal { gamma_n: 0.3 },
        Damping::Cd { k_d: 0.7 },
        Damping::CdRot { k_d: 0.7 },
        Damping::CdNormal { k_d: 0.7 },
    ];
    let tangentials = [
        Tangential::None,
        Tangential::CundallStrack {
            k_t: 300.0,
            mu: 0.3,
        },
    ];
    let mut checked = 0;
    for normal in normals {
        for damping in dampings {
            for tangential in tangentials {
                for point in [ContactPoint::Midway, ContactPoint::RadiusRatio] {
                    let law = ContactLaw::new(normal, damping, tangential, point).unwrap();
                    for _ in 0..50 {
                        let r = (0.4 + 0.2 * rng.uniform(), 0.4 + 0.3 * rng.uniform());
                        let a = std::f64::consts::TAU * rng.uniform();
                        let dist = (r.0 + r.1) * (0.9 + 0.099 * rng.uniform());
                        let d = (dist * a.cos(), dist * a.sin());
                        let m = Motion {
                            dvx: rng.normal(),
                            dvy: rng.normal(),
                            w_i: rng.normal(),
                            w_j: rng.normal(),
                        };
                        let mut s = 1e-3 * rng.normal();
                        let c = law.pair(d, r, m, &mut s, 1e-3).unwrap();
                        // Moment about j's centre of the force on i, plus both torques.
                        let l = d.0 * c.fy - d.1 * c.fx + c.t_i + c.t_j;
                        let scale = dist * (c.fx.abs() + c.fy.abs()) + c.t_i.abs() + 1e-30;
                        assert!(l.abs() <= 1e-12 * scale, "{law:?}: net torque {l}");
                        checked += 1;
                    }
                }
            }
        }
    }
    assert_eq!(checked, 3 * 5 * 2 * 2 * 50);
}

#[test]
fn laws_are_validated_when_built() {
    let bad = [
        (Normal::Linear { k_n: -1.0 }, "k_n"),
        (Normal::PowerLaw { k: 1.0, alpha: 0.5 }, "alpha"),
        (
            Normal::PowerLaw {
                k: f64::NAN,
                alpha: 2.5,
            },
            "stiffness",
        ),
        (Normal::RelativePowerLaw { alpha: 9.0 }, "alpha"),
    ];
    for (normal, key) in bad {
        let e = ContactLaw::new(
            normal,
            Damping::None,
            Tangential::None,
            ContactPoint::Midway,
        )
        .unwrap_err();
        assert!(e.contains(key), "{e}");
    }
    let e = ContactLaw::new(
        Normal::Linear { k_n: 1.0 },
        Damping::CdRot { k_d: -1.0 },
        Tangential::CundallStrack { k_t: 1.0, mu: 0.1 },
        ContactPoint::Midway,
    )
    .unwrap_err();
    assert!(e.contains("k_d"), "{e}");
    assert_eq!(
        pillar_law(Normal::Linear { k_n: 1.0 }, 0.0).history_width(),
        1
    );
    assert_eq!(vagberg(2.0, Damping::None).history_width(), 0);
}

/// A law is made only through its validating constructor: the bar's friction too.
#[test]
fn friction_set_later_is_validated_too() {
    let law = pillar_law(Normal::Linear { k_n: 1000.0 }, 0.1);
    let bar = law.with_friction(0.5).unwrap();
    assert_eq!(
        bar.tangential(),
        Tangential::CundallStrack {
            k_t: 300.0,
            mu: 0.5
        }
    );
    assert!(law.with_friction(-0.1).is_err());
    assert!(law.with_friction(f64::NAN).is_err());
}
