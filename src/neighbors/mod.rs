//! Fixed-radius neighbour search with a cell list, for open boxes and for periodic /
//! Lees–Edwards boxes. One query description (cutoff, inclusive or strict, box); the
//! analysis and the simulators share it.

use crate::error::{Error, Result};
use crate::geom::{SimBox, Vec2, floor_index};

/// Whether a pair at exactly the cutoff counts. The paper (Li et al., Sec. III) uses
/// |r_ji| < R_c; OVITO uses ≤.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cutoff {
    Strict,
    Inclusive,
}

/// Cell list over a set of positions. Cells are at least `cutoff` wide, so all
/// neighbours of a point lie in its own and the adjacent cells (Lees–Edwards: in the
/// x-range shifted by the box offset).
pub struct CellList {
    cutoff: f64,
    cutoff2: f64,
    kind: Cutoff,
    simbox: Option<SimBox>,
    x0: f64,
    y0: f64,
    cw: f64,
    ch: f64,
    nx: usize,
    ny: usize,
    /// Start of each cell in `order`, length nx*ny + 1.
    cell_start: Vec<u32>,
    /// Particle indices sorted by cell.
    order: Vec<u32>,
    /// Positions in cell order (cache locality).
    sorted: Vec<Vec2>,
}

impl CellList {
    /// Build over `pos`. With a periodic box, positions are wrapped into it; the cutoff
    /// must not exceed half of any periodic side (minimum image).
    pub fn new(pos: &[Vec2], cutoff: f64, kind: Cutoff, simbox: Option<SimBox>) -> Result<Self> {
        if !(cutoff > 0.0 && cutoff.is_finite()) {
            return Err(Error::param("rc", format!("cutoff {cutoff} must be > 0")));
        }
        if pos.len() >= u32::MAX as usize {
            return Err(Error::param("n", "too many particles for one frame"));
        }
        if let Some(b) = simbox
            && cutoff > b.half_min_side()
        {
            return Err(Error::param(
                "rc",
                format!(
                    "cutoff {cutoff} exceeds half the periodic box ({}): minimum image is ambiguous",
                    b.half_min_side()
                ),
            ));
        }
        let (mut xmin, mut xmax, mut ymin, mut ymax) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        // In an open box the positions are used as given (no copy: a frame of a
        // million particles is 16 MB).
        let wrapped: std::borrow::Cow<[Vec2]> = match simbox {
            Some(b) => pos.iter().map(|&p| b.wrap(p)).collect(),
            None => pos.into(),
        };
        for p in wrapped.iter() {
            xmin = xmin.min(p.x);
            xmax = xmax.max(p.x);
            ymin = ymin.min(p.y);
            ymax = ymax.max(p.y);
        }
        if wrapped.is_empty() {
            (xmin, xmax, ymin, ymax) = (0.0, 0.0, 0.0, 0.0);
        }
        let axis = |periodic: bool, lo: f64, len: f64, min: f64, max: f64| -> (f64, f64, usize) {
            if periodic {
                let n = ((len / cutoff).floor() as usize).max(1);
                (lo, len / n as f64, n)
            } else {
                let span = (max - min).max(0.0);
                // Cap the grid so a sparse outlier cannot allocate a huge empty grid. The
                // cap is applied in f64: a span of 1e40 or inf saturates the cast to
                // usize::MAX, whose + 1 wrapped to an empty grid (issue 24's panic).
                let n = ((span / cutoff).floor() + 1.0)
                    .min((1 << 13) as f64)
                    .max(1.0) as usize;
                let w = (span / n as f64).max(cutoff);
                (min, w, n)
            }
        };
        let (x0, cw, nx) = match simbox {
            Some(b) => axis(b.periodic_x, b.x_lo, b.lx, xmin, xmax),
            None => axis(false, 0.0, 0.0, xmin, xmax),
        };
        let (y0, ch, ny) = match simbox {
            Some(b) => axis(b.periodic_y, b.y_lo, b.ly, ymin, ymax),
            None => axis(false, 0.0, 0.0, ymin, ymax),
        };
        let cell_of = |p: Vec2| -> usize {
            let cx = (((p.x - x0) / cw) as isize).clamp(0, nx as isize - 1) as usize;
            let cy = (((p.y - y0) / ch) as isize).clamp(0, ny as isize - 1) as usize;
            cy * nx + cx
        };
        let cells: Vec<u32> = wrapped.iter().map(|&p| cell_of(p) as u32).collect();
        let mut cell_start = vec![0u32; nx * ny + 1];
        for &c in &cells {
            cell_start[c as usize + 1] += 1;
        }
        for k in 0..nx * ny {
            cell_start[k + 1] += cell_start[k];
        }
        let mut fill = cell_start.clone();
        let mut order = vec![0u32; wrapped.len()];
        for (i, &c) in cells.iter().enumerate() {
            order[fill[c as usize] as usize] = i as u32;
            fill[c as usize] += 1;
        }
        let sorted = order.iter().map(|&i| wrapped[i as usize]).collect();
        Ok(CellList {
            cutoff,
            cutoff2: cutoff * cutoff,
            kind,
            simbox,
            x0,
            y0,
            cw,
            ch,
            nx,
            ny,
            cell_start,
            order,
            sorted,
        })
    }

