//! Transient shear lines (li-granular-pillars Sec. V, Fig. 11): thin bands of grains with
//! a high deviatoric strain rate J2 (Eq. 18), about 45° to the compression axis and about
//! 2 D wide whatever the pillar's size. This finds them in one J2 map and measures each.
//!
//! Method, for grains at centres r_i with J2_i (NaN: undetermined, left out everywhere):
//! 1. High grains: J2_i > threshold × J2_ref, with J2_ref the mean of the determined
//!    J2 below their 99th percentile (the trim keeps a few near-singular fits from
//!    setting it). Not the median: in a compressed pillar a third or more of the grains
//!    are at rest (J2 = 0 up to round-off, held by substrate friction) and most of the
//!    rest creep, so the median falls between the two populations, 10⁻² of the mean or
//!    less, and 3 × it marks 40 % of the pillar as high (simulated N = 1000 pillar,
//!    Δt = 8/15 R/v_c: one cluster spanning the moving part, no line). The mean is set by
//!    the grains that deform, and 3 × it marks about 13 %.
//! 2. Local direction of each high grain: among the high grains within 4 D, the direction
//!    (5° steps) of the line through it that holds the most of them within 0.6 D. Unlike
//!    the principal axis of the neighbourhood, this follows one line where two cross.
//! 3. Single linkage: two high grains closer than the link length (1.25 D, the kinematics'
//!    R_c) whose local directions differ by at most 30° belong to one cluster. Clusters
//!    that lie on one axis (directions within 15°, each centre within half the wider
//!    cluster's width + D/2 of the other's axis) and come within 4 D of each other are
//!    then joined: a line crossed by another is cut where the other's grains took the
//!    crossing; this puts it back together. A grain belongs to one line.
//! 4. Each cluster of at least `min_grains` grains: principal axes of its centres (the
//!    2×2 covariance, λ_max ≥ λ_min, long axis u). A line when elongation
//!    sqrt(λ_max/λ_min) ≥ `min_elongation` and length ≥ `min_length_over_d` D; other
//!    clusters are counted as compact.
//!
//! Width w = sqrt(12 λ_min) and length L = sqrt(12 λ_max) (both in D): the sides of the
//! uniform strip with the same second moments, so the elongation is L/w. Why this width:
//! in a disordered packing the centres of the grains in a band of width w fill it
//! uniformly across (homogeneity), so sqrt(12) σ_⊥ is w without bias and no bin width or
//! profile fit enters; it is the width of the strip the band's grains tile (their share
//! of the area), additive like an area. It is not the edge-to-edge extent of the drawn
//! disks, which in a disordered band adds about one mean diameter (grains sticking out
//! on both sides). A band of k straight lattice rows of spacing h reads h sqrt(k² − 1)
//! instead of k h (two rows: −13 %), so a band along crystalline rows reads narrow.
//!
//! Angle: between u and the compression axis y (the pillar's bars move along y; li-
//! granular-pillars Fig. 1), folded into [0°, 90°]; 45° is the direction of maximum shear
//! stress. The direction of u from +x in [0°, 180°) tells conjugate lines (45°, 135°)
//! apart. Limits: lines crossing at less than about 30° are one cluster; a curved line is
//! measured as its chord (its width grows with the sagitta).

pub mod tracks;

use crate::error::{Error, Result};
use crate::geom::Vec2;
use crate::neighbors::{CellList, Cutoff};

/// Radius of the neighbourhood the local direction is taken over, in D.
const ORIENT_RADIUS_D: f64 = 4.0;
/// Half-width of the trial lines of the local direction, in D.
const STRIP_HALF_WIDTH_D: f64 = 0.6;
/// Trial directions: every 5° over 180°.
const DIRECTIONS: usize = 36;
/// Largest difference of local directions that links two grains (degrees).
const LINK_TOLERANCE_DEG: f64 = 30.0;
/// Largest difference of cluster axes that joins two clusters (degrees), and their
/// largest gap (D).
const JOIN_TOLERANCE_DEG: f64 = 15.0;
const JOIN_GAP_D: f64 = 4.0;

