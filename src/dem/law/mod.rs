//! Contact laws: the physics of one contact, in one place.
//!
//! A [`ContactLaw`] is one choice from each of four small closed enums, as LAMMPS's
//! granular pair style picks one normal, damping, tangential and rolling sub-model:
//!
//! | enum | variants | equations |
//! | --- | --- | --- |
//! | [`Normal`] | `Linear`, `PowerLaw`, `RelativePowerLaw` | li Eq. 4; vågberg Eq. 1 (α = 2, 5/2) |
//! | [`Damping`] | `None`, `ViscousNormal`, `Cd`, `CdRot`, `CdNormal` | vågberg Eqs. 3, 5–6; CDn (Sec. II) |
//! | [`Tangential`] | `None`, `CundallStrack` | li Eq. 7 |
//! | [`ContactPoint`] | `Midway`, `RadiusRatio` | li Eq. 8; vågberg Eq. 7 |
//!
//! [`ContactLaw::pair`] is **the scalar reference** for a grain–grain contact and
//! [`ContactLaw::wall`] for a grain against a flat body (the pillar's bars). Every
//! scenario calls them; the vector kernels in the backends say which laws they
//! implement ([`ContactLaw::is_linear_cundall_strack`],
//! [`ContactLaw::is_harmonic_vagberg`]) and must give the reference's numbers bit for
//! bit, which the backends' tests check. Any other law runs the reference.
//!
//! Sign conventions: `d = r_i − r_j` (minimum image), `n̂ = d/|d|` points from j to i,
//! `t̂ = ẑ × n̂`; the returned force acts on i (j receives its negative); overlap
//! δ = R_i + R_j − |d| > 0 in contact; relative velocities are i's minus j's.
//!
//! # Adding a law
//! Add a variant to the enum it belongs to with its equation and units in the doc
//! comment, its arm in `pair`/`wall` (and `energy`, `validate`), a closed-form test in
//! `law/tests.rs`, and its name where options are parsed (`NormalLawName` for the
//! pillar). Nothing else changes: kernels that do not implement it are bypassed.
//! A law that needs more per-contact history than one number raises
//! [`ContactLaw::history_width`].

mod substrate;
#[cfg(test)]
mod tests;

pub use substrate::{SubstrateFriction, pick};

/// Elastic normal force magnitude of an overlap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normal {
    /// F = k_n δ (li-granular-pillars Eq. 4): k_n in N/m, δ in m.
    Linear { k_n: f64 },
    /// F = k δ^(α−1) (vågberg-sheared-disks Eq. 1's exponent on an absolute overlap):
    /// k in N/m^(α−1), δ in m; α = 5/2 is Hertzian.
    PowerLaw { k: f64, alpha: f64 },
    /// F = (k_e/d_ij) (δ/d_ij)^(α−1) with d_ij = R_i + R_j (vågberg-sheared-disks
    /// Eq. 2, from the potential of Eq. 1), in units where k_e = 1.
    RelativePowerLaw { alpha: f64 },
}

/// Dissipation in a contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Damping {
    None,
    /// −γ_n v_n along n̂, added to the elastic force before it is clipped at zero so a
    /// separating contact never pulls (γ_n in kg/s).
    ViscousNormal {
        gamma_n: f64,
    },
    /// CD: f_dis = −k_d (v_i − v_j), the whole relative velocity of the centres
    /// (vågberg-sheared-disks Eq. 3); no torque from it on a central force.
    Cd {
        k_d: f64,
    },
    /// CDrot: f_dis = −k_d Δv at the contact point (Eqs. 5–6), torques s × f_dis
    /// (Eq. 7).
    CdRot {
        k_d: f64,
    },
    /// CDn: f_dis = −k_d ((v_i − v_j) · n̂) n̂, the normal part of CD's force only
    /// (vågberg-sheared-disks Sec. II: k_d^(n) = k_d, k_d^(t) = 0, "CDn"), central, so
    /// no torque; not clipped, as CD's is not.
    CdNormal {
        k_d: f64,
    },
}

