//! The front between moving and resting grains (li-granular-pillars Fig. 5a and Sec. IV:
//! a sharp boundary between the grains the bar drives and those at rest, inclined at
//! about 45°). Per slab one D wide across the pillar, the boundary is the height that
//! best separates moving grains on one side from resting ones on the other; each half
//! of the pillar (left and right of the median x) fits a straight line through its
//! slabs' boundaries. The angle is the line's to the x axis (the bar), 0–90°, which is
//! also its complement's to the compression axis; the rms distance of the slab
//! boundaries from the line (in D) says how straight, and the fraction of grains on the
//! wrong side of their slab's boundary how sharp, the front is.

use serde::Serialize;

/// One half's front line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrontSide {
    /// Angle of the line to the x axis, degrees in [0, 90].
    pub angle_deg: f64,
    /// dy/dx and the line's y at x = 0 (length unit).
    pub slope: f64,
    pub intercept: f64,
    /// Rms distance (vertical) of the slab boundaries from the line, in D.
    pub rms_d: f64,
    /// Slabs with both moving and resting grains (the line's points).
    pub slabs: usize,
}

/// The front of one frame pair.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Front {
    /// Median x, the halves' divide.
    pub x_mid: f64,
    /// Whether the moving grains lie above the front (larger y).
    pub moving_above: bool,
    pub left: Option<FrontSide>,
    pub right: Option<FrontSide>,
    /// Grains on the wrong side of their slab's boundary, over the grains in slabs
    /// with a boundary.
    pub misplaced: f64,
    /// (slab centre x, boundary y) of every slab with both kinds of grain.
    pub profile: Vec<(f64, f64)>,
}

/// Fewest slabs a half's line is fitted through.
pub const MIN_SLABS: usize = 3;

