use super::Vec2;

/// A rectangular box, periodic along x and/or y, with a Lees–Edwards offset.
///
/// The box spans `[x_lo, x_lo + lx) × [y_lo, y_lo + ly)`. With `periodic_y`, the periodic
/// image above is shifted along x by `xy` (length unit): for simple shear at rate γ̇,
/// `xy = γ ly` with γ the accumulated strain (vagberg-sheared-disks, Sec. II). This is
/// the LAMMPS triclinic `xy` tilt factor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimBox {
    pub x_lo: f64,
    pub y_lo: f64,
    pub lx: f64,
    pub ly: f64,
    pub xy: f64,
    pub periodic_x: bool,
    pub periodic_y: bool,
}

impl SimBox {
    /// A fully periodic box with no shear offset.
    pub fn periodic(lx: f64, ly: f64) -> Self {
        SimBox {
            x_lo: 0.0,
            y_lo: 0.0,
            lx,
            ly,
            xy: 0.0,
            periodic_x: true,
            periodic_y: true,
        }
    }

    /// Minimum-image form of a separation `d = r_j − r_i` (Lees–Edwards aware), by
    /// the project's one rule ([`super::MinImage`]).
    #[inline]
    pub fn min_image(&self, d: Vec2) -> Vec2 {
        let (dx, dy) = self.image().of(d.x, d.y);
        Vec2::new(dx, dy)
    }

    /// The box's minimum-image map, for loops that apply it many times.
    pub fn image(&self) -> super::MinImage {
        super::MinImage::new(
            if self.periodic_x { self.lx } else { 0.0 },
            if self.periodic_y { self.ly } else { 0.0 },
            self.xy,
        )
    }

    /// Map a position into the primary cell (Lees–Edwards aware).
    pub fn wrap(&self, mut r: Vec2) -> Vec2 {
        if self.periodic_y {
            let ny = ((r.y - self.y_lo) / self.ly).floor();
            r.y -= ny * self.ly;
            r.x -= ny * self.xy;
        }
        if self.periodic_x {
            let nx = ((r.x - self.x_lo) / self.lx).floor();
            r.x -= nx * self.lx;
        }
        r
    }

    /// Smallest distance over which minimum image is unambiguous.
    pub fn half_min_side(&self) -> f64 {
        let mut h = f64::INFINITY;
        if self.periodic_x {
            h = h.min(0.5 * self.lx);
        }
        if self.periodic_y {
            h = h.min(0.5 * self.ly);
        }
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lees_edwards_min_image_crosses_top() {
        let b = SimBox {
            xy: 3.0,
            ..SimBox::periodic(10.0, 10.0)
        };
        // j just above the top boundary seen from i just below it: the image below j is
        // shifted by -xy in x.
        let ri = Vec2::new(5.0, 9.5);
        let rj = Vec2::new(2.5, 0.3); // wrapped image of (5.5, 10.3)
        let d = b.min_image(rj - ri);
        assert!(
            (d.x - 0.5).abs() < 1e-12 && (d.y - 0.8).abs() < 1e-12,
            "{d:?}"
        );
    }

    #[test]
    fn wrap_is_consistent_with_min_image() {
        let b = SimBox {
            xy: 2.7,
            ..SimBox::periodic(10.0, 8.0)
        };
        let r = Vec2::new(13.2, 17.9);
        let w = b.wrap(r);
        assert!(w.x >= 0.0 && w.x < 10.0 && w.y >= 0.0 && w.y < 8.0);
        let d = b.min_image(w - r);
        assert!(d.norm() < 1e-12);
    }
}
