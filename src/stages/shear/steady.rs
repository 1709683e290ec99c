//! Steady-state accumulations of a sheared-disk run beyond the series: the collision
//! angle ϑ (vagberg-sheared-disks Eq. 27) at contact making and breaking (3.6° bins) and the velocity profile
//! v_x(y) — both counted only after the transient.

use crate::dem::base::codec::{Dec, Enc};
use crate::dem::shear::{ANGLE_BIN_DEG, ANGLE_BINS, ShearSim, angle_edge};
use crate::error::{Error, Result};
use crate::io::table::write_table;
use polars::prelude::*;
use std::path::Path;

/// Bins of the velocity profile across the box.
pub const PROFILE_BINS: usize = 20;

#[derive(Debug, Clone, Default)]
pub struct Steady {
    pub started: bool,
    /// Histogram counts when the steady window began.
    pub making0: Vec<u64>,
    pub breaking0: Vec<u64>,
    /// Σ v_x and samples per y bin (primary-cell images).
    pub vx_sum: Vec<f64>,
    pub count: Vec<f64>,
    /// Contact-velocity samples [V_T, V^R, V^C_T, V_N] (Fig. 21), flattened.
    pub contact_v: Vec<f64>,
    /// Σ disk area per y bin (for φ(y)) and the number of samples.
    pub area_sum: Vec<f64>,
    pub samples: u64,
    /// Local fields over circles of radius 4 d_s on a grid (Figs. 27–28): Σ φ, Σ γ̇
    /// and snapshots taken.
    pub field_phi: Vec<f64>,
    pub field_gdot: Vec<f64>,
    pub field_snapshots: u64,
}

/// Radius of the circles the local fields average over (d_s).
pub const FIELD_RADIUS: f64 = 4.0;
/// Snapshots of the local fields over the steady window.
pub const FIELD_SNAPSHOTS: u64 = 10;

/// Collisions sampled for Fig. 21, spread over the steady window.
pub const CONTACT_SAMPLES: usize = 5000;

impl Steady {
    /// Called at every sample of the steady window; `per_sample` contacts are drawn
    /// (seeded) for the contact-velocity table until it holds CONTACT_SAMPLES.
    pub fn sample(&mut self, sim: &ShearSim, per_sample: usize, field_every: u64, seed: u64) {
        if self.contact_v.len() < 4 * CONTACT_SAMPLES {
            let cv = sim.contact_velocities();
            if !cv.is_empty() {
                let mut rng =
                    crate::rng::Rng::new(seed ^ sim.step.wrapping_mul(0x9E37_79B9_7F4A_7C15));
                for _ in 0..per_sample.min(CONTACT_SAMPLES - self.contact_v.len() / 4) {
                    self.contact_v.extend_from_slice(&cv[rng.below(cv.len())]);
                }
            }
        }
        if !self.started {
            self.started = true;
            self.making0 = sim.coll.angle_making.clone();
            self.breaking0 = sim.coll.angle_breaking.clone();
            self.vx_sum = vec![0.0; PROFILE_BINS];
            self.count = vec![0.0; PROFILE_BINS];
            self.area_sum = vec![0.0; PROFILE_BINS];
            let g = field_grid(sim.l);
            self.field_phi = vec![0.0; g * g];
            self.field_gdot = vec![0.0; g * g];
        }
        if self.samples.is_multiple_of(field_every) {
            self.field_snapshot(sim);
        }
        self.samples += 1;
        let shear_v = sim.p.rate * sim.l;
        for i in 0..sim.g.len() {
            let (_, yw) = sim.wrapped(i);
            // The primary-cell image moves n γ̇ L slower than the unwrapped grain.
            let n = ((sim.g.y[i] - yw) / sim.l).round();
            let b = ((yw / sim.l * PROFILE_BINS as f64) as usize).min(PROFILE_BINS - 1);
            self.vx_sum[b] += sim.g.vx[i] - n * shear_v;
            self.count[b] += 1.0;
            self.area_sum[b] += std::f64::consts::PI * sim.g.radius[i] * sim.g.radius[i];
        }
    }

