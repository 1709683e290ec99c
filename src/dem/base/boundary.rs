//! Where the grains live: an open plane, a periodic box, or a Lees–Edwards box, and
//! each one's minimum-image rule (`geom::MinImage`).

use crate::geom::MinImage;

/// Where the grains live.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Boundary {
    /// Unbounded plane (the pillar: bars and substrate confine it).
    Open,
    /// Periodic in x and y with sides `lx`, `ly` (m); minimum-image separations.
    Periodic { lx: f64, ly: f64 },
    /// Lees–Edwards: periodic, and the image above is shifted along x by `offset`
    /// (= γ L_y for accumulated strain γ; any real value, not wrapped).
    LeesEdwards { lx: f64, ly: f64, offset: f64 },
}

impl Boundary {
    /// The boundary's minimum-image map (`geom::MinImage`: the project's one rule).
    pub fn image(&self) -> MinImage {
        match *self {
            Boundary::Open => MinImage::OPEN,
            Boundary::Periodic { lx, ly } => MinImage::new(lx, ly, 0.0),
            Boundary::LeesEdwards { lx, ly, offset } => MinImage::new(lx, ly, offset),
        }
    }

    /// Separation r_i − r_j given as raw `(dx, dy)`, mapped to its minimum image.
    #[inline(always)]
    pub fn delta(&self, dx: f64, dy: f64) -> (f64, f64) {
        self.image().of(dx, dy)
    }

    /// As [`Boundary::delta`], also returning the y image index n used for j (the
    /// image of j sits at y_j + n L_y, x_j + n offset, moving n γ̇ L_y faster along x).
    #[inline(always)]
    pub fn delta_image(&self, dx: f64, dy: f64) -> (f64, f64, f64) {
        self.image().with_index(dx, dy)
    }

    /// The Lees–Edwards offset (0 for other boundaries).
    pub fn offset(&self) -> f64 {
        match *self {
            Boundary::LeesEdwards { offset, .. } => offset,
            _ => 0.0,
        }
    }
}
