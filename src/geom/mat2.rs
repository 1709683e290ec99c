use super::Vec2;
use std::ops::{Add, Mul, Sub};

/// A 2×2 matrix, row-major: `[[a11, a12], [a21, a22]]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mat2 {
    pub a11: f64,
    pub a12: f64,
    pub a21: f64,
    pub a22: f64,
}

impl Mat2 {
    pub const IDENTITY: Mat2 = Mat2::new(1.0, 0.0, 0.0, 1.0);
    pub const ZERO: Mat2 = Mat2::new(0.0, 0.0, 0.0, 0.0);

    pub const fn new(a11: f64, a12: f64, a21: f64, a22: f64) -> Self {
        Mat2 { a11, a12, a21, a22 }
    }
    /// Outer product a bᵀ.
    #[inline]
    pub fn outer(a: Vec2, b: Vec2) -> Mat2 {
        Mat2::new(a.x * b.x, a.x * b.y, a.y * b.x, a.y * b.y)
    }
    /// Counter-clockwise rotation by `angle` (rad).
    pub fn rotation(angle: f64) -> Mat2 {
        let (s, c) = angle.sin_cos();
        Mat2::new(c, -s, s, c)
    }
    #[inline]
    pub fn det(&self) -> f64 {
        self.a11 * self.a22 - self.a12 * self.a21
    }
    #[inline]
    pub fn trace(&self) -> f64 {
        self.a11 + self.a22
    }
    #[inline]
    pub fn transpose(&self) -> Mat2 {
        Mat2::new(self.a11, self.a21, self.a12, self.a22)
    }
    /// Inverse, or `None` when |det| is below `tol` times the squared Frobenius norm
    /// (a scale-free singularity test).
    pub fn inverse(&self, tol: f64) -> Option<Mat2> {
        let d = self.det();
        let scale = self.frobenius2();
        if !(d.abs() > tol * scale) || !d.is_finite() {
            return None;
        }
        let inv = 1.0 / d;
        Some(Mat2::new(
            self.a22 * inv,
            -self.a12 * inv,
            -self.a21 * inv,
            self.a11 * inv,
        ))
    }
    #[inline]
    pub fn frobenius2(&self) -> f64 {
        self.a11 * self.a11 + self.a12 * self.a12 + self.a21 * self.a21 + self.a22 * self.a22
    }
    pub fn scale(&self, s: f64) -> Mat2 {
        Mat2::new(self.a11 * s, self.a12 * s, self.a21 * s, self.a22 * s)
    }
}

impl Mul for Mat2 {
    type Output = Mat2;
    #[inline]
    fn mul(self, o: Mat2) -> Mat2 {
        Mat2::new(
            self.a11 * o.a11 + self.a12 * o.a21,
            self.a11 * o.a12 + self.a12 * o.a22,
            self.a21 * o.a11 + self.a22 * o.a21,
            self.a21 * o.a12 + self.a22 * o.a22,
        )
    }
}
impl Mul<Vec2> for Mat2 {
    type Output = Vec2;
    #[inline]
    fn mul(self, v: Vec2) -> Vec2 {
        Vec2::new(
            self.a11 * v.x + self.a12 * v.y,
            self.a21 * v.x + self.a22 * v.y,
        )
    }
}
impl Add for Mat2 {
    type Output = Mat2;
    #[inline]
    fn add(self, o: Mat2) -> Mat2 {
        Mat2::new(
            self.a11 + o.a11,
            self.a12 + o.a12,
            self.a21 + o.a21,
            self.a22 + o.a22,
        )
    }
}
impl Sub for Mat2 {
    type Output = Mat2;
    #[inline]
    fn sub(self, o: Mat2) -> Mat2 {
        Mat2::new(
            self.a11 - o.a11,
            self.a12 - o.a12,
            self.a21 - o.a21,
            self.a22 - o.a22,
        )
    }
}
