//! The stress–strain definitions of li-granular-pillars Sec. III, shared by the
//! simulator's `stress_strain` table and `ingest-force` (a force sensor's bar forces), so
//! that a measured curve and a simulated one are computed the same way (Fig. 4a, 4b).
//! SI units: lengths in m, forces in N, stress (2D: force per length) in N/m.

/// The band below the top bar, in large-grain diameters D, whose grains give the
/// pillar width W at the top edge ("the maximum width of the pillar near the top edge").
pub const WIDTH_BAND_D: f64 = 2.0;

/// One row of bar state: the top bar's face now and at the start, the bottom bar's face,
/// and the force of the grains on the top bar (positive pushing it up).
#[derive(Debug, Clone, Copy)]
pub struct BarState {
    pub top_y0: f64,
    pub bottom_y: f64,
    pub top_y: f64,
    pub top_force: f64,
}

/// What Sec. III and Eq. 20 derive from one [`BarState`] and the width W.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StressPoint {
    /// ε = ΔH/H0, H0 the initial bar separation.
    pub strain: f64,
    /// σ = F_bar / W (N/m); 0 where W = 0 (no grain near the top bar).
    pub stress: f64,
    /// σ in the paper's unit m g μ / D.
    pub stress_reduced: f64,
    /// P_in = F_bar v_c (W), Eq. 20.
    pub p_in: f64,
}

/// The pillar width W at the top edge: the lateral extent, radii included, of the grains
/// whose centres lie within `band` below the top bar's face `top` (0 when there are none).
pub fn width_near_top(x: &[f64], y: &[f64], radius: &[f64], top: f64, band: f64) -> f64 {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..x.len() {
        if top - y[i] <= band {
            lo = lo.min(x[i] - radius[i]);
            hi = hi.max(x[i] + radius[i]);
        }
    }
    if hi > lo { hi - lo } else { 0.0 }
}

/// Engineering strain ε = ΔH/H0 (Sec. III) with the bottom bar fixed at `bottom_y`.
pub fn strain(top_y0: f64, bottom_y: f64, top_y: f64) -> f64 {
    (top_y0 - top_y) / (top_y0 - bottom_y)
}

/// Sec. III's ε and σ = F_bar / W, σ / (m g μ / D) with `stress_unit` = m g μ / D, and
/// Eq. 20's P_in = F_bar v_c.
pub fn stress_point(b: BarState, width: f64, stress_unit: f64, bar_speed: f64) -> StressPoint {
    let stress = if width > 0.0 {
        b.top_force / width
    } else {
        0.0
    };
    StressPoint {
        strain: strain(b.top_y0, b.bottom_y, b.top_y),
        stress,
        stress_reduced: stress / stress_unit,
        p_in: b.top_force * bar_speed,
    }
}