    /// Particle indices in cell order: iterating in this order keeps neighbour data in
    /// cache.
    pub fn cell_order(&self) -> &[u32] {
        &self.order
    }

    /// The positions in cell order exactly as given, where there is no box to wrap
    /// them into (`None` with a box).
    pub fn positions_as_given(&self) -> Option<&[Vec2]> {
        self.simbox.is_none().then_some(&self.sorted[..])
    }

    #[inline]
    fn accept(&self, r2: f64) -> bool {
        match self.kind {
            Cutoff::Strict => r2 < self.cutoff2,
            Cutoff::Inclusive => r2 <= self.cutoff2,
        }
    }

    /// Call `f(j, d)` for every indexed particle j within the cutoff of point `p`, with
    /// `d = r_j − p` (minimum image). Includes a particle sitting exactly at `p` (the
    /// caller skips itself by index).
    #[inline]
    pub fn for_each_within<F: FnMut(usize, Vec2)>(&self, p: Vec2, mut f: F) {
        self.for_each_within_at(p, |j, _, d| f(j, d));
    }

    /// As [`CellList::for_each_within`], with each particle's place `k` in cell order
    /// too (`f(j, k, d)`, `cell_order()[k] == j`): data a caller keeps in cell order is
    /// read from the same few runs of memory as the positions.
    #[inline]
    pub fn for_each_within_at<F: FnMut(usize, usize, Vec2)>(&self, p: Vec2, mut f: F) {
        let b = self.simbox;
        let p = match b {
            Some(b) => b.wrap(p),
            None => p,
        };
        let periodic_x = b.is_some_and(|b| b.periodic_x);
        let periodic_y = b.is_some_and(|b| b.periodic_y);
        let cy = floor_index((p.y - self.y0) / self.ch);
        let (ylo, yhi) = if periodic_y && self.ny < 3 {
            (0, self.ny as isize - 1)
        } else {
            (cy - 1, cy + 1)
        };
        // The box's minimum image, made once (`geom::MinImage`).
        let image = b.map(|b| b.image());
        for ry in ylo..=yhi {
            // Row index in the grid and the x shift of that row's images.
            let (row, shift) = if ry < 0 || ry >= self.ny as isize {
                if !periodic_y {
                    continue;
                }
                let n = self.ny as isize;
                let wraps = ry.div_euclid(n);
                // Images of the row `wraps` boxes up are displaced by wraps·xy in x.
                (
                    ry.rem_euclid(n) as usize,
                    wraps as f64 * b.map_or(0.0, |b| b.xy),
                )
            } else {
                (ry as usize, 0.0)
            };
            let xa = floor_index((p.x - self.cutoff - shift - self.x0) / self.cw);
            let xb = floor_index((p.x + self.cutoff - shift - self.x0) / self.cw);
            let (xa, xb) = if periodic_x {
                if xb - xa + 1 >= self.nx as isize {
                    (0, self.nx as isize - 1)
                } else {
                    (xa, xb)
                }
            } else {
                (xa.max(0), xb.min(self.nx as isize - 1))
            };
            for rx in xa..=xb {
                let col = if periodic_x {
                    rx.rem_euclid(self.nx as isize) as usize
                } else {
                    rx as usize
                };
                let c = row * self.nx + col;
                let (s, e) = (self.cell_start[c] as usize, self.cell_start[c + 1] as usize);
                for k in s..e {
                    let mut d = self.sorted[k] - p;
                    if let Some(img) = image {
                        let (dx, dy) = img.of(d.x, d.y);
                        d = Vec2::new(dx, dy);
                    }
                    if self.accept(d.norm2()) {
                        f(self.order[k] as usize, k, d);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn brute(pos: &[Vec2], i: usize, rc: f64, b: Option<SimBox>) -> Vec<usize> {
        let mut v: Vec<usize> = (0..pos.len())
            .filter(|&j| {
                let mut d = pos[j] - pos[i];
                if let Some(b) = b {
                    d = b.min_image(d);
                }
                d.norm2() < rc * rc
            })
            .collect();
        v.sort();
        v
    }

    fn check(b: Option<SimBox>, n: usize, l: f64, rc: f64, seed: u64) {
        let mut rng = Rng::new(seed);
        let pos: Vec<Vec2> = (0..n)
            .map(|_| Vec2::new(rng.uniform() * l, rng.uniform() * l))
            .collect();
        let cl = CellList::new(&pos, rc, Cutoff::Strict, b).unwrap();
        for i in 0..n {
            let mut got = Vec::new();
            cl.for_each_within(pos[i], |j, _| got.push(j));
            got.sort();
            assert_eq!(got, brute(&pos, i, rc, b), "particle {i}");
        }
    }

    #[test]
    fn open_box_matches_brute_force() {
        check(None, 400, 20.0, 1.3, 1);
    }

    #[test]
    fn periodic_box_matches_brute_force() {
        check(Some(SimBox::periodic(20.0, 20.0)), 400, 20.0, 1.3, 2);
    }

    #[test]
    fn lees_edwards_box_matches_brute_force() {
        for xy in [0.37, 5.5, -7.9, 13.0] {
            let b = SimBox {
                xy,
                ..SimBox::periodic(20.0, 20.0)
            };
            check(Some(b), 400, 20.0, 1.7, 3);
        }
    }

    /// Issue 24: a coordinate of 1e40 (or an infinite span) made the grid's cell count
    /// wrap to zero and `clamp` panic ("min > max"). Far-apart points still find
    /// their near neighbours and not each other.
    #[test]
    fn huge_extents_do_not_panic() {
        for far in [1e40, 1e300, f64::MAX, f64::INFINITY] {
            let pos = [
                Vec2::new(0.0, 0.0),
                Vec2::new(0.5, 0.0),
                Vec2::new(far, 1.0),
                Vec2::new(-far, -far),
            ];
            let cl = CellList::new(&pos, 1.0, Cutoff::Strict, None).unwrap();
            let mut got = Vec::new();
            cl.for_each_within(pos[0], |j, _| got.push(j));
            got.sort();
            assert_eq!(got, vec![0, 1], "far = {far}");
        }
    }

    #[test]
    fn tiny_periodic_box_has_no_duplicates() {
        check(Some(SimBox::periodic(4.0, 4.0)), 60, 4.0, 1.9, 4);
    }
}
