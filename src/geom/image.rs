//! The minimum image: the one rule every periodic or Lees–Edwards separation in the
//! project goes through (kinematics, neighbour lists, both simulators' pair lists and
//! pair loops, observables).
//!
//! A separation d = r_a − r_b is first mapped along y to its nearest image, n = rint(d_y
//! / L_y), which under Lees–Edwards shear drags x by n times the offset γ L_y
//! (vagberg-sheared-disks Sec. II; LAMMPS's triclinic `xy`); then along x. Divisions by
//! L are multiplications by 1/L, computed once, and rounding is to the nearest integer
//! with ties to even (`rint`), which is what the vector kernels' rounding instruction
//! does: the scalar and vector paths agree bit for bit. An open axis has L = 1/L = 0,
//! which maps nothing.

/// `v.floor() as isize`, without the libm call that `floor` is on baseline x86-64 (no
/// SSE4.1 `roundsd`): three per neighbour query in the kinematics (5 % of its kernel),
/// two a grain in each DEM pair-list build. Equal for every f64, NaN (0) and the
/// saturating ends included.
#[inline]
pub fn floor_index(v: f64) -> isize {
    let t = v as isize;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// Nearest integer of `v` (ties to even) for |v| < 2^51 without a libm call (x86-64
/// without SSE4.1 has no rounding instruction; a pair loop calls this twice per pair). A
/// zero result keeps the sign of `v`, as the AVX2 kernels' `vroundpd` does.
#[inline(always)]
pub fn rint(v: f64) -> f64 {
    const M: f64 = 6_755_399_441_055_744.0; // 1.5 × 2^52
    ((v + M) - M).copysign(v)
}

/// A box's minimum-image map: sides L_x, L_y (0 for an open axis), their inverses, and
/// the Lees–Edwards offset of the image above (0 without shear).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinImage {
    pub lx: f64,
    pub ly: f64,
    pub inv_lx: f64,
    pub inv_ly: f64,
    pub offset: f64,
}

impl MinImage {
    /// No periodic axis: every separation is its own image.
    pub const OPEN: MinImage = MinImage {
        lx: 0.0,
        ly: 0.0,
        inv_lx: 0.0,
        inv_ly: 0.0,
        offset: 0.0,
    };

    /// Sides `lx`, `ly` (0: that axis is open) and Lees–Edwards `offset` (any real
    /// value, not wrapped).
    pub fn new(lx: f64, ly: f64, offset: f64) -> Self {
        let inv = |l: f64| if l > 0.0 { 1.0 / l } else { 0.0 };
        MinImage {
            lx,
            ly,
            inv_lx: inv(lx),
            inv_ly: inv(ly),
            offset: if ly > 0.0 { offset } else { 0.0 },
        }
    }

    /// The separation (dx, dy) at its nearest image, and the y image index n of the
    /// second point (whose image sits n L_y above and n·offset along x; under shear at
    /// rate γ̇ it moves n γ̇ L_y faster along x).
    #[inline(always)]
    pub fn with_index(&self, dx: f64, dy: f64) -> (f64, f64, f64) {
        let n = rint(dy * self.inv_ly);
        let dy = dy - n * self.ly;
        let dx = dx - n * self.offset;
        (dx - self.lx * rint(dx * self.inv_lx), dy, n)
    }

    /// The separation (dx, dy) at its nearest image.
    #[inline(always)]
    pub fn of(&self, dx: f64, dy: f64) -> (f64, f64) {
        let (dx, dy, _) = self.with_index(dx, dy);
        (dx, dy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn floor_index_is_floor_as_isize_for_every_kind_of_value() {
        let mut rng = Rng::new(9);
        let mut vals = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.5,
            -2.5,
            1e-300,
            -1e-300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN,
            9.3e18,
            -9.3e18,
            isize::MAX as f64,
            isize::MIN as f64,
            -4503599627370497.0,
            4503599627370497.5,
        ];
        vals.extend((0..100_000).map(|_| (rng.uniform() - 0.5) * 1e3));
        vals.extend((-50..50).map(|k| k as f64 - f64::EPSILON * k as f64));
        for v in vals {
            assert_eq!(floor_index(v), v.floor() as isize, "{v:e}");
        }
    }

    #[test]
    fn rint_rounds_ties_to_even_and_keeps_the_sign_of_zero() {
        for (v, r) in [
            (0.5, 0.0),
            (1.5, 2.0),
            (2.5, 2.0),
            (-0.5, -0.0),
            (-1.5, -2.0),
        ] {
            assert_eq!(rint(v), r);
            assert_eq!(rint(v).is_sign_negative(), r.is_sign_negative(), "{v}");
        }
        assert_eq!(rint(-0.2).to_bits(), (-0.0f64).to_bits());
        assert_eq!(rint(3.7), 4.0);
    }

    #[test]
    fn lees_edwards_image_drags_x_by_the_offset() {
        // Box 10 × 10 sheared by an offset of 3: a separation of (1, 9) is (1 − 3, −1)
        // from the image below.
        let m = MinImage::new(10.0, 10.0, 3.0);
        let (dx, dy, n) = m.with_index(1.0, 9.0);
        assert_eq!((dx, dy, n), (-2.0, -1.0, 1.0));
        // Then x itself wraps: (8, 0) → (−2, 0).
        assert_eq!(m.of(8.0, 0.0), (-2.0, 0.0));
        // Open: nothing moves.
        assert_eq!(MinImage::OPEN.with_index(8.0, 90.0), (8.0, 90.0, 0.0));
        // An open y axis ignores the offset; x still wraps.
        assert_eq!(MinImage::new(10.0, 0.0, 3.0).of(8.0, 9.0), (-2.0, 9.0));
        for _ in 0..3 {
            let (dx, dy) = m.of(123.4, -56.7);
            assert!(dx.abs() <= 5.0 && dy.abs() <= 5.0, "({dx}, {dy})");
        }
    }
}
