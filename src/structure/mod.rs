//! Structure of a packing: the pair distribution g(r) by the species at the centre
//! (li-granular-pillars Fig. 2: small-centred and large-centred g(r) against r/D), and
//! the pillar's outline ([`Outline`], Fig. 9) with a distance between rescaled outlines,
//! the transient shear lines of a J2 map ([`shear_lines()`], Fig. 11), and the yield
//! point of a stress–strain curve ([`yielding`], Sec. III, Fig. 4), and the front
//! between moving and resting grains ([`front`], Fig. 5a).
//!
//! An open pillar has edges, where a shell around a grain reaches into empty space and
//! g(r) would fall below 1 for no physical reason. So only centres at least r_max inside
//! the packing count as references: the region is the convex hull of all centres (a
//! compressed pillar stays close to convex), its area gives the number density, and a
//! centre qualifies when its distance to every hull edge is at least r_max, so each of its
//! shells up to r_max lies wholly inside. Periodic boxes need none of this: every centre
//! counts and the density is N over the box's area.
//!
//! g_c(r) = ⟨number of grains in [r, r + dr) around a centre of species c⟩ / (ρ 2π r dr),
//! with ρ the density of all grains: it tends to 1 at large r for any species mix.

pub mod edge_stress;
pub mod front;
mod outline;
mod pair_counts;
pub mod pressure;
mod shear_lines;
pub mod yielding;

pub use outline::{Outline, shape_distance};
pub use shear_lines::tracks as line_tracks;
pub use shear_lines::{ShearLine, ShearLineOptions, ShearLineSummary, ShearLines, shear_lines};

use crate::error::{Error, Result};
use crate::geom::{SimBox, Vec2};
use crate::neighbors::{CellList, Cutoff};

/// g(r) on bins of width `dr` from 0 to `r_max` (length unit): around all counted
/// centres, around small ones and around large ones.
#[derive(Debug, Clone, PartialEq)]
pub struct PairDistribution {
    /// Bin centres (length unit).
    pub r: Vec<f64>,
    pub g_all: Vec<f64>,
    pub g_small: Vec<f64>,
    pub g_large: Vec<f64>,
    /// Centres counted (inside by r_max), by species: all, small, large.
    pub centres: [usize; 3],
    /// Number density ρ (grains per length unit²) and the region's area.
    pub density: f64,
    pub area: f64,
}

/// g(r) of the grains at `pos` (species `small[i]` true for small grains) up to
/// `r_max` in `bins` bins; `simbox` for periodic positions, else the open-packing rule.
pub fn pair_distribution(
    pos: &[Vec2],
    small: &[bool],
    r_max: f64,
    bins: usize,
    simbox: Option<SimBox>,
) -> Result<PairDistribution> {
    if pos.len() != small.len() {
        return Err(Error::Other(
            "g(r): positions and species differ in length".into(),
        ));
    }
    if !(r_max > 0.0 && r_max.is_finite()) || bins == 0 {
        return Err(Error::param("r-max", format!("must be > 0, got {r_max}")));
    }
    let periodic = simbox.filter(|b| b.periodic_x && b.periodic_y);
    let (area, inside): (f64, Vec<bool>) = match periodic {
        Some(b) => {
            if r_max > b.half_min_side() {
                return Err(Error::param(
                    "r-max",
                    format!("{r_max} exceeds half the box ({})", b.half_min_side()),
                ));
            }
            (b.lx * b.ly, vec![true; pos.len()])
        }
        None => {
            let hull = convex_hull(pos);
            if hull.len() < 3 {
                return Err(Error::Other(
                    "g(r): fewer than three grains not on a line".into(),
                ));
            }
            let area = polygon_area(&hull);
            let inside = pos
                .iter()
                .map(|&p| distance_inside(&hull, p) >= r_max)
                .collect();
            (area, inside)
        }
    };
    let density = pos.len() as f64 / area;
    let dr = r_max / bins as f64;
    let mut centres = [0usize; 3];
    for i in (0..pos.len()).filter(|&i| inside[i]) {
        centres[0] += 1;
        centres[if small[i] { 1 } else { 2 }] += 1;
    }
    let [c_small, c_large] =
        match pair_counts::count_pairs(pos, small, &inside, r_max, bins, periodic) {
            Some(c) => c,
            None => around_each_centre(pos, small, &inside, r_max, bins, periodic)?,
        };
    let all: Vec<u64> = c_small.iter().zip(&c_large).map(|(a, b)| a + b).collect();
    let counts = [all, c_small, c_large];
    let r: Vec<f64> = (0..bins).map(|k| (k as f64 + 0.5) * dr).collect();
    let norm = |c: &[u64], n: usize| -> Vec<f64> {
        (0..bins)
            .map(|k| {
                let shell = std::f64::consts::PI
                    * ((k as f64 + 1.0).powi(2) - (k as f64).powi(2))
                    * dr
                    * dr;
                if n == 0 {
                    f64::NAN
                } else {
                    c[k] as f64 / (n as f64 * density * shell)
                }
            })
            .collect()
    };
    Ok(PairDistribution {
        g_all: norm(&counts[0], centres[0]),
        g_small: norm(&counts[1], centres[1]),
        g_large: norm(&counts[2], centres[2]),
        r,
        centres,
        density,
        area,
    })
}