/// The detection's parameters (defaults in [`ShearLineOptions::default`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ShearLineOptions {
    /// A grain is high when J2 > threshold × J2_ref (dimensionless; J2_ref: step 1).
    pub threshold: f64,
    /// Single-linkage distance in D.
    pub link_over_d: f64,
    /// Fewest grains in a cluster that is measured.
    pub min_grains: usize,
    /// Least sqrt(λ_max/λ_min) of a line.
    pub min_elongation: f64,
    /// Least length of a line in D.
    pub min_length_over_d: f64,
}

impl Default for ShearLineOptions {
    fn default() -> Self {
        ShearLineOptions {
            threshold: 3.0,
            link_over_d: 1.25,
            min_grains: 15,
            min_elongation: 2.5,
            min_length_over_d: 5.0,
        }
    }
}

/// One shear line; lengths in D except the centre x, y (the positions' length unit).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShearLine {
    /// 0, 1, ... by decreasing number of grains.
    pub id: usize,
    pub n_grains: usize,
    pub x: f64,
    pub y: f64,
    /// Long axis to the compression axis y, degrees in [0, 90].
    pub angle_deg: f64,
    /// Long axis from +x, degrees in [0, 180).
    pub direction_deg: f64,
    pub width_d: f64,
    pub length_d: f64,
    /// sqrt(λ_max/λ_min) = length/width.
    pub elongation: f64,
    /// Mean J2 of its grains (1/time) and that over J2_ref.
    pub j2_mean: f64,
    pub j2_contrast: f64,
    /// Its grains: indices into the positions given to [`shear_lines()`], ascending.
    /// Not stored with a line (a cached analysis keeps the measures only); the linking
    /// of lines across frame pairs ([`tracks`]) maps them to particle ids.
    #[serde(skip)]
    pub members: Vec<usize>,
}

/// What the detection saw besides the lines.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ShearLineSummary {
    /// Grains with a determined J2, and of those the high ones.
    pub determined: usize,
    pub high: usize,
    /// J2_ref (1/time): the trimmed mean of step 1.
    pub j2_ref: f64,
    /// Clusters of at least `min_grains`: lines and the rest (compact).
    pub lines: usize,
    pub compact: usize,
    /// Medians over the lines (NaN without lines): degrees, D, D.
    pub median_angle_deg: f64,
    pub median_width_d: f64,
    pub median_length_d: f64,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ShearLines {
    pub lines: Vec<ShearLine>,
    pub summary: ShearLineSummary,
}