/// The front of grains at (`x`, `y`), `moving[i]` telling which move; `d` the slab
/// width (the large-grain diameter). None without both moving and resting grains.
pub fn front(x: &[f64], y: &[f64], moving: &[bool], d: f64) -> Option<Front> {
    let n = x.len().min(y.len()).min(moving.len());
    let idx: Vec<usize> = (0..n)
        .filter(|&i| x[i].is_finite() && y[i].is_finite())
        .collect();
    let moves = idx.iter().filter(|&&i| moving[i]).count();
    if moves == 0 || moves == idx.len() || !(d > 0.0) {
        return None;
    }
    let mean = |pick: bool| {
        let v: Vec<f64> = idx
            .iter()
            .filter(|&&i| moving[i] == pick)
            .map(|&i| y[i])
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let moving_above = mean(true) > mean(false);
    let x_lo = idx.iter().map(|&i| x[i]).fold(f64::INFINITY, f64::min);
    let mut xs: Vec<f64> = idx.iter().map(|&i| x[i]).collect();
    xs.sort_by(f64::total_cmp);
    let x_mid = xs[xs.len() / 2];
    let slab_of = |xi: f64| ((xi - x_lo) / d).floor() as usize;
    let slabs = slab_of(xs[xs.len() - 1]) + 1;
    let mut by_slab: Vec<Vec<(f64, bool)>> = vec![Vec::new(); slabs];
    for &i in &idx {
        by_slab[slab_of(x[i])].push((y[i], moving[i]));
    }
    let (mut profile, mut misplaced, mut counted) = (Vec::new(), 0usize, 0usize);
    for (k, g) in by_slab.iter_mut().enumerate() {
        let m = g.iter().filter(|p| p.1).count();
        if m == 0 || m == g.len() {
            continue;
        }
        g.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Cut after grain c (c in 0..=len): below the cut one class, above the other.
        // Wrong below = the grains there of the class that belongs above.
        let above_class = moving_above;
        let mut wrong_below = 0usize;
        let wrong_above_total = g.iter().filter(|p| p.1 != above_class).count();
        let mut wrong_above = wrong_above_total;
        let (mut best, mut best_cut) = (wrong_above, 0usize);
        for (c, p) in g.iter().enumerate() {
            if p.1 == above_class {
                wrong_below += 1;
            } else {
                wrong_above -= 1;
            }
            if wrong_below + wrong_above < best {
                best = wrong_below + wrong_above;
                best_cut = c + 1;
            }
        }
        let yb = match best_cut {
            0 => g[0].0,
            c if c == g.len() => g[c - 1].0,
            c => 0.5 * (g[c - 1].0 + g[c].0),
        };
        misplaced += best;
        counted += g.len();
        profile.push((x_lo + (k as f64 + 0.5) * d, yb));
    }
    let side = |pts: Vec<(f64, f64)>| -> Option<FrontSide> {
        if pts.len() < MIN_SLABS {
            return None;
        }
        let m = pts.len() as f64;
        let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
        let (mx, my) = (sx / m, sy / m);
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        if sxx <= 0.0 {
            return None;
        }
        let slope = sxy / sxx;
        let intercept = my - slope * mx;
        let rms = (pts
            .iter()
            .map(|p| (p.1 - intercept - slope * p.0).powi(2))
            .sum::<f64>()
            / m)
            .sqrt();
        Some(FrontSide {
            angle_deg: slope.abs().atan().to_degrees(),
            slope,
            intercept,
            rms_d: rms / d,
            slabs: pts.len(),
        })
    };
    let left = side(profile.iter().copied().filter(|p| p.0 < x_mid).collect());
    let right = side(profile.iter().copied().filter(|p| p.0 >= x_mid).collect());
    Some(Front {
        x_mid,
        moving_above,
        left,
        right,
        misplaced: misplaced as f64 / counted.max(1) as f64,
        profile,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square lattice of spacing 0.5 D over 40 D × 30 D; grains above
    /// y = 8 + tan(θ)|x − 20| move (a V with both sides at θ), or below it.
    fn planted(theta_deg: f64, above: bool) -> (Vec<f64>, Vec<f64>, Vec<bool>) {
        let (mut x, mut y, mut m) = (Vec::new(), Vec::new(), Vec::new());
        let t = theta_deg.to_radians().tan();
        for i in 0..80 {
            for j in 0..60 {
                let (xi, yj) = (0.25 + 0.5 * i as f64, 0.25 + 0.5 * j as f64);
                x.push(xi);
                y.push(yj);
                m.push((yj > 8.0 + t * (xi - 20.0).abs()) == above);
            }
        }
        (x, y, m)
    }

    #[test]
    fn a_planted_front_is_found_at_its_angle_on_both_sides() {
        for theta in [45.0, 30.0, 60.0] {
            for above in [true, false] {
                let (x, y, m) = planted(theta, above);
                let f = front(&x, &y, &m, 1.0).expect("both kinds of grain");
                assert_eq!(f.moving_above, above);
                for s in [f.left.as_ref().unwrap(), f.right.as_ref().unwrap()] {
                    // Slab boundaries sit on the lattice: within half a spacing.
                    assert!(
                        (s.angle_deg - theta).abs() < 2.0,
                        "θ = {theta}: {}",
                        s.angle_deg
                    );
                    assert!(s.rms_d < 0.3, "{}", s.rms_d);
                }
                assert!(f.left.unwrap().slope * f.right.unwrap().slope < 0.0, "a V");
                // Two lattice columns share a slab; one cut misplaces at most the few
                // grains between their boundaries.
                assert!(f.misplaced < 0.02, "a sharp front: {}", f.misplaced);
            }
        }
    }

    #[test]
    fn noise_shows_as_misplaced_grains_and_no_front_without_both_kinds() {
        let (x, y, mut m) = planted(45.0, true);
        // Every 10th grain flipped.
        for k in (0..m.len()).step_by(10) {
            m[k] = !m[k];
        }
        let f = front(&x, &y, &m, 1.0).unwrap();
        assert!(f.misplaced > 0.03 && f.misplaced < 0.15, "{}", f.misplaced);
        let s = f.left.unwrap();
        assert!((s.angle_deg - 45.0).abs() < 5.0, "{}", s.angle_deg);
        assert!(front(&x, &y, &vec![true; x.len()], 1.0).is_none());
        assert!(front(&x, &y, &vec![false; x.len()], 1.0).is_none());
    }
}
