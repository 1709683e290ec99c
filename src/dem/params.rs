//! Model parameters of li-granular-pillars Sec. II.C, in SI units, and the presets.

use serde::{Deserialize, Serialize};

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
