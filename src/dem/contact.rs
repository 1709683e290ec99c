//! Contact laws as small pluggable pieces (normal, tangential, substrate), as LAMMPS's
//! granular sub-models are. A model picks one of each; the pair loop is generic over
//! them, so a frictionless model (the sheared disks) pays nothing for friction.

/// Normal force magnitude between two bodies in contact.
pub trait NormalLaw {
    /// Repulsive force (N) for overlap `delta` (m, > 0) and normal relative velocity
    /// `vn` (m/s, negative when approaching). Never attractive.
    fn force(&self, delta: f64, vn: f64) -> f64;
    /// Elastic energy stored at overlap `delta` (J).
    fn energy(&self, delta: f64) -> f64;
}

/// Linear spring F_n = k_n δ (li-granular-pillars Eq. 4) with optional viscous damping
/// −γ_n v_n, clipped at zero so a separating contact never pulls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hooke {
    /// Stiffness k_n (N/m).
    pub k_n: f64,
    /// Damping γ_n (kg/s).
    pub damping: f64,
}

impl NormalLaw for Hooke {
    #[inline(always)]
    fn force(&self, delta: f64, vn: f64) -> f64 {
        let f = self.k_n * delta - self.damping * vn;
        if f > 0.0 { f } else { 0.0 }
    }
    fn energy(&self, delta: f64) -> f64 {
        0.5 * self.k_n * delta * delta
    }
}

/// Tangential force from the contact's history.
pub trait TangentialLaw {
    /// Advance the stored shear displacement `s` (m, along the tangent t̂) by the
    /// tangential relative velocity `vt` (m/s) over `dt` (s), apply the friction limit
    /// for normal force `f_n` (N), and return the tangential force on the first body
    /// along t̂ (N).
    fn force(&self, s: &mut f64, vt: f64, dt: f64, f_n: f64) -> f64;
    /// Whether this law keeps history (frictionless laws do not).
    const HAS_HISTORY: bool;
}

/// Cundall–Strack spring with Coulomb truncation (li-granular-pillars Eq. 7, following
/// Silbert et al.): F_t = −k_t u_t with |F_t| ≤ μ |F_n|. In 2D the shear displacement is
/// a scalar along t̂, so it stays in the tangent plane, with its magnitude, as the
/// contact turns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CundallStrack {
    /// Tangential stiffness k_t (N/m).
    pub k_t: f64,
    /// Friction coefficient μ.
    pub mu: f64,
}

impl CundallStrack {
    /// μ/k_t (m/N): the spring's stretch at the Coulomb limit per newton of normal
    /// force.
    #[inline(always)]
    pub fn mu_over_k_t(&self) -> f64 {
        self.mu / self.k_t
    }
}

impl TangentialLaw for CundallStrack {
    const HAS_HISTORY: bool = true;
    #[inline(always)]
    fn force(&self, s: &mut f64, vt: f64, dt: f64, f_n: f64) -> f64 {
        let mut u = *s + vt * dt;
        let f_max = self.mu * f_n;
        if self.k_t * u.abs() > f_max {
            // Sliding: the spring is held at the Coulomb limit μ F_n / k_t, as
            // F_n (μ/k_t): one multiplication, where a division would cost the vector
            // kernels a divider slot per pair.
            u = (f_n * self.mu_over_k_t()).copysign(u);
        }
        *s = u;
        -self.k_t * u
    }
}

/// No tangential force (frictionless disks, vagberg-sheared-disks).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frictionless;

impl TangentialLaw for Frictionless {
    const HAS_HISTORY: bool = false;
    #[inline(always)]
    fn force(&self, _s: &mut f64, _vt: f64, _dt: f64, _f_n: f64) -> f64 {
        0.0
    }
}

/// `a` when `c`, else `b`, as a bit mask (no branch to mispredict).
#[inline(always)]
pub fn pick(c: bool, a: f64, b: f64) -> f64 {
    let m = 0u64.wrapping_sub(c as u64);
    f64::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// Coulomb friction of the substrate under each grain (li-granular-pillars
/// Sec. II.B.3 and Eq. 9, with the ξ rule of Eq. 11).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubstrateFriction {
    /// g (m/s²).
    pub g: f64,
    /// μ (grain–substrate).
    pub mu: f64,
}

impl SubstrateFriction {
    /// Friction force (N) on a grain of mass `m` moving at `v` (m/s) under contact
    /// force `f` (N, grain–grain plus grain–bar): opposite to the motion with
    /// magnitude m g μ; on a grain at rest, whatever cancels `f` up to m g μ.
    #[inline(always)]
    pub fn force(&self, m: f64, vx: f64, vy: f64, fx: f64, fy: f64) -> (f64, f64) {
        let f_max = m * self.g * self.mu;
        self.force_with(f_max, f_max * f_max, vx, vy, fx, fy)
    }

    /// [`SubstrateFriction::force`] given m g μ (N) and its square.
    #[inline(always)]
    pub fn force_with(
        &self,
        f_max: f64,
        f_max2: f64,
        vx: f64,
        vy: f64,
        fx: f64,
        fy: f64,
    ) -> (f64, f64) {
        // Both cases computed and one picked without a branch: moving and resting
        // grains mix at random.
        // One square root and one division: a moving grain's scale is m g μ/|v|, a
        // resting grain's 1 or m g μ/|f|, so the root is taken of whichever applies.
        let v2 = vx * vx + vy * vy;
        let f2 = fx * fx + fy * fy;
        let moving = v2 > 0.0;
        let q = pick(moving, v2, f2);
        let k_q = f_max / q.max(f64::MIN_POSITIVE).sqrt();
        let k = pick(moving | (f2 > f_max2), k_q, 1.0);
        let (ax, ay) = (pick(moving, vx, fx), pick(moving, vy, fy));
        (-k * ax, -k * ay)
    }

    /// Largest substrate torque (2/3) m g μ R (N m), Eq. 9.
    #[inline(always)]
    pub fn torque_max(&self, m: f64, r: f64) -> f64 {
        2.0 / 3.0 * m * self.g * self.mu * r
    }

    /// Friction torque (N m) on a grain spinning at `omega` (rad/s) under contact
    /// torque `t` (N m): −T_max ω̂ (Eq. 9), or whatever cancels `t` up to T_max at rest.
    #[inline(always)]
    pub fn torque(&self, m: f64, r: f64, omega: f64, t: f64) -> f64 {
        self.torque_with(self.torque_max(m, r), omega, t)
    }

    /// [`SubstrateFriction::torque`] given T_max = (2/3) m g μ R (N m).
    #[inline(always)]
    pub fn torque_with(&self, t_max: f64, omega: f64, t: f64) -> f64 {
        let spinning = -t_max.copysign(omega);
        let at_rest = (-t).clamp(-t_max, t_max);
        pick(omega != 0.0, spinning, at_rest)
    }

    /// ξ_v = g μ δt (m/s), Eq. 11.
    pub fn xi_v(&self, dt: f64) -> f64 {
        self.g * self.mu * dt
    }

    /// ξ_ω = 4 g μ δt / (3 R) (rad/s), Eq. 11.
    pub fn xi_omega(&self, dt: f64, r: f64) -> f64 {
        4.0 * self.g * self.mu * dt / (3.0 * r)
    }
}