/// Force along t̂ from the contact's history.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Tangential {
    None,
    /// Cundall–Strack spring with Coulomb truncation (li-granular-pillars Eq. 7,
    /// following Silbert et al.): F_t = −k_t u_t with |F_t| ≤ μ F_n, u_t the stored
    /// shear displacement (m, a scalar along t̂ in 2D); k_t in N/m.
    CundallStrack {
        k_t: f64,
        mu: f64,
    },
}

/// Where on the centre line a grain–grain contact acts (the lever arms of the
/// torques and of the contact-point velocities).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactPoint {
    /// ½|d| from each centre (li-granular-pillars Eq. 8), so the tangential spring
    /// does no spurious work on a rigidly rotating pair.
    Midway,
    /// Dividing the centre line in the ratio of the radii: s_i = R_i |d|/d_ij from i
    /// (vågberg-sheared-disks Eq. 7).
    RadiusRatio,
}

/// One contact law: a choice from each enum. Its parts are private: a law is made by
/// [`ContactLaw::new`], which validates it, so no kernel meets a negative stiffness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactLaw {
    normal: Normal,
    damping: Damping,
    tangential: Tangential,
    point: ContactPoint,
}

/// Relative motion of a pair: v_i − v_j (m/s; under Lees–Edwards with the image's
/// flow velocity) and both spins (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    pub dvx: f64,
    pub dvy: f64,
    pub w_i: f64,
    pub w_j: f64,
}

/// What a touching contact exerts: the force on i (N; j gets −f), the torque on each
/// grain (N m), and for records and virials the unit normal n̂, the magnitudes
/// F_n ≥ 0 and F_t (signed along t̂), and the vector damping force `dis` (CD, CDrot;
/// included in f, zero for the other laws).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PairForce {
    pub fx: f64,
    pub fy: f64,
    pub t_i: f64,
    pub t_j: f64,
    pub n: (f64, f64),
    pub f_n: f64,
    pub f_t: f64,
    pub dis: (f64, f64),
}

impl ContactLaw {
    /// The law, checked once: stiffnesses positive, exponents in (1, 4], damping and
    /// friction non-negative, everything finite.
    pub fn new(
        normal: Normal,
        damping: Damping,
        tangential: Tangential,
        point: ContactPoint,
    ) -> Result<Self, String> {
        let law = ContactLaw {
            normal,
            damping,
            tangential,
            point,
        };
        law.validate()?;
        Ok(law)
    }

    /// A law rebuilt inside a kernel from the constants of one that [`ContactLaw::new`]
    /// validated (so that its choices fold away); the kernel asserts equality in debug
    /// builds.
    pub(crate) const fn rebuilt(
        normal: Normal,
        damping: Damping,
        tangential: Tangential,
        point: ContactPoint,
    ) -> Self {
        ContactLaw {
            normal,
            damping,
            tangential,
            point,
        }
    }

    pub fn normal(&self) -> Normal {
        self.normal
    }
    pub fn damping(&self) -> Damping {
        self.damping
    }
    pub fn tangential(&self) -> Tangential {
        self.tangential
    }
    pub fn point(&self) -> ContactPoint {
        self.point
    }

    /// The law with the Coulomb coefficient of its tangential spring set to `mu`
    /// (validated; a law without a spring is returned as it is).
    pub fn with_friction(mut self, mu: f64) -> Result<Self, String> {
        if let Tangential::CundallStrack { k_t, .. } = self.tangential {
            self.tangential = Tangential::CundallStrack { k_t, mu };
        }
        self.validate()?;
        Ok(self)
    }

