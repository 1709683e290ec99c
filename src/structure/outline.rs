//! The outline of a pillar (li-granular-pillars Fig. 9) and how far two outlines are
//! apart once rescaled (is the shape self-similar? a number, not an impression).
//!
//! Construction: the outermost grains. The pillar is cut into horizontal slabs one
//! large diameter D thick from its lowest grain edge; in each slab the outline passes
//! through the leftmost and the rightmost grain edges (x ∓ R). Up the right side and down
//! the left, that is a polygon whose half-width at each height is what the paper's W
//! measures at the top. Why not an alpha shape or a hull: the slabs keep the concave
//! waist and the bulge under the bar (a convex hull fills the waist in), need no radius
//! parameter beyond D, and give the half-width profile directly, which is what two sizes
//! are compared by.

use crate::geom::Vec2;

/// A pillar's outline: per slab (bottom to top), the slab's mid-height and the left and
/// right edges (length unit); empty slabs (gaps) are skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct Outline {
    pub y: Vec<f64>,
    pub left: Vec<f64>,
    pub right: Vec<f64>,
    /// The slab thickness (length unit) and the lowest grain edge it starts from.
    pub slab: f64,
    pub y0: f64,
}

impl Outline {
    /// The outline of grains at `pos` with radii `radius`, slabs `slab` thick.
    pub fn of(pos: &[Vec2], radius: &[f64], slab: f64) -> Outline {
        let y0 = pos
            .iter()
            .zip(radius)
            .map(|(p, r)| p.y - r)
            .fold(f64::INFINITY, f64::min);
        let mut lo: Vec<f64> = Vec::new();
        let mut hi: Vec<f64> = Vec::new();
        for (p, &r) in pos.iter().zip(radius) {
            if !(p.x.is_finite() && p.y.is_finite() && slab > 0.0) {
                continue;
            }
            let k = ((p.y - y0) / slab).floor().max(0.0) as usize;
            if k >= lo.len() {
                lo.resize(k + 1, f64::INFINITY);
                hi.resize(k + 1, f64::NEG_INFINITY);
            }
            lo[k] = lo[k].min(p.x - r);
            hi[k] = hi[k].max(p.x + r);
        }
        let mut o = Outline {
            y: Vec::new(),
            left: Vec::new(),
            right: Vec::new(),
            slab,
            y0,
        };
        for k in 0..lo.len() {
            if lo[k].is_finite() {
                o.y.push(y0 + (k as f64 + 0.5) * slab);
                o.left.push(lo[k]);
                o.right.push(hi[k]);
            }
        }
        o
    }

    /// The polygon: up the right side, down the left (counter-clockwise).
    pub fn polygon(&self) -> Vec<Vec2> {
        let up = (0..self.y.len()).map(|k| Vec2::new(self.right[k], self.y[k]));
        let down = (0..self.y.len())
            .rev()
            .map(|k| Vec2::new(self.left[k], self.y[k]));
        up.chain(down).collect()
    }

    /// Half-width (length unit) at each slab.
    pub fn half_width(&self) -> Vec<f64> {
        (0..self.y.len())
            .map(|k| 0.5 * (self.right[k] - self.left[k]))
            .collect()
    }

    /// Height spanned: from the lowest slab's bottom to the highest's top.
    pub fn height(&self) -> f64 {
        match (self.y.first(), self.y.last()) {
            (Some(a), Some(b)) => b - a + self.slab,
            _ => 0.0,
        }
    }
}

/// How far apart the half-width profiles of two outlines are once each is rescaled by
/// its own initial width `w0_a`, `w0_b`: heights as fractions of each outline's height,
/// half-widths over W0, compared at 50 evenly spaced fractions (linear interpolation)
/// by the root mean square difference. 0 for outlines of one shape at any size.
pub fn shape_distance(a: &Outline, w0_a: f64, b: &Outline, w0_b: f64) -> f64 {
    let profile = |o: &Outline, w0: f64| -> Vec<(f64, f64)> {
        let (y_lo, h) = (
            o.y.first().copied().unwrap_or(0.0) - 0.5 * o.slab,
            o.height(),
        );
        o.y.iter()
            .zip(o.half_width())
            .map(|(&y, w)| ((y - y_lo) / h, w / w0))
            .collect()
    };
    let at = |p: &[(f64, f64)], s: f64| -> f64 {
        match p.iter().position(|&(f, _)| f >= s) {
            Some(0) => p[0].1,
            Some(k) => {
                let ((f0, w0), (f1, w1)) = (p[k - 1], p[k]);
                w0 + (w1 - w0) * (s - f0) / (f1 - f0)
            }
            None => p.last().map_or(f64::NAN, |q| q.1),
        }
    };
    let (pa, pb) = (profile(a, w0_a), profile(b, w0_b));
    if pa.is_empty() || pb.is_empty() {
        return f64::NAN;
    }
    let m = 50;
    let ss: f64 = (0..m)
        .map(|k| {
            let s = (k as f64 + 0.5) / m as f64;
            (at(&pa, s) - at(&pb, s)).powi(2)
        })
        .sum();
    (ss / m as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Grains filling a shape whose half-width at height y is w(y), radius r.
    fn pillar(scale: f64, bulge: f64) -> (Vec<Vec2>, Vec<f64>) {
        let (r, h, w0) = (0.5, 40.0 * scale, 10.0 * scale);
        let (mut pos, mut rad) = (Vec::new(), Vec::new());
        let mut y = r;
        while y < h - r {
            let w = w0 * (1.0 + bulge * (y / h).powi(2)) - r;
            let mut x = -w;
            while x <= w + 1e-9 {
                pos.push(Vec2::new(x, y));
                rad.push(r);
                x += 2.0 * r;
            }
            y += 2.0 * r;
        }
        (pos, rad)
    }

    #[test]
    fn the_outline_follows_the_outermost_grains() {
        let (p, r) = pillar(1.0, 0.5);
        let o = Outline::of(&p, &r, 1.0);
        let hw = o.half_width();
        assert!((hw[0] - 10.0).abs() < 1.01, "bottom half-width {}", hw[0]);
        assert!(
            hw.last().unwrap() > &13.0,
            "the top bulges: {}",
            hw.last().unwrap()
        );
        assert!((o.height() - 40.0).abs() < 1.01, "{}", o.height());
        let poly = o.polygon();
        assert_eq!(poly.len(), 2 * o.y.len());
        // Counter-clockwise: positive area, about the shape's.
        let area = crate::structure::polygon_area(&poly);
        assert!(area > 0.9 * 20.0 * 40.0, "{area}");
    }

    #[test]
    fn one_shape_at_two_sizes_is_self_similar_and_another_is_not() {
        let (pa, ra) = pillar(1.0, 0.5);
        let (pb, rb) = pillar(2.0, 0.5);
        let (pc, rc) = pillar(2.0, 0.0);
        let (a, b, c) = (
            Outline::of(&pa, &ra, 1.0),
            Outline::of(&pb, &rb, 1.0),
            Outline::of(&pc, &rc, 1.0),
        );
        let same = shape_distance(&a, 20.0, &b, 40.0);
        let other = shape_distance(&a, 20.0, &c, 40.0);
        assert!(same < 0.03, "same shape, twice the size: {same}");
        // Half-widths over W0 differ by s²/4 at height fraction s: 0.11 rms.
        assert!(
            other > 0.06,
            "a straight pillar against a bulging one: {other}"
        );
    }
}
