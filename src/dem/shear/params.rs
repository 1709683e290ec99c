//! What the sheared disks' parts share: the run's parameters and law
//! (vagberg-sheared-disks Sec. II), and the per-evaluation sums the pair loops fill
//! (virial, collision bookkeeping).

use crate::dem::law::{ContactLaw, ContactPoint, Damping, Normal, Tangential};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Dissipation {
    /// f_dis = −k_d (v_i − v_j), Eq. 3.
    Cd,
    /// f_dis = −k_d (v_i^{Cj} − v_j^{Ci}) at the contact point, Eqs. 5–7.
    Cdrot,
    /// f_dis = −k_d ((v_i − v_j) · n̂) n̂, normal dissipation only (the paper's CDn,
    /// Sec. II; Bagnoldian at every φ and Q): the reference it contrasts CD and CDrot
    /// with.
    Cdn,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShearParams {
    pub n: usize,
    /// Packing fraction φ (Eq. 11).
    pub phi: f64,
    /// Quality factor Q = τ_d/τ_e (Eq. 9); k_d = 1/Q.
    pub q: f64,
    /// Strain rate γ̇ τ_e.
    pub rate: f64,
    pub model: Dissipation,
    /// Exponent α of Eq. 1 (2: harmonic).
    pub alpha: f64,
    /// Time step Δt/τ_e (paper: 0.05, 0.01 for Q < 0.5).
    pub dt: f64,
    pub seed: u64,
}

impl ShearParams {
    pub fn validate(&self) -> Result<(), String> {
        if self.n < 4 {
            return Err(format!("n must be ≥ 4, got {}", self.n));
        }
        // Minimum images and the lists' displacement bounds need every pair within reach
        // (2 R_max + skin = 1.7 d_s) to be its own nearest image: L > 2 × 1.7 d_s.
        if self.phi.is_finite() && self.phi > 0.0 && self.box_side() <= 3.5 {
            return Err(format!(
                "n = {} at φ = {} gives a box of side {:.2} d_s; at least 3.5 is needed (more disks)",
                self.n,
                self.phi,
                self.box_side()
            ));
        }
        for (k, v, lo, hi) in [
            ("phi", self.phi, 0.05, 1.5),
            ("q", self.q, 1e-6, 1e6),
            ("rate", self.rate, 1e-12, 1.0),
            ("alpha", self.alpha, 1.5, 4.0),
            ("dt", self.dt, 1e-6, 0.2),
        ] {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(format!("{k} must be in [{lo}, {hi}], got {v}"));
            }
        }
        Ok(())
    }
    /// The contact law: Eq. 2's repulsion (exponent α) with CD (Eq. 3), CDrot
    /// (Eqs. 5–7) or CDn dissipation, k_d = 1/Q, frictionless, in units where k_e = 1.
    ///
    /// # Panics
    /// If the parameters do not validate (Q outside [1e-6, 1e6], α outside (1, 4]):
    /// every way into a run (options, checkpoints, pipelines) validates them first.
    pub fn law(&self) -> ContactLaw {
        let k_d = 1.0 / self.q;
        ContactLaw::new(
            Normal::RelativePowerLaw { alpha: self.alpha },
            match self.model {
                Dissipation::Cdrot => Damping::CdRot { k_d },
                Dissipation::Cd => Damping::Cd { k_d },
                Dissipation::Cdn => Damping::CdNormal { k_d },
            },
            Tangential::None,
            ContactPoint::RadiusRatio,
        )
        .expect("sheared-disk parameters are validated before a run")
    }

    /// Box side L from φ (Eq. 11), in d_s.
    pub fn box_side(&self) -> f64 {
        let area = std::f64::consts::PI * self.n as f64 / 2.0 * (0.25 + 0.25 * 1.4 * 1.4);
        (area / self.phi).sqrt()
    }
    /// The paper's step: 0.05, or 0.01 for Q < 0.5.
    pub fn default_dt(q: f64) -> f64 {
        if q < 0.5 { 0.01 } else { 0.05 }
    }
}

/// Per-evaluation sums for the pressure tensor (Eqs. 12–13), components xx, xy, yx, yy.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Virial {
    pub el: [f64; 4],
    pub dis: [f64; 4],
    pub contacts: usize,
}

/// Contact bookkeeping for τ_dur and ν_coll (Eq. 25).
#[derive(Debug, Clone, PartialEq)]
pub struct Collisions {
    pub begun: u64,
    pub ended: u64,
    /// Σ durations of the contacts that ended (τ_e).
    pub duration_sum: f64,
    /// Histograms of the collision angle ϑ of Eq. 27 ([`collision_angle`]) at contact
    /// making and breaking, in [`ANGLE_BINS`] bins of 3.6° ([`angle_bin`]); events with
    /// no relative velocity have no angle and are counted in `angle_undefined`.
    pub angle_making: Vec<u64>,
    pub angle_breaking: Vec<u64>,
    pub angle_undefined: u64,
    /// The cohort whose durations give τ_dur without censoring bias: contacts begun at
    /// or after `window_start` (τ_e; +∞ until the caller opens the window). Those that
    /// ended are recorded here, by duration and by half of the cohort (see
    /// [`cohort_half`]); those still open when the run ends are read from the pair
    /// histories then (`ShearSim::open_contact_starts`).
    pub window_start: f64,
    pub cohort_ended: [DurationHistogram; 2],
}