    /// Local φ and γ̇ at every grid point: disks whose centres lie within FIELD_RADIUS
    /// (their whole area counted), and the least-squares slope dv_x/dy of their velocity
    /// images (Lees–Edwards aware) against height.
    fn field_snapshot(&mut self, sim: &ShearSim) {
        let (l, g) = (sim.l, field_grid(sim.l));
        let b = sim.boundary();
        let shear_v = sim.p.rate * l;
        let r2max = FIELD_RADIUS * FIELD_RADIUS;
        // Grid points apart (each sums its disks in order: the same numbers on any
        // number of threads), k = c g + a; on rayon's threads unless the run asked for
        // one, or runs inside rayon's pool already (a sweep's point, whose waiting
        // thread could take up another whole run meanwhile).
        use rayon::prelude::*;
        let point = |k: usize| {
            let (a, c) = (k % g, k / g);
            let (gx, gy) = (
                (a as f64 + 0.5) * l / g as f64,
                (c as f64 + 0.5) * l / g as f64,
            );
            let (mut area, mut n, mut sy, mut sv, mut syy, mut syv) =
                (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            for i in 0..sim.g.len() {
                let (dx, dy, img) = b.delta_image(sim.g.x[i] - gx, sim.g.y[i] - gy);
                if dx * dx + dy * dy >= r2max {
                    continue;
                }
                let v = sim.g.vx[i] - img * shear_v;
                area += std::f64::consts::PI * sim.g.radius[i] * sim.g.radius[i];
                n += 1.0;
                sy += dy;
                sv += v;
                syy += dy * dy;
                syv += dy * v;
            }
            let den = n * syy - sy * sy;
            let gdot = (n >= 3.0 && den > 0.0).then(|| (n * syv - sy * sv) / den);
            (area / (std::f64::consts::PI * r2max), gdot)
        };
        let points: Vec<_> = if sim.threads == 1 || rayon::current_thread_index().is_some() {
            (0..g * g).map(point).collect()
        } else {
            (0..g * g).into_par_iter().map(point).collect()
        };
        for (k, (phi, gdot)) in points.into_iter().enumerate() {
            self.field_phi[k] += phi;
            if let Some(gdot) = gdot {
                self.field_gdot[k] += gdot;
            }
        }
        self.field_snapshots += 1;
    }

    pub fn encode(&self, e: &mut Enc) {
        e.u64(self.started as u64);
        let u = |v: &[u64]| v.iter().map(|&x| x as i64).collect::<Vec<_>>();
        e.i64s(&u(&self.making0));
        e.i64s(&u(&self.breaking0));
        e.f64s(&self.vx_sum);
        e.f64s(&self.count);
        e.f64s(&self.contact_v);
        e.f64s(&self.area_sum);
        e.u64(self.samples);
        e.f64s(&self.field_phi);
        e.f64s(&self.field_gdot);
        e.u64(self.field_snapshots);
    }

    pub fn decode(d: &mut Dec) -> std::result::Result<Self, String> {
        let started = d.u64()? != 0;
        let u = |v: Vec<i64>| v.into_iter().map(|x| x as u64).collect::<Vec<_>>();
        Ok(Steady {
            started,
            making0: u(d.i64s()?),
            breaking0: u(d.i64s()?),
            vx_sum: d.f64s()?,
            count: d.f64s()?,
            contact_v: d.f64s()?,
            area_sum: d.f64s()?,
            samples: d.u64()?,
            field_phi: d.f64s()?,
            field_gdot: d.f64s()?,
            field_snapshots: d.u64()?,
        })
    }

    /// The collision-angle counts (ϑ of Eq. 27) of the steady window: (making, breaking),
    /// [`ANGLE_BINS`] each.
    pub fn angle_counts(&self, sim: &ShearSim) -> (Vec<u64>, Vec<u64>) {
        let diff = |now: &[u64], then: &[u64]| {
            now.iter()
                .zip(then.iter().chain(std::iter::repeat(&0)))
                .map(|(a, b)| a.saturating_sub(*b))
                .collect::<Vec<u64>>()
        };
        (
            diff(&sim.coll.angle_making, &self.making0),
            diff(&sim.coll.angle_breaking, &self.breaking0),
        )
    }

    /// `collision_angles.parquet`, `profile.parquet` and `contact_velocities.parquet`.
    pub fn write(&self, sim: &ShearSim, out: &Path) -> Result<()> {
        if !self.started {
            return Err(Error::param(
                "strain",
                "the run ended before its steady window began",
            ));
        }
        let (mk, br) = self.angle_counts(sim);
        let (mk, br): (Vec<f64>, Vec<f64>) = (
            mk.iter().map(|&c| c as f64).collect(),
            br.iter().map(|&c| c as f64).collect(),
        );
        let both: Vec<f64> = mk.iter().zip(&br).map(|(a, b)| a + b).collect();
        // Probability density per degree, so curves from runs of any length compare.
        let pdf = |c: &[f64]| {
            let t: f64 = c.iter().sum();
            c.iter()
                .map(|x| {
                    if t > 0.0 {
                        x / (t * ANGLE_BIN_DEG)
                    } else {
                        0.0
                    }
                })
                .collect::<Vec<f64>>()
        };
        let lo: Vec<f64> = (0..ANGLE_BINS).map(angle_edge).collect();
        let hi: Vec<f64> = (1..=ANGLE_BINS).map(angle_edge).collect();
        let mut df = DataFrame::new(
            ANGLE_BINS,
            vec![
                Column::new("theta_lo_deg".into(), &lo),
                Column::new("theta_hi_deg".into(), &hi),
                Column::new("making".into(), &mk),
                Column::new("breaking".into(), &br),
                Column::new("making_pdf".into(), &pdf(&mk)),
                Column::new("breaking_pdf".into(), &pdf(&br)),
                Column::new("pdf".into(), &pdf(&both)),
            ],
        )
        .map_err(|e| Error::polars("building the angle table", e))?;
        write_table(&mut df, &out.join("collision_angles.parquet"))?;
        let y: Vec<f64> = (0..PROFILE_BINS)
            .map(|b| (b as f64 + 0.5) / PROFILE_BINS as f64 * sim.l)
            .collect();
        let vx: Vec<f64> = self
            .vx_sum
            .iter()
            .zip(&self.count)
            .map(|(s, n)| if *n > 0.0 { s / n } else { 0.0 })
            .collect();
        let affine: Vec<f64> = y.iter().map(|y| sim.p.rate * y).collect();
        let bin_area = sim.l * sim.l / PROFILE_BINS as f64;
        let phi: Vec<f64> = self
            .area_sum
            .iter()
            .map(|a| a / (self.samples.max(1) as f64 * bin_area))
            .collect();
        // γ̇(y) by central differences; across the boundary the image flows γ̇L faster.
        let h = sim.l / PROFILE_BINS as f64;
        let nb = PROFILE_BINS;
        let gdot: Vec<f64> = (0..nb)
            .map(|k| {
                let up = if k + 1 < nb {
                    vx[k + 1]
                } else {
                    vx[0] + sim.p.rate * sim.l
                };
                let down = if k > 0 {
                    vx[k - 1]
                } else {
                    vx[nb - 1] - sim.p.rate * sim.l
                };
                (up - down) / (2.0 * h)
            })
            .collect();
        let mut df = DataFrame::new(
            PROFILE_BINS,
            vec![
                Column::new("y".into(), &y),
                Column::new("vx".into(), &vx),
                Column::new("vx_affine".into(), &affine),
                Column::new("gamma_dot".into(), &gdot),
                Column::new("phi".into(), &phi),
                Column::new("samples".into(), &self.count),
            ],
        )
        .map_err(|e| Error::polars("building the profile", e))?;
        write_table(&mut df, &out.join("profile.parquet"))?;
        let c = |k: usize| {
            self.contact_v
                .iter()
                .skip(k)
                .step_by(4)
                .copied()
                .collect::<Vec<f64>>()
        };
        let n = self.contact_v.len() / 4;
        let mut df = DataFrame::new(
            n,
            vec![
                Column::new("v_t".into(), &c(0)),
                Column::new("v_r".into(), &c(1)),
                Column::new("v_c_t".into(), &c(2)),
                Column::new("v_n".into(), &c(3)),
            ],
        )
        .map_err(|e| Error::polars("building the contact velocities", e))?;
        write_table(&mut df, &out.join("contact_velocities.parquet"))?;
        let g = field_grid(sim.l);
        let ns = self.field_snapshots.max(1) as f64;
        let coord = |k: usize| (k as f64 + 0.5) * sim.l / g as f64;
        let (fx, fy): (Vec<f64>, Vec<f64>) =
            (0..g * g).map(|k| (coord(k % g), coord(k / g))).unzip();
        let phi: Vec<f64> = self.field_phi.iter().map(|v| v / ns).collect();
        let gd: Vec<f64> = self.field_gdot.iter().map(|v| v / ns).collect();
        let gd_rel: Vec<f64> = gd.iter().map(|v| v / sim.p.rate).collect();
        let mut df = DataFrame::new(
            g * g,
            vec![
                Column::new("x".into(), &fx),
                Column::new("y".into(), &fy),
                Column::new("phi".into(), &phi),
                Column::new("gamma_dot".into(), &gd),
                Column::new("gamma_dot_over_rate".into(), &gd_rel),
            ],
        )
        .map_err(|e| Error::polars("building the local fields", e))?;
        write_table(&mut df, &out.join("fields.parquet"))
    }
}

/// Grid points per side for the local fields: spacing ≥ FIELD_RADIUS.
pub fn field_grid(l: f64) -> usize {
    ((l / FIELD_RADIUS).floor() as usize).max(1)
}
