//! Model parameters of li-granular-pillars Sec. II.C, in SI units, and the presets.

use crate::dem::law::{ContactLaw, ContactPoint, Damping, Normal, Tangential};
use serde::{Deserialize, Serialize};

/// The grain–grain normal law of a pillar run (li-granular-pillars uses `linear`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NormalLawName {
    /// F_n = k_n δ (Eq. 4), the paper's.
    #[default]
    Linear,
    /// F_n = k δ^{3/2} (the power law of vågberg-sheared-disks Eq. 1 with α = 5/2).
    Hertz,
}

impl NormalLawName {
    pub fn is_linear(&self) -> bool {
        *self == NormalLawName::Linear
    }
}

impl std::str::FromStr for NormalLawName {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "linear" => Ok(NormalLawName::Linear),
            "hertz" => Ok(NormalLawName::Hertz),
            _ => Err(format!(
                "unknown normal law '{s}'; expected linear or hertz"
            )),
        }
    }
}

/// Everything that defines a pillar run's physics (SI units throughout).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PillarParams {
    /// Preset this was derived from (`paper`, `fast`, or `custom`).
    pub preset: String,
    /// Large-grain diameter D (m); small grains have d = 3D/4 (Sec. II).
    pub d_large: f64,
    /// Small-grain diameter d (m).
    pub d_small: f64,
    /// Large-grain mass (kg).
    pub m_large: f64,
    /// Small-grain mass (kg).
    pub m_small: f64,
    /// Grain–substrate friction coefficient μ (Sec. II.B.3).
    pub mu: f64,
    /// Grain–grain friction coefficient μ_g (Sec. II.B.1, Coulomb limit of Eq. 7).
    pub mu_g: f64,
    /// Grain–bar friction coefficient (not given in the paper; default μ_g).
    pub mu_bar: f64,
    /// Grain–grain normal stiffness k_n (N/m), Eq. 4. Grain–bar uses 2 k_n (Sec. II.B.2).
    pub k_n: f64,
    /// Tangential stiffness k_t / k_n (2/7, Silbert et al.), Eq. 7.
    pub kt_over_kn: f64,
    /// Normal damping γ_n (kg/s); the paper has none, so 0 by default.
    pub damping_n: f64,
    /// Time step δt (s).
    pub dt: f64,
    /// Grain–grain normal law; grain–bar contacts use the same with twice the
    /// stiffness.
    #[serde(default, skip_serializing_if = "NormalLawName::is_linear")]
    pub normal_law: NormalLawName,
    /// Hertzian stiffness k (N/m^{3/2}) when `normal_law` is `hertz`; 0 takes
    /// [`PillarParams::hertz_k`]'s default.
    #[serde(default)]
    pub k_hertz: f64,
    /// Top-bar speed v_c (m/s).
    pub bar_speed: f64,
    /// Gravitational acceleration g (m/s²).
    pub g: f64,
}

impl PillarParams {
    /// The paper's values (Sec. II and II.C).
    pub fn paper() -> Self {
        PillarParams {
            preset: "paper".into(),
            d_large: 0.635e-2,
            d_small: 0.47625e-2,
            m_large: 0.80e-3,
            m_small: 0.45e-3,
            mu: 0.23,
            mu_g: 0.2,
            mu_bar: 0.2,
            k_n: 1.0e4,
            kt_over_kn: 2.0 / 7.0,
            damping_n: 0.0,
            dt: 1.0e-5,
            normal_law: NormalLawName::Linear,
            k_hertz: 0.0,
            bar_speed: 0.0084667e-2,
            g: 9.81,
        }
    }

    /// Demos and CI: k_n at the low end of the paper's tested range (1 N/mm), δt 4×
    /// larger, bar 10× faster. Eq. 12's ratio 2 k_n v_c δt / (m_s g μ) is 0.067 (paper
    /// preset: 0.017), still far below 1; δt is 1/12 of √(m_s / 2k_n).
    pub fn fast() -> Self {
        PillarParams {
            preset: "fast".into(),
            k_n: 1.0e3,
            dt: 4.0e-5,
            bar_speed: 10.0 * 0.0084667e-2,
            ..Self::paper()
        }
    }