/// [`pair_counts::count_pairs`]'s histograms by a query around each counted centre
/// (where its cells cannot be laid out, e.g. a sheared or small periodic box).
fn around_each_centre(
    pos: &[Vec2],
    small: &[bool],
    inside: &[bool],
    r_max: f64,
    bins: usize,
    periodic: Option<SimBox>,
) -> Result<[Vec<u64>; 2]> {
    let cl = CellList::new(pos, r_max, Cutoff::Strict, periodic)?;
    let dr = r_max / bins as f64;
    let mut counts = [vec![0u64; bins], vec![0u64; bins]];
    for (i, &p) in pos.iter().enumerate() {
        if !inside[i] {
            continue;
        }
        let which = if small[i] { 0 } else { 1 };
        cl.for_each_within(p, |j, d| {
            if j == i {
                return;
            }
            let k = (d.norm() / dr) as usize;
            if k < bins {
                counts[which][k] += 1;
            }
        });
    }
    Ok(counts)
}

/// Convex hull, counter-clockwise (Andrew's monotone chain).
pub fn convex_hull(pos: &[Vec2]) -> Vec<Vec2> {
    let mut p: Vec<Vec2> = pos
        .iter()
        .copied()
        .filter(|q| q.x.is_finite() && q.y.is_finite())
        .collect();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    let mut h: Vec<Vec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    h
}

/// Area of a simple polygon (shoelace), positive for counter-clockwise.
pub fn polygon_area(poly: &[Vec2]) -> f64 {
    let n = poly.len();
    0.5 * (0..n)
        .map(|k| {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            a.x * b.y - b.x * a.y
        })
        .sum::<f64>()
}

