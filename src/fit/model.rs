//! The crossover law of Li et al., Eq. 19: D²min/R² = 4Θη − 4Θη_c (1 − e^{−η/η_c}),
//! ballistic (2Θη²/η_c) below η_c and diffusive (4Θη) above it.

/// x − (1 − e^{−x}), accurate for small x (where the difference cancels).
#[inline]
pub fn crossover_shape(x: f64) -> f64 {
    if x < 1e-3 {
        x * x * (0.5 - x * (1.0 / 6.0 - x / 24.0))
    } else {
        x + (-x).exp_m1()
    }
}

/// Eq. 19: the predicted D²min/R² (dimensionless) at deviatoric strain `eta` for
/// temperature-like Θ `theta` and crossover strain `eta_c`.
#[inline]
pub fn d2min_over_r2(eta: f64, theta: f64, eta_c: f64) -> f64 {
    4.0 * theta * eta_c * crossover_shape(eta / eta_c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_of_eq19() {
        let (th, ec) = (0.3, 0.05);
        // ballistic: 2Θη²/η_c
        let e = 1e-5;
        let b = d2min_over_r2(e, th, ec);
        assert!((b / (2.0 * th * e * e / ec) - 1.0).abs() < 1e-3);
        // diffusive: 4Θ(η − η_c)
        let e = 5.0;
        assert!((d2min_over_r2(e, th, ec) / (4.0 * th * (e - ec)) - 1.0).abs() < 1e-12);
        // series branch joins the direct formula continuously
        let x: f64 = 1e-3;
        let direct = x - (1.0 - (-x).exp());
        assert!((crossover_shape(x) / direct - 1.0).abs() < 1e-8);
    }
}
