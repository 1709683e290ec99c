//! Per-grain contact statistics of force snapshots (the pair loops themselves live with
//! each model: `pillar_phases`, `shear_pairs`).

/// Per-grain contact statistics for force snapshots (li-granular-pillars Fig. 6).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactRecord {
    /// Σ |F_n| over the grain's grain–grain contacts (N).
    pub f_n: Vec<f64>,
    /// Σ |F_t| over the grain's grain–grain contacts (N).
    pub f_t: Vec<f64>,
    /// Number of grain–grain contacts.
    pub contacts: Vec<u32>,
    /// Normal force of the top (moving) bar on the grain (N), 0 where it does not
    /// touch it: the bar's contact pressure (li-granular-pillars Fig. 10c).
    pub f_bar: Vec<f64>,
}

impl ContactRecord {
    pub fn zeroed(n: usize) -> Self {
        ContactRecord {
            f_n: vec![0.0; n],
            f_t: vec![0.0; n],
            contacts: vec![0; n],
            f_bar: vec![0.0; n],
        }
    }
}