/// Distance from `p` to the nearest edge of the convex polygon `hull` (counter-
/// clockwise), negative outside.
fn distance_inside(hull: &[Vec2], p: Vec2) -> f64 {
    let n = hull.len();
    (0..n)
        .map(|k| {
            let (a, b) = (hull[k], hull[(k + 1) % n]);
            let e = b - a;
            // Signed distance to the edge's line, positive on the inner (left) side.
            (e.x * (p.y - a.y) - e.y * (p.x - a.x)) / e.norm()
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// The cell-pair counting gives the histograms of a query around every centre: the
    /// same integers in an open packing (same differences, same arithmetic), and in a
    /// periodic box the same up to a pair on a bin edge (minimum image against a
    /// shifted cell), for thread counts 1 and 2.
    #[test]
    fn pair_counts_equal_queries_around_each_centre() {
        let mut rng = Rng::new(4);
        let n = 3000;
        let pos: Vec<Vec2> = (0..n)
            .map(|_| Vec2::new(60.0 * rng.uniform(), 45.0 * rng.uniform()))
            .collect();
        let small: Vec<bool> = (0..n).map(|_| rng.uniform() < 0.5).collect();
        let counted: Vec<bool> = (0..n).map(|_| rng.uniform() < 0.7).collect();
        let b = SimBox::periodic(60.0, 45.0);
        for (periodic, exact) in [(None, true), (Some(b), false)] {
            let want = around_each_centre(&pos, &small, &counted, 4.0, 80, periodic).unwrap();
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let got = pool
                    .install(|| pair_counts::count_pairs(&pos, &small, &counted, 4.0, 80, periodic))
                    .expect("cells laid out");
                for s in 0..2 {
                    let total: (u64, u64) = (got[s].iter().sum(), want[s].iter().sum());
                    assert!(total.0 > 10_000, "{total:?}");
                    for k in 0..80 {
                        let diff = got[s][k].abs_diff(want[s][k]);
                        assert!(
                            diff == 0 || (!exact && diff <= 2),
                            "species {s} bin {k}: {} vs {}",
                            got[s][k],
                            want[s][k]
                        );
                    }
                    assert!(total.0.abs_diff(total.1) <= if exact { 0 } else { 2 });
                }
            }
        }
        // A stray grain a million diameters away does not make a grid of 10^11 cells:
        // the layout is left to the queries, and g(r) is still computed.
        let mut far = pos.clone();
        far.push(Vec2::new(1e6, -1e6));
        let (mut sm, mut ct) = (small.clone(), counted.clone());
        sm.push(false);
        ct.push(false);
        assert!(pair_counts::count_pairs(&far, &sm, &ct, 4.0, 80, None).is_none());
        assert!(pair_distribution(&far, &sm, 4.0, 80, None).is_ok());
        // A sheared box is left to the queries.
        let mut sheared = b;
        sheared.xy = 3.0;
        assert!(pair_counts::count_pairs(&pos, &small, &counted, 4.0, 80, Some(sheared)).is_none());
    }

    /// Uniform random points (an ideal gas): g(r) = 1 at every r, within counting noise,
    /// in the open rule (only centres r_max inside the hull) as in a periodic box.
    #[test]
    fn an_ideal_gas_has_g_of_one() {
        let mut rng = Rng::new(4);
        let n = 20_000;
        let pos: Vec<Vec2> = (0..n)
            .map(|_| Vec2::new(100.0 * rng.uniform(), 100.0 * rng.uniform()))
            .collect();
        let small: Vec<bool> = (0..n).map(|k| k % 2 == 0).collect();
        for simbox in [None, Some(SimBox::periodic(100.0, 100.0))] {
            let g = pair_distribution(&pos, &small, 5.0, 10, simbox).unwrap();
            for (k, (&r, &v)) in g.r.iter().zip(&g.g_all).enumerate().skip(2) {
                assert!(
                    (v - 1.0).abs() < 0.06,
                    "{simbox:?} bin {k} r = {r}: g = {v}"
                );
            }
            assert!((g.g_small[5] - 1.0).abs() < 0.1 && (g.g_large[5] - 1.0).abs() < 0.1);
            if simbox.is_none() {
                // Without the edge rule the shells of border centres would be half empty.
                assert!(
                    g.centres[0] < n && g.centres[0] > n * 8 / 10,
                    "{:?}",
                    g.centres
                );
            }
        }
    }

    /// A triangular lattice of spacing a: nothing below a, the first peak at a holding
    /// six neighbours (∫ ρ g 2πr dr over it), the next at √3 a.
    #[test]
    fn a_triangular_lattice_has_six_neighbours_at_its_spacing() {
        let a = 1.0;
        let mut pos = Vec::new();
        for r in 0..60 {
            for c in 0..60 {
                pos.push(Vec2::new(
                    (c as f64 + 0.5 * (r % 2) as f64) * a,
                    r as f64 * a * 3f64.sqrt() / 2.0,
                ));
            }
        }
        let small = vec![true; pos.len()];
        let g = pair_distribution(&pos, &small, 2.0, 40, None).unwrap();
        let dr = 2.0 / 40.0;
        let count = |lo: f64, hi: f64| -> f64 {
            g.r.iter()
                .zip(&g.g_all)
                .filter(|(r, _)| **r > lo && **r < hi)
                .map(|(r, v)| g.density * v * 2.0 * std::f64::consts::PI * r * dr)
                .sum()
        };
        assert!(count(0.0, 0.95) < 1e-9, "nothing below the spacing");
        let first = count(0.95, 1.05);
        assert!((first - 6.0).abs() < 0.35, "first shell holds {first}");
        assert!(count(1.68, 1.78) > 5.0, "second shell at √3 a");
        assert!(g.g_large.iter().all(|v| v.is_nan()), "no large centres");
    }

    #[test]
    fn bad_input_is_refused() {
        let p = vec![Vec2::new(0.0, 0.0); 3];
        assert!(pair_distribution(&p, &[true; 2], 1.0, 10, None).is_err());
        assert!(pair_distribution(&p, &[true; 3], 0.0, 10, None).is_err());
        assert!(pair_distribution(&p, &[true; 3], 1.0, 10, None).is_err());
        let b = Some(SimBox::periodic(4.0, 4.0));
        assert!(pair_distribution(&p, &[true; 3], 3.0, 10, b).is_err());
    }
}