    pub fn preset(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Self::paper()),
            "fast" => Some(Self::fast()),
            _ => None,
        }
    }

    /// Eq. 12's ratio 2 k_n v_c δt / (m_small g μ): must be ≪ 1 for quasistatic loading.
    pub fn quasistatic_ratio(&self) -> f64 {
        2.0 * self.k_n * self.bar_speed * self.dt / (self.m_small * self.g * self.mu)
    }

    /// δt / √(m_small / (2 k_n)): the stiffest contact's oscillation resolution.
    pub fn stiffness_ratio(&self) -> f64 {
        self.dt / (self.m_small / (2.0 * self.k_n)).sqrt()
    }

    /// The Hertzian stiffness in use (N/m^{3/2}): `k_hertz`, or by default the one
    /// that gives the linear law's force at the overlap δ_u = m g μ / k_n where the
    /// linear spring carries the force unit, k = k_n/√δ_u. The two laws then agree
    /// where the pillar's contact forces live; above it the Hertzian contact stiffens
    /// as F^{1/3}.
    pub fn hertz_k(&self) -> f64 {
        if self.k_hertz > 0.0 {
            return self.k_hertz;
        }
        self.k_n / (self.force_unit() / self.k_n).sqrt()
    }

    /// The grain–grain contact law: `normal_law`, viscous normal damping γ_n,
    /// Cundall–Strack friction μ_g with k_t = (k_t/k_n) k_n, lever arms ½|r_ij|
    /// (Eqs. 4, 7, 8).
    pub fn grain_law(&self) -> Result<ContactLaw, String> {
        let normal = match self.normal_law {
            NormalLawName::Linear => Normal::Linear { k_n: self.k_n },
            NormalLawName::Hertz => Normal::PowerLaw {
                k: self.hertz_k(),
                alpha: 2.5,
            },
        };
        ContactLaw::new(
            normal,
            Damping::ViscousNormal {
                gamma_n: self.damping_n,
            },
            Tangential::CundallStrack {
                k_t: self.kt_over_kn * self.k_n,
                mu: self.mu_g,
            },
            ContactPoint::Midway,
        )
    }

    /// The grain–bar law: the grains' with twice the stiffnesses (bars are grains of
    /// infinite radius, Sec. II.B.2) and the bar's friction μ_bar.
    pub fn bar_law(&self) -> Result<ContactLaw, String> {
        self.grain_law()?.stiffer(2.0).with_friction(self.mu_bar)
    }

    /// The paper's force unit m g μ with m the large-grain mass (N).
    pub fn force_unit(&self) -> f64 {
        self.m_large * self.g * self.mu
    }

    /// The paper's stress unit m g μ / D (N/m).
    pub fn stress_unit(&self) -> f64 {
        self.force_unit() / self.d_large
    }

    /// Check that the parameters can run: positive, finite, stable.
    pub fn validate(&self) -> Result<(), String> {
        let pos = [
            ("d_large", self.d_large),
            ("d_small", self.d_small),
            ("m_large", self.m_large),
            ("m_small", self.m_small),
            ("k_n", self.k_n),
            ("dt", self.dt),
            ("g", self.g),
        ];
        for (k, v) in pos {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{k} must be positive and finite, got {v}"));
            }
        }
        for (k, v) in [
            ("mu", self.mu),
            ("mu_g", self.mu_g),
            ("mu_bar", self.mu_bar),
            ("kt_over_kn", self.kt_over_kn),
            ("damping_n", self.damping_n),
            ("bar_speed", self.bar_speed),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{k} must be ≥ 0 and finite, got {v}"));
            }
        }
        if !(self.k_hertz.is_finite() && self.k_hertz >= 0.0) {
            return Err(format!(
                "k_hertz must be ≥ 0 and finite (0: the default), got {}",
                self.k_hertz
            ));
        }
        self.bar_law()?;
        if self.stiffness_ratio() > 0.2 {
            return Err(format!(
                "dt = {} s is too large for k_n = {} N/m: dt/√(m_s/2k_n) = {:.3} (> 0.2, unstable)",
                self.dt,
                self.k_n,
                self.stiffness_ratio()
            ));
        }
        Ok(())
    }
}
