//! Coulomb friction of the substrate under each grain (li-granular-pillars Sec. II.B.3,
//! Eq. 9, with the ξ rule of Eq. 11): a one-body law, beside the pair laws.

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