/// The shear lines of grains at `pos` with deviatoric strain rates `j2` (NaN where
/// undetermined), large-grain diameter `d` (the positions' length unit).
pub fn shear_lines(pos: &[Vec2], j2: &[f64], d: f64, opt: &ShearLineOptions) -> Result<ShearLines> {
    if pos.len() != j2.len() {
        return Err(Error::Other(format!(
            "shear lines: {} positions but {} J2 values",
            pos.len(),
            j2.len()
        )));
    }
    if !(d > 0.0 && d.is_finite()) {
        return Err(Error::param("diameter", format!("D = {d} must be > 0")));
    }
    if !(opt.threshold > 0.0 && opt.threshold.is_finite()) {
        return Err(Error::param(
            "threshold",
            format!("{} must be > 0", opt.threshold),
        ));
    }
    if !(opt.link_over_d > 0.0 && opt.link_over_d <= ORIENT_RADIUS_D) {
        return Err(Error::param(
            "link",
            format!("{} D must be in (0, {ORIENT_RADIUS_D}]", opt.link_over_d),
        ));
    }
    let det: Vec<usize> = (0..pos.len())
        .filter(|&i| j2[i].is_finite() && pos[i].is_finite())
        .collect();
    let mut v: Vec<f64> = det.iter().map(|&i| j2[i]).collect();
    v.sort_by(f64::total_cmp);
    let cut = crate::stats::quantile_sorted(&v, 0.99);
    let kept = v.partition_point(|&x| x <= cut);
    let j2_ref = crate::stats::mean(&v[..kept]);
    let high: Vec<usize> = det
        .iter()
        .copied()
        .filter(|&i| j2[i] > opt.threshold * j2_ref)
        .collect();
    let hp: Vec<Vec2> = high.iter().map(|&i| pos[i]).collect();
    let clusters = link(&hp, d, opt.link_over_d)?;
    let mut lines = Vec::new();
    let mut compact = 0;
    for c in clusters.iter().filter(|c| c.len() >= opt.min_grains.max(3)) {
        let pts: Vec<Vec2> = c.iter().map(|&k| hp[k]).collect();
        let a = Axes::of(&pts);
        let (width, length) = (a.width() / d, a.length() / d);
        if a.elongation() >= opt.min_elongation && length >= opt.min_length_over_d {
            let j2_mean = c.iter().map(|&k| j2[high[k]]).sum::<f64>() / c.len() as f64;
            let mut members: Vec<usize> = c.iter().map(|&k| high[k]).collect();
            members.sort_unstable();
            lines.push(ShearLine {
                id: 0,
                n_grains: c.len(),
                x: a.centre.x,
                y: a.centre.y,
                angle_deg: a.u.y.abs().min(1.0).acos().to_degrees(),
                direction_deg: a.u.y.atan2(a.u.x).to_degrees().rem_euclid(180.0),
                width_d: width,
                length_d: length,
                elongation: a.elongation(),
                j2_mean,
                j2_contrast: j2_mean / j2_ref,
                members,
            });
        } else {
            compact += 1;
        }
    }
    lines.sort_by_key(|l| std::cmp::Reverse(l.n_grains));
    for (k, l) in lines.iter_mut().enumerate() {
        l.id = k;
    }
    let median = |f: fn(&ShearLine) -> f64| {
        let mut v: Vec<f64> = lines.iter().map(f).collect();
        crate::stats::median_select(&mut v)
    };
    let summary = ShearLineSummary {
        determined: det.len(),
        high: high.len(),
        j2_ref,
        lines: lines.len(),
        compact,
        median_angle_deg: median(|l| l.angle_deg),
        median_width_d: median(|l| l.width_d),
        median_length_d: median(|l| l.length_d),
    };
    Ok(ShearLines { lines, summary })
}

/// Steps 2 and 3 of the method: the clusters of the high grains at `hp`, as indices.
fn link(hp: &[Vec2], d: f64, link_over_d: f64) -> Result<Vec<Vec<usize>>> {
    let cl = CellList::new(hp, ORIENT_RADIUS_D * d, Cutoff::Strict, None)?;
    let half = STRIP_HALF_WIDTH_D * d;
    let trial: Vec<Vec2> = (0..DIRECTIONS)
        .map(|k| {
            let t = std::f64::consts::PI * k as f64 / DIRECTIONS as f64;
            Vec2::new(t.cos(), t.sin())
        })
        .collect();
    let mut dir: Vec<Option<f64>> = Vec::with_capacity(hp.len());
    let mut near: Vec<Vec<usize>> = Vec::with_capacity(hp.len());
    let link2 = (link_over_d * d).powi(2);
    for (i, &p) in hp.iter().enumerate() {
        let mut counts = [0u32; DIRECTIONS];
        let mut close = Vec::new();
        cl.for_each_within(p, |j, r| {
            if j == i {
                return;
            }
            for (c, u) in counts.iter_mut().zip(&trial) {
                *c += u32::from(r.cross(*u).abs() <= half);
            }
            if j > i && r.norm2() < link2 {
                close.push(j);
            }
        });
        // The first of equal maxima: a grain where two lines cross takes one of them.
        let best = (0..DIRECTIONS).fold(0, |b, k| if counts[k] > counts[b] { k } else { b });
        dir.push((counts[best] > 0).then(|| 180.0 * best as f64 / DIRECTIONS as f64));
        near.push(close);
    }
    let mut uf = UnionFind::new(hp.len());
    for (i, close) in near.iter().enumerate() {
        for &j in close {
            if let (Some(a), Some(b)) = (dir[i], dir[j])
                && axial_difference(a, b) <= LINK_TOLERANCE_DEG
            {
                uf.union(i, j);
            }
        }
    }
    join_collinear(hp, d, &mut uf);
    Ok(uf.groups())
}