impl Default for Collisions {
    fn default() -> Self {
        Collisions {
            begun: 0,
            ended: 0,
            duration_sum: 0.0,
            angle_making: vec![0; ANGLE_BINS],
            angle_breaking: vec![0; ANGLE_BINS],
            angle_undefined: 0,
            window_start: f64::INFINITY,
            cohort_ended: Default::default(),
        }
    }
}

impl Collisions {
    /// Record a contact that began at `start` and ended at `now` (τ_e).
    #[inline]
    pub fn ended_at(&mut self, start: f64, now: f64) {
        self.ended += 1;
        self.duration_sum += now - start;
        if start >= self.window_start {
            self.cohort_ended[cohort_half(start)].add(now - start);
        }
    }
}

/// Which of two halves of the cohort a contact begun at `start` belongs to: a bit of
/// its start time, so the split is the same when it ends as when it is still open,
/// and the two halves give two independent estimates (their spread is the error).
pub fn cohort_half(start: f64) -> usize {
    (start.to_bits() >> 20 & 1) as usize
}

/// Durations (τ_e) in logarithmic bins, [`DurationHistogram::PER_DECADE`] per decade
/// from 1e-3 τ_e (below: the first bin; beyond 1e9 τ_e: the last), with the sum of the
/// durations in each bin, so a bin's mean is exact.
#[derive(Debug, Clone, PartialEq)]
pub struct DurationHistogram {
    pub count: Vec<u64>,
    pub sum: Vec<f64>,
}

impl Default for DurationHistogram {
    fn default() -> Self {
        DurationHistogram {
            count: vec![0; Self::BINS],
            sum: vec![0.0; Self::BINS],
        }
    }
}

impl DurationHistogram {
    pub const PER_DECADE: usize = 20;
    pub const BINS: usize = 12 * Self::PER_DECADE + 2;
    const LOWEST: f64 = 1e-3;

    /// The bin of duration `d` (τ_e).
    pub fn bin(d: f64) -> usize {
        if !(d >= Self::LOWEST) {
            return 0;
        }
        let k = ((d / Self::LOWEST).log10() * Self::PER_DECADE as f64) as usize + 1;
        k.min(Self::BINS - 1)
    }

    /// Lower edge of bin `k` (τ_e).
    pub fn lower_edge(k: usize) -> f64 {
        if k == 0 {
            0.0
        } else {
            Self::LOWEST * 10f64.powf((k - 1) as f64 / Self::PER_DECADE as f64)
        }
    }

    pub fn add(&mut self, d: f64) {
        let k = Self::bin(d);
        self.count[k] += 1;
        self.sum[k] += d;
    }

    pub fn total(&self) -> u64 {
        self.count.iter().sum()
    }
}

/// Bins of the collision-angle histograms: 3.6° over (−180°, 180°]
/// (vagberg-sheared-disks Sec. III.C, Δϑ = 3.6°).
pub const ANGLE_BINS: usize = 100;

/// Width of a collision-angle bin (degrees).
pub const ANGLE_BIN_DEG: f64 = 360.0 / ANGLE_BINS as f64;

/// The collision angle ϑ of vagberg-sheared-disks Eq. 27 (degrees, −180° < ϑ ≤ 180°):
/// the angle by which v_ij = v_i − v_j must be rotated (counter-clockwise positive) to lie
/// along r_ij = r_i − r_j, so cos ϑ = v̂_ij · r̂_ij. Grains that approach have |ϑ| > 90°,
/// grains that separate |ϑ| < 90°. `None` when v_ij or r_ij is zero or not finite.
#[inline]
pub fn collision_angle((rx, ry): (f64, f64), (vx, vy): (f64, f64)) -> Option<f64> {
    let dot = vx * rx + vy * ry;
    let cross = vx * ry - vy * rx;
    if !(dot != 0.0 || cross != 0.0) {
        return None;
    }
    let t = cross.atan2(dot).to_degrees();
    if t.is_nan() {
        return None;
    }
    // atan2 gives −180° for a −0 cross product: the same direction as +180°, which the
    // paper's half-open range keeps.
    Some(if t <= -180.0 { 180.0 } else { t.min(180.0) })
}

/// Edge k of the collision-angle bins (degrees): k·360/100 − 180, exact at the multiples
/// of 90°; bin k lies between edges k and k + 1.
pub fn angle_edge(k: usize) -> f64 {
    k as f64 * 360.0 / ANGLE_BINS as f64 - 180.0
}

/// Histogram bin of the collision angle `theta` (degrees, −180° < ϑ ≤ 180°): bin k covers
/// (−180° + 3.6° k, −180° + 3.6° (k + 1)].
#[inline]
pub fn angle_bin(theta: f64) -> usize {
    // ×100/360 rather than /3.6: the edges at multiples of 90° are then exact.
    let u = (theta + 180.0) * ANGLE_BINS as f64 / 360.0;
    (u.ceil() as usize).saturating_sub(1).min(ANGLE_BINS - 1)
}

/// The bins on either side of ϑ = +90° (k = 74, 75) and of ϑ = −90° (k = 24, 25), whose
/// mean density is reported as P(90°) and P(−90°) (Figs. 9, 19): 90° is an edge.
pub const ANGLE_BINS_AT_90: [usize; 2] = [74, 75];
pub const ANGLE_BINS_AT_MINUS_90: [usize; 2] = [24, 25];

/// Positions, velocities, spins and radii of one state: x, y, v_x, v_y, ω, R.
pub type StateSlices<'a> = (
    &'a [f64],
    &'a [f64],
    &'a [f64],
    &'a [f64],
    &'a [f64],
    &'a [f64],
);
