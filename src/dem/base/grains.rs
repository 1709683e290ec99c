//! Grain state as structure-of-arrays: the force loops stream through contiguous f64s.

/// Species codes of the tracks schema.
pub const SMALL: i32 = 0;
pub const LARGE: i32 = 1;

/// N disks in 2D (SI units). Index order is the storage order (cell order after
/// [`Grains::sort_spatially`]); `id` is the particle id written to the tracks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Grains {
    pub id: Vec<i64>,
    pub species: Vec<i32>,
    /// Radius R_i (m).
    pub radius: Vec<f64>,
    /// Mass m_i (kg).
    pub mass: Vec<f64>,
    /// Moment of inertia I_i = ½ m_i R_i² (kg m²), Sec. II.B.4.
    pub inertia: Vec<f64>,
    /// Position (m).
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Velocity (m/s).
    pub vx: Vec<f64>,
    pub vy: Vec<f64>,
    /// Acceleration from the last force evaluation, substrate included (m/s²).
    pub ax: Vec<f64>,
    pub ay: Vec<f64>,
    /// Orientation θ (rad) and spin ω (rad/s), counter-clockwise.
    pub theta: Vec<f64>,
    pub omega: Vec<f64>,
}

impl Grains {
    pub fn len(&self) -> usize {
        self.x.len()
    }
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Add a grain at rest.
    pub fn push(&mut self, id: i64, species: i32, radius: f64, mass: f64, x: f64, y: f64) {
        self.id.push(id);
        self.species.push(species);
        self.radius.push(radius);
        self.mass.push(mass);
        self.inertia.push(0.5 * mass * radius * radius);
        self.x.push(x);
        self.y.push(y);
        for v in [
            &mut self.vx,
            &mut self.vy,
            &mut self.ax,
            &mut self.ay,
            &mut self.theta,
            &mut self.omega,
        ] {
            v.push(0.0);
        }
    }

    /// Reorder by (row, column) of a grid of `cell`-sized cells, so that grains close in
    /// space are close in memory (the pair loop then stays in cache).
    pub fn sort_spatially(&mut self, cell: f64) {
        let (xmin, ymin) = (
            self.x.iter().cloned().fold(f64::INFINITY, f64::min),
            self.y.iter().cloned().fold(f64::INFINITY, f64::min),
        );
        let key = |i: usize| {
            let cx = ((self.x[i] - xmin) / cell) as i64;
            let cy = ((self.y[i] - ymin) / cell) as i64;
            (cy, cx, self.id[i])
        };
        let mut order: Vec<usize> = (0..self.len()).collect();
        order.sort_by_key(|&i| key(i));
        self.permute(&order);
    }

    /// New order: element k is old element `order[k]`.
    pub fn permute(&mut self, order: &[usize]) {
        fn p<T: Copy>(v: &mut Vec<T>, order: &[usize]) {
            *v = order.iter().map(|&i| v[i]).collect();
        }
        p(&mut self.id, order);
        p(&mut self.species, order);
        for v in [
            &mut self.radius,
            &mut self.mass,
            &mut self.inertia,
            &mut self.x,
            &mut self.y,
            &mut self.vx,
            &mut self.vy,
            &mut self.ax,
            &mut self.ay,
            &mut self.theta,
            &mut self.omega,
        ] {
            p(v, order);
        }
    }

    /// Total linear momentum (kg m/s).
    pub fn momentum(&self) -> (f64, f64) {
        let mut p = (0.0, 0.0);
        for i in 0..self.len() {
            p.0 += self.mass[i] * self.vx[i];
            p.1 += self.mass[i] * self.vy[i];
        }
        p
    }

    /// Translational plus rotational kinetic energy (J).
    pub fn kinetic_energy(&self) -> f64 {
        (0..self.len())
            .map(|i| {
                0.5 * self.mass[i] * (self.vx[i] * self.vx[i] + self.vy[i] * self.vy[i])
                    + 0.5 * self.inertia[i] * self.omega[i] * self.omega[i]
            })
            .sum()
    }
}