/// Join clusters on one axis that a crossing line cut apart (step 3).
fn join_collinear(hp: &[Vec2], d: f64, uf: &mut UnionFind) {
    loop {
        let groups: Vec<Vec<usize>> = uf.groups().into_iter().filter(|g| g.len() >= 3).collect();
        let axes: Vec<Axes> = groups
            .iter()
            .map(|g| Axes::of(&g.iter().map(|&k| hp[k]).collect::<Vec<_>>()))
            .collect();
        let mut joined = false;
        for a in 0..groups.len() {
            for b in a + 1..groups.len() {
                let (pa, pb) = (&axes[a], &axes[b]);
                let dir_a = pa.u.y.atan2(pa.u.x).to_degrees();
                let dir_b = pb.u.y.atan2(pb.u.x).to_degrees();
                let off = 0.5 * pa.width().max(pb.width()) + 0.5 * d;
                let on_axis = |p: &Axes, q: Vec2| (q - p.centre).cross(p.u).abs() <= off;
                if axial_difference(dir_a, dir_b) <= JOIN_TOLERANCE_DEG
                    && on_axis(pa, pb.centre)
                    && on_axis(pb, pa.centre)
                    && gap(&groups[a], &groups[b], hp) <= JOIN_GAP_D * d
                {
                    uf.union(groups[a][0], groups[b][0]);
                    joined = true;
                }
            }
        }
        if !joined {
            return;
        }
    }
}

/// Smallest distance between a grain of `a` and one of `b`.
fn gap(a: &[usize], b: &[usize], hp: &[Vec2]) -> f64 {
    a.iter()
        .flat_map(|&i| b.iter().map(move |&j| (hp[i] - hp[j]).norm()))
        .fold(f64::INFINITY, f64::min)
}

/// Difference of two axial directions (degrees, a line at θ is the line at θ + 180°).
fn axial_difference(a: f64, b: f64) -> f64 {
    let x = (a - b).rem_euclid(180.0);
    x.min(180.0 - x)
}

/// Principal axes of a set of points: centre, long axis u, variances along and across.
struct Axes {
    centre: Vec2,
    u: Vec2,
    var_long: f64,
    var_short: f64,
}

impl Axes {
    fn of(p: &[Vec2]) -> Axes {
        let n = p.len() as f64;
        let c = p.iter().fold(Vec2::new(0.0, 0.0), |s, &q| s + q) * (1.0 / n);
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for &q in p {
            let r = q - c;
            sxx += r.x * r.x;
            sxy += r.x * r.y;
            syy += r.y * r.y;
        }
        let (a, b, e) = (sxx / n, sxy / n, syy / n);
        let mid = 0.5 * (a + e);
        let rad = (0.25 * (a - e).powi(2) + b * b).sqrt();
        let t = 0.5 * (2.0 * b).atan2(a - e);
        Axes {
            centre: c,
            u: Vec2::new(t.cos(), t.sin()),
            var_long: mid + rad,
            var_short: (mid - rad).max(0.0),
        }
    }
    fn width(&self) -> f64 {
        (12.0 * self.var_short).sqrt()
    }
    fn length(&self) -> f64 {
        (12.0 * self.var_long).sqrt()
    }
    fn elongation(&self) -> f64 {
        (self.var_long / self.var_short).sqrt()
    }
}

struct UnionFind(Vec<usize>);

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind((0..n).collect())
    }
    fn find(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }
    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        self.0[ra.max(rb)] = ra.min(rb);
    }
    /// Members of each set, sets ordered by their smallest member.
    fn groups(&mut self) -> Vec<Vec<usize>> {
        let mut by_root: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
        for i in 0..self.0.len() {
            let r = self.find(i);
            by_root.entry(r).or_default().push(i);
        }
        by_root.into_values().collect()
    }
}

#[cfg(test)]
mod tests;