    fn validate(&self) -> Result<(), String> {
        let positive = |k: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{k} must be positive and finite, got {v}"))
            }
        };
        let non_negative = |k: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{k} must be ≥ 0 and finite, got {v}"))
            }
        };
        let exponent = |a: f64| {
            if a.is_finite() && a > 1.0 && a <= 4.0 {
                Ok(())
            } else {
                Err(format!("the exponent alpha must be in (1, 4], got {a}"))
            }
        };
        match self.normal {
            Normal::Linear { k_n } => positive("k_n", k_n)?,
            Normal::PowerLaw { k, alpha } => {
                positive("the power-law stiffness k", k)?;
                exponent(alpha)?
            }
            Normal::RelativePowerLaw { alpha } => exponent(alpha)?,
        }
        match self.damping {
            Damping::None => {}
            Damping::ViscousNormal { gamma_n } => non_negative("gamma_n", gamma_n)?,
            Damping::Cd { k_d } | Damping::CdRot { k_d } | Damping::CdNormal { k_d } => {
                non_negative("k_d", k_d)?
            }
        }
        if let Tangential::CundallStrack { k_t, mu } = self.tangential {
            positive("k_t", k_t)?;
            non_negative("mu", mu)?;
        }
        Ok(())
    }

    /// Numbers of history each contact keeps (the tangential spring: 1, else 0).
    pub fn history_width(&self) -> usize {
        match self.tangential {
            Tangential::None => 0,
            Tangential::CundallStrack { .. } => 1,
        }
    }

    /// The law with every stiffness multiplied by `factor` (the pillar's bars are
    /// grains of infinite radius with twice the stiffnesses, li Sec. II.B.2).
    pub fn stiffer(mut self, factor: f64) -> Self {
        self.normal = match self.normal {
            Normal::Linear { k_n } => Normal::Linear { k_n: factor * k_n },
            Normal::PowerLaw { k, alpha } => Normal::PowerLaw {
                k: factor * k,
                alpha,
            },
            n @ Normal::RelativePowerLaw { .. } => n,
        };
        if let Tangential::CundallStrack { k_t, mu } = self.tangential {
            self.tangential = Tangential::CundallStrack {
                k_t: factor * k_t,
                mu,
            };
        }
        self
    }

    /// Whether this is the pillar's law (linear spring, viscous normal damping,
    /// Cundall–Strack, midway contact point), the one its AVX2 kernel implements;
    /// returns (k_n, γ_n, k_t, μ).
    pub fn is_linear_cundall_strack(&self) -> Option<(f64, f64, f64, f64)> {
        match *self {
            ContactLaw {
                normal: Normal::Linear { k_n },
                damping: Damping::ViscousNormal { gamma_n },
                tangential: Tangential::CundallStrack { k_t, mu },
                point: ContactPoint::Midway,
            } => Some((k_n, gamma_n, k_t, mu)),
            _ => None,
        }
    }

    /// Whether this is the sheared disks' harmonic law (α = 2, CD or CDrot,
    /// frictionless, radius-ratio contact point), the one their vector kernels
    /// implement; returns (k_d, CDrot).
    pub fn is_harmonic_vagberg(&self) -> Option<(f64, bool)> {
        match *self {
            ContactLaw {
                normal: Normal::RelativePowerLaw { alpha: 2.0 },
                damping,
                tangential: Tangential::None,
                point: ContactPoint::RadiusRatio,
            } => match damping {
                Damping::Cd { k_d } => Some((k_d, false)),
                Damping::CdRot { k_d } => Some((k_d, true)),
                _ => None,
            },
            _ => None,
        }
    }

    /// Elastic magnitude for centre distance `dist` and contact distance
    /// `rs` = R_i + R_j (m), 0 < dist < rs, `inv_rs` = 1/rs.
    #[inline(always)]
    fn elastic(&self, dist: f64, rs: f64, inv_rs: f64) -> f64 {
        match self.normal {
            Normal::Linear { k_n } => k_n * (rs - dist),
            Normal::PowerLaw { k, alpha } => {
                let delta = rs - dist;
                if alpha == 2.5 {
                    k * (delta * delta.sqrt())
                } else {
                    k * delta.powf(alpha - 1.0)
                }
            }
            Normal::RelativePowerLaw { alpha } => {
                let overlap = 1.0 - dist * inv_rs;
                if alpha == 2.0 {
                    overlap * inv_rs
                } else {
                    overlap.powf(alpha - 1.0) * inv_rs
                }
            }
        }
    }

    /// Elastic energy stored at centre distance `dist` with contact distance `rs` (J;
    /// the integral of the elastic force from contact, Eq. 1 for the relative law).
    pub fn energy(&self, dist: f64, rs: f64) -> f64 {
        if dist >= rs {
            return 0.0;
        }
        let delta = rs - dist;
        match self.normal {
            Normal::Linear { k_n } => 0.5 * k_n * delta * delta,
            Normal::PowerLaw { k, alpha } => k * delta.powf(alpha) / alpha,
            Normal::RelativePowerLaw { alpha } => (delta / rs).powf(alpha) / alpha,
        }
    }

    /// F_n from the elastic force and the normal relative velocity `vn` (negative
    /// approaching) for the scalar damping laws, clipped at zero.
    #[inline(always)]
    fn normal_magnitude(&self, elastic: f64, vn: f64) -> f64 {
        match self.damping {
            Damping::ViscousNormal { gamma_n } => {
                let f = elastic - gamma_n * vn;
                if f > 0.0 { f } else { 0.0 }
            }
            _ => elastic,
        }
    }

    /// Advance the tangential spring `spring` (m) by the slip velocity `vt` (m/s) over
    /// `dt` (s) under normal force `f_n` (N); returns F_t along t̂ (N).
    #[inline(always)]
    fn tangential_force(&self, spring: &mut f64, vt: f64, dt: f64, f_n: f64) -> f64 {
        match self.tangential {
            Tangential::None => 0.0,
            Tangential::CundallStrack { k_t, mu } => {
                let mut u = *spring + vt * dt;
                if k_t * u.abs() > mu * f_n {
                    // Held at the Coulomb limit μ F_n/k_t, written F_n (μ/k_t): one
                    // multiplication, as the vector kernels do it.
                    u = (f_n * (mu / k_t)).copysign(u);
                }
                *spring = u;
                -k_t * u
            }
        }
    }

    /// **The scalar reference** for grains i and j: `d` = r_i − r_j (m, minimum
    /// image), radii `r_i`, `r_j` (m), relative motion `m`, the contact's tangential
    /// spring `spring` (m; reset to 0 when apart), time step `dt` (s). `None` when
    /// apart (|d| ≥ R_i + R_j; a NaN distance counts as touching, so it shows).
    #[inline(always)]
    pub fn pair(
        &self,
        d: (f64, f64),
        radii: (f64, f64),
        m: Motion,
        spring: &mut f64,
        dt: f64,
    ) -> Option<PairForce> {
        let rs = radii.0 + radii.1;
        if d.0 * d.0 + d.1 * d.1 >= rs * rs {
            *spring = 0.0;
            return None;
        }
        Some(self.in_contact(d, radii, 1.0 / rs, m, spring, dt))
    }

    /// [`ContactLaw::pair`] for a pair known to touch, given 1/(R_i + R_j) (1/m):
    /// for contact lists that test and store both ahead (same numbers).
    #[inline(always)]
    pub fn in_contact(
        &self,
        (dx, dy): (f64, f64),
        (r_i, r_j): (f64, f64),
        inv_rs: f64,
        m: Motion,
        spring: &mut f64,
        dt: f64,
    ) -> PairForce {
        let rs = r_i + r_j;
        let dist = (dx * dx + dy * dy).sqrt();
        // One division for both components (the vector kernels' divider is their
        // bottleneck); within an ulp of dx / dist.
        let inv_dist = 1.0 / dist;
        let (nx, ny) = (dx * inv_dist, dy * inv_dist);
        let (mut dvx, mut dvy) = (m.dvx, m.dvy);
        let elastic = self.elastic(dist, rs, inv_rs);
        let f_n = self.normal_magnitude(elastic, dvx * nx + dvy * ny);
        let mut out = PairForce {
            f_n,
            n: (nx, ny),
            ..PairForce::default()
        };
        // Lever arms (m) of the contact point from i and from j.
        let (arm_i, arm_j) = match self.point {
            ContactPoint::Midway => (0.5 * dist, 0.5 * dist),
            ContactPoint::RadiusRatio => (r_i * inv_rs * dist, r_j * inv_rs * dist),
        };
        match self.tangential {
            Tangential::None => {
                (out.fx, out.fy) = (f_n * nx, f_n * ny);
            }
            Tangential::CundallStrack { .. } => {
                let vt = match self.point {
                    ContactPoint::Midway => dvy * nx - dvx * ny - 0.5 * dist * (m.w_i + m.w_j),
                    ContactPoint::RadiusRatio => {
                        dvy * nx - dvx * ny - (arm_i * m.w_i + arm_j * m.w_j)
                    }
                };
                let f_t = self.tangential_force(spring, vt, dt, f_n);
                out.f_t = f_t;
                out.fx = f_n * nx - f_t * ny;
                out.fy = f_n * ny + f_t * nx;
                (out.t_i, out.t_j) = match self.point {
                    ContactPoint::Midway => {
                        let t = -0.5 * dist * f_t;
                        (t, t)
                    }
                    ContactPoint::RadiusRatio => (-arm_i * f_t, -arm_j * f_t),
                };
            }
        }
        if let Damping::CdNormal { k_d } = self.damping {
            // Along n̂ only: no torque about either centre.
            let vn = dvx * nx + dvy * ny;
            let (ddx, ddy) = (-k_d * vn * nx, -k_d * vn * ny);
            out.dis = (ddx, ddy);
            out.fx += ddx;
            out.fy += ddy;
        }
        if let Damping::Cd { k_d } | Damping::CdRot { k_d } = self.damping {
            // Moment arms s_ji (i to the contact) = −d R_i/d_ij, s_ij = d R_j/d_ij
            // (vågberg Eq. 7 with d_ij = R_i + R_j).
            let (si, sj) = (r_i * inv_rs, r_j * inv_rs);
            let (six, siy, sjx, sjy) = (-dx * si, -dy * si, dx * sj, dy * sj);
            if matches!(self.damping, Damping::CdRot { .. }) {
                // v_i + ω_i ẑ×s_ji − (v_j + ω_j ẑ×s_ij), Eq. 6.
                dvx += -m.w_i * siy + m.w_j * sjy;
                dvy += m.w_i * six - m.w_j * sjx;
            }
            let (ddx, ddy) = (-k_d * dvx, -k_d * dvy);
            out.dis = (ddx, ddy);
            out.fx += ddx;
            out.fy += ddy;
            // Eq. 7: torques of the dissipative force about each centre.
            let (ti, tj) = (six * ddy - siy * ddx, sjx * (-ddy) - sjy * (-ddx));
            if matches!(self.tangential, Tangential::None) {
                (out.t_i, out.t_j) = (ti, tj);
            } else {
                out.t_i += ti;
                out.t_j += tj;
            }
        }
        out
    }

    /// The reference for grain i against a flat body (a wall or the pillar's bars,
    /// grains of infinite radius): `gap` (m) from i's centre to the face along the
    /// face's normal `(nx, ny)` (pointing into the grain), radius `r` (m), velocity
    /// of the grain relative to the face (m/s) and spin `w` (rad/s), the contact's
    /// tangential spring (m), `dt` (s). The contact point is on the face, lever arm
    /// `gap`; returns the force on the grain and its torque in `t_i`.
    #[inline(always)]
    pub fn wall(
        &self,
        gap: f64,
        (nx, ny): (f64, f64),
        r: f64,
        (dvx, dvy, w): (f64, f64, f64),
        spring: &mut f64,
        dt: f64,
    ) -> Option<PairForce> {
        let delta = r - gap;
        if delta <= 0.0 {
            *spring = 0.0;
            return None;
        }
        let elastic = match self.normal {
            Normal::Linear { k_n } => k_n * delta,
            Normal::PowerLaw { .. } | Normal::RelativePowerLaw { .. } => {
                // As a pair with the same overlap: centre distance r − δ to a
                // partner of radius 0 stands for the flat body.
                self.elastic(gap, r, 1.0 / r)
            }
        };
        let f_n = self.normal_magnitude(elastic, dvx * nx + dvy * ny);
        // t̂ = ẑ × n̂ = (−n_y, n_x).
        let (tx, ty) = (-ny, nx);
        let vt = dvx * tx + dvy * ty - gap * w;
        let f_t = self.tangential_force(spring, vt, dt, f_n);
        Some(PairForce {
            fx: f_n * nx + f_t * tx,
            fy: f_n * ny + f_t * ty,
            t_i: -gap * f_t,
            t_j: 0.0,
            n: (nx, ny),
            f_n,
            f_t,
            dis: (0.0, 0.0),
        })
    }
}
